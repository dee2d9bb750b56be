"""Gravity preload: the tau_e term of Eq. 13 for the static weight of the end-effector.

The closed-form derivative matrices ``G`` (d J_e^-T / d q times J^-1, per elastic joint)
come from the generated ``gravity`` kernel; only the static joint torques tau_e are
solved numerically here (a batched 6x6 or 3x3 linear solve).
"""

from __future__ import annotations

import numpy as np

__all__ = ["gravity_stiffness"]


def gravity_stiffness(
    ev, poses: np.ndarray, effects, params: dict, mats: dict, rigid: bool, basis: np.ndarray | None = None
) -> np.ndarray:
    """Stiffness added by the gravity preload (symmetric part), (N, 6, 6) or (N, 3, 3).

    The static load W (the platform's weight under each preload effect's acceleration)
    is a generated output, so no effect parameter is named here.

    tau_e: each leg's elastic joint torques under the static load W, from the
    displacement delta = K^-1 W and tau_e,i = K_qe,i J_e,i delta (Eq. 40). For the
    rigid model only the actuated joints carry load, on the platform's allowed twists
    ``basis`` (N, 6, n) (:mod:`.allowed`: a Delta's translations, a hexapod's six twists):
    ``delta = B (B^T K_R B)^-1 B^T W``, and the result is ``B^T K_G B``.
    """
    gk = ev.run_kernel("gravity", poses, effects, **params)  # G, Kqe, k_act, W and J_rows
    W = gk["W"]  # (n, 6): the preload's static wrench
    jr = gk["J_rows"]  # (n, legs, rows, 6), the actuated row first
    if rigid:
        B = basis
        Bt = np.swapaxes(B, 1, 2)
        delta = (B @ np.linalg.solve(Bt @ mats["K_R"] @ B, Bt @ W[:, :, None]))[..., 0]
        tau = np.zeros(jr.shape[:2] + (gk["G"].shape[2],))
        tau[..., 0] = gk["k_act"] * np.einsum("nlj,nj->nl", jr[:, :, 0, :], delta)
    else:
        delta = np.linalg.solve(mats["K_F"], W[:, :, None])[..., 0]
        je = jr[:, :, [0, 3], :]  # (n, legs, 2, 6)
        tau = np.einsum("nlab,nlbj,nj->nla", gk["Kqe"], je, delta)
    K_G = np.einsum("nla,nlaij->nij", tau, gk["G"])
    K_G = 0.5 * (K_G + np.swapaxes(K_G, -1, -2))
    return np.swapaxes(basis, 1, 2) @ K_G @ basis if rigid else K_G
