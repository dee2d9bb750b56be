"""Screw algebra in SymPy: twists, wrenches, reciprocal product, adjoints.

Conventions (Hoevenaars, Krut & Herder 2020, DOI 10.1016/j.mechmachtheory.2019.103775):

* a **twist** is ``[omega; v]`` (rad/s; m/s) with ``v = p x omega`` for a point ``p`` on
  the axis, measured from the reference point (the end-effector origin);
* a **wrench** is ``[moment; force]`` (N m; N);
* the **reciprocal product** of a wrench and a twist is their plain dot product (W).

Every function here is pure and works on ``sympy.Matrix`` objects.
"""

from __future__ import annotations

import sympy as sp

__all__ = [
    "stiffness_to_frame",
    "cross",
    "skew",
    "unit_twist",
    "pure_translation",
    "wrench_on_line",
    "pure_moment",
    "reciprocal_product",
    "adjoint",
    "homogeneous",
    "adjoint_of_homogeneous",
    "inverse_adjoint",
    "inertia_to_frame",
    "compliance_to_frame",
    "spatial_inertia",
    "normalize",
]


def cross(a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    """Cross product ``a x b`` of two 3-vectors."""
    return sp.Matrix(
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    )


def skew(p: sp.Matrix) -> sp.Matrix:
    """Skew-symmetric matrix ``[p]x`` such that ``skew(p) @ b == cross(p, b)``."""
    return sp.Matrix([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])


def normalize(v: sp.Matrix) -> sp.Matrix:
    """``v / |v|`` (no simplification)."""
    return v / sp.sqrt(v.dot(v))


def unit_twist(axis: sp.Matrix, point: sp.Matrix) -> sp.Matrix:
    """Unit twist of a revolute joint with unit ``axis`` through ``point`` (m): ``[s; p x s]``."""
    return sp.Matrix.vstack(axis, cross(point, axis))


def pure_translation(direction: sp.Matrix) -> sp.Matrix:
    """Unit twist of a prismatic (or parallelogram) joint: ``[0; s]``."""
    return sp.Matrix.vstack(sp.zeros(3, 1), direction)


def wrench_on_line(direction: sp.Matrix, point: sp.Matrix) -> sp.Matrix:
    """Wrench of a force along ``direction`` through ``point``: ``[p x f; f]``."""
    return sp.Matrix.vstack(cross(point, direction), direction)


def pure_moment(direction: sp.Matrix) -> sp.Matrix:
    """Wrench of a pure moment along ``direction``: ``[m; 0]``."""
    return sp.Matrix.vstack(direction, sp.zeros(3, 1))


def reciprocal_product(wrench: sp.Matrix, twist: sp.Matrix) -> sp.Expr:
    """Reciprocal product ``wrench . twist`` (power, W, for unit magnitudes)."""
    return sum((wrench[k] * twist[k] for k in range(6)), sp.Integer(0))


def adjoint(rotation: sp.Matrix, origin: sp.Matrix) -> sp.Matrix:
    """Adjoint that maps a twist expressed in a local frame to the reference frame.

    The local frame has axes ``rotation`` (columns, in reference axes) and its origin
    at ``origin`` (m) from the reference point. For twists ``[omega; v]``::

        Ad = [[R, 0], [[p]x R, R]]

    Its inverse-transpose maps wrenches; ``Ad**-1`` maps twists back (Murray et al.).
    """
    R = rotation
    top = sp.Matrix.hstack(R, sp.zeros(3, 3))
    bottom = sp.Matrix.hstack(skew(origin) * R, R)
    return sp.Matrix.vstack(top, bottom)


def homogeneous(rotation: sp.Matrix, origin: sp.Matrix) -> sp.Matrix:
    """4x4 homogeneous transform ``[[R, p], [0, 1]]`` of a frame (axes R, origin p in m)."""
    H = sp.eye(4)
    H[:3, :3] = rotation
    H[:3, 3] = origin
    return H


def adjoint_of_homogeneous(H: sp.Matrix) -> sp.Matrix:
    """Adjoint ``Ad_H`` of a homogeneous transform (twists [omega; v]), as in Eqs. 24, 44."""
    return adjoint(H[:3, :3], H[:3, 3])


def inverse_adjoint(rotation: sp.Matrix, origin: sp.Matrix) -> sp.Matrix:
    """Closed-form inverse of :func:`adjoint` (reference twist -> local twist)."""
    Rt = rotation.T
    top = sp.Matrix.hstack(Rt, sp.zeros(3, 3))
    bottom = sp.Matrix.hstack(-Rt * skew(origin), Rt)
    return sp.Matrix.vstack(top, bottom)


def inertia_to_frame(inertia_local: sp.Matrix, rotation: sp.Matrix, origin: sp.Matrix) -> sp.Matrix:
    """Spatial inertia (kg, kg m, kg m^2) moved from a local frame to the reference frame.

    Eqs. 24 and 30: ``M = Ad^T M_local Ad`` where ``Ad`` maps a reference twist to the
    local frame (the inverse of :func:`adjoint`).
    """
    A = inverse_adjoint(rotation, origin)
    return A.T * inertia_local * A


def stiffness_to_frame(stiffness_local: sp.Matrix, rotation: sp.Matrix, origin: sp.Matrix) -> sp.Matrix:
    """Stiffness (N/m, N m/rad, ...) moved from a local frame to the reference frame.

    A stiffness maps twists to wrenches like an inertia: ``K = Ad^T K_local Ad`` with
    ``Ad`` the map from a reference twist to the local frame.
    """
    return inertia_to_frame(stiffness_local, rotation, origin)


def compliance_to_frame(compliance_local: sp.Matrix, rotation: sp.Matrix, origin: sp.Matrix) -> sp.Matrix:
    """Compliance (rad/(N m), m/N, ...) moved from a local frame to the reference frame.

    Eqs. 44 and 49: ``C = Ad C_local Ad^T`` with ``Ad`` from :func:`adjoint`.
    """
    A = adjoint(rotation, origin)
    return A * compliance_local * A.T


def spatial_inertia(mass, com: sp.Matrix, inertia_at_origin: sp.Matrix) -> sp.Matrix:
    """6x6 spatial inertia ``[[I_o, m[c]x], [-m[c]x, m 1]]`` for twists ``[omega; v]``.

    ``inertia_at_origin`` is the 3x3 rotational inertia about the frame origin (kg m^2),
    ``com`` the centre of mass in the frame (m), ``mass`` in kg (Eqs. 23, 26, 31).
    """
    C = skew(com) * mass
    top = sp.Matrix.hstack(inertia_at_origin, C)
    bottom = sp.Matrix.hstack(-C, sp.eye(3) * mass)
    return sp.Matrix.vstack(top, bottom)
