"""Bodies from shapes: mass, centre of mass and inertia as functions of dimensions.

A body of a description may be given by its shape and material instead of measured
inertia: each function here returns a :class:`Shape` whose mass (kg), centre of mass
(m) and inertia about the centre of mass (kg m^2) are SymPy expressions of its
dimensions and density, so that the derivation, the sensitivities and ``optimize`` move
them with the design parameters. :meth:`Shape.spatial` gives the 6x6 spatial inertia
``[omega; v]`` at the body frame's origin that :class:`~.chain.ChainBody` and
``platform_inertia`` take (:func:`~.screw.spatial_inertia`, parallel-axis theorem).

Frames: a rod, cylinder or tube lies along the body frame's x axis from its origin
(``0 <= x <= length``); a box and a sphere are centred on the origin (box sides along
x, y, z). Densities in kg/m^3; ``mass=`` instead of a density where a shape allows it.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import DescriptionError
from .screw import spatial_inertia

__all__ = [
    "Shape",
    "point_mass",
    "slender_rod",
    "cylinder",
    "tube",
    "box",
    "sphere",
    "compound",
    "hub_and_rod",
    "hub_and_rod_fit",
]


@dataclass(frozen=True)
class Shape:
    """A rigid body's mass ``mass`` (kg), centre of mass ``com`` (3x1, m, body frame) and
    inertia ``inertia`` (3x3, kg m^2) about the centre of mass in the body frame's axes."""

    mass: sp.Expr
    com: sp.Matrix
    inertia: sp.Matrix

    def spatial(self) -> sp.Matrix:
        """6x6 spatial inertia at the body frame's origin, ``[omega; v]`` (Eq. 23 form):
        rotational part ``I_c + m (|c|^2 1 - c c^T)`` (parallel-axis theorem)."""
        c = sp.Matrix(self.com)
        at_origin = sp.Matrix(self.inertia) + self.mass * ((c.T * c)[0, 0] * sp.eye(3) - c * c.T)
        return spatial_inertia(self.mass, c, at_origin)


def _along_x(mass, length, normal, axial) -> Shape:
    return Shape(sp.sympify(mass), sp.Matrix([length / 2, 0, 0]), sp.diag(axial, normal, normal))


def point_mass(mass, at=(0, 0, 0)) -> Shape:
    """A point mass ``mass`` (kg) at ``at`` (m): no inertia about its centre of mass."""
    return Shape(sp.sympify(mass), sp.Matrix(at), sp.zeros(3, 3))


def slender_rod(length, mass=None, *, density=None, area=None) -> Shape:
    """A slender uniform rod along x from the origin, ``length`` (m): its ``mass`` (kg), or
    ``density * area * length`` (kg/m^3, m^2). Centre of mass at ``length/2``; inertia
    about it ``m l^2 / 12`` about any axis normal to the rod, zero about its own axis."""
    if mass is None:
        if density is None or area is None:
            raise DescriptionError("slender_rod: give its mass, or its density and cross-section area")
        mass = density * area * length
    return _along_x(mass, length, mass * length**2 / 12, 0)


def tube(length, r_o, r_i, density) -> Shape:
    """A hollow circular tube along x from the origin: ``length``, outer and inner radii
    ``r_o``, ``r_i`` (m), ``density`` (kg/m^3). ``m = rho pi (r_o^2 - r_i^2) l``; about its
    centre of mass (at ``l/2``): ``m (l^2/12 + (r_o^2 + r_i^2)/4)`` normal to the axis,
    ``m (r_o^2 + r_i^2)/2`` about it."""
    mass = density * sp.pi * (r_o**2 - r_i**2) * length
    return _along_x(mass, length, mass * (length**2 / 12 + (r_o**2 + r_i**2) / 4), mass * (r_o**2 + r_i**2) / 2)


def cylinder(length, radius, density) -> Shape:
    """A solid circular cylinder along x from the origin (a tube with ``r_i = 0``):
    ``m = rho pi r^2 l``, ``m (l^2/12 + r^2/4)`` normal to the axis, ``m r^2/2`` about it."""
    return tube(length, radius, 0, density)


def box(a, b, c, density) -> Shape:
    """A solid box centred on the origin, sides ``a, b, c`` (m) along x, y, z: ``m = rho a b
    c``, inertia ``m/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2)``."""
    mass = density * a * b * c
    return Shape(mass, sp.zeros(3, 1), mass / 12 * sp.diag(b**2 + c**2, a**2 + c**2, a**2 + b**2))


def sphere(radius, density) -> Shape:
    """A solid sphere centred on the origin: ``m = rho 4/3 pi r^3``, inertia ``2/5 m r^2``
    about any axis."""
    mass = density * sp.Rational(4, 3) * sp.pi * radius**3
    return Shape(mass, sp.zeros(3, 1), sp.Rational(2, 5) * mass * radius**2 * sp.eye(3))


def compound(*shapes: Shape) -> Shape:
    """One rigid body made of ``shapes`` (all in the same body frame): masses added, the
    centre of mass their mass-weighted mean, the inertias moved to it (parallel axes)."""
    if not shapes:
        raise DescriptionError("compound: no shapes: expected at least one")
    mass = sum((sp.sympify(s.mass) for s in shapes), sp.Integer(0))
    com = sum((s.mass * sp.Matrix(s.com) for s in shapes), sp.zeros(3, 1)) / mass
    shift = lambda m, c: m * ((c.T * c)[0, 0] * sp.eye(3) - c * c.T)  # noqa: E731
    inertia = sum((sp.Matrix(s.inertia) + shift(s.mass, sp.Matrix(s.com) - com) for s in shapes), sp.zeros(3, 3))
    return Shape(mass, com, inertia)


def hub_and_rod(length, mass_per_length, hub_mass, hub_inertia) -> Shape:
    """A link turning about a joint at its frame's origin: a uniform slender rod along x
    from the origin (``length`` m, ``mass_per_length`` kg/m: mass ``lambda l``, its inertia
    about the origin ``lambda l^3 / 3`` normal to x) and a hub at the origin (the motor
    flange, bearings, clamps: ``hub_mass`` kg, ``hub_inertia`` 3 diagonal entries, kg m^2,
    about the origin). Mass ``m_hub + lambda l``; first moment ``lambda l^2 / 2`` along x."""
    hub = Shape(sp.sympify(hub_mass), sp.zeros(3, 1), sp.diag(*hub_inertia))
    return compound(hub, slender_rod(length, mass_per_length * length))


def hub_and_rod_fit(mass, cog, inertia, length) -> dict:
    """The :func:`hub_and_rod` whose body at ``length`` (m) is a measured one: ``mass`` (kg),
    centre of gravity ``cog`` (m along x), ``inertia`` (3 diagonal entries about the origin,
    kg m^2). Returns exact rationals ``{"mass_per_length": 2 m c / l^2, "hub_mass": m - lambda l,
    "hub_inertia": (I_xx, I_yy - lambda l^3/3, I_zz - lambda l^3/3)}`` (the values read as
    written decimals). Raises ``DescriptionError`` when the hub would need a negative mass or
    inertia (the measured body is lighter near the joint than a uniform rod)."""
    m, c, l = (sp.Rational(str(v)) for v in (mass, cog, length))
    I = [sp.Rational(str(v)) for v in inertia]
    lam = 2 * m * c / l**2
    rod = lam * l**3 / 3
    out = {"mass_per_length": lam, "hub_mass": m - lam * l, "hub_inertia": (I[0], I[1] - rod, I[2] - rod)}
    if out["hub_mass"] < 0 or min(out["hub_inertia"]) < 0:
        raise DescriptionError(
            f"hub_and_rod_fit: mass {mass} kg, cog {cog} m, inertia {tuple(inertia)} kg m^2 at length {length} m "
            f"leave the hub {float(out['hub_mass']):.4g} kg, {[float(v) for v in out['hub_inertia']]} kg m^2: "
            "expected non-negative (a body at least as heavy near the joint as a uniform rod)"
        )
    return out
