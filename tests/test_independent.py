"""Independent checks of M and K_R for every robot: kinetic energy and
stiffness from finite differences of the inverse kinematics, with the body twists and
inertia transport written here in plain NumPy (not from the symbolic derivation)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import eigentwist
from eigentwist.robots import NAMES

from .conftest import random_poses


def _num(v, params):
    subs = {sp.Symbol(k, real=True): val for k, val in params.items()}
    return np.array([float(sp.sympify(c).xreplace(subs)) for c in v])


def _skew(p):
    return np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])


def _legs(robot, params):
    return [
        dict(
            u=_num(leg.radial, params),
            s=_num(leg.axis, params),
            a=_num(leg.attachment, params),
            B=_num(leg.base, params),
        )
        for leg in robot.legs
    ]


def _rod_inertia(p):
    m = 2 * p["l2"] * p["rho"] * np.pi * (p["r_o"] ** 2 - p["r_i"] ** 2)  # Eq. 29
    ix = m / 2 * (p["r_i"] ** 2 + p["r_o"] ** 2)  # Eq. 27
    iyz = m / 12 * (3 * (p["r_i"] ** 2 + p["r_o"] ** 2) + p["l2"] ** 2)  # Eq. 28
    return np.diag([ix, iyz, iyz, m, m, m])


def kinetic_energy(ev, pose, velocity, h=1e-7):
    """Sum over bodies of 1/2 t_L^T M_L t_L, joint rates from central differences of the IK."""
    p = ev.defaults
    legs = _legs(ev.robot, p)
    q0 = ev.joint_angles(pose)[0]
    qdot = (ev.joint_angles(pose + h * velocity)[0] - ev.joint_angles(pose - h * velocity)[0]) / (2 * h)
    ez = np.array([0.0, 0.0, 1.0])
    M1 = np.array(
        ev.robot.lower_link_inertia.xreplace({sp.Symbol(k, real=True): v for k, v in p.items()}).subs(
            {sp.Symbol("on_rotor_inertia", real=True): 0}
        ),
        dtype=float,
    )
    M3 = _rod_inertia(p)
    T = 0.5 * p["m_e"] * velocity @ velocity
    for leg, q, qd in zip(legs, q0, qdot):
        u, s, a = leg["u"], leg["s"], leg["a"]
        # body 1 rotates about s through B: local twist [0, qd1, 0, 0, 0, 0] in frame J_i1
        tl = np.zeros(6)
        tl[1] = qd[0]
        T += 0.5 * tl @ M1 @ tl
        # body 3 moves with t_a1 qd1 + t_a2 qd2 + t_a3 l2 qd3 (Eqs. 9, 18)
        w = np.cos(q[0] + q[1]) * u - np.sin(q[0] + q[1]) * ez
        r1 = np.cos(q[0]) * u - np.sin(q[0]) * ez
        r2 = np.cos(q[2]) * w + np.sin(q[2]) * s
        s3 = np.cos(q[2]) * s - np.sin(q[2]) * w
        elbow = a - p["l2"] * r2  # from the EE origin
        base = elbow - p["l1"] * r1
        omega = s * (qd[0] + qd[1])
        v = np.cross(base, s) * qd[0] + np.cross(elbow, s) * qd[1] + s3 * p["l2"] * qd[2]
        c = elbow + p["l2"] / 2 * r2
        R = np.column_stack([r2, s3, np.cross(r2, s3)])
        tl = np.concatenate([R.T @ omega, R.T @ (v + np.cross(omega, c))])
        T += 0.5 * tl @ M3 @ tl
    return T


# the Heli4-type legs (RR(Pi)RR): the hexapod's independent checks are in tests/test_hexapod.py
THREE_DOF = tuple(n for n in NAMES if n != "hexapod")


@pytest.mark.parametrize("robot", THREE_DOF)
def test_kinetic_energy_matches_M(robot):
    ev = eigentwist.load(robot, backend="numpy")
    rng = np.random.default_rng(5)
    poses = random_poses(ev.robot, 6, seed=5)
    M = ev.matrices(poses, "rigid")["M"]
    for pose, Mi in zip(poses, M):
        v = rng.normal(size=3)
        t = np.concatenate([np.zeros(3), v])
        assert kinetic_energy(ev, pose, v) == pytest.approx(0.5 * t @ Mi @ t, rel=1e-6)


@pytest.mark.parametrize("robot", THREE_DOF)
def test_rigid_stiffness_matches_finite_difference_jacobian(robot):
    ev = eigentwist.load(robot, backend="numpy")
    poses = random_poses(ev.robot, 6, seed=6)
    K = ev.matrices(poses, "rigid")["K_R"][:, 3:, 3:]
    h = 1e-6
    Ja = np.stack(
        [
            (ev.joint_angles(poses + h * e)[..., 0] - ev.joint_angles(poses - h * e)[..., 0]) / (2 * h)
            for e in np.eye(3)
        ],
        axis=-1,
    )  # (N, legs, 3) = d q_a / d x
    ka = ev.defaults["eta_a"] * ev.defaults["k_a"]
    K_fd = ka * np.einsum("nli,nlj->nij", Ja, Ja)
    np.testing.assert_allclose(K, K_fd, rtol=1e-6, atol=1e-6 * np.abs(K).max())
