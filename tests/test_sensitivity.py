"""Design sensitivities: generated dM/dp, dK/dp and frequency derivatives.

The derivative code is generated on first use (forward mode on the straight-line program
for dM/dp and dK/dp; reverse mode over the CSE'd M and K for the frequencies' derivatives;
seconds to a minute per parameter list) and cached by content hash; the fixtures below ask
for one parameter list per robot, so the suite generates it once per cache.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import eigentwist
from eigentwist.runtime import InputError
from eigentwist.runtime.sensitivity import eigenvalue_derivatives, sensitivity_kernels
from eigentwist.symbolic.sensitivity import gradient

from .conftest import random_poses

ROOT = Path(__file__).resolve().parents[1]
# every parameter kind: lengths, a mass, a modulus, a stiffness, k_a, a dimensionless ratio
WRT = {
    "heli4": ("l1", "l2", "h", "m_e", "E_rod", "k_E_lin", "k_a", "eta_a"),
    "delta": ("l1", "r_p", "m_e", "E_rod", "k_a", "p_x", "p_y", "m_p"),
}
MODELS = {"heli4": ("paper", "rigid"), "delta": ("paper", "rigid")}
compiled = pytest.mark.compiled


@pytest.fixture(scope="session")
def evs():
    return {name: eigentwist.load(name, backend="numpy") for name in WRT}


def _richardson(f, value, rel=1e-3):
    """Central difference with one Richardson step (error O(h^4)) of f at value."""
    h = rel * abs(value)
    d1 = (f(value + h) - f(value - h)) / (2 * h)
    d2 = (f(value + h / 2) - f(value - h / 2)) / h
    return (4 * d2 - d1) / 3


def _central(ev, poses, model, name, value, params):
    return _richardson(lambda v: ev.frequencies(poses, model, **{**params, name: v}), value)


def _assert_close(got, want, rtol=1e-6):
    """Entry-wise relative agreement; entries far below their column's largest (where
    finite differences see only round-off) are held to rtol * 1e-2 of that largest."""
    scale = np.abs(want).max(axis=(0, 1), keepdims=True)
    err = np.abs(got - want) / (np.abs(want) + 1e-2 * scale + 1e-300)
    assert np.all(err <= rtol), err.max()


def test_gradient_matches_sympy_diff():
    x, y = sp.symbols("x y", real=True)
    for e in (
        sp.atan2(x * y, x**2 + 1) + sp.sin(x) ** 3 / y,
        sp.acos(x / (1 + y**2)) * sp.sqrt(x + y),
        (x + y) ** 4 / sp.asin(y / 3),
    ):
        g = gradient(e)
        for s in (x, y):
            assert sp.simplify(g[s] - sp.diff(e, s)) == 0


@pytest.mark.parametrize("robot", sorted(WRT))
def test_sensitivities_equal_central_differences(evs, robot):
    ev = evs[robot]
    poses = random_poses(ev.robot, 3, seed=16)
    for model in MODELS[robot]:
        params = {"m_p": 0.3, "p_x": 0.01, "p_y": -0.02} if robot == "delta" else {}
        model_ = model + (",payload_mass" if robot == "delta" else "")
        got = ev.sensitivities(poses, WRT[robot], model_, **params)
        assert got.shape == (3, 3 if model == "rigid" else 6, len(WRT[robot]))
        want = np.stack(
            [_central(ev, poses, model_, name, {**ev.defaults, **params}[name], params) for name in WRT[robot]], axis=-1
        )
        _assert_close(got, want)


def test_sensitivities_equal_an_independent_per_pose_model(evs):
    """Central differences of benchmarks/reference_loop.py (numeric inverses, no generated code)."""
    spec = importlib.util.spec_from_file_location("reference_loop", ROOT / "benchmarks" / "reference_loop.py")
    ref = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ref)
    ev = evs["heli4"]
    poses = random_poses(ev.robot, 2, seed=7)
    got = ev.sensitivities(poses, WRT["heli4"], "paper")
    for j, name in enumerate(WRT["heli4"]):
        p = dict(ev.defaults)
        want = _richardson(lambda v: ref.frequencies_loop(poses, {**p, name: v}), p[name])
        _assert_close(got[..., j : j + 1], want[..., None])


def test_cluster_gives_individual_derivatives(evs):
    """Heli4 with h -> 0: legs 3, 4 at the height of legs 1, 2, so the rigid x and y modes
    coincide at x_ref. h splits them: each mode's derivative is the one-sided derivative of
    the sorted frequencies in the direction of increasing h, not the pair's mean."""
    ev = evs["heli4"]
    x = np.array([ev.robot.x_ref])
    h0, d = 1e-9, 1e-5
    f0 = ev.frequencies(x, "rigid", h=h0)
    assert abs(f0[0, 1] - f0[0, 0]) < 1e-7 * f0[0, 0]
    got = ev.sensitivities(x, WRT["heli4"], "rigid", h=h0)[0, :, WRT["heli4"].index("h")]
    f1, f2 = ev.frequencies(x, "rigid", h=h0 + d), ev.frequencies(x, "rigid", h=h0 + 2 * d)
    want = ((-3 * f0 + 4 * f1 - f2) / (2 * d))[0]
    assert np.allclose(got, want, rtol=1e-6, atol=1e-6 * np.abs(want).max())
    assert abs(got[1] - got[0]) > 10.0  # split, not averaged


def test_eigenvalue_derivatives_of_a_constructed_cluster():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    A = A + A.T
    K0 = np.diag([1.0, 1.0, 2.0])
    lam, V = np.linalg.eigh(K0)
    got = eigenvalue_derivatives(lam[None], V[None], A[None, None], np.zeros((1, 1, 3, 3)))[0, :, 0]
    t = 1e-7
    want = (np.linalg.eigvalsh(K0 + t * A) - lam) / t
    assert np.allclose(got, want, atol=1e-5)
    assert not np.isclose(got[0], got[1])


def test_gravity_preload_is_refused(evs):
    ev = evs["heli4"]
    with pytest.raises(InputError, match="gravity_preload"):
        ev.sensitivities(ev.robot.x_ref, ("k_a",), "paper,gravity_preload")
    with pytest.raises(InputError, match="unknown parameter"):
        ev.sensitivities(ev.robot.x_ref, ("nope",))


def test_subset_of_a_loaded_kernel_needs_no_generation(evs):
    ev = evs["heli4"]
    ev.sensitivities(ev.robot.x_ref, WRT["heli4"])
    full = ev.sensitivities(ev.robot.x_ref, WRT["heli4"])
    sub = ev.sensitivities(ev.robot.x_ref, ("k_a", "l2"))
    assert np.array_equal(sub[..., 0], full[..., WRT["heli4"].index("k_a")])
    assert np.array_equal(sub[..., 1], full[..., WRT["heli4"].index("l2")])


# the C comparison on one of them: gcc's time grows with the kernel's size (about 6 s per
# parameter), and the NumPy side selects it from its kernel of WRT. The C rendering is the same
# code for every robot: the Delta on its payload offset p_x (what the Heli4 list lacks);
# tests/test_sensitivity_split.py compiles the Delta's kernel of two parameters (the (N, P)
# layout) cut into dozens of parts against NumPy
WRT_C = {"delta": ("p_x",)}


@compiled
@pytest.mark.parametrize("robot", sorted(WRT_C))
def test_c_equals_numpy(evs, robot):
    ev_np = evs[robot]
    ev_c = eigentwist.load(robot, backend="c")
    poses = random_poses(ev_np.robot, 50, seed=5)
    p = ev_np.resolver.resolve(len(poses), {}, "paper")
    wrt = WRT_C[robot]
    a = sensitivity_kernels(ev_np, wrt)(poses[:, 0], poses[:, 1], poses[:, 2], p)
    b = sensitivity_kernels(ev_c, wrt)(poses[:, 0], poses[:, 1], poses[:, 2], p)
    for k in a:
        scale = np.abs(a[k]).max()
        assert np.allclose(b[k], a[k], rtol=1e-12, atol=1e-12 * scale), k
    s_np = ev_np.sensitivities(poses, wrt)
    s_c = ev_c.sensitivities(poses, wrt)
    assert np.allclose(s_c, s_np, rtol=1e-9, atol=1e-12 * np.abs(s_np).max())


@pytest.mark.parametrize("robot", list(WRT))
def test_difference_method_equals_the_generated_kernel(evs, robot):
    """``method="differences"`` (central differences of the checked-in matrices, nothing
    derived) gives the generated kernel's derivatives, clusters included (the Heli4 with
    h -> 0 at x_ref: the rigid x and y modes coincide), to 1e-7 of each column's largest."""
    ev = evs[robot]
    poses = random_poses(ev.robot, 4, seed=11)
    for model in MODELS[robot]:
        m1, exact = ev.modes_and_sensitivities(poses, WRT[robot], model)
        m2, diff = ev.modes_and_sensitivities(poses, WRT[robot], model, method="differences")
        np.testing.assert_allclose(m1.freq_hz, m2.freq_hz, rtol=1e-12)  # the same model (two programs)
        scale = np.abs(exact).max(axis=(0, 1), keepdims=True)
        assert np.all(np.abs(diff - exact) <= 1e-7 * scale), np.max(np.abs(diff - exact) / scale)
    if robot == "heli4":
        x = np.array([ev.robot.x_ref])
        exact = ev.sensitivities(x, WRT[robot], "rigid", h=1e-9)
        diff = ev.sensitivities(x, WRT[robot], "rigid", h=1e-9, method="differences")
        j = WRT[robot].index("h")
        assert abs(exact[0, 1, j] - exact[0, 0, j]) > 10.0  # split, not averaged
        np.testing.assert_allclose(diff[0, :, j], exact[0, :, j], rtol=1e-6, atol=1e-8 * np.abs(exact[0, :, j]).max())


def test_each_backend_text_rendered_when_first_asked_for_from_one_kernel(monkeypatch, tmp_path):
    """Stand-ins for the derivation and the renderers: what is generated, and when."""
    from eigentwist import symbolic
    from eigentwist.codegen import sensitivity as cgs
    from eigentwist.runtime import sensitivity as sens
    from eigentwist.runtime.ccompile import private_directory
    from eigentwist.runtime.memo import NewestKept

    monkeypatch.setenv("EIGENTWIST_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(sens, "_KERNELS", NewestKept(sens.KERNELS_KEPT))
    built = []
    monkeypatch.setattr(symbolic, "derive", lambda robot: "model")
    monkeypatch.setattr(cgs, "sensitivity_kernel", lambda model, wrt, progress=None: built.append(wrt) or object())
    monkeypatch.setattr(cgs, "render_numpy_sensitivity", lambda robot, kernel, wrt: f"# numpy {wrt}\n")
    monkeypatch.setattr(cgs, "render_c_sensitivity", lambda robot, kernel, wrt: f"/* c {wrt} */\n")
    ev = eigentwist.load("heli4", backend="numpy")
    directory = private_directory("sensitivities")

    def texts():
        return sorted(p.suffix for p in directory.iterdir() if p.suffix != ".sha256")

    assert sens._source(ev, ("l1",), "numpy", None) == "# numpy ('l1',)\n" and texts() == [".py"]
    assert sens._source(ev, ("l1",), "c", None) == "/* c ('l1',) */\n" and texts() == [".c", ".py"]
    assert built == [("l1",)]  # the C text from the kernel built for the NumPy one
    assert sens._source(ev, ("l1",), "c", None) == "/* c ('l1',) */\n" and built == [("l1",)]  # from the cache
    others = [(f"p{k}",) for k in range(sens.KERNELS_KEPT)]
    for wrt in others:
        sens._source(ev, wrt, "numpy", None)
    sens._source(ev, others[0], "c", None)  # kept
    sens._source(ev, ("l1",), "c", None)  # on disk
    assert built == [("l1",), *others]
    for path in directory.glob("*.c*"):
        path.unlink()
    sens._source(ev, ("l1",), "c", None)  # neither on disk nor kept (two newer kernels): built again
    assert built == [("l1",), *others, ("l1",)]


def test_reverse_sweep_equals_sympy_diff():
    """The reverse sweep of a small program (products, powers, functions, a shared
    intermediate) gives d(w1 e1 + w2 e2)/dx and /dy equal to SymPy's diff of the expanded form."""
    from eigentwist.symbolic.adjoint import reverse_sweep
    from eigentwist.symbolic.program import Program

    x, y, w1, w2 = sp.symbols("x y w1 w2", real=True)
    prog = Program()
    for s_ in (x, y, w1, w2):
        prog.declare(s_)
    a = prog.let("a", x * y + sp.sin(x) ** 2)
    b = prog.let("b", sp.sqrt(a) * (x + 3 * y) ** 3 / y)
    e1, e2 = a * b + sp.cos(a * y), b**2 - x * a
    swept, grads = reverse_sweep(prog, [(w1, e1), (w2, e2)], [x, y])
    scalar = prog.expand(w1 * e1 + w2 * e2)
    values = {x: 0.7, y: 1.3, w1: -0.4, w2: 2.1}
    for s_, g in zip((x, y), grads):
        want = float(sp.diff(scalar, s_).subs(values))
        got = float(swept.expand(g).subs(values))
        assert got == pytest.approx(want, rel=1e-12)


def test_reverse_kernel_is_the_matrices_derivatives_contracted(evs):
    """The reverse-mode kernel of the flexible model with random symmetric weights W_M, W_K
    equals the central differences of the checked-in M and K_F (nothing derived) contracted
    with them, for lengths (through the IK), a mass, a modulus, stiffnesses and a ratio."""
    from eigentwist.runtime.sensitivity import _weights

    ev = evs["heli4"]
    wrt = WRT["heli4"]
    poses = random_poses(ev.robot, 20, seed=8)
    rng = np.random.default_rng(8)
    WM, WK = (w + np.swapaxes(w, 1, 2) for w in rng.normal(size=(2, len(poses), 6, 6)))
    p = ev.completion.with_pose(poses, ev.resolver.resolve(len(poses), {}, "paper"))
    d = ev.matrix_derivatives(poses, wrt, "paper")
    want = np.einsum("nij,npij->np", WM, d["dM"]) + np.einsum("nij,npij->np", WK, d["dK_F"])
    rev = sensitivity_kernels(ev, wrt, kind="flexible")
    got = rev(poses[:, 0], poses[:, 1], poses[:, 2], {**p, **_weights(WM, "M"), **_weights(WK, "K")})["g"]
    err = np.abs(got - want) / (np.abs(want) + 1e-6 * np.abs(want).max(axis=0) + 1e-300)
    assert err.max() <= 1e-6, err.max()


def test_a_kernel_kind_or_stiffness_not_known_is_named(evs):
    from eigentwist.codegen.adjoint import adjoint_kernel

    with pytest.raises(InputError, match="kind='reverse': expected one of forward, rigid, flexible"):
        sensitivity_kernels(evs["heli4"], ("k_a",), kind="reverse")
    with pytest.raises(InputError, match="stiffness='soft'"):
        adjoint_kernel(None, ("k_a",), "soft")


def _linear_kernel(A, B):
    """A stand-in for the reverse-mode kernel of M(p) = M0 + sum_j p_j A_j, K(p) = K0 + sum_j
    p_j B_j (A, B: (P, 6, 6) symmetric): each row's weights read back from the kernel's inputs
    (W_ii on the diagonal, W_ij + W_ji above it) and contracted with A_j and B_j."""
    from eigentwist.description.weights import weight_name

    def weights(rows, matrix, n):
        W = np.zeros((n, 6, 6))
        for i in range(6):
            for j in range(i, 6):
                w = np.broadcast_to(rows[weight_name(matrix, i, j)], (n,))
                W[:, i, j] = w if i == j else w / 2
                W[:, j, i] = W[:, i, j]
        return W

    def kern(x, y, z, rows):
        n = len(x)
        W_M, W_K = weights(rows, "M", n), weights(rows, "K", n)
        return {"g": np.einsum("rij,pij->rp", W_M, A) + np.einsum("rij,pij->rp", W_K, B)}

    return kern


def test_lowest_modes_sweep_only_those_and_solve_a_cluster_across_the_cut_whole():
    """adjoint_eigen_derivatives with ``lowest``: the first columns of the eigenvalue
    perturbation of an independent computation (eigenvalue_derivatives on dK = B, dM = A),
    the kernel asked for one row per pose and kept mode; a double eigenvalue across the cut
    (modes 2 and 3) gets the sorted eigenvalues of its projected derivative, not the arbitrary
    basis' Rayleigh quotients."""
    from eigentwist.runtime.sensitivity import adjoint_eigen_derivatives

    rng = np.random.default_rng(11)
    P = 4
    A = rng.normal(size=(P, 6, 6))
    A = A + np.swapaxes(A, 1, 2)
    B = rng.normal(size=(P, 6, 6))
    B = B + np.swapaxes(B, 1, 2)
    M = np.broadcast_to(np.eye(6), (2, 6, 6)).copy()
    K = np.array([np.diag([1.0, 2.0, 3.0, 3.0, 5.0, 7.0]), np.diag([1.0, 2.0, 4.0, 5.0, 6.0, 8.0])])
    Q = np.linalg.qr(rng.normal(size=(6, 6)))[0]  # the double eigenvalue's basis left arbitrary
    K[0] = Q @ K[0] @ Q.T
    kern = _linear_kernel(A, B)
    rows = []
    counted = lambda x, y, z, r: rows.append(len(x)) or kern(x, y, z, r)  # noqa: E731
    x = np.zeros(2)
    lam, V = np.linalg.eigh(K)
    want = eigenvalue_derivatives(lam, V, np.broadcast_to(B, (2, P, 6, 6)), np.broadcast_to(A, (2, P, 6, 6)))
    for k in (1, 3, 6):
        rows.clear()
        got = adjoint_eigen_derivatives(counted, x, x, x, {}, M, K, np.eye(6), lowest=k)[2]
        assert got.shape == (2, k, P)
        np.testing.assert_allclose(got, want[:, :k], rtol=1e-10, atol=1e-10)
        assert rows[0] == 2 * k  # one row a pose and kept mode
    # the cut inside the cluster: its members' raw quotients differ from the sorted eigenvalues
    raw = np.einsum("ik,pij,jk->kp", V[0], B, V[0]) - lam[0][:, None] * np.einsum("ik,pij,jk->kp", V[0], A, V[0])
    assert np.abs(raw[2] - want[0, 2]).max() > 1e-3
    assert adjoint_eigen_derivatives(kern, x, x, x, {}, M, K, np.eye(6), lowest=99)[2].shape == (2, 6, P)


def test_lowest_is_the_first_columns_of_every_route(evs):
    """Evaluator.sensitivities(lowest=k): the first k columns of every mode's derivatives, by
    the generated kernel (flexible and rigid) and by differences; more than the model's modes
    gives them all; anything but a whole number >= 1 is refused, naming the value."""
    ev = evs["heli4"]
    poses = random_poses(ev.robot, 3, seed=5)
    for model, method in (("paper", "exact"), ("rigid", "exact"), ("paper", "differences")):
        full = ev.sensitivities(poses, WRT["heli4"], model, method=method)
        for k in (1, 2):
            got = ev.sensitivities(poses, WRT["heli4"], model, method=method, lowest=k)
            assert got.shape == (3, k, len(WRT["heli4"]))
            np.testing.assert_allclose(got, full[:, :k], rtol=1e-10, atol=1e-12 * np.abs(full).max())
        np.testing.assert_array_equal(ev.sensitivities(poses, WRT["heli4"], model, method=method, lowest=40), full)
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(InputError, match=f"lowest = {bad!r}: expected"):
            ev.sensitivities(poses, ("k_a",), "paper", lowest=bad)


@compiled
def test_eigensolver_is_the_c_librarys_where_it_has_the_size(evs, monkeypatch):
    """The reverse-mode route solves the pencil with the mode solver's ``eigh``: the C
    library's Cholesky and Jacobi where the backend has them for its size (the eigenvalues LAPACK's to round-off), else
    with LAPACK's (a size the library lacks, the NumPy backend)."""
    from eigentwist.runtime.eigen import generalized_eigh

    ev_c = eigentwist.load("heli4", backend="c")
    rng = np.random.default_rng(4)
    A = rng.normal(size=(5, 6, 6))
    K = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(6)
    B = rng.normal(size=(5, 6, 6))
    M = B @ np.swapaxes(B, 1, 2) + np.eye(6)
    calls = []
    solve = ev_c.kernels.generalized_eigh
    monkeypatch.setattr(ev_c.kernels, "generalized_eigh", lambda K, M, **k: calls.append(K.shape) or solve(K, M, **k))
    lam, V = ev_c.solver.eigh(K, M)
    assert calls == [(5, 6, 6)]
    want, _ = generalized_eigh(K, M)
    np.testing.assert_allclose(lam, want, rtol=1e-12)
    np.testing.assert_allclose(np.swapaxes(V, 1, 2) @ M @ V, np.broadcast_to(np.eye(6), (5, 6, 6)), atol=1e-12)
    small = ev_c.solver.eigh(K[:, :2, :2], M[:, :2, :2])[0]
    assert calls == [(5, 6, 6)]  # 2 x 2: LAPACK's
    np.testing.assert_allclose(small, generalized_eigh(K[:, :2, :2], M[:, :2, :2])[0], rtol=1e-14)
    np.testing.assert_array_equal(evs["heli4"].solver.eigh(K, M)[0], want)


def _bad_poses(ev):
    from .test_evaluator_rules import singular_z

    good = list(ev.robot.x_ref)
    return np.array([good, [0.0, 0.0, -1.2]]), np.array([good, [0.0, 0.0, singular_z(ev)]])


@pytest.mark.parametrize("method", ["exact", "differences"])
def test_an_unreachable_or_singular_pose_raises_naming_it(evs, method):
    """Derivatives at a pose the robot cannot take, or a serial singular one, are refused
    with the error of every evaluation, naming the pose or the leg (both methods, every mode
    or the lowest)."""
    from eigentwist.runtime import SingularPoseError, UnreachablePoseError

    unreachable, singular = _bad_poses(evs["heli4"])
    with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, -1.2\]"):
        evs["heli4"].sensitivities(unreachable, WRT["heli4"], "paper", method=method)
    with pytest.raises(SingularPoseError, match="leg 1"):
        evs["heli4"].sensitivities(singular, WRT["heli4"], "paper", method=method, lowest=1)


@compiled
def test_an_unreachable_pose_raises_on_the_c_backend():
    from eigentwist.runtime import UnreachablePoseError

    ev = eigentwist.load("delta", backend="c")
    poses = np.array([ev.robot.x_ref, [0.0, 0.0, -5.0]])
    with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, -5.0\]"):
        ev.sensitivities(poses, WRT_C["delta"], "paper")


def test_a_bad_pose_is_refused_before_the_kernel_is_loaded_or_generated(evs, monkeypatch):
    """The poses are checked before the reverse-mode kernel is asked for (its first
    generation takes a minute): an unreachable pose raises with no kernel requested; a good
    one requests it once."""
    from eigentwist.runtime import UnreachablePoseError
    from eigentwist.runtime import sensitivity as sens

    asked = []
    real = sens.sensitivity_kernels
    monkeypatch.setattr(sens, "sensitivity_kernels", lambda *a, **k: asked.append(a[1]) or real(*a, **k))
    unreachable, _ = _bad_poses(evs["heli4"])
    with pytest.raises(UnreachablePoseError):
        evs["heli4"].sensitivities(unreachable, WRT["heli4"], "paper")
    assert asked == []
    evs["heli4"].sensitivities(unreachable[:1], WRT["heli4"], "paper")
    assert len(asked) == 1


@compiled
def test_the_route_solves_its_pencil_with_the_mode_solvers_eigh(monkeypatch):
    """The reverse-mode route's pencil goes to ``ModeSolver.eigh`` (the C Jacobi where the
    library has the size), not to a solver of its own."""
    ev = eigentwist.load("delta", backend="c")
    sizes = []
    real = ev.solver.eigh
    monkeypatch.setattr(ev.solver, "eigh", lambda K, M: sizes.append(K.shape) or real(K, M))
    ev.sensitivities(random_poses(ev.robot, 4, seed=2), WRT_C["delta"], "paper")
    assert sizes and all(s == (4, 6, 6) for s in sizes)
