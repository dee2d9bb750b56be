"""The platform's allowed twists and the rigid model on them.

The rigid model (Eq. 14) acts on the twists the legs allow the platform: the null space
of their constraint wrenches at the pose. Each constraint wrench reaches the runtime as
its virtual joint's inverse-Jacobian row ``j_c`` (Huang's method, ``J_rows``): a linear
form on twists ``[omega; v]`` that an allowed twist ``t`` annihilates, ``j_c . t = 0``.

The basis ``B`` (6 x n, orthonormal in the Euclidean metric of ``[omega; v]``) is the
Gram-Schmidt orthonormalisation, in twist order (rot_x ... z), of the orthogonal
projections of the coordinates' unit twists (``rot_z`` -> omega_z, ``x`` -> v_x) onto
that null space: well defined, it turns with the pose (a 3-PRS's), and it is exactly the
coordinates' unit twists where they are allowed (a Delta's or Heli4's translations,
whose constraint rows have exact zeros there: their 3x3 translational subsets of M and
K_R are this rule's special case; a hexapod's six twists: no constraint). The rigid
model is then ``M_r = B^T M B``, ``K_r = B^T K_R B`` (``n`` modes).
"""
from __future__ import annotations

import numpy as np

from ..description.pose import TWIST_AXIS

__all__ = ["constraint_positions", "allowed_twists", "coordinate_twists", "reduce"]


def constraint_positions(leg) -> list[int]:
    """Positions in a leg's ``J_rows`` (``leg.kinematics.jacobian_rows``) of its virtual
    joints' rows: the constraint wrenches."""
    of = [j for j, joint in enumerate(leg.joints) for _ in range(joint.freedoms)]
    return [r for r, k in enumerate(leg.kinematics.jacobian_rows) if leg.joints[of[k]].virtual]


def coordinate_twists(names) -> np.ndarray:
    """(6, n) unit twists ``[omega; v]`` of the pose coordinates ``names``."""
    E = np.zeros((6, len(names)))
    for c, name in enumerate(names):
        E[TWIST_AXIS[name], c] = 1.0
    return E


def _orthonormal_rows(A: np.ndarray, rtol: float) -> list:
    """An orthonormal basis (list of (N, 6)) of the span of the rows ``A`` (N, c, 6):
    Gram-Schmidt twice per row, a row within ``rtol`` of the span so far dropped (its
    vector 0): dependent constraints (a planar leg's three, four Heli4 legs' couples)."""
    Q: list = []
    for k in range(A.shape[1]):
        a = A[:, k, :]
        v = a.copy()
        for _ in range(2):
            for q in Q:
                v -= np.einsum("ni,ni->n", q, v)[:, None] * q
        norm = np.linalg.norm(v, axis=1)
        keep = norm > rtol * np.linalg.norm(a, axis=1)
        Q.append(np.where(keep[:, None], v / np.where(keep, norm, 1.0)[:, None], 0.0))
    return Q


def allowed_twists(rows: np.ndarray, candidates: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """(N, 6, n) orthonormal bases of the allowed twists.

    rows : (N, c, 6) constraint rows ``j_c`` (any scale); c may be 0.
    candidates : (6, n) or (N, 6, n) twists to project (the coordinates' unit twists).

    ``P e = e - sum_q q (q . e)`` over an orthonormal basis q of the rows' span (a
    dependent row, within ``rtol`` of the others', is dropped), then modified
    Gram-Schmidt of the projections in order. A candidate whose projection vanishes (the
    coordinate cannot move there) gives a NaN column. A candidate the rows already
    annihilate exactly is kept exactly (``q . e = 0``).
    """
    A = np.asarray(rows, dtype=float)
    n = A.shape[0]
    E = np.broadcast_to(np.asarray(candidates, dtype=float), (n,) + np.shape(candidates)[-2:])
    P = np.array(E)
    for q in _orthonormal_rows(A, rtol):
        P -= q[:, :, None] * np.einsum("ni,nik->nk", q, E)[:, None, :]
    B = np.empty_like(P)
    scale = np.linalg.norm(E, axis=1)                                # (N, n)
    for k in range(P.shape[2]):
        v = P[:, :, k].copy()
        for m in range(k):
            v -= np.einsum("ni,ni->n", B[:, :, m], v)[:, None] * B[:, :, m]
        norm = np.linalg.norm(v, axis=1)
        ok = norm > 1e-8 * scale[:, k]
        B[:, :, k] = np.where(ok[:, None], v / np.where(ok, norm, 1.0)[:, None], np.nan)
    return B


def reduce(X: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``B^T X B`` per pose: (N, n, n) from (N, 6, 6) and (N, 6, n)."""
    return np.swapaxes(B, 1, 2) @ X @ B
