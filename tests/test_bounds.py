"""Hard physical bounds apart from plausible ranges: what every fit and difference step respects.

``Parameter.bounds`` is what the physics admits (an actuator delivers at most its commanded
stiffness: eta_a in (0, 1]); the constraints between parameters (a tube's inner radius below its
outer one, the inertia triangle inequality) cut a fitted parameter's range; a difference step
never crosses either.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import eigentwist
from eigentwist.description.effects import EFFECTS
from eigentwist.diagnose.fit import Transform, constraint_range
from eigentwist.runtime import InputError


@pytest.fixture(scope="module")
def delta():
    return eigentwist.load("delta", backend="numpy")


def test_eta_a_hard_bound_is_zero_to_one_with_one_included():
    eta = EFFECTS["actuator_loss"].params[0]
    assert eta.admits(1.0) and eta.admits(1e-6)  # just inside, both ends
    assert not eta.admits(1.0 + 1e-12) and not eta.admits(0.0)  # just outside
    with pytest.raises(ValueError, match=r"eta_a.*\(0, 1\]"):
        eta.check(1.0 + 1e-9)
    lo, hi = eta.plausible_range
    assert hi <= eta.bounds[1]  # a plausible value is always admissible


def test_a_positive_parameter_excludes_zero_and_admits_any_positive_value():
    k_t = EFFECTS["transmission_compliance"].params[0]
    assert k_t.admits(1e-300) and not k_t.admits(0.0) and not k_t.admits(-1.0) and not k_t.admits(math.inf)


def test_the_tube_constraint_cuts_the_outer_radius_range_at_the_inner_one(delta):
    r_i = 0.013
    lo, hi = constraint_range(delta, "r_o_l1", {"r_i_l1": r_i}, ("lower_link_compliance",))
    assert lo == pytest.approx(r_i) and hi == math.inf
    lo, hi = constraint_range(delta, "r_i_l1@2", {"r_o_l1@2": 0.02, "r_o_l1": 0.015}, ("lower_link_compliance@2",))
    assert hi == pytest.approx(0.02) and lo == -math.inf  # a leg's own copy pairs with its own partner
    # the effect not in the model: no constraint
    assert constraint_range(delta, "r_o_l1", {"r_i_l1": r_i}, ("actuator_loss",)) == (-math.inf, math.inf)
    t = Transform.of(delta.parameter("r_o_l1")).within(lo=r_i, hi=math.inf)
    assert r_i < t.lo < r_i * (1 + 1e-8)  # strictly inside, by a relative margin
    with pytest.raises(InputError, match="no range"):
        Transform.of(delta.parameter("r_o_l1")).within(lo=1.0, hi=0.5)


def test_the_triangle_inequality_bounds_each_moment_by_the_other_two(delta):
    vals = {"I_e_xx": 1.875e-4, "I_e_yy": 1.875e-4, "I_e_zz": 3.75e-4}
    lo, hi = constraint_range(delta, "I_e_zz", vals, ())
    assert hi == pytest.approx(3.75e-4) and lo == pytest.approx(0.0, abs=1e-18)
    lo, hi = constraint_range(delta, "I_e_xx", vals, ())
    assert lo == pytest.approx(1.875e-4) and hi == pytest.approx(5.625e-4)


def test_difference_derivatives_step_away_from_a_constraint_at_equality(delta):
    """The Delta's disc platform sits on the triangle inequality (I_zz = I_xx + I_yy): a step
    down in I_e_xx leaves it, so the derivative is one-sided upward and equals an independent
    forward difference of the (linear) mass matrix."""
    pose = [[0.0, 0.0, -0.75]]
    out = delta.matrix_derivatives(pose, ("I_e_xx", "I_e_zz"), "paper")
    h = 1e-4 * 1.875e-4
    up = delta.matrices(pose, "paper", I_e_xx=1.875e-4 + h)["M"]
    base = delta.matrices(pose, "paper")["M"]
    assert np.allclose(out["dM"][:, 0], (up - base) / h, rtol=1e-6, atol=1e-6)
    down = delta.matrices(pose, "paper", I_e_zz=3.75e-4 - h)["M"]
    assert np.allclose(out["dM"][:, 1], (base - down) / h, rtol=1e-6, atol=1e-6)
    # inside the constraint (not at equality): central differences give the same (M is linear in I)
    inside = delta.matrix_derivatives(pose, ("I_e_xx",), "paper", I_e_zz=3.0e-4)
    assert np.allclose(inside["dM"][:, 0], out["dM"][:, 0], rtol=1e-6, atol=1e-6)


def test_sensitivity_of_every_delta_parameter_runs_at_the_defaults(capsys):
    from eigentwist.cli.main import main

    assert main(["sensitivity", "--robot", "delta", "--backend", "numpy", "--wrt", "all"]) == 0
    assert "I_e_zz" in capsys.readouterr().out


def test_a_fit_of_the_outer_radius_stays_above_the_inner_one(delta):
    """A tube 0.2 mm thicker than its inner radius: the fit of r_o_l1 from the default 15 mm down
    to it never steps across r_i_l1 (13 mm), and lands on the truth."""
    from eigentwist.diagnose import synth
    from eigentwist.diagnose.fit import fit

    truth = 0.0132
    meas = synth(
        f"paper+lower_link_compliance:r_o_l1={truth}",
        (1000, 4000),
        [[0.0, 0.0, -0.75]],
        ("x", "z"),
        0.0,
        seed=0,
        ev=delta,
    )
    f = fit(meas, ("actuator_loss", "rod_compliance", "lower_link_compliance"), delta, ("r_o_l1",))
    assert 0.013 < f.values["r_o_l1"] and f.values["r_o_l1"] == pytest.approx(truth, rel=1e-4)


def test_an_optimisation_box_across_a_constraint_is_one_error_line(delta):
    from eigentwist.design.optimize import Vary, optimize_worst_case

    with pytest.raises(InputError, match=r"vary r_o_l1=0.012:0.02: .*r_i_l1 = 0.013.*inner radius"):
        optimize_worst_case(
            delta, [Vary("r_o_l1", 0.012, 0.02)], [[0.0, 0.0, -0.75]], model="paper,lower_link_compliance"
        )


def test_the_only_explanation_implausible_names_the_inputs_to_check(delta):
    """A thinner tube than the model's: lower_link_compliance would explain the data only with a
    modulus below any tube material's; the answer names that value beside the tube's radii."""
    from types import SimpleNamespace as NS

    from eigentwist.diagnose.answer import check_inputs

    final = NS(aicc=100.0, effects=("actuator_loss", "rod_compliance"), names=(), values={}, fixed={})
    cand = NS(
        effect="lower_link_compliance",
        plausible=False,
        implausible={"E_l1": 1.78e10},
        names=("E_l1",),
        p_value=1e-9,
        fit=NS(aicc=20.0, names=("E_l1",), fixed={"E_l1": 1.78e10}, values={"E_l1": 1.78e10}),
    )
    d = NS(implausible={}, explained=False, manual=False, final=final, alpha=0.01, steps=[NS(ranking=[cand])])
    text = check_inputs(d, delta)
    lo, hi = delta.parameter("E_l1").plausible_range
    assert text.startswith("Check the inputs: lower_link_compliance needs E_l1 = 1.78e+10 Pa")
    assert f"plausible {lo:.3g} ... {hi:.3g} Pa" in text
    assert "r_o_l1 = 0.015 m" in text and "r_i_l1 = 0.013 m" in text and "dimensions" in text
    # a candidate that would not be significant even with its value allowed: nothing to check
    cand.p_value = 0.5
    assert check_inputs(d, delta) is None
