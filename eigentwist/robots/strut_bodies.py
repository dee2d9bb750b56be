"""The hexapod's strut bodies (cylinder and piston), measured or from shapes.

``"measured"``: each body's mass, centre-of-mass distance along the strut and transverse
inertia at the centre of mass are parameters of their own (``m_cyl``, ``d_cyl``, ``I_cyl``;
``m_pis``, ``d_pis``, ``I_pis``). ``"shapes"``: each body is a hub at its joint and a
uniform slender rod along the strut from it (:func:`~eigentwist.description.shapes.hub_and_rod`):
the cylinder from the base U joint towards the platform (``l_cyl`` m, ``lambda_cyl`` kg/m,
``m_cyl_hub`` kg, ``I_cyl_hub`` kg m^2 about the joint), the piston from the platform S
joint towards the base (``l_pis``, ``lambda_pis``, ``m_pis_hub``, ``I_pis_hub``). Fitted
(:func:`~eigentwist.description.shapes.hub_and_rod_fit`) to be the measured bodies at the
default lengths, so that their masses and inertias follow ``l_cyl`` and ``l_pis`` in
sensitivities and ``optimize``. Both forms are slender: no inertia about the strut axis.
"""

from __future__ import annotations

import sympy as sp

from ..description import Parameter
from ..description.chain import ChainBody
from ..description.screw import spatial_inertia
from ..description.shapes import hub_and_rod_fit
from ..errors import DescriptionError, InputError

__all__ = ["BODIES", "MEASURED", "LENGTHS", "parameters", "bodies"]

#: the bodies' forms ``hexapod.describe(bodies=...)`` offers
BODIES = ("measured", "shapes")
#: the measured strut bodies' parameters, which the shape form replaces
MEASURED = ("m_cyl", "d_cyl", "I_cyl", "m_pis", "d_pis", "I_pis")
#: the rods' default lengths (m) in the shape form: inside the window where the fitted
#: hubs are non-negative (cylinder 0.30-0.325 m, piston 0.20-0.225 m for the measured bodies)
LENGTHS = {"cyl": 0.32, "pis": 0.21}
_PART = {"cyl": ("cylinder", "base U joint", "platform"), "pis": ("piston", "platform S joint", "base")}


def parameters(base: tuple, bodies: str, lengths: dict = LENGTHS) -> tuple:
    """``base`` (the hexapod's parameters, the measured strut bodies among them) in form
    ``bodies``: for ``"shapes"`` the measured ones replaced by each body's rod length,
    mass per length, hub mass and hub inertia, fitted to the measured body at ``lengths``
    (m, by part ``"cyl"``, ``"pis"``). Raises ``InputError`` for an unknown form and
    ``DescriptionError`` when a length leaves a hub negative."""
    if bodies not in BODIES:
        raise InputError(f"bodies {bodies!r}: expected one of {', '.join(BODIES)}")
    if bodies == "measured":
        return base
    v = {q.name: sp.Rational(str(q.default)) for q in base}
    shapes = []
    for part, (body, joint, towards) in _PART.items():
        m, d, i = v[f"m_{part}"], v[f"d_{part}"], v[f"I_{part}"]
        about_joint = i + m * d**2
        try:
            fit = hub_and_rod_fit(float(m), float(d), (0, float(about_joint), float(about_joint)), lengths[part])
        except DescriptionError as e:
            raise DescriptionError(f"the hexapod's {body} at l_{part} = {lengths[part]:g} m: {e}") from None
        why = f"; with the rod, the measured {body} at l_{part} = {lengths[part]:g} m"
        shapes += [
            Parameter(f"l_{part}", lengths[part], "m", f"length of the {body}'s uniform tube from the {joint}"),
            Parameter(
                f"lambda_{part}",
                float(fit["mass_per_length"]),
                "kg/m",
                f"mass per length of the {body}'s tube, a slender rod from the {joint} towards the {towards}{why}",
            ),
            Parameter(
                f"m_{part}_hub", float(fit["hub_mass"]), "kg", f"the {body}'s hub at the {joint}{why}", closed=True
            ),
            Parameter(
                f"I_{part}_hub",
                float(fit["hub_inertia"][1]),
                "kg m^2",
                f"the {body}'s hub's transverse inertia about the {joint}{why}",
                closed=True,
            ),
        ]
    return tuple(q for q in base if q.name not in MEASURED) + tuple(shapes)


def _strut_body(name, mass, first_moment, about_joint, after, origin) -> ChainBody:
    """A slender strut body in a frame at its joint, x along the strut (no axial inertia):
    ``first_moment`` m c_x (kg m), ``about_joint`` its transverse inertia there (kg m^2)."""
    return ChainBody(
        name,
        after,
        spatial_inertia(mass, sp.Matrix([first_moment / mass, 0, 0]), sp.diag(0, about_joint, about_joint)),
        ("s", "e2", "u2"),
        origin,
    )


def bodies(p: dict, bodies: str) -> tuple:
    """``(cylinder, piston)``: the strut's two ``ChainBody`` in form ``bodies`` (``p``:
    parameter symbols by name), the cylinder moved by the U joint (frame at the base joint
    ``b``), the piston by the actuator too (frame at the platform joint ``top``)."""
    out = []
    for part, after, origin, sign in (("cyl", 1, "b", 1), ("pis", 2, "top", -1)):
        if bodies == "shapes":
            # hub_and_rod along sign * x: mass m_hub + lambda l, first moment sign lambda l^2 / 2,
            # transverse inertia about the joint I_hub + lambda l^3 / 3
            lam, length = p[f"lambda_{part}"], p[f"l_{part}"]
            mass = p[f"m_{part}_hub"] + lam * length
            moment, about = sign * lam * length**2 / 2, p[f"I_{part}_hub"] + lam * length**3 / 3
        else:
            mass, distance = p[f"m_{part}"], sign * p[f"d_{part}"]
            moment, about = mass * distance, p[f"I_{part}"] + mass * distance**2
        out.append(_strut_body(_PART[part][0], mass, moment, about, after, origin))
    return tuple(out)
