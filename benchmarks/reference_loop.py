"""A straightforward per-pose NumPy implementation of the paper's Heli4 model.

Written from the paper (Hoevenaars, Krut & Herder 2020, DOI
10.1016/j.mechmachtheory.2019.103775) and ``heli4-facts.md`` without using
eigentwist's derivation or generated code: numeric 3-vectors and 6x6 matrices,
``np.cross`` and ``@`` in a Python loop over poses. It is the baseline of the benchmarks
and an independent check of the generated evaluators (``tests/test_reference_loop.py``).

Where eigentwist uses closed forms, this uses plain numerics:

* the leg inverse Jacobian is the numeric inverse of ``[t_a1 .. t_a5, t_c]`` (facts file,
  misprint 4), not Huang's reciprocal-wrench rows;
* the rod-pair compliance is the numeric inverse of Eq. C.7 (two Eq. C.1 rods moved by
  +-d_Pi/2), not the closed form C.10; likewise the lower-link tube;
* each leg's 2x2 elastic joint stiffness is a numeric inverse (Eqs. 40-43).

Units: SI (m, rad, kg, N); frequencies in Hz. Parameter names are eigentwist's.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh

__all__ = ["PAPER", "legs", "inverse_kinematics", "matrices", "frequencies", "matrices_loop", "frequencies_loop"]

PAPER = ("actuator_loss", "rod_compliance", "ee_compliance")
EZ = np.array([0.0, 0.0, 1.0])


def legs(p: dict) -> list[dict]:
    """Base geometry of the four legs (facts file): u_i radial, s_i axis, B_i, a_i (App. A)."""
    R, r, d, h = p["R"], p["r"], p["d"], p["h"]
    ex, ey = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    layout = ((ex, ey, [r, 0, d]), (-ex, -ey, [-r, 0, d]), (ey, -ex, [0, r, d + h]), (-ey, ex, [0, -r, d + h]))
    return [dict(u=u, s=s, B=R * u, a=np.array(a, dtype=float)) for u, s, a in layout]


def inverse_kinematics(pose, p: dict) -> np.ndarray:
    """Joint angles (4, 3): q1 (actuated), q2 (elbow), q3 (parallelogram), rad (facts file)."""
    q = np.empty((4, 3))
    for i, leg in enumerate(legs(p)):
        D = np.asarray(pose, dtype=float) + leg["a"] - leg["B"]
        q3 = np.arcsin(D @ leg["s"] / p["l2"])
        lp = p["l2"] * np.cos(q3)
        rho_u, rho_z = D @ leg["u"], -D[2]
        q2 = np.arccos((rho_u**2 + rho_z**2 - p["l1"] ** 2 - lp**2) / (2 * p["l1"] * lp))
        q1 = np.arctan2(rho_z, rho_u) - np.arctan2(lp * np.sin(q2), p["l1"] + lp * np.cos(q2))
        q[i] = q1, q2, q3
    return q


def _unit(v):
    return v / np.linalg.norm(v)


def _twist(axis, point):
    """Unit twist [s; p x s] of a revolute joint through ``point`` (from the EE origin)."""
    return np.concatenate([axis, np.cross(point, axis)])


def _to_local(rotation, origin):
    """Adjoint mapping a twist at the EE origin to a frame (axes ``rotation``, origin ``origin``)."""
    Rt = rotation.T
    S = np.array([[0, -origin[2], origin[1]], [origin[2], 0, -origin[0]], [-origin[1], origin[0], 0]])
    A = np.zeros((6, 6))
    A[:3, :3] = Rt
    A[3:, 3:] = Rt
    A[3:, :3] = -Rt @ S  # v_local = R^T (v + w x o) = R^T v - R^T [o]x w
    return A


def _to_ee(rotation, origin):
    """Adjoint mapping a twist in a local frame to the EE origin (inverse of :func:`_to_local`)."""
    return np.linalg.inv(_to_local(rotation, origin))


def _beam_stiffness(L, A, Ix, Iy, Iz, E, G):
    """Eq. C.1: tip stiffness of a cantilever beam, x along the beam, [rotation; translation]."""
    K = np.zeros((6, 6))
    K[0, 0] = G * Ix / L
    K[1, 1], K[2, 2] = 4 * E * Iy / L, 4 * E * Iz / L
    K[3, 3] = A * E / L
    K[4, 4], K[5, 5] = 12 * E * Iz / L**3, 12 * E * Iy / L**3
    K[1, 5] = K[5, 1] = 6 * E * Iy / L**2
    K[2, 4] = K[4, 2] = -6 * E * Iz / L**2
    return K


def _inv_spd(K):
    """Inverse of a symmetric positive definite matrix, diagonally scaled for accuracy."""
    s = 1 / np.sqrt(np.diag(K))
    return s[:, None] * np.linalg.inv(s[:, None] * K * s[None, :]) * s[None, :]


def _rod_pair_compliance(p, q3):
    """Eqs. C.2-C.9: two rods d_Pi = w_Pi cos q3 apart, stiffness summed and inverted numerically."""
    A = np.pi * (p["r_o"] ** 2 - p["r_i"] ** 2)
    Ix = np.pi / 2 * (p["r_o"] ** 4 - p["r_i"] ** 4)
    Iy = np.pi / 4 * (p["r_o"] ** 4 - p["r_i"] ** 4)
    K_rod = _beam_stiffness(p["l2"], A, Ix, Iy, Iy, p["E_rod"], p["G_rod"])
    d_pi = p["w_pi"] * np.cos(q3)
    K = np.zeros((6, 6))
    for sign in (1, -1):
        Ad = _to_local(np.eye(3), np.array([0, sign * d_pi / 2, 0]))
        K += Ad.T @ K_rod @ Ad
    return _inv_spd(K)


def _tube_compliance(p):
    """Lower-link tube clamped at the actuated joint (effect ``lower_link_compliance``)."""
    A = np.pi * (p["r_o_l1"] ** 2 - p["r_i_l1"] ** 2)
    I = np.pi / 4 * (p["r_o_l1"] ** 4 - p["r_i_l1"] ** 4)
    G = p["E_l1"] / (2 * (1 + p["nu_l1"]))
    return _inv_spd(_beam_stiffness(p["l1"], A, 2 * I, I, I, p["E_l1"], G))


def _skew(c):
    return np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])


def _lower_link_inertia(p, effects):
    """Eqs. 21-23 in frame J_i1: link (m_1, centre of gravity at l1_cog on x) and rotor."""
    rotor = p["I_rotor"] + (p["I_add"] if "rotor_inertia" in effects else 0.0)
    mc = p["m_1"] * _skew([p["l1_cog"], 0, 0])
    M = np.zeros((6, 6))
    M[:3, :3] = np.diag([p["I1_xx"], p["I1_yy"] + rotor, p["I1_zz"]])
    M[:3, 3:], M[3:, :3] = mc, -mc
    M[3:, 3:] = p["m_1"] * np.eye(3)
    return M


def _parallelogram_inertia(p):
    """Eqs. 26-29: one tube of double density at the parallelogram centre."""
    m = 2 * p["l2"] * p["rho"] * np.pi * (p["r_o"] ** 2 - p["r_i"] ** 2)
    ix = m / 2 * (p["r_i"] ** 2 + p["r_o"] ** 2)
    iyz = m / 12 * (3 * (p["r_i"] ** 2 + p["r_o"] ** 2) + p["l2"] ** 2)
    return np.diag([ix, iyz, iyz, m, m, m])


def _ee_inertia(p, effects):
    """Eq. 31, plus a point payload at (p_x, p_y, p_z) when ``payload_mass`` is on."""
    M = np.diag([p["I_e_xx"], p["I_e_yy"], p["I_e_zz"], p["m_e"], p["m_e"], p["m_e"]])
    if "payload_mass" in effects:
        c = np.array([p["p_x"], p["p_y"], p["p_z"]])
        Mp = np.zeros((6, 6))
        Mp[:3, :3] = p["m_p"] * (c @ c * np.eye(3) - np.outer(c, c))
        Mp[:3, 3:], Mp[3:, :3] = p["m_p"] * _skew(c), -p["m_p"] * _skew(c)
        Mp[3:, 3:] = p["m_p"] * np.eye(3)
        M = M + Mp
    return M


def matrices(pose, p: dict, effects=PAPER) -> dict:
    """M (Eq. 32), K_R (Eq. 14) and K_F (Eq. 13, tau_e = 0) at the EE origin for one pose."""
    effects = set(effects)
    q = inverse_kinematics(pose, p)
    eta = p["eta_a"] if "actuator_loss" in effects else 1.0
    c_act = 1 / (eta * p["k_a"]) + (1 / p["k_t"] if "transmission_compliance" in effects else 0.0)
    M = _ee_inertia(p, effects)
    M1, M3 = _lower_link_inertia(p, effects), _parallelogram_inertia(p)
    K_R, K_F = np.zeros((6, 6)), np.zeros((6, 6))
    C_tube = _tube_compliance(p) if "lower_link_compliance" in effects else None
    for i, (leg, (q1, q2, q3)) in enumerate(zip(legs(p), q)):
        u, s, a = leg["u"], leg["s"], leg["a"]
        r1 = np.cos(q1) * u - np.sin(q1) * EZ
        w = np.cos(q1 + q2) * u - np.sin(q1 + q2) * EZ
        r2 = np.cos(q3) * w + np.sin(q3) * s
        s3 = np.cos(q3) * s - np.sin(q3) * w
        s4 = _unit(np.cross(np.cross(r2, s), s))  # misprint 3: normalised
        elbow = a - p["l2"] * r2
        base = elbow - p["l1"] * r1
        f5 = np.cross(np.cross(r1, s), s3)
        c = _unit(np.cross(np.cross(f5, s4), s4))
        T = np.column_stack(
            [
                _twist(s, base),
                _twist(s, elbow),
                np.concatenate([np.zeros(3), s3]),
                _twist(s4, a),
                _twist(s, a),
                _twist(c, a),
            ]
        )  # App. A
        Jinv = np.linalg.inv(T)  # Eq. 15 (facts file)
        # inertia, Eqs. 9, 24, 30, 32: body twist = (first j twists) (their joint rates)
        for M_local, frame, j in (
            (M1, (np.column_stack([r1, s, np.cross(r1, s)]), base), 1),
            (M3, (np.column_stack([r2, s3, np.cross(r2, s3)]), elbow + p["l2"] / 2 * r2), 3),
        ):
            body = _to_local(*frame) @ T[:, :j] @ Jinv[:j]
            M += body.T @ M_local @ body
        # rigid-body stiffness, Eqs. 14, 33, 34
        K_R += Jinv[0][:, None] * Jinv[0][None, :] / c_act
        # flexible-body stiffness, Eqs. 13, 36-50
        Je = Jinv[[0, 5]]
        Ad = _to_ee(np.column_stack([r2, s3, np.cross(r2, s3)]), a)
        Cs = np.zeros((6, 6))
        if "rod_compliance" in effects:
            Cs += Ad @ _rod_pair_compliance(p, q3) @ Ad.T  # Eq. 44
        if "ee_compliance" in effects:
            C_ltp = np.zeros((6, 6))
            if i < 2:
                C_ltp[1, 1] = 1 / (0.5 * p["k_E_rot"])  # Eqs. 45, 46
            else:
                C_ltp[4, 4] = 1 / (0.5 * p["k_E_lin"])  # Eqs. 47, 48
            Ad_ltp = _to_ee(np.eye(3), np.array([0, 0, p["d"]]))
            Cs += Ad_ltp @ C_ltp @ Ad_ltp.T  # Eq. 49
        if C_tube is not None:
            Ad_e1 = _to_ee(np.column_stack([r1, s, np.cross(r1, s)]), elbow)
            Cs += Ad_e1 @ C_tube @ Ad_e1.T
        Cq = Je @ Cs @ Je.T + np.diag([c_act, p["c_rigid"]])  # Eqs. 41-43
        K_F += Je.T @ np.linalg.inv(Cq) @ Je  # Eqs. 13, 40
    return {"M": M, "K_R": K_R, "K_F": K_F}


def frequencies(pose, p: dict, effects=PAPER, rigid: bool = False) -> np.ndarray:
    """Natural frequencies (Hz) of one pose, ascending (Eq. 7): 6 flexible or 3 rigid."""
    m = matrices(pose, p, effects)
    if rigid:
        lam = eigh(m["K_R"][3:, 3:], m["M"][3:, 3:], eigvals_only=True)
    else:
        lam = eigh(m["K_F"], m["M"], eigvals_only=True)
    return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)


def matrices_loop(poses, p: dict, effects=PAPER) -> dict:
    """:func:`matrices` for every pose of ``poses`` (N, 3): M, K_R, K_F of shape (N, 6, 6)."""
    out = [matrices(pose, p, effects) for pose in poses]
    return {k: np.array([o[k] for o in out]) for k in ("M", "K_R", "K_F")}


def frequencies_loop(poses, p: dict, effects=PAPER, rigid: bool = False) -> np.ndarray:
    """:func:`frequencies` for every pose of ``poses`` (N, 3): (N, 6) or (N, 3) Hz."""
    return np.array([frequencies(pose, p, effects, rigid) for pose in poses])
