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


def _contracted_differences(ev, x, wrt, model, params, W, h_rel=1e-5):
    """Central differences of <W, M> (``ev.matrices``) for each parameter of ``wrt``."""
    out = []
    for name in wrt:
        v = params.get(name, ev.defaults[name.partition("@")[0]])
        h = h_rel * abs(v)
        hi, lo = ({**params, name: v + s * h} for s in (1, -1))
        m_hi, m_lo = (ev.matrices(x, model, **pp)["M"] for pp in (hi, lo))
        out.append(np.einsum("ij,nij->n", W, m_hi - m_lo) / (2 * h))
    return np.stack(out, axis=-1)


def test_weighted_mass_follows_a_legs_own_value_and_refuses_other_weights(ev):
    """<W, M> and its gradient from the reverse-mode kernel (what the moving-mass constraint
    reads) equal ``matrices`` contracted with W and its central differences, with leg 2's
    rotor inertia given its own value (d/dI_add moves legs 1, 3, 4 only); weights that are
    not a symmetric 6 x 6 matrix are refused, naming their shape."""
    from eigentwist.runtime.errors import InputError

    rng = np.random.default_rng(4)
    W = rng.normal(size=(6, 6))
    W = W + W.T
    x = np.array(ev.robot.x_ref) + 0.02 * rng.standard_normal((3, 3))
    model = "paper,rotor_inertia"
    params = {"I_add": 2e-4, "I_add@2": 5e-4}
    wrt = ("I_add", "I_add@2", "l2", "m_e")
    value, grad = ev.sensitivity_route.weighted_mass(x, wrt, model, params, W)
    np.testing.assert_allclose(value, np.einsum("ij,nij->n", W, ev.matrices(x, model, **params)["M"]), rtol=1e-12)
    want = _contracted_differences(ev, x, wrt, model, params, W)
    np.testing.assert_allclose(grad, want, rtol=1e-6, atol=1e-8 * np.abs(want).max())
    assert np.abs(grad[:, 0]).max() > 0 and np.abs(grad[:, 1]).max() > 0
    with pytest.raises(InputError, match=r"weights of shape \(6, 5\): expected a symmetric 6x6 matrix"):
        ev.sensitivity_route.weighted_mass(x, wrt, model, params, W[:, :5])
    # symmetric to round-off (1e-12 of its largest entry) is symmetric; 1e-10 off is not
    scale = np.abs(W).max()
    for off, refused in ((1e-14, False), (1e-10, True)):
        skewed = W + off * scale * np.triu(np.ones((6, 6)), 1)
        if refused:
            with pytest.raises(InputError, match="symmetric"):
                ev.sensitivity_route.weighted_mass(x, wrt, model, params, skewed)
        else:
            assert ev.sensitivity_route.weighted_mass(x, wrt, model, params, skewed)[0] == pytest.approx(value)
