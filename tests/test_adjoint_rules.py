"""The rules of reverse-mode sensitivities, on small programs and a kernel written here.

``eigentwist.symbolic.adjoint`` (elementary form, the sweep, the running sums) is checked
against SymPy's ``diff``; ``eigentwist.runtime.sensitivity.adjoint_eigen_derivatives`` (the
weights, one weighting per mode, clusters of repeated eigenvalues, twists the eigenproblem
is posed on, further terms) against finite differences of the generalized eigenvalues of
matrices M(p), K(p) written in this file, through a kernel that contracts their exact
derivatives with the weights it is given, as the generated kernel does. Nothing is derived
or compiled: these run in a second.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import sympy as sp

from eigentwist.description.weights import weight_name
from eigentwist.runtime.sensitivity import (
    CLUSTER_RTOL,
    _weights,
    adjoint_eigen_derivatives,
    cluster_spans,
    clusters,
)
from eigentwist.symbolic.adjoint import elementary, reverse_sweep
from eigentwist.symbolic.program import Program

# ------------------------------------------------------------------ the symbolic sweep


def _program(*names):
    prog = Program()
    symbols = sp.symbols(names, real=True)
    for s_ in symbols:
        prog.declare(s_)
    return prog, symbols


def _check_gradient(prog, weighted, inputs, values, rel=1e-12):
    swept, grads = reverse_sweep(prog, weighted, inputs)
    scalar = prog.expand(sp.Add(*(w * e for w, e in weighted)))
    for s_, g in zip(inputs, grads):
        want = float(sp.diff(scalar, s_).subs(values))
        got = float(swept.expand(g).subs(values))
        assert got == pytest.approx(want, rel=rel, abs=1e-14), s_
    return swept, grads


def test_symbolic_exponent_and_two_argument_functions():
    """x**y (the exponent's partial log(x) x**y), atan2 and a quotient of sums."""
    prog, (x, y, w) = _program("x", "y", "w")
    a = prog.let("a", x**y + sp.atan2(y, x))
    e = a * sp.exp(x * y) / (x + y**2)
    _check_gradient(prog, [(w, e)], [x, y], {x: 1.3, y: 0.6, w: 0.9})


def test_an_input_no_output_reads_and_a_constant_output_give_zero():
    prog, (x, y, z, w1, w2) = _program("x", "y", "z", "w1", "w2")
    a = prog.let("a", sp.sin(x) * y)
    swept, grads = _check_gradient(prog, [(w1, a * y), (w2, sp.Integer(3))], [x, y, z], {x: 0.4, y: 2.0, w1: 1.5})
    assert grads[2] == 0
    # the constant output adds no statement of the sweep
    assert not any(s_.name.endswith("_o1") for s_, _ in swept.assignments)


def test_an_intermediate_read_by_several_outputs_is_summed_as_it_goes():
    """Three outputs read ``a``: its adjoint is a running sum, b1_a, b2_a, b3_a, each
    statement one term more than the last (never the three terms at the end)."""
    prog, (x, w1, w2, w3) = _program("x", "w1", "w2", "w3")
    a = prog.let("a", sp.sin(x) * sp.cos(x))
    weighted = [(w1, a**3), (w2, sp.exp(a) * x), (w3, sp.log(a + 2) * a)]
    swept, _ = _check_gradient(prog, weighted, [x], {x: 0.7, w1: 0.3, w2: -1.1, w3: 2.4})
    names = [s_.name for s_, _ in swept.assignments]
    assert {"b1_a", "b2_a", "b3_a"} <= set(names)
    rhs = dict((s_.name, r) for s_, r in swept.assignments)
    assert sp.Symbol("b1_a", real=True) in rhs["b2_a"].free_symbols
    assert sp.Symbol("b2_a", real=True) in rhs["b3_a"].free_symbols


def test_a_statement_that_reads_no_input_gets_no_adjoint():
    """``k`` depends on the constant ``c`` only: the sweep writes no adjoint of it (its
    derivative is 0 for every input), though the output reads it."""
    prog, (x, c, w) = _program("x", "c", "w")
    k = prog.let("k", sp.exp(c) + c**2)
    a = prog.let("a", sp.sin(x) * x)
    swept, _ = _check_gradient(prog, [(w, a * k)], [x], {x: 0.3, c: 0.9, w: 1.2})
    names = [s_.name for s_, _ in swept.assignments]
    assert any(n.endswith("_a") and n.startswith("b") for n in names)
    assert not any(n.endswith("_k") and n.startswith("b") for n in names)


def test_the_sweep_says_what_it_does_and_how_large_it_is():
    prog, (x, y, w) = _program("x", "y", "w")
    a = prog.let("a", sp.sin(x) * y)
    messages = []
    swept, _ = reverse_sweep(prog, [(w, a * x)], [x, y], progress=messages.append)
    # before the sweep of the statements: e1_a = sin(x), a = e1_a y, and the output's
    # contributions b1_a = w x, b1_x = w a
    assert messages == ["elementary form (1 statements)", "reverse sweep (4 statements)"]
    assert len(swept.assignments) > 4


def test_elementary_form_names_what_partials_read_and_leaves_sums_alone():
    """Terms of a sum are not named (their partial is 1); the active argument of a product,
    power or function that is neither an atom nor a numeric power of one is; inactive
    subexpressions stay in place; statements keep their names."""
    prog, (x, y, c) = _program("x", "y", "c")
    prog.let("s", x * y + x**2 + sp.sin(x))
    prog.let("t", sp.cos(x + y) * (y + 1) * sp.exp(c**2))
    prog.let("u", x**2 * y)  # a numeric power of an atom is cheap to recompute: not named
    prog.let("k", sp.exp(c) + c**2)  # reads no active symbol
    active = {x, y}
    out = elementary(prog, active)
    rhs = {s_.name: r for s_, r in out.assignments}
    assert rhs["u"] == x**2 * y and rhs["k"] == sp.exp(c) + c**2
    assert sp.Symbol("k", real=True) not in active
    # the argument of cos, cos itself (a factor) and y + 1 (a factor): three names
    named = {r: sp.Symbol(n, real=True) for n, r in rhs.items() if n.startswith("e")}
    assert sorted(n.name for n in named.values()) == ["e1_t", "e2_t", "e3_t"]
    cos_of = sp.cos(named[x + y])
    assert set(named) == {x + y, y + 1, cos_of}
    assert rhs["t"] == named[cos_of] * named[y + 1] * sp.exp(c**2)
    assert rhs["s"] == x * y + x**2 + sp.sin(x)
    assert sp.exp(c**2) in rhs["t"].args  # inactive: not named
    assert {sp.Symbol("s", real=True), sp.Symbol("t", real=True)} <= active
    assert sp.Symbol("c", real=True) not in active


# ------------------------------------------------------------------ the eigenvalue derivatives

P = 3
NAMES = ("p0", "p1", "p2")


def _spd(rng, n=6):
    a = rng.normal(size=(n, n))
    return a @ a.T + n * np.eye(n)


class Matrices:
    """Per pose (x its index, y and z coordinates): M(p) = y (A0 + p0 A1 + p1² A2),
    K(p) = z (B0 + p0 B1 + p2 B2 + p0 p1 B3), 6x6, symmetric, positive definite near the
    p used here, and their exact derivatives (N, P, 6, 6)."""

    def __init__(self, A, B, y, z):
        self.A, self.B, self.y, self.z = A, B, np.asarray(y)[:, None, None], np.asarray(z)[:, None, None]

    def at(self, x, y, z):
        """The matrices of rows at poses (x: the pose's index; y, z its coordinates)."""
        pose = np.asarray(x).astype(int)
        return Matrices(self.A[pose], self.B[pose], y, z)

    def M(self, p):
        A = self.A
        return self.y * (A[:, 0] + p[:, 0, None, None] * A[:, 1] + p[:, 1, None, None] ** 2 * A[:, 2])

    def K(self, p):
        B = self.B
        return self.z * (
            B[:, 0]
            + p[:, 0, None, None] * B[:, 1]
            + p[:, 2, None, None] * B[:, 2]
            + (p[:, 0] * p[:, 1])[:, None, None] * B[:, 3]
        )

    def dM(self, p):
        A = self.A
        d = np.stack([A[:, 1], 2 * p[:, 1, None, None] * A[:, 2], np.zeros_like(A[:, 0])], axis=1)
        return self.y[:, None] * d

    def dK(self, p):
        B = self.B
        d = np.stack([B[:, 1] + p[:, 1, None, None] * B[:, 3], p[:, 0, None, None] * B[:, 3], B[:, 2]], axis=1)
        return self.z[:, None] * d


def _kern(mats, drop=()):
    """``kern(x, y, z, rows) -> {"g": (R, P)}``: Σ_(i<=j) w_M_i_j dM_ij/dp + w_K_i_j dK_ij/dp at
    each row's pose, the generated kernel's contract; ``drop``: (matrix, parameter index)
    pairs of derivatives left out (a kernel that knows part of them)."""

    def kern(x, y, z, rows):
        own = mats.at(x, y, z)
        p = np.column_stack([np.broadcast_to(np.asarray(rows[k], dtype=float), (len(x),)) for k in NAMES])
        d = {"M": own.dM(p), "K": own.dK(p)}
        for matrix, k in drop:
            d[matrix][:, k] = 0.0
        g = np.zeros((len(x), P))
        for i in range(6):
            for j in range(i, 6):
                for matrix in "MK":
                    g += rows[weight_name(matrix, i, j)][:, None] * d[matrix][..., i, j]
        return {"g": g}

    return kern


def _setup(n=4, seed=3):
    rng = np.random.default_rng(seed)
    A = np.stack([np.stack([_spd(rng), *(0.1 * _spd(rng) for _ in range(2))]) for _ in range(n)])
    B = np.stack([np.stack([_spd(rng) * 10, *(_spd(rng) for _ in range(3))]) for _ in range(n)])
    pose = (np.arange(n, dtype=float), 0.5 + rng.random(n), 0.5 + rng.random(n))
    return Matrices(A, B, pose[1], pose[2]), 0.5 + rng.random((n, P)), pose


def _eig(M, K, E):
    Et = np.swapaxes(E, -1, -2)
    return np.array([scipy.linalg.eigh(k, m, eigvals_only=True) for k, m in zip(Et @ K @ E, Et @ M @ E)])


def _differences(mats, p, E, h=1e-6):
    out = np.empty((len(p), np.shape(E)[-1], P))
    for k in range(P):
        up, dn = p.copy(), p.copy()
        up[:, k] += h
        dn[:, k] -= h
        out[:, :, k] = (_eig(mats.M(up), mats.K(up), E) - _eig(mats.M(dn), mats.K(dn), E)) / (2 * h)
    return out


def _derivatives(mats, p, pose, E, kern=None, extra=None, rtol=CLUSTER_RTOL, params=None):
    kern = _kern(mats) if kern is None else kern
    params = {k: p[:, i] for i, k in enumerate(NAMES)} if params is None else params
    return adjoint_eigen_derivatives(kern, *pose, params, mats.M(p), mats.K(p), E, rtol=rtol, extra=extra)


@pytest.mark.parametrize("case", ["all six", "translations", "each pose its own"])
def test_eigenvalue_derivatives_equal_differences_on_the_twists_asked(case):
    mats, p, pose = _setup()
    n = len(p)
    if case == "all six":
        E = np.eye(6)
    elif case == "translations":
        E = np.eye(6)[:, 3:]
    else:
        rng = np.random.default_rng(9)
        E = np.stack([np.linalg.qr(rng.normal(size=(6, 4)))[0] for _ in range(n)])
    lam, V, dlam = _derivatives(mats, p, pose, E)
    np.testing.assert_allclose(lam, _eig(mats.M(p), mats.K(p), E), rtol=1e-12)
    want = _differences(mats, p, E)
    assert dlam.shape == want.shape
    np.testing.assert_allclose(dlam, want, rtol=1e-6, atol=1e-7 * np.abs(want).max())


@pytest.mark.parametrize("n", [1, 2, 3])
def test_parameters_per_pose_or_shared_reach_each_modes_row(n):
    """Per-pose parameter arrays (N,) are repeated for each mode's row and scalars kept, for
    a batch of one pose, of two (as many modes' rows as poses would not do) and more."""
    mats, p, pose = _setup(n=n, seed=4)
    p[:, 2] = 0.8  # one parameter shared by every pose, given as a scalar
    params = {"p0": p[:, 0], "p1": p[:, 1], "p2": 0.8}
    _, _, dlam = _derivatives(mats, p, pose, np.eye(6), params=params)
    want = _differences(mats, p, np.eye(6))
    np.testing.assert_allclose(dlam, want, rtol=1e-6, atol=1e-7 * np.abs(want).max())


def _rest(mats, p, drop):
    """The derivatives ``drop`` leaves out, as ``extra`` (dM, dK)."""
    rest = {"M": np.zeros((len(p), P, 6, 6)), "K": np.zeros((len(p), P, 6, 6))}
    for matrix, k in drop:
        rest[matrix][:, k] = (mats.dM if matrix == "M" else mats.dK)(p)[:, k]
    return rest["M"], rest["K"]


def test_further_terms_are_contracted_with_the_same_weights():
    """A kernel that knows only part of the derivatives (dM through p1, dK through p2 left
    out) plus that part given as ``extra`` equals the whole."""
    mats, p, pose = _setup(seed=5)
    drop = (("M", 1), ("K", 2))
    whole = _derivatives(mats, p, pose, np.eye(6))[2]
    parted = _derivatives(mats, p, pose, np.eye(6), kern=_kern(mats, drop), extra=_rest(mats, p, drop))[2]
    np.testing.assert_allclose(parted, whole, rtol=1e-12, atol=1e-12 * np.abs(whole).max())
    without = _derivatives(mats, p, pose, np.eye(6), kern=_kern(mats, drop))[2]
    assert np.abs(without - whole).max() > 1e-3 * np.abs(whole).max()


def _repeated(n=4):
    """Matrices whose eigenvalues 2 and 3 (ascending, from 0) are equal within CLUSTER_RTOL at
    p = 0 (M = I, K = diag(1, 2, 4, 4 + 4e-12, 7, 9)), split by each parameter at first order;
    the last pose's pair is far apart (K_33 = 5)."""
    rng = np.random.default_rng(11)
    A = np.zeros((n, 3, 6, 6))
    A[:, 0] = np.eye(6)
    A[:, 1] = 0.05 * np.stack([_spd(rng) for _ in range(n)])
    B = np.zeros((n, 4, 6, 6))
    B[:, 0] = np.diag([1.0, 2.0, 4.0, 4.0 + 4e-12, 7.0, 9.0])
    B[-1, 0, 3, 3] = 5.0
    for k in (1, 2, 3):
        B[:, k] = np.stack([_spd(rng) for _ in range(n)])
    pose = (np.arange(n, dtype=float), np.ones(n), np.ones(n))
    return Matrices(A, B, pose[1], pose[2]), np.zeros((n, P)), pose


def _one_sided(mats, p, lam, h=1e-7):
    out = np.empty((len(p), 6, P))
    for k in range(P):
        up = p.copy()
        up[:, k] += h
        out[:, :, k] = (_eig(mats.M(up), mats.K(up), np.eye(6)) - lam) / h
    return out


def test_a_repeated_eigenvalue_gets_the_one_sided_derivatives_of_its_pair():
    """Where modes 2 and 3 coincide their derivatives along each parameter are the sorted
    eigenvalues of the pair's projected derivative, which forward differences (h > 0,
    eigenvalues sorted) give; with an rtol below their gap they are two modes, and the
    diagonal of that projection (each eigenvector's own derivative) differs from them."""
    mats, p, pose = _repeated()
    lam, _, dlam = _derivatives(mats, p, pose, np.eye(6))
    assert np.allclose(lam[:-1, 2], lam[:-1, 3]) and lam[-1, 3] - lam[-1, 2] > 0.5
    np.testing.assert_allclose(dlam, _one_sided(mats, p, lam), rtol=1e-4, atol=1e-5)
    _, _, plain = _derivatives(mats, p, pose, np.eye(6), rtol=1e-14)
    assert np.abs(plain[:-1, 2:4] - dlam[:-1, 2:4]).max() > 1e-3
    np.testing.assert_array_equal(plain[-1], dlam[-1])  # no cluster there: the same numbers


def test_a_repeated_eigenvalue_with_further_terms():
    """The pair's projected derivative takes the further terms (``extra``) too."""
    mats, p, pose = _repeated()
    drop = (("K", 0), ("M", 0), ("K", 2))
    lam, _, dlam = _derivatives(mats, p, pose, np.eye(6), kern=_kern(mats, drop), extra=_rest(mats, p, drop))
    np.testing.assert_allclose(dlam, _one_sided(mats, p, lam), rtol=1e-4, atol=1e-5)


def test_forward_mode_eigenvalue_derivatives_take_the_same_rules():
    """``eigenvalue_derivatives`` (from dM and dK themselves, forward mode): differences
    apart from a cluster, the one-sided derivatives of a repeated eigenvalue's pair."""
    from eigentwist.runtime.eigen import generalized_eigh
    from eigentwist.runtime.sensitivity import eigenvalue_derivatives

    for mats, p, one_sided in ((*_setup(seed=6)[:2], False), (*_repeated()[:2], True)):
        lam, V = generalized_eigh(mats.K(p), mats.M(p))
        got = eigenvalue_derivatives(lam, V, mats.dK(p), mats.dM(p))
        want = _one_sided(mats, p, lam) if one_sided else _differences(mats, p, np.eye(6))
        np.testing.assert_allclose(got, want, rtol=1e-4 if one_sided else 1e-6, atol=1e-5 if one_sided else 1e-6)
    plain = eigenvalue_derivatives(lam, V, mats.dK(p), mats.dM(p), rtol=1e-14)  # the pair as two modes
    assert np.abs(plain[:-1, 2:4] - got[:-1, 2:4]).max() > 1e-3


def test_clusters_join_neighbours_within_rtol_on_either_side_of_it():
    lam = np.array([[1.0, 1.0 + 1.9e-6, 3.0, 3.0 * (1 + 2.1e-6), 5.0]])
    joined = clusters(lam, rtol=1e-6)
    assert joined.tolist() == [[True, False, False, False]]
    assert clusters(lam, rtol=1.1e-6).tolist() == [[True, False, True, False]]
    # the gap is relative to the larger of the two
    assert clusters(np.array([[1e-12, 2e-12]]), rtol=0.3).tolist() == [[True]]
    assert clusters(np.array([[1e-12, 2e-12]]), rtol=0.2).tolist() == [[False]]
    assert clusters(np.array([[0.0, 0.0]]), rtol=1e-6).tolist() == [[True]]
    # a gap of exactly 2 rtol times the larger joins (exact in binary: 0.5 = 2 * 0.25 * 1.0)
    assert clusters(np.array([[0.5, 1.0]]), rtol=0.25).tolist() == [[True]]


def test_cluster_spans_walk_each_row_and_each_cluster():
    joined = np.array(
        [
            [False, False, False, False, False],
            [True, True, False, False, True],
            [False, True, False, True, False],
        ]
    )
    assert list(cluster_spans(joined)) == [(1, slice(0, 3)), (1, slice(4, 6)), (2, slice(1, 3)), (2, slice(3, 5))]
    assert list(cluster_spans(np.ones((1, 3), dtype=bool))) == [(0, slice(0, 4))]


def test_weights_are_the_upper_triangle_with_each_off_diagonal_entry_counted_twice():
    rng = np.random.default_rng(2)
    W = rng.normal(size=(3, 6, 6))
    W = W + np.swapaxes(W, 1, 2)
    rows = _weights(W, "K")
    assert len(rows) == 21 and all(name.startswith("w_K_") for name in rows)
    np.testing.assert_array_equal(rows[weight_name("K", 2, 2)], W[:, 2, 2])
    np.testing.assert_array_equal(rows[weight_name("K", 1, 4)], 2 * W[:, 1, 4])
    # Σ over the upper triangle of these weights times a symmetric S is <W, S>
    S = rng.normal(size=(6, 6))
    S = S + S.T
    total = sum(rows[weight_name("K", i, j)] * S[i, j] for i in range(6) for j in range(i, 6))
    np.testing.assert_allclose(total, np.einsum("nij,ij->n", W, S), rtol=1e-12)
