"""The routes table of ``Evaluator.modes`` (eigentwist.runtime.routes)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import eigentwist
from eigentwist.runtime import evaluator as evaluator_module
from eigentwist.runtime.routes import ANY, ROUTES, Route, choose_route

CASES = list(itertools.product((False, True), repeat=5))  # c_pass, exact, damped, pass_solves, c_backend


def expected(c_pass, exact, damped, solves, c_backend) -> Route:
    """The rules as stated in the module's docstrings, written out as formulas."""
    if c_pass:
        if exact:
            return Route("pass", "exact" if solves else None)
        if damped:
            return Route("pass", "pass" if solves else "keep")
        return Route("pass", None)
    return Route("matrices", keep=exact or (damped and not c_backend))


@pytest.mark.parametrize("case", CASES, ids=lambda c: "".join("TF"[not b] for b in c))
def test_every_case_takes_the_route_its_rules_give(case):
    c_pass, exact, damped, solves, c_backend = case
    assert choose_route(c_pass, exact, damped, lambda: solves, c_backend) == expected(*case)


def test_each_case_matches_one_row_and_every_row_is_used():
    used = set()
    for case in CASES:
        rows = [k for k, (cond, _) in enumerate(ROUTES) if all(w is ANY or w == v for w, v in zip(cond, case))]
        assert len(rows) == 1, (case, rows)
        used.add(rows[0])
    assert used == set(range(len(ROUTES)))


@pytest.mark.parametrize("c_pass, exact, damped", [(False, True, True), (True, False, False), (False, False, True)])
def test_the_c_pass_question_is_asked_only_where_a_row_depends_on_it(c_pass, exact, damped):
    def never():
        raise AssertionError("asked")

    choose_route(c_pass, exact, damped, never, True)


def test_the_c_pass_question_is_asked_once():
    asked = []
    route = choose_route(True, False, True, lambda: asked.append(1) or False, True)
    assert route == Route("pass", "keep") and asked == [1]


def test_the_numpy_backend_takes_the_matrices_route_and_keeps_a_damped_models_outputs(monkeypatch):
    chosen = []
    real = evaluator_module.choose_route
    monkeypatch.setattr(evaluator_module, "choose_route", lambda **kw: chosen.append(real(**kw)) or chosen[-1])
    ev = eigentwist.load("heli4", backend="numpy")
    poses = np.array([[0.02, -0.03, -0.62]])
    ev.modes(poses, "rigid")
    ev.modes(poses, "servo_damping")
    assert chosen == [Route("matrices", keep=False), Route("matrices", keep=True)]


@pytest.mark.compiled
def test_the_c_backend_takes_the_pass_unless_the_gravity_preload_is_on(monkeypatch):
    chosen = []
    real = evaluator_module.choose_route
    monkeypatch.setattr(evaluator_module, "choose_route", lambda **kw: chosen.append(real(**kw)) or chosen[-1])
    ev = eigentwist.load("heli4", backend="c", threads=1)
    poses = np.array([[0.02, -0.03, -0.62], [-0.05, 0.04, -0.6]])
    ev.modes(poses, "paper", complex_shapes=True)  # complex shapes: past the prepared pass
    ev.modes(poses, "paper,gravity_preload", complex_shapes=True)
    assert [r.solver for r in chosen] == ["pass", "matrices"]


POSES = np.array([[0.02, -0.03, -0.62], [-0.05, 0.04, -0.6]])


@pytest.mark.parametrize("bad", [{"m_e": np.nan}, {"k_A": 1.0}, {"r_i_l1@2": 0.02}])
def test_a_refused_call_leaves_the_models_route_as_it_was(bad):
    """The route's probe at x_ref runs with the call's values: values refused there (they are
    refused by the call too) decide nothing for the next calls."""
    from eigentwist.runtime import condense
    from eigentwist.runtime.errors import InputError

    ev = eigentwist.load("heli4", backend="numpy")
    model = "paper,lower_link_compliance"
    with pytest.raises(InputError):
        ev.frequencies(POSES, model, **bad)
    params, condensed = ev.constraint_route(model)
    assert not condensed and params["c_rigid"] is condense.EXACT


def test_a_reference_out_of_reach_condenses_that_call_only():
    ev = eigentwist.load("heli4", backend="numpy")
    model = "actuator_loss,rod_compliance"
    assert ev.constraint_route(model, l2=0.3)[1] is True  # x_ref unreachable with l2 = 0.3 m
    assert ev.constraint_route(model)[1] is False  # the description's l2: probed, no rigid direction
    assert ev.constraint_route(model, l2=0.3)[1] is False  # remembered per model from then on


def test_the_probe_takes_the_first_poses_values_of_per_pose_arrays():
    """A model's route is probed at x_ref with the first pose's values; per-pose values (an
    (N,) array) are not refused there (the paper model: no rigid direction, K_F exact)."""
    from eigentwist.runtime import condense

    ev = eigentwist.load("heli4", backend="numpy")
    params, condensed = ev.constraint_route("paper", k_a=np.array([1500.0, 2500.0, 2000.0]))
    assert not condensed and params["c_rigid"] is condense.EXACT
    assert params["k_a"].tolist() == [1500.0, 2500.0, 2000.0]  # the call's own values, whole
    rigid_rods = eigentwist.load("heli4", backend="numpy")  # rods 1e30 N/m2 at every pose: rigid directions
    assert rigid_rods.constraint_route("paper", E_rod=np.array([1e30, 1e30]), G_rod=np.array([1e30, 1e30]))[1]
