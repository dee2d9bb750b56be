"""Per-leg scope: EFFECT@N and NAME@N, with no regeneration."""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist
from eigentwist.description.effects import EFFECTS, resolve_model
from eigentwist.runtime.errors import InputError

from .conftest import random_poses


@pytest.fixture(scope="module")
def heli4():
    return eigentwist.load("heli4", backend="numpy")


def _rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def test_an_effect_on_every_leg_alone_equals_the_effect_on_all_legs(heli4):
    poses = random_poses(heli4.robot, 4, 11)
    for effect in (
        "actuator_loss",
        "rod_compliance",
        "lower_link_compliance",
        "transmission_compliance",
        "rotor_inertia",
    ):
        legs = ",".join(f"{effect}@{k}" for k in range(1, 5))
        a = heli4.matrices(poses, f"paper,{effect}")
        b = heli4.matrices(poses, f"rod_compliance,ee_compliance,actuator_loss,{legs}")
        for key in a:
            assert _rel(b[key], a[key]) < 1e-12, (effect, key)


def test_one_leg_actuator_changes_only_that_legs_term_of_K_R(heli4):
    """K_R = sum_i k_act,i j_i j_i^T (Eq. 14): eta_a@3 changes leg 3's term alone."""
    pose = np.array([[0.03, -0.02, -0.62]])
    k_a, eta = heli4.defaults["k_a"], heli4.defaults["eta_a"]
    base = heli4.matrices(pose, "paper")["K_R"][0]
    weak = heli4.matrices(pose, "paper,actuator_loss@3", **{"eta_a@3": 0.5})["K_R"][0]
    j3 = heli4.jacobians(pose)["J_rows"][0, 2, 0]
    want = base + (0.5 - eta) * k_a * np.outer(j3, j3)
    assert _rel(weak, want) < 1e-10
    # the same values without the scoped effect in the model: the per-leg value applies
    again = heli4.matrices(pose, "paper", **{"eta_a@3": 0.5})["K_R"][0]
    assert _rel(again, weak) < 1e-14


def test_a_leg_scoped_effect_without_the_all_legs_one_acts_on_that_leg_alone(heli4):
    pose = heli4.robot.x_ref
    none = heli4.frequencies(pose, "paper")
    leg2 = heli4.frequencies(pose, "paper,lower_link_compliance@2")
    both = heli4.frequencies(pose, "paper,lower_link_compliance")
    assert np.all(leg2 <= none + 1e-9) and np.all(both <= leg2 + 1e-9) and not np.allclose(leg2, none)


def test_resolve_model_orders_scoped_effects_after_their_effect(heli4):
    got = resolve_model("actuator_loss@4,paper,actuator_loss@2,transmission_compliance@1", heli4.robot)
    assert got == (
        "actuator_loss",
        "actuator_loss@2",
        "actuator_loss@4",
        "rod_compliance",
        "ee_compliance",
        "transmission_compliance@1",
    )


@pytest.mark.parametrize(
    "spec, message",
    [
        ("paper,actuator_loss@0", "'0' is not a leg number; expected actuator_loss@N with N in 1..4"),
        ("paper,actuator_loss@9", "'9' is not a leg number; expected actuator_loss@N with N in 1..4"),
        ("paper,actuator_loss@x", "'x' is not a leg number"),
        ("paper,ee_compliance@2", "acts on the whole platform, not on one leg"),
        ("payload_mass@1", "acts on the whole platform, not on one leg"),
    ],
)
def test_bad_scopes_fail_with_one_line(heli4, spec, message):
    with pytest.raises(ValueError, match=message) as exc:
        heli4.frequencies(heli4.robot.x_ref, spec)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize(
    "params, message",
    [
        ({"eta_a@0": 0.5}, "'0' is not a leg number"),
        ({"eta_a@5": 0.5}, "'5' is not a leg number; expected eta_a@N with N in 1..4"),
        ({"k_a@2": 100.0}, "k_a belongs to no leg-level effect"),
        ({"eta_a@2": -1.0}, "parameter 'eta_a@2'"),
        ({"r_i_l1@2": 0.02}, "leg 2: parameters"),
    ],
)
def test_bad_scoped_parameters_fail_with_one_line(heli4, params, message):
    with pytest.raises(InputError, match=message) as exc:
        heli4.frequencies(heli4.robot.x_ref, "paper,lower_link_compliance", **params)
    assert "\n" not in str(exc.value)


def test_every_leg_level_effect_is_scoped_in_the_generated_code(heli4):
    names = set(heli4.module.SWITCHES)
    for name, e in EFFECTS.items():
        if name in heli4.effects:
            want = {f"on_{name}__{k}" for k in range(1, 5)} if e.leg_level else {f"on_{name}"}
            assert want <= names, name


@pytest.mark.compiled
def test_c_equals_numpy_with_per_leg_values():
    ev_c = eigentwist.load("heli4", backend="c")
    ev_n = eigentwist.load("heli4", backend="numpy")
    poses = random_poses(ev_c.robot, 50, 3)
    model = "paper,lower_link_compliance@1,transmission_compliance@4,rotor_inertia@2,actuator_loss@3"
    params = {"eta_a@3": 0.45, "E_l1@1": 3e9, "k_t@4": 3000.0, "I_add@2": 0.01, "E_rod@2": 1e9}
    a = ev_c.modes(poses, model, **params)
    b = ev_n.modes(poses, model, **params)
    np.testing.assert_allclose(a.freq_hz, b.freq_hz, rtol=1e-10)
    ma, mb = ev_c.matrices(poses, model, **params), ev_n.matrices(poses, model, **params)
    for key in ma:
        assert _rel(ma[key], mb[key]) < 1e-11, key


def test_measurement_columns_take_a_leg(heli4):
    from eigentwist.diagnose.measurements import parse_csv

    text = "k_a,mode,freq_hz,eta_a@3\n2000,x,20.5,0.5\n1000,y,15.0,0.6\n"
    meas = parse_csv(text, "legs.csv", heli4)
    np.testing.assert_array_equal(meas.evaluation_params()["eta_a@3"], [0.5, 0.6])


def test_the_command_line_takes_scoped_names(capsys):
    from eigentwist.cli.main import main

    assert main(["matrices", "--model", "paper,actuator_loss@3", "--set", "eta_a@3=0.5", "--json"]) == 0
    capsys.readouterr()
    assert main(["matrices", "--model", "paper,actuator_loss@9"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "actuator_loss@N with N in 1..4" in err
