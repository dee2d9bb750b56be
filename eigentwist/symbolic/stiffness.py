"""Cartesian stiffness: rigid-body K_R (Eq. 14) and flexible-body K_F (Eq. 13).

Structural compliances (App. C rods, App. D end-effector, lower-link tubes) are given
in local frames, moved to the EE frame with the adjoint (Eqs. 44, 49), projected on
each leg's elastic joints (Eq. 43), added to the joint compliance (Eqs. 41, 42) and the
2x2 sum is inverted in closed form (Eq. 40).
"""
from __future__ import annotations

import sympy as sp

__all__ = ["rod_pair_compliance", "tube_cantilever_compliance", "inverse_2x2", "inverse_small", "rows_outer",
           "condense_coupling"]


def rod_pair_compliance(L, r_i, r_o, E, G, d_pi) -> sp.Matrix:
    """Compliance of two parallel cantilever rods at their tip frame (Eq. C.10, corrected).

    Frame L_i2: x along the rods (root to tip), y the direction separating them (rods
    ``d_pi`` apart, m), twist order [rotation; translation], wrench [moment; force].
    Corrections (facts file): ``d_pi**2`` in entry (1,1); entry (6,2) = (2,6).
    Units: rad/(N m), m/N and rad/N.
    """
    A = sp.pi * (r_o**2 - r_i**2)                # Eq. C.2
    Ix = sp.pi / 2 * (r_o**4 - r_i**4)           # Eq. C.3
    Iy = sp.pi / 4 * (r_o**4 - r_i**4)           # Eq. C.4 (I_y = I_z)
    Iz = Iy
    S = A * d_pi**2 + 4 * Iz
    C = sp.zeros(6, 6)
    C[0, 0] = L**3 / (2 * (G * Ix * L**2 + 3 * E * Iy * d_pi**2))
    C[1, 1] = L / (2 * E * Iy)
    C[1, 5] = C[5, 1] = -L**2 / (4 * E * Iy)
    C[2, 2] = 2 * L / (E * S)
    C[2, 4] = C[4, 2] = L**2 / (E * S)
    C[3, 3] = L / (2 * A * E)
    C[4, 4] = L**3 * (A * d_pi**2 + 16 * Iz) / (24 * E * Iz * S)
    C[5, 5] = L**3 / (6 * E * Iy)
    return C


def tube_cantilever_compliance(L, r_i, r_o, E, nu) -> sp.Matrix:
    """Compliance of a hollow tube clamped at its root, at its tip frame.

    Euler-Bernoulli bending about y and z, axial extension and Saint-Venant torsion
    (G = E / (2 (1 + nu))). x along the tube; same ordering and units as
    :func:`rod_pair_compliance`.
    """
    A = sp.pi * (r_o**2 - r_i**2)
    I = sp.pi / 4 * (r_o**4 - r_i**4)
    J = 2 * I
    G = E / (2 * (1 + nu))
    C = sp.zeros(6, 6)
    C[0, 0] = L / (G * J)
    C[1, 1] = C[2, 2] = L / (E * I)
    C[3, 3] = L / (E * A)
    C[4, 4] = C[5, 5] = L**3 / (3 * E * I)
    C[2, 4] = C[4, 2] = L**2 / (2 * E * I)
    C[1, 5] = C[5, 1] = -L**2 / (2 * E * I)
    return C


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
    raise ValueError(f"coupling with {S.shape[0]} compliant directions: expected at most 3")


def condense_coupling(prog, Kp: sp.Matrix, G: sp.Matrix, Kc: sp.Matrix, switch, name: str) -> sp.Matrix:
    """Stiffness of a group of legs reaching the tool through a compliant coupling.

    ``Kp`` (6x6) is the legs' Cartesian stiffness at the EE origin, ``G`` (6xm) the
    coupling's unit twists at the EE origin, ``Kc`` (mxm) its stiffness. Condensing the
    coupling coordinates in closed form gives (issue 7)::

        Kp - Kp G (G^T Kp G + Kc)^-1 G^T Kp

    which tends to ``Kp`` (rigid connection) as Kc -> infinity; ``switch`` (0/1)
    multiplies the correction so the coupling can be switched off.
    """
    Kp = prog.let_matrix(f"Kp_{name}", Kp)
    KpG = prog.let_matrix(f"KpG_{name}", Kp * G)
    S = prog.let_matrix(f"Sc_{name}", G.T * KpG + Kc)
    Sinv = prog.let_matrix(f"Sci_{name}", inverse_small(S))
    return Kp - switch * (KpG * Sinv * KpG.T)
