"""The compiled damped solver (:mod:`eigentwist.runtime.c_damped`) against the NumPy one
(:func:`eigentwist.runtime.damped.damped_modes`, itself tested against independent models in
tests/test_damped.py): random well-conditioned problems and the Heli4's paper poses, with
overdamped modes, eliminated legs and growing modes; its size guards and the dispatch."""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist
from eigentwist.runtime import c_damped
from eigentwist.runtime.damped import RIGID, actuator_wrenches, damped_modes

from .conftest import skip_tier

pytestmark = pytest.mark.compiled

#: both solvers are backward stable on the same state matrix (~1e-15 |s| apart, seen ~2e-14
#: on these cases): poles, omega_n and omega_d agree to RTOL of |s|, zeta (a ratio) to RTOL
RTOL = 1e-10
X_REF = np.array([0.0, 0.0, -0.625])


@pytest.fixture(scope="module")
def driver():
    from eigentwist.runtime.ccompile import CompilerNotFoundError, find_compiler

    try:
        find_compiler()
    except CompilerNotFoundError as exc:
        skip_tier("compiled", str(exc))
    assert c_damped.driver() is not None
    return c_damped.driver()


def _agree(c, numpy):
    """The two solvers' results for the same problem, to RTOL (a column without a pole, a rigid
    constraint's mode, keeps the undamped frequency on both)."""
    scale = np.abs(numpy.poles)
    assert np.array_equal(np.isnan(c.poles), np.isnan(numpy.poles))
    ok = ~np.isnan(numpy.poles)
    np.testing.assert_array_equal(np.isnan(c.natural_hz), np.isnan(numpy.natural_hz))
    assert np.all(np.abs(c.poles - numpy.poles)[ok] <= RTOL * scale[ok])
    for name in ("natural_hz", "damped_hz"):
        a, b = getattr(c, name)[ok], getattr(numpy, name)[ok]
        assert np.all(np.abs(a - b) <= RTOL * scale[ok] / (2 * np.pi)), name
    assert np.all(np.abs(c.damping_ratio - numpy.damping_ratio)[ok] <= RTOL)
    assert np.array_equal(c.stable, numpy.stable)


def _problem(rng, N, n, L, c_scale, t_d, rigid_legs=0):
    """N poses: SPD M and K (omega ~ 100 rad/s), L legs of random wrenches; ``rigid_legs``
    legs without series compliance (h = k_d: beta = 0, eliminated)."""
    A = rng.normal(size=(N, n, n))
    M = A @ np.swapaxes(A, -1, -2) + n * np.eye(n)
    B = rng.normal(size=(N, n, n))
    K = 1e4 * (B @ np.swapaxes(B, -1, -2) + n * np.eye(n))
    W = 50.0 * rng.normal(size=(N, L, n))
    kd = rng.uniform(100.0, 4000.0, (N, L))
    h = kd * rng.uniform(0.3, 0.95, (N, L))
    h[:, :rigid_legs] = kd[:, :rigid_legs]
    return M, K, W, h, kd, c_scale * rng.uniform(0.5, 4.0, (N, L)), np.full((N, L), t_d)


@pytest.mark.parametrize(
    "n, L, c_scale, t_d, rigid_legs",
    [(4, 4, 1.0, 0.0, 0), (6, 4, 10.0, 0.0, 2), (6, 6, 1.0, 2e-3, 0), (3, 2, 3000.0, 0.0, 2), (2, 1, 0.0, 0.0, 0)],
)
def test_random_problems_agree(driver, n, L, c_scale, t_d, rigid_legs):
    rng = np.random.default_rng(n * 10 + L)
    args = _problem(rng, 30, n, L, c_scale, t_d, rigid_legs)
    numpy = damped_modes(*args)
    _agree(damped_modes(*args, solver="c"), numpy)
    if c_scale == 3000.0:  # strong damping through eliminated legs: overdamped modes
        assert np.any(numpy.damped_hz == 0) and np.all(numpy.damping_ratio[numpy.damped_hz == 0] > 1)
    if t_d:  # a lag above c/t: growing modes
        assert not numpy.stable.all() and numpy.stable.any()


@pytest.mark.parametrize(
    "n, L, c_scale, t_d, rigid_legs", [(4, 4, 1.0, 0.0, 0), (6, 6, 1.0, 2e-3, 0), (3, 2, 3000.0, 0.0, 2)]
)
def test_random_problems_with_loss_agree(driver, n, L, c_scale, t_d, rigid_legs):
    """A structural loss factor: stiffness K + i K_loss, complex wrenches (a leg's loss makes
    its w_i and h_i complex): the complex C solver and the NumPy one (stacked eig) agree,
    overdamped legs and a lag included."""
    rng = np.random.default_rng(n * 10 + L + 1)
    M, K, W, h, kd, cd, td = _problem(rng, 30, n, L, c_scale, t_d, rigid_legs)
    args = (M, K, W * (1 + 0.03j), h * (1 + 0.01j), kd, cd, td)
    kw = {"K_loss": 0.04 * K}
    _agree(damped_modes(*args, solver="c", **kw), damped_modes(*args, **kw))


@pytest.fixture(scope="module")
def backends(driver):
    return {b: eigentwist.load("heli4", backend=b) for b in ("numpy", "c")}


@pytest.mark.parametrize(
    "model, params",
    [
        ("damped", {"k_a": np.array([125.0, 500.0, 2000.0, 4000.0])}),  # zeta 0.45 ... 0.03
        ("rigid,servo_damping", {"k_a": np.array([125.0, 4000.0]), "c_a": 3.0}),  # every leg eliminated
        ("rigid,servo_damping", {"k_a": np.array([125.0, 300.0]), "c_a": 20.0}),  # overdamped modes
        ("damped,servo_delay", {"k_a": np.array([2200.0, 4000.0]), "t_d": 1.3e-3}),  # growing above c/t
        ("damped,structural_loss", {"k_a": np.array([125.0, 4000.0]), "eta_s": 0.05}),  # complex
        ("actuator_loss,ee_compliance,servo_damping,structural_loss", {"k_a": np.array([125.0]), "eta_s": 0.1}),
    ],
)
def test_heli4_paper_poses_agree(backends, model, params):
    """The Heli4's paper poses (the reference pose and the campaign's), each k_a: the C
    backend (compiled solver) and the NumPy backend (NumPy solver) give the same poles."""
    poses = np.array([X_REF, [0.0, 0.1, -0.55], [0.1, 0.0, -0.55], [0.05, -0.03, -0.6]])
    ka = params["k_a"]
    P = np.repeat(poses, len(ka), axis=0)
    kw = dict(params, k_a=np.tile(ka, len(poses)))
    c, numpy = (backends[b].modes(P, model, vectors=False, unstable="nan", **kw).damping for b in ("c", "numpy"))
    _agree(c, numpy)
    if params.get("c_a") == 20.0:
        assert np.any(numpy.damped_hz == 0)
    if "t_d" in params:
        assert not numpy.stable.all() and numpy.stable.any()


def test_dispatch(backends, monkeypatch):
    """The C backend's evaluator solves by the driver, the NumPy one does not; complex shapes
    stay in NumPy, a loss factor goes to the complex driver; the fused pass solves its routes
    itself, the exact condensation's too (its own pass), except with complex shapes (NumPy) or
    a loss factor (the complex driver)."""
    calls = []
    solve, one_pass, solve_legs = c_damped.solve, c_damped.one_pass, c_damped.solve_legs
    exact_pass, solve_complex = c_damped.exact_pass, c_damped.solve_complex
    monkeypatch.setattr(
        c_damped, "solve_complex", lambda *a, **k: calls.append(("complex", len(a[1]))) or solve_complex(*a, **k)
    )
    monkeypatch.setattr(c_damped, "solve", lambda *a, **k: calls.append(("solve", len(a[1]))) or solve(*a, **k))
    monkeypatch.setattr(c_damped, "one_pass", lambda *a, **k: calls.append(("pass", a[3])) or one_pass(*a, **k))
    monkeypatch.setattr(c_damped, "solve_legs", lambda *a: calls.append(("legs", len(a[3]))) or solve_legs(*a))
    monkeypatch.setattr(c_damped, "exact_pass", lambda *a: calls.append(("exact", a[3])) or exact_pass(*a))
    for model in ("damped", "paper,structural_loss", EXACT):  # each route probed once (IK, legs at x_ref)
        for b in ("numpy", "c"):
            backends[b].modes(X_REF, model, k_a=125.0, eta_s=0.05)
    calls.clear()
    ran = []
    for kernels in (backends["numpy"].kernels, backends["c"].kernels):  # no kernel runs twice: the legs after
        for name in ("inverse_kinematics", "matrices", "legs"):
            monkeypatch.setattr(kernels, name, lambda *a, f=getattr(kernels, name), k=name: ran.append(k) or f(*a))
    backends["numpy"].modes(X_REF, "damped", k_a=125.0)
    assert ran == ["inverse_kinematics", "matrices", "legs"]
    ran.clear()
    backends["c"].modes(X_REF, "damped", k_a=125.0, complex_shapes=True)  # the fused pass, then the legs
    backends["c"].modes(X_REF, "paper,structural_loss", k_a=125.0, eta_s=0.05)
    assert calls == [("complex", 1)] and ran == ["legs", "legs"]
    calls.clear()
    backends["c"].modes(np.tile(X_REF, (3, 1)), EXACT, k_a=[125.0, 125.0, 500.0])
    assert ran[:2] == ["legs", "legs"] and "legs" not in ran[2:]  # its pass runs the legs kernel itself
    backends["c"].modes(np.tile(X_REF, (3, 1)), "damped", k_a=[125.0, 125.0, 500.0])
    backends["c"].modes(X_REF, "rigid,servo_damping", k_a=125.0)
    assert calls == [("exact", 3), ("pass", 3), ("pass", 1)]
    # legs with rigid directions and the user's finite c_rigid: K_F not exact, not the pass's route
    backends["c"].modes(np.tile(X_REF, (3, 1)), EXACT, k_a=[125.0, 125.0, 500.0], c_rigid=1e-7)
    assert calls[3:] == [("legs", 2)]  # rows of one condition solved once
    ran.clear()
    backends["c"].modes(np.tile(X_REF, (3, 1)), EXACT, k_a=[125.0, 125.0, 500.0], complex_shapes=True)
    assert calls[4:] == [] and "legs" in ran  # complex shapes: the NumPy solver
    ran.clear()
    backends["c"].modes(X_REF, EXACT + ",structural_loss", k_a=125.0, eta_s=0.05)
    assert calls[4:] == [("complex", 1)] and "legs" in ran
    backends["c"].modes(X_REF, "actuator_loss,ee_coupling,servo_damping,structural_loss", k_a=125.0, eta_s=0.05)
    assert calls[5:] == []  # legs on coupled platform bodies: NumPy


#: a flexible model whose legs have rigid directions (the exact condensation: not in the fused pass)
EXACT = "actuator_loss,ee_compliance,servo_damping"
ONE_PASS = [
    ("damped", {"k_a": np.array([125.0, 4000.0])}),
    ("damped,servo_delay", {"k_a": np.array([125.0, 2000.0]), "t_d": 5e-4}),
    ("rigid,servo_damping", {"k_a": np.array([125.0, 4000.0]), "c_a": 20.0}),
]


def _poses_and_kw(params, unreachable: bool = False):
    """The paper poses × k_a (and, where asked, an unreachable pose), with the kwargs."""
    poses = np.array([X_REF, [0.0, 0.1, -0.55], [0.1, 0.0, -0.55], [0.05, -0.03, -0.6]])
    if unreachable:
        poses = np.vstack([poses, [0.0, 0.0, -2.0]])
    ka = params["k_a"]
    return np.repeat(poses, len(ka), axis=0), dict(params, k_a=np.tile(ka, len(poses)))


def _same(a, b, rtol):
    """Two Damping results equal to rtol of the pose's largest |s| (an eigensolver's error is
    backward stable: relative to the matrix's norm, so a pole 100 times slower than the
    fastest has 100 times its relative error); NaN where the other is NaN; a column without a
    pole, a rigid constraint's mode, keeps the undamped frequency on both."""
    assert np.array_equal(np.isnan(a.poles), np.isnan(b.poles))
    ok = ~np.isnan(b.poles)
    np.testing.assert_array_equal(a.natural_hz[~ok], b.natural_hz[~ok])
    # a row without a pole (an unreachable pose's) has no scale: its entries are not compared
    size = np.where(ok, np.abs(b.poles), 0.0).max(axis=1, keepdims=True)
    top = np.broadcast_to(size, b.poles.shape)[ok]
    assert np.all(np.abs(a.poles - b.poles)[ok] <= rtol * top)
    for name in ("natural_hz", "damped_hz"):
        assert np.all(np.abs(getattr(a, name) - getattr(b, name))[ok] <= rtol * top / (2 * np.pi)), name
    assert np.all(np.abs(a.damping_ratio - b.damping_ratio)[ok] <= rtol * top / np.abs(b.poles[ok]))
    assert np.array_equal(a.stable, b.stable)


@pytest.mark.parametrize("model, params", ONE_PASS)
def test_one_pass_against_two_steps_and_numpy(backends, monkeypatch, model, params):
    """The fused pass's damped modes (kernels and solve in one C call) equal, to 1e-12 of the largest |s|,
    the two-step route (kernels, then the driver) and the NumPy solver (stacked eig) on the
    same kernels' outputs, with an unreachable pose among them (invalid="nan": NaN on every
    route). (The NumPy backend's own kernels round differently: its undamped frequencies of
    the flexible model already differ by ~1e-12, K_F's condition; test_heli4_paper_poses_agree.)"""
    from eigentwist.runtime import damped_modes as dm

    P, kw = _poses_and_kw(params, unreachable=True)
    ev = backends["c"]
    one = ev.modes(P, model, vectors=False, invalid="nan", **kw)
    monkeypatch.setattr(dm, "one_pass_takes", lambda *a: False)
    two = ev.modes(P, model, vectors=False, invalid="nan", **kw)
    monkeypatch.setattr(dm, "solver_of", lambda ev: "numpy")
    numpy = ev.modes(P, model, vectors=False, invalid="nan", **kw)
    bad = len(params["k_a"])  # the unreachable pose's rows, last
    assert np.isnan(one.damping.natural_hz[-bad:]).all() and not one.valid[-bad:].any() and one.valid[:-bad].all()
    _same(one.damping, two.damping, 1e-12)
    _same(one.damping, numpy.damping, 1e-12)
    np.testing.assert_array_equal(one.freq_hz, two.freq_hz)
    np.testing.assert_array_equal(one.stable, two.stable)


def test_one_pass_leaves_undecided_poses_to_the_two_step_route(backends, monkeypatch):
    """Poses the driver marks undecided are solved from the pass's own kernel outputs by the
    two-step route: the same poles as where the pass decided them."""
    P, kw = _poses_and_kw(ONE_PASS[0][1])
    ev = backends["c"]
    decided = ev.modes(P, "damped", vectors=False, **kw).damping
    one_pass = c_damped.one_pass

    def undecided(*a, **k):
        out = one_pass(*a, **k)
        out[-1][::2] = True
        return out

    calls = []
    solve_legs = c_damped.solve_legs
    monkeypatch.setattr(c_damped, "one_pass", undecided)
    monkeypatch.setattr(c_damped, "solve_legs", lambda *a: calls.append(len(a[3])) or solve_legs(*a))
    _same(ev.modes(P, "damped", vectors=False, **kw).damping, decided, 1e-12)
    assert calls == [len(P[::2])]


@pytest.mark.parametrize("n, decided", [(10, True), (11, False)])
@pytest.mark.parametrize("eta", [0.0, 0.02])
def test_assignment_guard(driver, n, decided, eta):
    """Modes of one frequency (no order decides, every share alike) go to the one-to-one
    assignment by share, which the driver does for up to MAX_ASSIGN (10) poles of positive
    frequency; the 11th pose goes to NumPy. Both routes give every mode its pole: omega, or
    with a loss factor eta (K + i eta K) s = i omega sqrt(1 + i eta), |s| = omega (1 +
    eta^2)^(1/4), zeta = sin(atan(eta) / 2)."""
    om = 2 * np.pi * 10.0
    M, K = np.eye(n)[None], om**2 * np.eye(n)[None]
    W, h, kd, zero = np.ones((1, 1, n)), np.array([[1e3]]), np.array([[1e3]]), np.zeros((1, 1))
    if eta:
        *_, redo = c_damped.solve_complex(M, K, eta * K, W + 0j, h + 0j, kd, zero, zero, 1e-9, 1e-9, 0.5)
    else:
        *_, redo = c_damped.solve(M, K, W, h, kd, zero, zero, 1e-9, 1e-9, 0.5)
    assert bool(redo[0]) is not decided
    d = damped_modes(M, K, W, h, kd, 0.0, 0.0, K_loss=eta * K if eta else None, solver="c")
    np.testing.assert_allclose(d.natural_hz, 10.0 * (1 + eta**2) ** 0.25, rtol=1e-12)
    np.testing.assert_allclose(d.damping_ratio, np.sin(np.arctan(eta) / 2), atol=1e-12)


@pytest.mark.parametrize("n, compiled", [(c_damped.MAX_MODES, True), (c_damped.MAX_MODES + 1, False)])
@pytest.mark.parametrize("loss", [False, True])
def test_size_guard(driver, monkeypatch, n, compiled, loss):
    """Up to MAX_MODES modes the driver (real, or complex with a loss factor) solves; one more
    goes to NumPy; both agree."""
    calls = []
    name = "solve_complex" if loss else "solve"
    solve = getattr(c_damped, name)
    monkeypatch.setattr(c_damped, name, lambda *a, **k: calls.append(1) or solve(*a, **k))
    args = _problem(np.random.default_rng(n), 3, n, 2, 1.0, 0.0)
    kw = {"K_loss": 0.03 * args[1]} if loss else {}
    _agree(damped_modes(*args, solver="c", **kw), damped_modes(*args, **kw))
    assert bool(calls) is compiled


@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_wrenches_rigid_threshold(driver, factor):
    """A joint-compliance eigenvalue just inside (0.5) or outside (2) RIGID times the largest:
    rigid (left out of the pseudo-inverse) or a stiff spring; both routes alike, and J_e^T C_q^+ J_e
    computed here."""
    rng = np.random.default_rng(3)
    U = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    lam = np.array([1e-3, 2e-3, factor * RIGID * 2e-3])
    Cq = (U * lam) @ U.T
    Je = rng.normal(size=(3, 6))
    Cp = (U[:, :2] / lam[:2]) @ U[:, :2].T if factor < 1 else np.linalg.inv(Cq)
    for solver in ("numpy", "c"):
        K, W, h = actuator_wrenches(Je[None, None], Cq[None, None], None, solver=solver)
        np.testing.assert_allclose(K[0], Je.T @ Cp @ Je, rtol=1e-6)
        np.testing.assert_allclose(h[0, 0], Cp[0, 0], rtol=1e-6)


@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_wrenches_with_loss(driver, factor):
    """A structural loss factor eta: the joint compliance (C_s / (1 + i eta) + a0 e0 e0^T),
    complex symmetric, with a passive direction (orthogonal to the actuated joint e0) whose
    eigenvalue lies just inside (0.5) or outside (2) RIGID times the largest: left out (the
    inverse on the other two directions, computed here) or a stiff spring (the inverse); the
    compiled wrenches and NumPy's (eig of the complex matrix) alike."""
    rng = np.random.default_rng(4)
    t = rng.uniform(0.0, np.pi)
    plane = np.array([[1.0, 0.0], [0.0, 0.8], [0.0, -0.6]]) @ [[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]
    V = np.column_stack([plane, [0.0, 0.6, 0.8]])  # orthonormal; the third orthogonal to e0
    a0, eta = 1e-3, 0.05
    e0 = np.eye(3)[0]
    top = np.linalg.eigvalsh((V[:, :2] * [1e-3, 2e-3]) @ V[:, :2].T + a0 * np.outer(e0, e0))[-1]
    Cs = (V * [1e-3, 2e-3, factor * RIGID * top]) @ V.T
    Cq = Cs + a0 * np.outer(e0, e0)
    Cc = Cs / (1 + 1j * eta) + a0 * np.outer(e0, e0)
    P = V[:, :2]
    X = P @ np.linalg.inv(P.T @ Cc @ P) @ P.T if factor < 1 else np.linalg.inv(Cc)
    Je = rng.normal(size=(3, 6))
    # the stiff spring's inverse has condition ~1 / (2 RIGID): ~1e-6 of the largest entries
    close = lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-6 * np.abs(b).max())  # noqa: E731
    for solver in ("numpy", "c"):
        K, W, h = actuator_wrenches(Je[None, None], Cq[None, None], np.array([[a0]]), np.array([eta]), solver=solver)
        close(K[0], Je.T @ X @ Je)
        close(W[0, 0], X[:, 0] @ Je)
        close(h[0, 0], X[0, 0])


@pytest.mark.parametrize("loss", [False, True])
def test_threads_give_the_same_poles(driver, loss):
    """Ranges of whole blocks on two threads: each pose solved alone, the same bits (the real
    driver and, with a loss factor, the complex one)."""
    args = _problem(np.random.default_rng(7), 40 * c_damped.BLOCK, 2, 1, 1.0, 0.0)
    kw = {"K_loss": 0.05 * args[1]} if loss else {}
    one, two = (damped_modes(*args, solver="c", threads=t, **kw) for t in (1, 2))
    np.testing.assert_array_equal(one.poles, two.poles)
    np.testing.assert_array_equal(one.stable, two.stable)


def test_exact_route_from_the_legs_in_one_call(backends, monkeypatch):
    """The exact condensation's route outside its fused pass solves from the legs' outputs in
    one C call (wrenches, projection, solve); to 1e-12 of the largest |s| it equals the NumPy route of a
    problem beyond the driver's legs (NumPy glue and stacked eig), the NumPy solver, and the
    NumPy route of the poses the call leaves undecided."""
    from eigentwist.runtime import damped_modes as dm

    P, kw = _poses_and_kw({"k_a": np.array([125.0, 4000.0]), "c_a": 8.0})  # overdamped modes at 125
    ev = backends["c"]
    monkeypatch.setattr(dm, "one_pass_takes", lambda *a: False)  # not the exact condensation's own pass
    calls = []
    solve_legs, solve = c_damped.solve_legs, c_damped.solve
    monkeypatch.setattr(c_damped, "solve_legs", lambda *a: calls.append("legs") or solve_legs(*a))
    monkeypatch.setattr(c_damped, "solve", lambda *a, **k: calls.append("solve") or solve(*a, **k))
    one = ev.modes(P, EXACT, vectors=False, **kw).damping
    assert calls == ["legs"] and np.any(one.damped_hz == 0)
    with monkeypatch.context() as m:
        m.setattr(c_damped, "MAX_LEGS", ev.n_legs - 1)
        _same(one, ev.modes(P, EXACT, vectors=False, **kw).damping, 1e-12)
    assert calls == ["legs"]

    def undecided(*a):
        out = solve_legs(*a)
        out[-1][::2] = True
        return out

    with monkeypatch.context() as m:
        m.setattr(c_damped, "solve_legs", undecided)
        _same(one, ev.modes(P, EXACT, vectors=False, **kw).damping, 1e-12)
    monkeypatch.setattr(dm, "solver_of", lambda ev: "numpy")
    _same(one, ev.modes(P, EXACT, vectors=False, **kw).damping, 1e-12)
    assert calls == ["legs"]


def test_one_pass_threads_give_the_same_poles(driver):
    """The fused passes' damped modes on ranges of whole blocks on two threads: the same bits
    as one thread (each block's kernels and poses its own)."""
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

    n = 2 * MIN_BLOCKS_PER_THREAD * 64 + 5  # two threads' worth of blocks of 64 poses, a partial block
    rng = np.random.default_rng(11)
    P = np.column_stack([rng.uniform(-0.08, 0.08, n), rng.uniform(-0.08, 0.08, n), rng.uniform(-0.68, -0.58, n)])
    ka = rng.uniform(125.0, 4000.0, n)
    evs = [eigentwist.load("heli4", backend="c", threads=t) for t in (1, 2)]
    for model in ("rigid,servo_damping", EXACT):  # the fused pass's route, the exact condensation's pass
        one, two = (ev.modes(P, model, k_a=ka, vectors=False) for ev in evs)
        np.testing.assert_array_equal(one.damping.poles, two.damping.poles)
        np.testing.assert_array_equal(one.freq_hz, two.freq_hz)


#: the exact condensation's models: undamped, damped with overdamped modes (c_a = 8 at
#: k_a = 125), a lag that makes modes grow above c/t
EXACT_PASS = [
    ("actuator_loss,ee_compliance", {"k_a": np.array([125.0, 4000.0])}),
    (EXACT, {"k_a": np.array([125.0, 4000.0]), "c_a": 8.0}),
    (EXACT + ",servo_delay", {"k_a": np.array([125.0, 2200.0]), "t_d": 1.3e-3}),
]


def _same_modes(a, b):
    """Two exact condensations' modes alike to their conditioning: both solve the symmetric
    problem on bases of one admissible subspace (a rotation apart), backward stably, so
    lambda_i moves by ~eps lambda_max (frequency: half that relative to lambda_max / lambda_i)
    and an eigentwist by ~eps over its relative gap to the nearest lambda; 100 eps each.
    The damped modes to 1e-12 of the largest |s| (:func:`_same`)."""
    eps = np.finfo(float).eps
    np.testing.assert_array_equal(a.valid, b.valid)
    np.testing.assert_array_equal(a.stable, b.stable)
    np.testing.assert_array_equal(a.constrained, b.constrained)
    assert np.array_equal(np.isnan(a.freq_hz), np.isnan(b.freq_hz))
    rows = np.ones(len(b.freq_hz), dtype=bool) if b.valid is None else b.valid
    fin = ~b.constrained[rows][0]  # the finite modes' columns, alike at every valid pose
    np.testing.assert_array_equal(a.freq_hz[:, ~fin], b.freq_hz[:, ~fin])  # K_F's stand-ins
    f, lam = b.freq_hz[rows][:, fin], b.freq_hz[rows][:, fin] ** 2
    top = lam.max(axis=1, keepdims=True)
    assert np.all(np.abs(a.freq_hz[rows][:, fin] - f) <= 100 * eps * top / lam * f)
    if b.eigentwists is not None:
        gap = np.abs(lam[:, :, None] - lam[:, None, :]) + np.where(np.eye(len(lam[0]), dtype=bool), np.inf, 0)
        err = np.abs(a.eigentwists[rows][:, :, fin] - b.eigentwists[rows][:, :, fin]).max(axis=1)
        assert np.all(err <= 100 * eps * top / gap.min(axis=2))
        np.testing.assert_array_equal(a.eigentwists[:, :, ~fin], b.eigentwists[:, :, ~fin])
    assert (a.damping is None) == (b.damping is None)
    if b.damping is not None:
        _same(a.damping, b.damping, 1e-12)


@pytest.mark.parametrize("model, params", EXACT_PASS)
def test_exact_pass_against_the_python_route(backends, monkeypatch, model, params):
    """The exact condensation in its own C pass (fused pass, legs kernel, condensation and
    damped solve, no Python between them) equals the route with Python between them (the
    NumPy condensation on the C Jacobi solver, the damped modes from the legs' outputs) on
    the same kernels' outputs, an unreachable pose among them (NaN on both)."""
    from eigentwist.runtime import damped_modes as dm

    P, kw = _poses_and_kw(params, unreachable=True)
    ev = backends["c"]
    calls = []
    exact_pass = c_damped.exact_pass
    monkeypatch.setattr(c_damped, "exact_pass", lambda *a: calls.append(a[3]) or exact_pass(*a))
    one = ev.modes(P, model, invalid="nan", **kw)
    assert calls == [len(P)] and not one.valid[-2:].any() and one.valid[:-2].all()
    assert one.constrained[:-2].sum(axis=1).tolist() == [3] * (len(P) - 2)  # the Heli4's three rigid twists
    monkeypatch.setattr(dm, "one_pass_takes", lambda *a: False)
    _same_modes(one, ev.modes(P, model, invalid="nan", **kw))
    assert calls == [len(P)]


@pytest.mark.parametrize("change", ["none", "twists", "undamped", "damped"])
def test_exact_pass_fallbacks(backends, monkeypatch, change):
    """The pass stands for the condensation (no kernel from Python, no other solve) unless
    its valid rows differ in their number of admissible twists (``twists``) or a row's
    undamped modes are not solved (code 2): then the Python route runs on the pass's q and M
    (the legs kernel again, the damped modes from its outputs); a row whose damped modes the
    driver left undecided (code 1) goes alone to the legs' route on the pass's outputs. The
    same modes on every route."""
    P, kw = _poses_and_kw({"k_a": np.array([125.0, 4000.0]), "c_a": 8.0})
    ev = backends["c"]
    reference = ev.modes(P, EXACT, **kw)
    exact_pass, solve_legs = c_damped.exact_pass, c_damped.solve_legs

    def changed(*a):
        out = exact_pass(*a)
        if change == "twists":
            out["nb"][1] -= 1
        elif change == "undamped":
            out["code"][1] = 2
        elif change == "damped":
            out["code"][::2] = 1
        return out

    calls, ran = [], []
    monkeypatch.setattr(c_damped, "exact_pass", changed)
    monkeypatch.setattr(c_damped, "solve_legs", lambda *a: calls.append(len(a[3])) or solve_legs(*a))
    monkeypatch.setattr(ev.kernels, "legs", lambda *a, f=ev.kernels.legs: ran.append(1) or f(*a))
    _same_modes(ev.modes(P, EXACT, **kw), reference)
    expected = {"none": ([], []), "damped": ([len(P[::2])], [])}.get(change, ([len(P)], [1]))
    assert (calls, ran) == expected


def test_exact_pass_without_a_valid_pose(backends):
    """No valid pose (invalid="nan"): nothing to condense, the Python route's answer (its
    early return): NaN modes and poles, no pose valid."""
    m = backends["c"].modes(np.array([[0.0, 0.0, -2.0]] * 2), EXACT, k_a=125.0, invalid="nan")
    assert not m.valid.any() and np.isnan(m.freq_hz).all() and np.isnan(m.damping.poles).all()


@pytest.mark.parametrize("factor, extra", [(1 - 1e-6, 0), (1 + 1e-6, 1)])
def test_exact_pass_admissible_threshold(backends, monkeypatch, factor, extra):
    """An admissible twist: an eigenvalue of the rigid rows' Gram matrix at most RIGID_RTOL *
    NULL_FACTOR times the largest. With the threshold just below (above) the smallest nonzero
    ratio, computed here from the rows of condense.leg_condensation, the pass condenses the
    Heli4's three rigid twists (two, the third admitted), as the Python route does."""
    from eigentwist.runtime import condense
    from eigentwist.runtime import damped_modes as dm

    ev, model = backends["c"], "actuator_loss,ee_compliance"
    out = ev.run_kernel("legs", X_REF[None], model, k_a=125.0)
    A = np.concatenate([condense.leg_condensation(out["Je"][:, i], out["Cq"][:, i])[1] for i in range(4)], axis=1)
    g = np.linalg.eigvalsh(A[0].T @ A[0])
    assert np.sum(g <= 1e-12 * g[-1]) == 3 and g[3] > 0.1 * g[-1]
    monkeypatch.setattr(condense, "NULL_FACTOR", factor * g[3] / g[-1] / condense.RIGID_RTOL)
    one = ev.modes(X_REF, model, k_a=125.0)
    assert one.constrained.sum() == 3 - extra
    monkeypatch.setattr(dm, "one_pass_takes", lambda *a: False)
    np.testing.assert_array_equal(ev.modes(X_REF, model, k_a=125.0).constrained, one.constrained)
