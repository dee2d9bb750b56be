"""Gravity preload: the tau_e term of Eq. 13 for the static weight of the end-effector.

The closed-form derivative matrices ``G`` (d J_e^-T / d q times J^-1, per elastic joint)
come from the generated ``gravity`` kernel; only the static joint torques tau_e are
solved numerically here (a batched 6x6 or 3x3 linear solve).
"""
from __future__ import annotations

import numpy as np

__all__ = ["gravity_stiffness"]


def gravity_stiffness(ev, poses: np.ndarray, effects, params: dict, mats: dict, rigid: bool) -> np.ndarray:
    """Stiffness added by the gravity preload (symmetric part), (N, 6, 6) or (N, 3, 3).

    The static load W (the platform's weight under each preload effect's acceleration)
    is a generated output, so no effect parameter is named here.

    tau_e: each leg's elastic joint torques under the static load W, from the
    displacement delta = K^-1 W and tau_e,i = K_qe,i J_e,i delta (Eq. 40). For the
    rigid model only the actuated joints carry load (a 3-DoF robot: the 3x3 translational
    subset; a 6-DoF robot, whose legs have no constraint wrench: the full 6x6 K_R).
    """
    n = len(poses)
    gk = ev.run_kernel("gravity", poses, effects, **params)        # G, Kqe, k_act, W and J_rows
    W = gk["W"]                                              # (n, 6): the preload's static wrench
    jr = gk["J_rows"]                                        # (n, legs, rows, 6), the actuated row first
    translational = rigid and getattr(ev, "dof", 3) == 3     # a 3-DoF robot's rigid model: x, y, z only
    if rigid:
        delta = np.zeros((n, 6))
        if translational:
            delta[:, 3:] = np.linalg.solve(mats["K_R"][:, 3:, 3:], W[:, 3:, None])[..., 0]
        else:
            delta = np.linalg.solve(mats["K_R"], W[:, :, None])[..., 0]
        tau = np.zeros(jr.shape[:2] + (gk["G"].shape[2],))
        tau[..., 0] = gk["k_act"] * np.einsum("nlj,nj->nl", jr[:, :, 0, :], delta)
    else:
        delta = np.linalg.solve(mats["K_F"], W[:, :, None])[..., 0]
        je = jr[:, :, [0, 3], :]                                  # (n, legs, 2, 6)
        tau = np.einsum("nlab,nlbj,nj->nla", gk["Kqe"], je, delta)
    K_G = np.einsum("nla,nlaij->nij", tau, gk["G"])
    K_G = 0.5 * (K_G + np.swapaxes(K_G, -1, -2))
    return K_G[:, 3:, 3:] if translational else K_G
