"""Cartesian inertia matrix M of the manipulator (Eqs. 8-12, 21-32)."""
from __future__ import annotations

import sympy as sp

from ..description.formulas import parallelogram_inertia, point_mass_inertia
from ..description.screw import inverse_adjoint
from .leg import LegScrews
from .program import Program

__all__ = ["parallelogram_inertia", "body_inertia_contribution", "point_mass_inertia"]


def body_inertia_contribution(prog: Program, screws: LegScrews, body, inertia_local: sp.Matrix, name: str) -> sp.Matrix:
    """Term ``J_i^-T J_ij^T M_ij J_ij J_i^-1`` of Eq. 12 for one body of one leg.

    The body (:class:`~eigentwist.description.chain.ChainBody`) is moved by the unit
    twists of the first ``body.after`` joints of the leg (J_ij, Eqs. 16-20); its spatial
    inertia ``inertia_local`` (kg, kg m, kg m^2) is given in the body frame (axes
    ``body.rotation``, origin ``body.origin``: names of the leg's geometry, Eqs. 24, 30;
    the origin is measured from the platform origin ``screws.origin``).
    The body's joint-space inertia ``B^T M_local B`` (B: the joint twists seen in the
    body frame) is formed first, then mapped with the inverse-Jacobian rows.
    """
    g = screws.vectors
    vec = lambda v: sp.Matrix(g[v]) if isinstance(v, str) else sp.Matrix(v)  # noqa: E731
    A = inverse_adjoint(sp.Matrix.hstack(*[vec(a) for a in body.rotation]), vec(body.origin) - screws.origin)
    keys = screws.twists_of(body.after)
    B = prog.let_matrix(f"B{name}", A * sp.Matrix.hstack(*[screws.twists[k] for k in keys]))
    Mq = prog.let_matrix(f"Mq{name}", B.T * inertia_local * B)
    rows = sp.Matrix.vstack(*[screws.rows[k] for k in keys])
    return rows.T * Mq * rows
