"""The Gough-Stewart hexapod (6-UPS) as joint lists.

Six legs, each a universal joint on the base, a prismatic actuator and a spherical
joint on the platform. Base U joints on a circle of radius R_b at -10, 10, 110, 130,
230, 250 deg (base plane z = 0, z up); platform S joints on a circle of radius R_p in
the platform frame's z = 0 plane at -50, 50, 70, 170, 190, 290 deg; leg i joins base
joint i to platform joint i. Each strut is a cylinder on the U joint and a piston on
the S joint, slender (no inertia about the strut axis); the first U axis is horizontal
and tangent to the base circle, the second normal to it and to the strut, so the
cylinder does not spin about its axis. The pose is the platform origin (m) and the
rotation vector of the platform frame (rad); home is [0, 0, 0.80] m, rotation 0.
"""

from __future__ import annotations

import sympy as sp

from ..description import Parameter
from ..description.chain import ChainJoint, ChainLeg, ChainRobot
from ..description.effects import Effect, effect_parameters
from ..description.screw import cross, spatial_inertia
from . import strut_bodies

BASE_ANGLES = (-10, 10, 110, 130, 230, 250)
PLATFORM_ANGLES = (-50, 50, 70, 170, 190, 290)

PARAMETERS = (
    Parameter("R_b", 0.50, "m", "radius of the base U joints"),
    Parameter("R_p", 0.30, "m", "radius of the platform S joints"),
    Parameter("m_pl", 50.0, "kg", "mass of the platform"),
    Parameter("c_pl", 0.05, "m", "height of the platform's centre of mass above its origin"),
    Parameter("I_pl_xx", 2.0, "kg m^2", "platform inertia about X at its centre of mass"),
    Parameter("I_pl_yy", 2.0, "kg m^2", "platform inertia about Y at its centre of mass"),
    Parameter("I_pl_zz", 3.5, "kg m^2", "platform inertia about Z at its centre of mass"),
    Parameter("m_cyl", 2.0, "kg", "mass of each strut's cylinder (on the base U joint)"),
    Parameter("d_cyl", 0.15, "m", "distance from the base joint to the cylinder's centre of mass, along the strut"),
    Parameter("I_cyl", 0.02, "kg m^2", "transverse inertia of the cylinder at its centre of mass"),
    Parameter("m_pis", 1.0, "kg", "mass of each strut's piston (on the platform S joint)"),
    Parameter("d_pis", 0.10, "m", "distance from the platform joint to the piston's centre of mass, along the strut"),
    Parameter("I_pis", 0.005, "kg m^2", "transverse inertia of the piston at its centre of mass"),
    Parameter("k_a", 2.0e7, "N/m", "axial stiffness of each prismatic actuator"),
)


def _strut_series(ctx):
    return 1 / ctx.p["k_s"]


def _joint_series(ctx):
    return 2 / ctx.p["k_j"]


STRUT_COMPLIANCE = Effect(
    "strut_compliance",
    "axial compliance 1/k_s of each strut's tube in series with its actuator",
    (
        Parameter(
            "k_s",
            1.0e8,
            "N/m",
            "axial stiffness of each strut's tube; plausible 1e7-1e9 N/m",
            (0.0, float("inf")),
            "strut_compliance",
            (1.0e7, 1.0e9),
        ),
    ),
    ("k_s",),
    primitive="joint_series",
    leg_level=True,
    build=_strut_series,
    component="strut",
)
JOINT_COMPLIANCE = Effect(
    "joint_compliance",
    "compliance of the U and S joints along the strut (each 1/k_j), in series with the actuator",
    (
        Parameter(
            "k_j",
            2.0e8,
            "N/m",
            "axial stiffness of each U or S joint along the strut; plausible 2e7-2e9 N/m",
            (0.0, float("inf")),
            "joint_compliance",
            (2.0e7, 2.0e9),
        ),
    ),
    ("k_j",),
    primitive="joint_series",
    leg_level=True,
    build=_joint_series,
    component="U and S joints",
)

EFFECTS = ("actuator_loss", STRUT_COMPLIANCE, JOINT_COMPLIANCE, "payload_mass", "gravity_preload")
EFFECT_VALUES = {
    "m_p": {"default": 5.0, "doc": "payload mass on the platform; plausible 0-200 kg", "plausible": (0.0, 200.0)}
}


def _on_circle(radius, degrees) -> sp.Matrix:
    a = sp.pi * degrees / 180
    return sp.Matrix([radius * sp.cos(a), radius * sp.sin(a), 0])


def _geometry(base_deg, platform_deg):
    """The closed-form IK of one leg: joint points, strut direction and length, U axes."""

    def geometry(position, rotation, p, q=None):
        b = _on_circle(p["R_b"], base_deg)
        a = _on_circle(p["R_p"], platform_deg)
        top = position + rotation * a
        d = top - b
        length = sp.sqrt(d.dot(d)) if q is None else q
        s = d / length
        angle = sp.pi * base_deg / 180
        u1 = sp.Matrix([-sp.sin(angle), sp.cos(angle), 0])
        n = cross(s, u1)
        u2 = n / sp.sqrt(n.dot(n))
        return {
            "b": b,
            "top": top,
            "length": length,
            "s": s,
            "u1": u1,
            "u2": u2,
            "e2": cross(u2, s),
            "cos_u": s.dot(u1),
        }

    return geometry


def describe(bodies: str = "measured") -> ChainRobot:
    """The hexapod with its specified values as defaults.

    bodies : ``"measured"`` (each strut's cylinder and piston: ``m_*``, ``d_*``, ``I_*``,
        parameters of their own) or ``"shapes"``: each a hub at its joint and a uniform rod
        along the strut (``l_cyl`` = 0.32 m, ``l_pis`` = 0.21 m), fitted to be the measured
        bodies at those lengths, so that their masses and inertias follow ``l_cyl`` and
        ``l_pis`` (robot ``hexapod_shapes``, generated on first use; :mod:`.strut_bodies`).
        The platform's stays measured in both.
    """
    parameters = strut_bodies.parameters(PARAMETERS, bodies) + effect_parameters(
        ("actuator_loss", "payload_mass", "gravity_preload"), EFFECT_VALUES
    )
    p = {q.name: q.symbol for q in parameters}
    joints = (
        ChainJoint("U", ("u1", "u2"), "b", doc="base universal joint"),
        ChainJoint("P", ("s",), actuated=True, doc="prismatic actuator along the strut"),
        ChainJoint("S", (), "top", doc="platform spherical joint"),
    )
    struts = strut_bodies.bodies(p, bodies)
    legs = tuple(
        ChainLeg(f"leg {i + 1}", joints, struts, _geometry(b, a), checks=("cos_u",))
        for i, (b, a) in enumerate(zip(BASE_ANGLES, PLATFORM_ANGLES))
    )
    com = sp.Matrix([0, 0, p["c_pl"]])
    at_com = sp.diag(p["I_pl_xx"], p["I_pl_yy"], p["I_pl_zz"])
    platform = spatial_inertia(p["m_pl"], com, at_com + p["m_pl"] * (com.dot(com) * sp.eye(3) - com * com.T))
    return ChainRobot(
        name="hexapod" if bodies == "measured" else "hexapod_shapes",
        title="Gough-Stewart hexapod (6-UPS)",
        parameters=parameters,
        legs=legs,
        platform_inertia=platform,
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, 0.80, 0.0, 0.0, 0.0),
        workspace=((-0.1, 0.1), (-0.1, 0.1), (0.70, 0.90), (-0.1, 0.1), (-0.1, 0.1), (-0.2, 0.2)),
        source="description in eigentwist/robots/hexapod.py; method DOI 10.1016/j.mechmachtheory.2019.103775",
        effects=EFFECTS,
        # the bare strut stiffness k_a: the catalogue's "paper" and "rigid" carry the Heli4's
        # measured actuator loss (eta_a = 0.82), not this robot's; add it by name
        presets={"rigid": (), "paper": (), "coupled": ()},
    )
