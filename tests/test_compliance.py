"""App. C against an independent computation; screw-algebra identities."""

from __future__ import annotations

import numpy as np
import sympy as sp

from eigentwist.description.screw import adjoint, compliance_to_frame, inertia_to_frame, spatial_inertia
from eigentwist.symbolic.stiffness import rod_pair_compliance, tube_cantilever_compliance


def _rod_stiffness(L, r_i, r_o, E, G):
    """Single-rod tip stiffness by inverting the cantilever compliance (beam theory)."""
    C = np.array(tube_cantilever_compliance(L, r_i, r_o, E, (E / (2 * G)) - 1).evalf(), dtype=float)
    return np.linalg.inv(C)


def _guided_pair_stiffness(L, r_i, r_o, E, G, d):
    """Eq. C.7: two rods at +-d/2 along y, both fixed to the tip frame (numerical)."""
    K = np.zeros((6, 6))
    for off in (d / 2, -d / 2):
        Ad = np.array(adjoint(sp.eye(3), sp.Matrix([0, off, 0])).evalf(), dtype=float)
        Adinv = np.linalg.inv(Ad)
        K += Adinv.T @ _rod_stiffness(L, r_i, r_o, E, G) @ Adinv
    return K


def test_rod_pair_compliance_matches_inverse_of_eq_c7():
    L, r_i, r_o, E, G, d = 0.53, 0.0035, 0.005, 170e9, 65e9, 0.05
    C = np.array(rod_pair_compliance(L, r_i, r_o, E, G, d).evalf(), dtype=float)
    C7 = np.linalg.inv(_guided_pair_stiffness(L, r_i, r_o, E, G, d))
    # every entry a leg can load (axial, in-plane rotation and their couplings) and bending
    for idx in [(1, 1), (1, 5), (2, 2), (2, 4), (3, 3), (4, 4), (5, 5)]:
        np.testing.assert_allclose(C[idx], C7[idx], rtol=1e-9, err_msg=str(idx))
    np.testing.assert_allclose(C, C.T)


def test_inertia_transport_preserves_kinetic_energy():
    rng = np.random.default_rng(3)
    m, c = 0.7, sp.Matrix([0.1, -0.05, 0.02])
    I = sp.Matrix(np.diag([0.01, 0.02, 0.03]))
    Ml = spatial_inertia(m, c, I)
    ang = rng.random(3)
    Rm = sp.Matrix(np.linalg.qr(rng.normal(size=(3, 3)))[0])
    p = sp.Matrix(rng.normal(size=3))
    Me = np.array(inertia_to_frame(Ml, Rm, p).evalf(), dtype=float)
    t_e = rng.normal(size=6)
    Ad = np.array(adjoint(Rm, p).evalf(), dtype=float)
    t_local = np.linalg.solve(Ad, t_e)
    ke_local = t_local @ np.array(Ml.evalf(), dtype=float) @ t_local
    assert np.isclose(t_e @ Me @ t_e, ke_local, rtol=1e-12)
    assert ang is not None


def test_compliance_transport_preserves_elastic_energy():
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 6))
    Cl = sp.Matrix(A @ A.T)
    Rm = sp.Matrix(np.linalg.qr(rng.normal(size=(3, 3)))[0])
    p = sp.Matrix(rng.normal(size=3))
    Ce = np.array(compliance_to_frame(Cl, Rm, p).evalf(), dtype=float)
    Ad = np.array(adjoint(Rm, p).evalf(), dtype=float)
    w_e = rng.normal(size=6)
    w_local = Ad.T @ w_e  # wrenches transform with Ad^T
    assert np.isclose(w_e @ Ce @ w_e, w_local @ np.array(Cl, dtype=float) @ w_local, rtol=1e-12)


def test_adjoint_of_homogeneous_composes_and_inverts():
    from eigentwist.description.screw import adjoint_of_homogeneous, homogeneous

    rng = np.random.default_rng(8)
    Hs = [
        homogeneous(sp.Matrix(np.linalg.qr(rng.normal(size=(3, 3)))[0]), sp.Matrix(rng.normal(size=3)))
        for _ in range(2)
    ]
    A = [np.array(adjoint_of_homogeneous(H).evalf(), dtype=float) for H in Hs]
    A12 = np.array(adjoint_of_homogeneous(Hs[0] * Hs[1]).evalf(), dtype=float)
    np.testing.assert_allclose(A[0] @ A[1], A12, atol=1e-12)
    Ainv = np.array(adjoint_of_homogeneous(Hs[0].inv()).evalf(), dtype=float)
    np.testing.assert_allclose(Ainv @ A[0], np.eye(6), atol=1e-12)
    # the reciprocal product is invariant: wrenches move with Ad^-T
    t, w = rng.normal(size=6), rng.normal(size=6)
    assert np.isclose((np.linalg.inv(A[0]).T @ w) @ (A[0] @ t), w @ t)
