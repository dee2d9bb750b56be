"""Gravity preload: the tau_e term of Eq. 13 for the static weight of the end-effector.

The closed-form derivative matrices ``G`` (d J_e^-T / d q times J^-1, per elastic joint)
come from the generated ``gravity`` kernel; only the static joint torques tau_e are
solved numerically here (a batched 6x6 or 3x3 linear solve).
"""
from __future__ import annotations

import numpy as np

__all__ = ["gravity_stiffness", "gravity_wrench"]


def gravity_wrench(p: dict, effects) -> np.ndarray:
    """Wrench [moment; force] (N m; N) of the EE (and payload) weight at the EE origin, (N, 6)."""
    g = np.asarray(p["g"], dtype=float)
    m = np.asarray(p["m_e"], dtype=float)
    force = np.zeros(np.broadcast_shapes(g.shape, m.shape) + (3,))
    force[..., 2] = -m * g
    moment = np.zeros_like(force)
    if "payload_mass" in effects:
        mp = np.asarray(p["m_p"], dtype=float)
        fp = np.zeros(np.broadcast_shapes(g.shape, mp.shape) + (3,))
        fp[..., 2] = -mp * g
        offset = np.stack(np.broadcast_arrays(p["p_x"], p["p_y"], p["p_z"]), axis=-1)
        moment = moment + np.cross(offset, fp)
        force = force + fp
    return np.concatenate(np.broadcast_arrays(moment, force), axis=-1)


def gravity_stiffness(ev, poses: np.ndarray, effects, params: dict, mats: dict, rigid: bool) -> np.ndarray:
    """Stiffness added by the gravity preload (symmetric part), (N, 6, 6) or (N, 3, 3).

    tau_e: each leg's elastic joint torques under the static load W, from the
    displacement delta = K^-1 W and tau_e,i = K_qe,i J_e,i delta (Eq. 40). For the
    rigid model only the actuated joints carry load (3x3 translational subset).
    """
    n = len(poses)
    p = ev.parameter_values(n, effects, **params)
    W = np.broadcast_to(gravity_wrench(p, effects), (n, 6))
    gk = ev.run_kernel("gravity", poses, effects, **params)        # G, Kqe, k_act and J_rows
    jr = gk["J_rows"]                                        # (n, legs, 4, 6)
    if rigid:
        delta = np.zeros((n, 6))
        delta[:, 3:] = np.linalg.solve(mats["K_R"][:, 3:, 3:], W[:, 3:, None])[..., 0]
        tau = np.zeros(jr.shape[:2] + (2,))
        tau[..., 0] = gk["k_act"][:, None] * np.einsum("nlj,nj->nl", jr[:, :, 0, :], delta)
    else:
        delta = np.linalg.solve(mats["K_F"], W[:, :, None])[..., 0]
        je = jr[:, :, [0, 3], :]                                  # (n, legs, 2, 6)
        tau = np.einsum("nlab,nlbj,nj->nla", gk["Kqe"], je, delta)
    K_G = np.einsum("nla,nlaij->nij", tau, gk["G"])
    K_G = 0.5 * (K_G + np.swapaxes(K_G, -1, -2))
    return K_G[:, 3:, 3:] if rigid else K_G
