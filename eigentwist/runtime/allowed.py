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

__all__ = ["constraint_positions", "allowed_twists", "coordinate_twists", "reduce", "DEPENDENT_RTOL", "VANISHING"]


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


def _dot(a: list, b: list) -> np.ndarray:
    """Entry-wise dot product of two twists held as six (N,) arrays."""
    s = a[0] * b[0]
    for i in range(1, 6):
        s += a[i] * b[i]
    return s


def _orthonormal_rows(A: np.ndarray, rtol: float) -> list:
    """An orthonormal basis (list of twists, each six (N,) arrays) of the span of the rows
    ``A`` (N, c, 6): Gram-Schmidt twice per row, a row within ``rtol`` of the span so far
    dropped (its vector 0): dependent constraints (a planar leg's three, four Heli4 legs'
    couples). The twists' components are separate arrays: every step is a vector
    operation over the N poses."""
    Q: list = []
    for k in range(A.shape[1]):
        a = [A[:, k, i] for i in range(6)]
        v = [c.copy() for c in a]
        for _ in range(2):
            for q in Q:
                d = _dot(q, v)
                for i in range(6):
                    v[i] -= d * q[i]
        norm = np.sqrt(_dot(v, v))
        keep = norm > rtol * np.sqrt(_dot(a, a))
        if not keep.any():  # dependent at every pose: a zero vector adds nothing
            continue
        inv = np.where(keep, 1.0 / np.where(keep, norm, 1.0), 0.0)
        Q.append([np.where(keep, c * inv, 0.0) for c in v])
    return Q


#: a constraint row within this of the span of the rows before it (relative to its norm) is dependent
DEPENDENT_RTOL = 1e-9
#: a candidate whose projection is shorter than this (relative to its norm) cannot move: a NaN column
VANISHING = 1e-8


def allowed_twists(
    rows: np.ndarray,
    candidates: np.ndarray,
    rtol: float = DEPENDENT_RTOL,
    compiled: bool = False,
    threads: int = 1,
    picks=None,
) -> np.ndarray:
    """(N, 6, n) orthonormal bases of the allowed twists.

    rows : (N, c, 6) constraint rows ``j_c`` (any scale); c may be 0. With ``picks``
        (indices), the constraint rows are rows ``picks`` of each pose's ``rows`` (N, ..., 6).
    candidates : (6, n) or (N, 6, n) twists to project (the coordinates' unit twists).
    compiled : compute them in C (:mod:`.c_allowed`, on ``threads`` threads) where its
        driver builds; NumPy otherwise. The two agree to round-off.

    ``P e = e - sum_q q (q . e)`` over an orthonormal basis q of the rows' span (a
    dependent row, within ``rtol`` of the others', is dropped), then modified
    Gram-Schmidt of the projections in order. A candidate whose projection vanishes
    (shorter than :data:`VANISHING` of it: the coordinate cannot move there) gives a NaN
    column, and so does every later candidate at that pose. A candidate the rows already
    annihilate exactly is kept exactly (``q . e = 0``).
    """
    if compiled:
        from . import c_allowed

        if c_allowed.driver() is not None:
            return c_allowed.allowed_twists(rows, candidates, rtol, VANISHING, picks, threads)
    A = np.asarray(rows, dtype=float)
    if picks is not None:
        A = A.reshape(len(A), -1, 6)[:, np.asarray(picks, dtype=int)]
    n = A.shape[0]
    E = np.broadcast_to(np.asarray(candidates, dtype=float), (n,) + np.shape(candidates)[-2:])
    Et = np.moveaxis(E, 0, -1)  # (6, m, N)
    m = Et.shape[1]
    Q = _orthonormal_rows(A, rtol)
    P = []
    for k in range(m):
        e = [Et[i, k] for i in range(6)]
        p = [c.copy() for c in e]
        for q in Q:
            d = _dot(q, e)
            for i in range(6):
                p[i] -= q[i] * d
        P.append(p)
    B = np.empty((6, m, n))
    cols: list = []
    for k in range(m):
        v = P[k]
        for b in cols:
            d = _dot(b, v)
            for i in range(6):
                v[i] -= d * b[i]
        norm = np.sqrt(_dot(v, v))
        ok = norm > VANISHING * np.sqrt(_dot(Et[:, k], Et[:, k]))
        inv = 1.0 / np.where(ok, norm, 1.0)
        col = [np.where(ok, c * inv, np.nan) for c in v]
        cols.append(col)
        for i in range(6):
            B[i, k] = col[i]
    return np.moveaxis(B, -1, 0)


def reduce(
    X: np.ndarray, B: np.ndarray, compiled: bool = False, threads: int = 1, out: np.ndarray | None = None
) -> np.ndarray:
    """``B^T X B`` per pose: (N, n, n) from (N, 6, 6) and (N, 6, n); with ``compiled``, in C
    (:func:`.c_allowed.reduce`, ~3x faster at 20 000 poses; on ``threads`` threads) where
    its driver builds; into ``out`` (N, n, n) where given (C: a C-contiguous float64 array)."""
    if compiled and len(X):
        from . import c_allowed

        if c_allowed.driver() is not None:
            return c_allowed.reduce(X, B, threads, out)
    if out is None:
        return np.swapaxes(B, 1, 2) @ X @ B
    out[...] = np.swapaxes(B, 1, 2) @ X @ B
    return out
