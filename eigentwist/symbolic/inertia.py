"""Cartesian inertia matrix M of the manipulator (Eqs. 8-12, 21-32)."""

from __future__ import annotations

import sympy as sp

from ..errors import DescriptionError
from ..description.formulas import parallelogram_inertia, point_mass_inertia
from ..description.screw import inverse_adjoint, unit_twist
from .leg import LegScrews
from .program import Program

__all__ = ["parallelogram_inertia", "body_inertia_contribution", "point_mass_inertia"]


def body_inertia_contribution(
    prog: Program, screws: LegScrews, body, inertia_local: sp.Matrix, name: str, joints: tuple = ()
) -> sp.Matrix:
    """Term ``J_i^-T J_ij^T M_ij J_ij J_i^-1`` of Eq. 12 for one body of one leg.

    The body (:class:`~eigentwist.description.chain.ChainBody`) is moved by the unit
    twists of the first ``body.after`` joints of the leg (J_ij, Eqs. 16-20); its spatial
    inertia ``inertia_local`` (kg, kg m, kg m^2) is given in the body frame (axes
    ``body.rotation``, origin ``body.origin``: names of the leg's geometry, Eqs. 24, 30;
    the origin is measured from the platform origin ``screws.origin``).
    The body's joint-space inertia ``B^T M_local B`` (B: the joint twists seen in the
    body frame) is formed first, then mapped with the inverse-Jacobian rows. A body with
    a ``pivot`` hangs on the moving part of its last joint, a Pi joint (``joints``: the
    leg's joint list): that joint moves it by the rotation about the joint's ``swing``
    axis through the pivot, ``[n; p x n] / length`` per unit of the Pi coordinate (m), in
    place of the translation (a rod of the parallelogram swinging with q3). A body of
    zero inertia contributes nothing.
    """
    if all(e == 0 for e in inertia_local):
        return sp.zeros(6, 6)
    g = screws.vectors
    vec = lambda v: sp.Matrix(g[v]) if isinstance(v, str) else sp.Matrix(v)  # noqa: E731
    A = inverse_adjoint(sp.Matrix.hstack(*[vec(a) for a in body.rotation]), vec(body.origin) - screws.origin)
    keys = screws.twists_of(body.after)
    twists = [screws.twists[k] for k in keys]
    if getattr(body, "pivot", None) is not None:
        joint = joints[body.after - 1] if len(joints) >= body.after else None
        if joint is None or not joint.swing:
            raise DescriptionError(
                f"body {body.name!r} has a pivot: expected joint {body.after} of its leg to be a Pi "
                "joint with a swing (axis, length)"
            )
        axis, length = joint.swing
        scalar = lambda v: g[v] if isinstance(v, str) else v  # noqa: E731
        twists[-1] = unit_twist(vec(axis), vec(body.pivot) - screws.origin) / scalar(length)
    B = prog.let_matrix(f"B{name}", A * sp.Matrix.hstack(*twists))
    Mq = prog.let_matrix(f"Mq{name}", B.T * inertia_local * B)
    rows = sp.Matrix.vstack(*[screws.rows[k] for k in keys])
    return rows.T * Mq * rows
