"""Cartesian stiffness: rigid-body K_R (Eq. 14) and flexible-body K_F (Eq. 13).

Structural compliances (App. C rods, App. D end-effector, lower-link tubes) are given
in local frames, moved to the EE frame with the adjoint (Eqs. 44, 49), projected on
each leg's elastic joints (Eq. 43), added to the joint compliance (Eqs. 41, 42) and the
2x2 sum is inverted in closed form (Eq. 40).
"""

from __future__ import annotations

import sympy as sp

from ..errors import DescriptionError
from ..description.formulas import rod_pair_compliance, tube_cantilever_compliance

__all__ = [
    "rod_pair_compliance",
    "tube_cantilever_compliance",
    "inverse_2x2",
    "inverse_small",
    "rows_outer",
    "condense_coupling",
]


def inverse_2x2(C: sp.Matrix) -> sp.Matrix:
    """Closed-form inverse of a symmetric 2x2 matrix (Eq. 41 inverted, Eq. 40 block)."""
    det = C[0, 0] * C[1, 1] - C[0, 1] * C[1, 0]
    return sp.Matrix([[C[1, 1], -C[0, 1]], [-C[1, 0], C[0, 0]]]) / det


def rows_outer(rows: sp.Matrix, K: sp.Matrix) -> sp.Matrix:
    """``rows^T K rows``: a joint-space stiffness mapped to the EE frame (Eqs. 13, 14)."""
    return rows.T * K * rows


def inverse_small(S: sp.Matrix) -> sp.Matrix:
    """Closed-form inverse of a 1x1, 2x2 or 3x3 matrix (adjugate / determinant), or of a
    diagonal one of any size (a leg with several constraint wrenches and no body
    compliance: a planar leg's actuated joint and three virtual joints)."""
    if S.shape[0] > 3 and all(S[i, j] == 0 for i in range(S.rows) for j in range(S.cols) if i != j):
        return sp.diag(*[1 / S[i, i] for i in range(S.rows)])
    if S.shape == (1, 1):
        return sp.Matrix([[1 / S[0, 0]]])
    if S.shape == (2, 2):
        return inverse_2x2(S)
    if S.shape == (3, 3):
        return S.adjugate() / S.det(method="berkowitz")
    raise DescriptionError(f"coupling with {S.shape[0]} compliant directions: expected at most 3")


def condense_coupling(prog, Kp: sp.Matrix, G: sp.Matrix, Kc: sp.Matrix, switch, name: str) -> sp.Matrix:
    """Stiffness of a group of legs reaching the tool through a compliant coupling.

    ``Kp`` (6x6) is the legs' Cartesian stiffness at the EE origin, ``G`` (6xm) the
    coupling's unit twists at the EE origin, ``Kc`` (mxm) its stiffness. Condensing the
    coupling coordinates in closed form gives::

        Kp - Kp G (G^T Kp G + Kc)^-1 G^T Kp

    which tends to ``Kp`` (rigid connection) as Kc -> infinity; ``switch`` (0/1)
    multiplies the correction so the coupling can be switched off.
    """
    Kp = prog.let_matrix(f"Kp_{name}", Kp)
    KpG = prog.let_matrix(f"KpG_{name}", Kp * G)
    S = prog.let_matrix(f"Sc_{name}", G.T * KpG + Kc)
    Sinv = prog.let_matrix(f"Sci_{name}", inverse_small(S))
    return Kp - switch * (KpG * Sinv * KpG.T)
