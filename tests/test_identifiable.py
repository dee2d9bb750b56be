"""Which extra parameters the data identify: payload offsets only when rotational modes are measured."""

from __future__ import annotations

import pytest

import eigentwist
from eigentwist.description.effects import resolve_model
from eigentwist.diagnose import synth
from eigentwist.diagnose.identifiable import extra_parameters, sign_free, trial_value

KA = (250, 1000, 4000)
POSES = ((0.0, 0.0, -0.625), (-0.1, 0.0, -0.55))


@pytest.fixture(scope="module")
def ev_fast():
    return eigentwist.load("heli4", backend="auto")


def test_trial_offset_is_away_from_the_symmetric_zero(ev_fast):
    p_z = ev_fast.parameters["p_z"]
    assert sign_free(p_z) and trial_value(p_z) == pytest.approx(0.05)  # 1/6 of the 0.3 m half-width
    assert not sign_free(ev_fast.parameters["m_p"]) and trial_value(ev_fast.parameters["m_p"]) == 0.2


@pytest.mark.parametrize(
    "modes, expected", [(("x", "y", "z"), ()), (("x", "y", "z", "rx", "ry", "rz"), ("p_x", "p_y", "p_z"))]
)
def test_payload_offsets_join_the_fit_only_when_the_data_see_them(ev_fast, modes, expected):
    meas = synth("paper+payload_mass:m_p=0.5", KA, POSES, modes, 0.005, seed=1, ev=ev_fast)
    effects = resolve_model("paper,payload_mass", ev_fast.effects)
    assert extra_parameters(meas, ev_fast, effects, "payload_mass", {"m_p": 0.5}, {"m_p": 0.5}) == expected


def test_collinear_and_inert_parameters_never_join(ev_fast):
    # r_o_l1 scales the lower link's stiffness as E_l1 does (correlation > 0.99); G_rod has no influence
    meas = synth("paper", KA, POSES, ("x", "y", "z", "rx", "ry", "rz"), 0.005, seed=1, ev=ev_fast)
    llc = resolve_model("paper,lower_link_compliance", ev_fast.effects)
    assert extra_parameters(meas, ev_fast, llc, "lower_link_compliance", {"E_l1": 70e9}, {"E_l1": 70e9}) == ()
    paper = resolve_model("paper", ev_fast.effects)
    assert extra_parameters(meas, ev_fast, paper, "rod_compliance", {"E_rod": 170e9}, {"E_rod": 170e9}) == ()


def test_a_switched_effect_stays_switched(ev_fast):
    meas = synth("paper+gravity_preload", (20, 50, 100), POSES, ("x", "y"), 0.005, seed=1, ev=ev_fast)
    effects = resolve_model("paper,gravity_preload", ev_fast.effects)
    assert extra_parameters(meas, ev_fast, effects, "gravity_preload", {}, {}) == ()
