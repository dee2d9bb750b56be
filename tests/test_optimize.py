"""Worst-case frequency optimisation: known optimum, bounds, constraints, no FD."""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist
from eigentwist.design import Constraint, Vary, moving_mass, optimize_worst_case
from eigentwist.runtime import sensitivity as sens

from .test_sensitivity import WRT


@pytest.fixture(scope="module")
def ev():
    ev = eigentwist.load("heli4", backend="numpy")
    ev.sensitivities(ev.robot.x_ref, WRT["heli4"])  # one generated kernel serves every subset below
    return ev


def _count_calls(monkeypatch, ev):
    calls = {"sens": 0, "freq": 0}
    real = sens.frequency_sensitivities

    def counted(*a, **k):
        calls["sens"] += 1
        return real(*a, **k)

    monkeypatch.setattr(sens, "frequency_sensitivities", counted)
    real_modes = ev.modes

    def modes(*a, **k):
        calls["freq"] += 1
        return real_modes(*a, **k)

    monkeypatch.setattr(ev, "modes", modes)
    return calls


def test_one_parameter_optimum_equals_brute_force(ev, monkeypatch):
    """f1(l1) of the paper model at two poses has an interior maximum of its minimum."""
    poses = np.array([ev.robot.x_ref, [0.05, -0.03, -0.6]])
    grid = np.linspace(0.15, 0.25, 401)
    f1 = ev.frequencies(np.repeat(poses, len(grid), axis=0), "paper", l1=np.tile(grid, len(poses)))[:, 0]
    worst = f1.reshape(len(poses), -1).min(axis=0)
    k = int(np.argmax(worst))
    assert 0 < k < len(grid) - 1  # interior: a real optimum
    calls = _count_calls(monkeypatch, ev)
    res = optimize_worst_case(ev, [Vary("l1", 0.15, 0.25)], poses, "paper")
    assert abs(res.values["l1"] - grid[k]) <= grid[1] - grid[0]
    assert res.worst_hz >= worst[k] - 1e-6
    assert 0.15 <= res.values["l1"] <= 0.25
    # exact gradients: one kernel call per design point, no frequency-only evaluations (no FD)
    assert calls["freq"] == 0
    assert calls["sens"] == res.evaluations <= 3 * max(res.nit, 1) + 3


@pytest.mark.parametrize("method", ["SLSQP", "trust-constr"])
def test_bounds_and_mass_constraint_are_respected(ev, method):
    poses = np.array([ev.robot.x_ref, [0.04, 0.04, -0.62]])
    vary = [Vary("l2", 0.5, 0.56), Vary("m_e", 0.3, 0.6)]
    start_mass, _ = moving_mass(ev, ("l2", "m_e"), {})
    limit = start_mass * 0.98
    res = optimize_worst_case(
        ev, vary, poses, "paper", constraints=[Constraint("moving-mass", "<=", limit)], method=method, maxiter=60
    )
    for v in vary:
        assert v.lo - 1e-12 <= res.values[v.name] <= v.hi + 1e-12
    mass, _ = moving_mass(ev, ("l2", "m_e"), res.values)
    assert mass <= limit * (1 + 1e-6)
    assert res.worst_hz >= res.start_worst_hz - 1e-9
    assert np.isclose(res.worst_hz, ev.frequencies(poses, "paper", **res.values)[:, 0].min(), rtol=1e-12)


def test_moving_mass_gradient_equals_central_differences(ev):
    m, g = moving_mass(ev, ("l2", "m_e", "l1"), {})
    for j, name in enumerate(("l2", "m_e", "l1")):
        v, h = ev.defaults[name], 1e-5 * ev.defaults[name]
        fd = (moving_mass(ev, ("l2",), {name: v + h})[0] - moving_mass(ev, ("l2",), {name: v - h})[0]) / (2 * h)
        assert np.isclose(g[j], fd, rtol=1e-6, atol=1e-9)
