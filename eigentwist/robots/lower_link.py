"""The lower link (body 1, Eq. 23) of the shipped RR(Pi)RR robots, measured or from shapes.

``"measured"``: its mass ``m_1``, centre of gravity ``l1_cog`` and inertias ``I1_xx``,
``I1_yy``, ``I1_zz`` about the actuated joint (frame J_i1) are parameters of their own, as
the paper gives them. ``"shapes"``: a uniform rod along ``l1`` and a hub at the actuated
joint (:func:`~eigentwist.description.shapes.hub_and_rod`: ``lambda_1`` kg/m, ``m_hub`` kg,
``I_hub_xx``, ``I_hub_yy``, ``I_hub_zz`` kg m^2), fitted to be the measured body at the
default ``l1`` (:func:`~eigentwist.description.shapes.hub_and_rod_fit`), so that its mass
and inertia follow ``l1`` in sensitivities and ``optimize``. The rotor's inertia
``I_rotor`` is added about the actuated axis (y of J_i1) in both.
"""

from __future__ import annotations

import sympy as sp

from ..description import Parameter, triangle_inequality
from ..description.screw import spatial_inertia
from ..description.shapes import hub_and_rod_fit
from ..errors import InputError

__all__ = ["BODIES", "MEASURED", "parameters", "inertia"]

#: the bodies' forms a shipped robot's ``describe(bodies=...)`` offers
BODIES = ("measured", "shapes")
#: the measured lower link's parameters, which the shape form replaces
MEASURED = ("m_1", "l1_cog", "I1_xx", "I1_yy", "I1_zz")


def parameters(base: tuple, bodies: str, link: str) -> tuple:
    """``base`` (the robot's parameters, the measured lower link among them) in form
    ``bodies``: for ``"shapes"`` the measured ones replaced by the fitted hub and rod
    (``link`` names the body in the docs, e.g. "lower link"). Raises ``InputError`` for
    an unknown form."""
    if bodies not in BODIES:
        raise InputError(f"bodies {bodies!r}: expected one of {', '.join(BODIES)}")
    if bodies == "measured":
        return base
    v = {q.name: q.default for q in base}
    fit = hub_and_rod_fit(v["m_1"], v["l1_cog"], (v["I1_xx"], v["I1_yy"], v["I1_zz"]), v["l1"])
    hub = fit["hub_inertia"]
    why = f"; with the rod, the measured {link} at l1 = {v['l1']:g} m"
    shapes = (
        Parameter(
            "lambda_1",
            float(fit["mass_per_length"]),
            "kg/m",
            f"mass per length of the {link}'s uniform part, a slender rod along l1{why}",
        ),
        Parameter("m_hub", float(fit["hub_mass"]), "kg", f"the {link}'s hub at the actuated joint{why}", closed=True),
        Parameter("I_hub_xx", float(hub[0]), "kg m^2", f"the hub's inertia about x of frame J_i1{why}", closed=True),
        Parameter("I_hub_yy", float(hub[1]), "kg m^2", f"the hub's inertia about the actuated axis{why}", closed=True),
        Parameter("I_hub_zz", float(hub[2]), "kg m^2", f"the hub's inertia about z of frame J_i1{why}", closed=True),
    )
    return tuple(q for q in base if q.name not in MEASURED) + shapes


def inertia(p: dict, bodies: str, link: str) -> tuple:
    """``(spatial inertia 6x6 in frame J_i1 with the rotor, constraints)`` of the lower link in
    form ``bodies`` (``p``: parameter symbols by name): the triangle inequality of its
    inertias about the actuated joint."""
    rotor = sp.diag(0, p["I_rotor"], 0)
    if bodies == "shapes":
        # hub_and_rod's body written at the joint: mass m_hub + lambda l1, first moment
        # lambda l1^2 / 2 along x, inertia I_hub + lambda l1^3 / 3 normal to the rod
        lam, l1 = p["lambda_1"], p["l1"]
        mass, rod = p["m_hub"] + lam * l1, lam * l1**3 / 3
        at_joint = sp.diag(p["I_hub_xx"], p["I_hub_yy"] + rod, p["I_hub_zz"] + rod)
        body = spatial_inertia(mass, sp.Matrix([lam * l1**2 / 2 / mass, 0, 0]), at_joint + rotor)
    else:
        at_joint = sp.diag(p["I1_xx"], p["I1_yy"], p["I1_zz"])
        body = spatial_inertia(p["m_1"], sp.Matrix([p["l1_cog"], 0, 0]), at_joint + rotor)
    return body, triangle_inequality(at_joint[0, 0], at_joint[1, 1], at_joint[2, 2], f"the {link}")
