"""The linear algebra of the damped modes' coordinates (``eigentwist/runtime/damped_modes.py``) on
small matrices written here: the null space of the legs' rigid rows (orthonormal, of the rank
the relative threshold ``RIGID_RTOL`` gives, one rank for the batch), the admissible twists, and
the couplings' maps and stiffness of legs on platform bodies. No evaluator.
"""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest

from eigentwist.runtime import Modes, condense
from eigentwist.runtime import damped_modes as dm
from eigentwist.runtime.errors import InputError

RANK_MESSAGE = (
    "damped modes: the legs' rigid constraints change rank across the poses; evaluate the poses in groups of one rank"
)


def check_basis(B, A, dim):
    """B (n, d, dim) orthonormal columns that every row of A (n, rows, d) annihilates."""
    assert B.shape[-1] == dim
    assert np.allclose(np.swapaxes(B, -1, -2) @ B, np.eye(dim), atol=1e-12)
    assert np.allclose(A @ B, 0.0, atol=1e-9)


def test_null_space_of_rigid_rows():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(3, 2, 5))
    B = dm._null_space(A, 5, condense)
    assert B.shape == (3, 5, 3)
    check_basis(B, A, 3)


@pytest.mark.parametrize("small, rank", [(0.5e-10, 1), (2e-10, 2)])
def test_null_space_rank_at_rigid_rtol(small, rank):
    """A singular value below RIGID_RTOL times the largest is no constraint."""
    assert condense.RIGID_RTOL == 1e-10
    A = np.zeros((2, 2, 4))
    A[:, 0, 0], A[:, 1, 1] = 1e3, 1e3 * small
    B = dm._null_space(A, 4, condense)
    assert B.shape == (2, 4, 4 - rank)
    assert np.allclose(np.abs(B[:, 0, :]), 0.0) and (rank == 1) is not np.allclose(B[:, 1, :], 0.0)


def test_null_space_without_rows_and_with_a_rank_change():
    B = dm._null_space(np.zeros((3, 2, 4)), 4, condense)
    assert B.shape == (3, 4, 4) and np.array_equal(B[2], np.eye(4))
    A = np.zeros((2, 2, 4))
    A[0, 0, 0] = 1.0
    A[1, 0, 0] = A[1, 1, 2] = 1.0  # the second pose has one constraint more
    with pytest.raises(InputError) as err:
        dm._null_space(A, 4, condense)
    assert str(err.value) == RANK_MESSAGE


def legs_of(rigid_rows, compliant_rows, n=2):
    """Je (n, legs, 1, 6), Cq (n, legs, 1, 1): one elastic joint per leg, rigid (Cq = 0) or compliant."""
    rows = [(r, 0.0) for r in rigid_rows] + [(r, 1e-3) for r in compliant_rows]
    Je = np.array([[np.asarray(r, dtype=float)[None, :] for r, _ in rows]] * n)
    Cq = np.array([[[[c]] for _, c in rows]] * n)
    return Je, Cq


def test_admissible_twists_leave_out_the_rigid_legs_directions():
    e = np.eye(6)
    Je, Cq = legs_of([e[0], e[3] + e[4]], [e[1]])
    B = dm._admissible(Je, Cq, condense)
    check_basis(B, Je[:, :2, 0, :], 4)  # the compliant leg's direction stays admissible
    assert np.allclose(np.linalg.norm(B[:, 1, :], axis=-1), 1.0)
    B = dm._admissible(*legs_of([], [e[0], e[1]], n=3), condense)  # every direction compliant
    assert B.shape == (3, 6, 6) and np.array_equal(B[1], np.eye(6))


def test_admissible_twists_of_one_rank_for_the_batch():
    e = np.eye(6)
    Je, Cq = legs_of([e[0], e[1]], [])
    Cq[1, 1] = 1e-3  # the second pose: the second leg compliant
    with pytest.raises(InputError) as err:
        dm._admissible(Je, Cq, condense)
    assert str(err.value) == RANK_MESSAGE


def test_couplings_maps_and_stiffness():
    """Two couplings of platform bodies (one on), three legs: on the platform, on the coupled body,
    on the body whose coupling is off. x = [t; theta]: T_i maps x to leg i's body twist."""
    m = 2
    G = np.arange(2 * 6 * m, dtype=float).reshape(2, 6, m)  # per coupling (6, m)
    K_c = np.array([[10.0, 20.0], [30.0, 40.0]])
    ev = NS(
        robot=NS(
            couplings=[NS(body="b2", effect="c2"), NS(body="b1", effect="c1")],
            legs=[NS(platform_body="platform"), NS(platform_body="b2"), NS(platform_body="b1")],
        )
    )
    K_ground = np.diag(np.arange(1.0, 7.0))
    legs = {"G_c": G, "K_c": K_c, "K_ground": K_ground}
    T, K_x = dm._couplings(ev, ("c2",), legs, 3)
    # sorted by body: b1 (c1, off), b2 (c2, on): one active coupling, d = 6 + 2
    assert K_x.shape == (3, 8, 8)
    want = np.zeros((8, 8))
    want[:6, :6] = K_ground
    want[6, 6], want[7, 7] = 30.0, 40.0  # b2's coupling is the second in body order
    assert np.array_equal(K_x[0], want) and np.array_equal(K_x[2], want)
    assert np.array_equal(T[0][1], np.eye(6, 8)) and np.array_equal(T[2][0], np.eye(6, 8))
    on = np.zeros((6, 8))
    on[:, :6] = np.eye(6)
    on[:, 6:] = -G[1]
    assert np.array_equal(T[1][2], on)
    # per-pose arrays (a leading pose axis) read alike
    per_pose = {"G_c": np.broadcast_to(G, (3, 2, 6, m)), "K_c": np.broadcast_to(K_c, (3, 2, m)), "K_ground": K_ground}
    T3, K3 = dm._couplings(ev, ("c2",), per_pose, 3)
    assert np.array_equal(K3, K_x) and all(np.array_equal(a, b) for a, b in zip(T3, T))
    assert dm._couplings(ev, ("other",), legs, 3) is None


def test_couplings_of_two_bodies():
    m = 1
    G = np.stack([np.full((6, m), 1.0), np.full((6, m), 2.0)])
    K_c = np.array([[5.0], [7.0]])
    ev = NS(
        robot=NS(
            couplings=[NS(body="b1", effect="c1"), NS(body="b2", effect="c2")],
            legs=[NS(platform_body="b2"), NS(platform_body="b1")],
        )
    )
    T, K_x = dm._couplings(ev, ("c1", "c2"), {"G_c": G, "K_c": K_c, "K_ground": np.zeros((6, 6))}, 1)
    assert np.array_equal(np.diag(K_x[0])[6:], [5.0, 7.0])
    assert np.array_equal(T[0][0, :, 6:], np.column_stack([np.zeros(6), -2.0 * np.ones(6)]))
    assert np.array_equal(T[1][0, :, 6:], np.column_stack([-1.0 * np.ones(6), np.zeros(6)]))


# -- legs on a platform body joined by a compliant coupling ------------------------------------------------


def coupled_case(n=1, loss=None, K_G=None, M=None):
    """One leg with one elastic joint (compliance c0; the actuator's own 1/k_d enters through its
    wrench, :func:`.damped.actuator_wrenches`) along the unit row j, on a body joined to the
    platform by one coupling coordinate of stiffness k_c (map g); the ground's stiffness K_ground
    on the platform."""
    j = np.array([0.6, 0.0, 0.8, 0.0, 0.1, 0.0])
    g = np.array([0.0, 0.2, 0.0, 1.0, 0.0, 0.3])[:, None]
    c0, k_d, k_c = 2e-4, 800.0, 3000.0
    K_ground = np.diag([50.0, 60.0, 70.0, 5.0, 6.0, 7.0])
    M = np.diag([2.0, 2.0, 2.0, 0.01, 0.02, 0.03]) if M is None else M
    Je = np.broadcast_to(j[None, :], (n, 1, 1, 6)).copy()
    Cq = np.full((n, 1, 1, 1), c0)
    T0 = np.zeros((n, 6, 7))
    T0[:, :, :6] = np.eye(6)
    T0[:, :, 6:] = -g
    K_x = np.zeros((n, 7, 7))
    K_x[:, :6, :6] = K_ground
    K_x[:, 6, 6] = k_c
    args = (Je, Cq, np.full((n, 1), k_d), np.broadcast_to(M, (n, 6, 6)), K_G, [T0], K_x, condense, loss)
    if n > 1:
        return args, None
    # by hand: the leg's spring J_e^T C_q^+ J_e = j j^T / c0, moved by T0; the coupling condensed (Schur)
    Kx = K_x[0] + T0[0].T @ (np.outer(j, j) / c0) @ T0[0]
    if K_G is not None:
        Kx[:6, :6] += K_G
    Ks = Kx[:6, :6] - Kx[:6, 6:] @ np.linalg.solve(Kx[6:, 6:], Kx[6:, :6])
    return args, np.sort(np.linalg.eigvals(np.linalg.solve(M, Ks)).real)


def reduced_eigenvalues(Mr, K):
    return np.sort(np.linalg.eigvals(np.linalg.solve(Mr[0], K[0])).real)


def test_coupled_reduction_condenses_the_coupling():
    args, want = coupled_case()
    Mr, K, W, h, G, P = dm._coupled_reduction(*args)
    assert Mr.shape == (1, 6, 6) and P.shape == (1, 6, 6) and W.shape == (1, 1, 6) and h.shape == (1, 1)
    assert np.allclose(reduced_eigenvalues(Mr, K), want, rtol=1e-9)
    assert np.allclose(np.swapaxes(P, -1, -2) @ args[3] @ P, Mr, atol=1e-12)  # P: the platform's massive twists


def test_coupled_reduction_adds_the_gravity_preload():
    K_G = np.diag([1.0, 2.0, 3.0, 0.4, 0.5, 0.6]) * 10.0
    K_G[0, 1] = K_G[1, 0] = 4.0
    args, want = coupled_case(K_G=K_G)
    Mr, K, *_ = dm._coupled_reduction(*args)
    assert np.allclose(reduced_eigenvalues(Mr, K), want, rtol=1e-9)
    assert not np.allclose(want, coupled_case()[1])  # the case's premise: the preload shows


def test_coupled_reduction_with_a_loss_factor_is_complex():
    args, _ = coupled_case(loss=np.array([0.02]))
    Mr, K, *_ = dm._coupled_reduction(*args)
    assert np.iscomplexobj(K) and np.max(np.abs(K.imag)) > 1e-3 * np.max(np.abs(K.real))


def test_coupled_reduction_refuses_a_change_in_massive_coordinates():
    M = np.broadcast_to(np.diag([2.0, 2.0, 2.0, 0.01, 0.02, 0.03]), (2, 6, 6)).copy()
    M[1, 5, 5] = 0.0  # the second pose: one massless direction more
    args, _ = coupled_case(n=2, M=M)
    with pytest.raises(InputError) as err:
        dm._coupled_reduction(*args)
    assert str(err.value) == (
        "damped modes: the platform's massive coordinates change in number across the poses; evaluate the poses "
        "in groups"
    )


def test_coupled_reduction_without_loss_is_real():
    args, _ = coupled_case()
    Mr, K, W, h, G, P = dm._coupled_reduction(*args)
    assert not np.iscomplexobj(K)
    assert h[0, 0] == pytest.approx(1.0 / 2e-4, rel=1e-12)  # e_0^T C_q^+ e_0: the joint's own stiffness


def test_thresholds_are_relative_to_each_poses_largest_value():
    """Poses 1e12 (rows) or 1e14 (masses) apart in scale have the same rank and massive count."""
    A = np.zeros((2, 2, 4))
    A[:, 0, 0], A[:, 1, 1] = 1.0, 0.5
    A[0] *= 1e12
    assert dm._null_space(A, 4, condense).shape == (2, 4, 2)
    e = np.eye(6)
    Je, Cq = legs_of([e[0], e[1]], [])
    Je[0] *= 1e12
    assert dm._admissible(Je, Cq, condense).shape == (2, 6, 4)
    M = np.broadcast_to(np.diag([2.0, 2.0, 2.0, 0.01, 0.02, 0.03]), (2, 6, 6)).copy()
    M[0] *= 1e14
    args, _ = coupled_case(n=2, M=M)
    Mr, *_ = dm._coupled_reduction(*args)
    assert Mr.shape == (2, 6, 6)


def test_admissible_twists_ignore_a_rigid_row_below_rigid_rtol():
    e = np.eye(6)
    Je, Cq = legs_of([1e6 * e[0], 1e-6 * e[1]], [])  # the second 1e-12 of the first: no constraint
    B = dm._admissible(Je, Cq, condense)
    assert B.shape == (2, 6, 5)


def test_solver_of_the_backend():
    assert dm.solver_of(NS(backend="c")) == "c" and dm.solver_of(NS(backend="numpy")) == "numpy"


def test_actuator_values_of_the_effects_on():
    """eta_a of a leg whose actuator_loss switch is on, 1 where it is off (switch 0), whatever the
    effects named; c_a, t_d and eta_s only with their effects on."""
    ev = NS(n_legs=2, effects=("actuator_loss", "servo_damping"))
    p = {
        "on_actuator_loss__1": np.array([1.0, 0.0]),
        "on_actuator_loss__2": 0.0,
        "eta_a__1": np.array([0.5, 0.6]),
        "eta_a__2": 0.7,
        "k_a": np.array([1000.0, 2000.0]),
        "c_a": 3.0,
        "t_d": 1e-3,
        "eta_s": 0.02,
    }
    k_d, c_d, t_d, loss = dm.actuator_values(ev, p, ("servo_damping", "servo_delay", "structural_loss"), 2)
    assert np.array_equal(k_d, [[500.0, 1000.0], [2000.0, 2000.0]])
    assert np.array_equal(c_d, [[1.5, 3.0], [3.0, 3.0]]) and np.array_equal(t_d, np.full((2, 2), 1e-3))
    assert np.array_equal(loss, [0.02, 0.02])
    k_d, c_d, t_d, loss = dm.actuator_values(ev, p, (), 2)
    assert np.array_equal(k_d, [[500.0, 1000.0], [2000.0, 2000.0]])  # the switches say where eta_a acts
    assert not np.any(c_d) and not np.any(t_d) and loss is None
    plain = NS(n_legs=2, effects=("servo_damping",))  # a robot without actuator_loss: no switch read
    k_d, *_ = dm.actuator_values(plain, {"k_a": 1000.0, "c_a": 1.0, "t_d": 0.0, "eta_s": 0.0}, (), 3)
    assert np.array_equal(k_d, np.full((3, 2), 1000.0))


def _pass_outputs(n: int, r: int, seed: int):
    """K_F's modes of n poses and a pass's exact condensation (nb = r finite modes, damped
    poles), random but shaped as :func:`.damped_modes.fused_exact` gives them."""
    rng = np.random.default_rng(seed)
    freq = np.sort(rng.uniform(5.0, 80.0, (n, 6)), axis=1)
    wn = rng.uniform(30.0, 500.0, (n, 6))
    zeta = rng.uniform(0.0, 0.1, (n, 6))
    poles = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    solved = {
        "nb": np.full(n, r),
        "code": np.zeros(n, dtype=np.int8),
        "lam": np.sort(rng.uniform(1e3, 1e5, (n, 6)), axis=1),
        "V": rng.normal(size=(n, 6, 6)),
        "M": np.broadcast_to(np.eye(6), (n, 6, 6)),
        "damped": (wn, zeta, wn * np.sqrt(1 - zeta**2), poles, rng.uniform(size=n) > 0.2),
    }
    return freq, rng.normal(size=(n, 6, 6)), solved


def _merged(freq, vec, solved, valid=None):
    modes = Modes(freq.copy(), vec.copy(), ("rx", "ry", "rz", "x", "y", "z"), "flexible", valid=valid)
    return dm.exact_merge(None, (), None, {}, {}, solved, modes, True)


def _first(solved: dict, n: int) -> dict:
    return {k: tuple(a[:n] for a in v) if k == "damped" else v[:n] for k, v in solved.items()}


@pytest.mark.parametrize("r", [4, 6])
def test_exact_merge_of_every_row_equals_the_merge_of_the_valid_rows(r):
    """Every row valid (the pass's arrays as they are) and the same rows beside an invalid one
    (rows taken from the arrays): bit for bit; only the r finite columns replaced, a rigid
    direction's column keeps K_F's mode and is marked constrained."""
    n = 5
    freq, vec, solved = _pass_outputs(n + 1, r, seed=r)
    every = _merged(freq[:n], vec[:n], _first(solved, n))
    some = _merged(freq, vec, solved, valid=np.arange(n + 1) < n)
    for name in ("freq_hz", "eigentwists", "stable"):
        assert np.array_equal(getattr(every, name), getattr(some, name)[:n]), name
    for name in ("natural_hz", "damped_hz", "damping_ratio", "poles", "stable"):
        assert np.array_equal(getattr(every.damping, name), getattr(some.damping, name)[:n], equal_nan=True), name
    want = np.sqrt(solved["lam"][:n, :r]) / (2 * np.pi)
    assert np.allclose(every.freq_hz[:, :r], want, rtol=1e-15) and np.array_equal(every.freq_hz[:, r:], freq[:n, r:])
    assert np.array_equal(every.damping.damping_ratio[:, r:], np.zeros((n, 6 - r)))
    if r == 6:
        assert every.constrained is None and some.constrained is None
    else:
        assert every.constrained[:, r:].all() and not every.constrained[:, :r].any()
        assert np.array_equal(every.constrained, some.constrained[:n]) and not some.constrained[n].any()
    assert np.array_equal(some.freq_hz[n], freq[n])  # the invalid row untouched


def test_exact_merge_refuses_rows_of_different_admissible_counts_or_unsolved():
    freq, vec, solved = _pass_outputs(3, 5, seed=1)
    solved["nb"] = np.array([5, 5, 4])
    assert _merged(freq, vec, solved) is None
    solved["nb"], solved["code"] = np.full(3, 5), np.array([0, 2, 0], dtype=np.int8)  # a row not solved
    assert _merged(freq, vec, solved) is None
