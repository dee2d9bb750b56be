"""Cartesian inertia matrix M of the manipulator (Eqs. 8-12, 21-32)."""
from __future__ import annotations

import sympy as sp

from .leg import LegScrews
from .program import Program
from .screw import inverse_adjoint, spatial_inertia

__all__ = ["parallelogram_inertia", "body_inertia_contribution", "point_mass_inertia"]


def parallelogram_inertia(r_i, r_o, rho, l2) -> sp.Matrix:
    """Spatial inertia of the fictitious rod replacing the parallelogram (Eqs. 26-29).

    A single tube of double density, in frame C_i3 at its centre, x along the rod.
    Returns diag(I_x, I_y, I_z, m, m, m) in kg m^2 and kg.
    """
    m = 2 * l2 * rho * sp.pi * (r_o**2 - r_i**2)
    i_x = m / 2 * (r_i**2 + r_o**2)
    i_yz = m / 12 * (3 * (r_i**2 + r_o**2) + l2**2)
    return sp.diag(i_x, i_yz, i_yz, m, m, m)


def point_mass_inertia(mass, offset: sp.Matrix) -> sp.Matrix:
    """Spatial inertia at the EE origin of a point mass (kg) at ``offset`` (m)."""
    rot = (offset.dot(offset) * sp.eye(3) - offset * offset.T) * mass
    return spatial_inertia(mass, offset, rot)


def body_inertia_contribution(prog: Program, legs: LegScrews, joints: int, frame: str,
                              inertia_local: sp.Matrix, name: str) -> sp.Matrix:
    """Term ``J_i^-T J_ij^T M_ij J_ij J_i^-1`` of Eq. 12 for one body of one leg.

    The body is moved by the first ``joints`` unit twists of the leg (J_ij, Eqs. 16-20);
    its spatial inertia ``inertia_local`` is given in the leg frame ``frame`` (Eqs. 24,
    30). The body's joint-space inertia ``B^T M_local B`` (B: the joint twists seen in
    the local frame) is formed first, then mapped with the inverse-Jacobian rows.
    """
    rotation, origin = legs.frames[frame]
    A = inverse_adjoint(rotation, origin)
    local_twists = sp.Matrix.hstack(*[legs.twists[k] for k in range(1, joints + 1)])
    B = prog.let_matrix(f"B{name}", A * local_twists)
    Mq = B.T * inertia_local * B
    Mq = prog.let_matrix(f"Mq{name}", Mq)
    rows = sp.Matrix.vstack(*[legs.rows[k] for k in range(1, joints + 1)])
    return rows.T * Mq * rows
