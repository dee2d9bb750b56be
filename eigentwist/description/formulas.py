"""Closed-form component formulas the catalogue's effects build with (pure SymPy).

Structural compliances in their local frames (App. C rod pair, lower-link tube; twist order
[rotation; translation], wrench [moment; force]) and the spatial inertias of a point mass and
of the parallelogram's fictitious rod (Eqs. 26-29).
They belong to the description layer: effects (:mod:`.effects`) call them and the
derivation (:mod:`eigentwist.symbolic`) receives their results, so data flows one way.
"""

from __future__ import annotations

import sympy as sp

from .screw import spatial_inertia

__all__ = ["rod_pair_compliance", "tube_cantilever_compliance", "point_mass_inertia", "parallelogram_inertia"]


def rod_pair_compliance(L, r_i, r_o, E, G, d_pi) -> sp.Matrix:
    """Compliance of two parallel cantilever rods at their tip frame (Eq. C.10, corrected).

    Frame L_i2: x along the rods (root to tip), y the direction separating them (rods
    ``d_pi`` apart, m), twist order [rotation; translation], wrench [moment; force].
    Corrections (facts file): ``d_pi**2`` in entry (1,1); entry (6,2) = (2,6).
    Units: rad/(N m), m/N and rad/N.
    """
    A = sp.pi * (r_o**2 - r_i**2)  # Eq. C.2
    Ix = sp.pi / 2 * (r_o**4 - r_i**4)  # Eq. C.3
    Iy = sp.pi / 4 * (r_o**4 - r_i**4)  # Eq. C.4 (I_y = I_z)
    Iz = Iy
    S = A * d_pi**2 + 4 * Iz
    C = sp.zeros(6, 6)
    C[0, 0] = L**3 / (2 * (G * Ix * L**2 + 3 * E * Iy * d_pi**2))
    C[1, 1] = L / (2 * E * Iy)
    C[1, 5] = C[5, 1] = -(L**2) / (4 * E * Iy)
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
    C[1, 5] = C[5, 1] = -(L**2) / (2 * E * I)
    return C


def point_mass_inertia(mass, offset: sp.Matrix) -> sp.Matrix:
    """Spatial inertia at the EE origin of a point mass (kg) at ``offset`` (m)."""
    rot = (offset.dot(offset) * sp.eye(3) - offset * offset.T) * mass
    return spatial_inertia(mass, offset, rot)


def parallelogram_inertia(r_i, r_o, rho, l2) -> sp.Matrix:
    """Spatial inertia of the fictitious rod replacing the parallelogram (Eqs. 26-29).

    A single tube of double density, in frame C_i3 at its centre, x along the rod.
    Returns diag(I_x, I_y, I_z, m, m, m) in kg m^2 and kg.
    """
    m = 2 * l2 * rho * sp.pi * (r_o**2 - r_i**2)
    i_x = m / 2 * (r_i**2 + r_o**2)
    i_yz = m / 12 * (3 * (r_i**2 + r_o**2) + l2**2)
    return sp.diag(i_x, i_yz, i_yz, m, m, m)
