"""Identities of physics over the workspace (style: pinocchio-like identity tests)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from eigentwist.runtime.eigen import generalized_eigh

from .conftest import random_poses, workspace_grid

PAPER = "paper"
ALL_FLEX = "paper,lower_link_compliance,transmission_compliance,payload_mass,rotor_inertia"


@pytest.fixture(scope="module")
def grid(ev):
    return workspace_grid(ev.robot, 4)


@pytest.mark.parametrize("model", [PAPER, ALL_FLEX])
def test_M_spd_and_K_psd_over_grid(ev, grid, model):
    mats = ev.matrices(grid, model)
    for key in ("M", "K_R", "K_F"):
        A = mats[key]
        np.testing.assert_allclose(A, np.swapaxes(A, 1, 2), rtol=0, atol=1e-9 * np.abs(A).max())
    assert np.linalg.eigvalsh(mats["M"]).min() > 0
    for key in ("K_R", "K_F"):
        lam = np.linalg.eigvalsh(mats[key])
        scale = np.abs(lam).max(axis=1, keepdims=True)
        assert (lam >= -1e-9 * scale).all(), key
    # K_F is full rank (constraints are compliant), K_R has rank 4 (four actuators)
    assert np.linalg.eigvalsh(mats["K_F"]).min() > 0
    assert (np.linalg.matrix_rank(mats["K_R"], tol=1e-8 * np.abs(mats["K_R"]).max()) == 4).all()


def _twist_adjoint(p):
    """Adjoint moving the reference point of twists by -p (a change of reference point)."""
    P = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    A = np.eye(6)
    A[3:, :3] = P
    return A


def test_frequencies_invariant_under_change_of_reference_point(ev, grid):
    M, K = ev.stiffness(grid[:8], PAPER)
    f0 = np.sqrt(generalized_eigh(K, M)[0]) / (2 * np.pi)  # of the same (M, K) pair (K_F with its c_rigid)
    A = _twist_adjoint(np.array([0.03, -0.2, 0.11]))
    M2, K2 = A.T @ M @ A, A.T @ K @ A
    assert not np.allclose(M2, M)
    lam, _ = generalized_eigh(K2, M2)
    np.testing.assert_allclose(np.sqrt(lam) / (2 * np.pi), f0, rtol=1e-9)


def test_stiffness_scaling_scales_frequencies_by_sqrt_c(ev, grid):
    c = 3.7
    d = ev.defaults
    f0 = ev.frequencies(grid[:6], PAPER)
    f1 = ev.frequencies(
        grid[:6],
        PAPER,
        k_a=c * d["k_a"],
        k_E_rot=c * d["k_E_rot"],
        k_E_lin=c * d["k_E_lin"],
        E_rod=c * d["E_rod"],
        G_rod=c * d["G_rod"],
    )
    # the legs' rigid constraint directions are exact: no c_rigid to scale
    np.testing.assert_allclose(f1, np.sqrt(c) * f0, rtol=1e-12)


def test_inverse_jacobian_rows_match_finite_differences_of_ik(ev):
    poses = random_poses(ev.robot, 5, seed=7)
    rows = ev.jacobians(poses)["J_rows"]  # (N, legs, 4, 6)
    h = 1e-6
    l2 = ev.defaults["l2"]
    for k in range(3):
        dp = np.zeros(3)
        dp[k] = h
        dq = (ev.joint_angles(poses + dp) - ev.joint_angles(poses - dp)) / (2 * h)  # (N, legs, 3)
        np.testing.assert_allclose(rows[:, :, 0, 3 + k], dq[..., 0], rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(rows[:, :, 1, 3 + k], dq[..., 1], rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(rows[:, :, 2, 3 + k], l2 * dq[..., 2], rtol=1e-6, atol=1e-6)


def test_infinitely_stiff_structure_gives_the_rigid_model(ev, grid):
    d = ev.defaults
    stiff = dict(E_rod=d["E_rod"] * 1e7, k_E_rot=d["k_E_rot"] * 1e7, k_E_lin=d["k_E_lin"] * 1e7, c_rigid=1e-15)
    f_flex = ev.frequencies(grid[:10], PAPER, **stiff)[:, :3]
    f_rigid = ev.frequencies(grid[:10], "rigid")
    np.testing.assert_allclose(f_flex, f_rigid, rtol=1e-5)


def test_rod_shear_modulus_has_no_influence(ev, grid):
    a = ev.matrices(grid[:10], PAPER)["K_F"]
    b = ev.matrices(grid[:10], PAPER, G_rod=ev.defaults["G_rod"] / 50)["K_F"]
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)


def test_gravity_preload_matches_pendulum_estimate(ev):
    """A hanging load stiffens lateral modes by about m g / l2 (parallelograms in tension)."""
    x = np.array([ev.robot.x_ref])
    M, K0 = ev.stiffness(x, "rigid", k_a=125.0)
    _, K1 = ev.stiffness(x, "rigid,gravity_preload", k_a=125.0)
    d = ev.defaults
    dk = K1[0, 0, 0] - K0[0, 0, 0]
    estimate = d["m_e"] * d["g"] / d["l2"]
    assert dk > 0
    assert 0.5 * estimate < dk < 2.0 * estimate


def test_screws_are_reciprocal(derived):
    """Rows w_k / (w_k . t_k) times twists t_l give the identity (Huang's method, App. A corrected)."""
    robot = derived.robot
    vals = dict(robot.defaults)
    q = np.radians([[31.0, 85.0, 7.0], [22.0, 101.0, -4.0], [15.0, 104.0, 9.0], [8.0, 117.0, -11.0]])
    vals.update({s_: v for s_, v in zip(derived.joints, q.ravel())})
    for ls in derived.screws:
        keys = (1, 2, 3, 5, "c")
        T = sp.Matrix.hstack(*[ls.twists[k] for k in keys])
        R = sp.Matrix.vstack(*[ls.rows[k] for k in keys])
        num = lambda m: np.array(derived.program.evaluate(vals, m), dtype=float)  # noqa: E731
        T, R, t4 = num(T), num(R), num(ls.twists[4])  # numbers first: the products in NumPy
        np.testing.assert_allclose(R @ T, np.eye(5), atol=1e-12)
        # the actuation and constraint wrenches are also reciprocal to t_a4
        np.testing.assert_allclose(R[[0, 1, 2, 4]] @ t4, 0, atol=1e-12)
