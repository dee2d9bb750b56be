"""A Delta robot (3-RR(Pi)RR): three legs at 0, 120 and 240 degrees.

The same joint types as the Heli4, so this description is all the Delta needs: the
derivation, code generation, runtime and diagnosis are shared. Actuated revolute joints
on a base circle of radius R, upper arms l1 (0.40 kg, centre of gravity at mid-length,
rotor 2e-3 kg m^2), parallelogram forearms l2 of two carbon tubes like the Heli4's, a
platform of radius r_p and 0.30 kg.
"""

from __future__ import annotations

import sympy as sp

from ..description import Parameter, RobotDescription, triangle_inequality, tube
from ..description.effects import PRESETS, effect_parameters
from ..description.rrpirr import rrpirr_leg
from ..description.formulas import parallelogram_inertia
from . import lower_link

PARAMETERS = (
    Parameter("R", 0.20, "m", "radius of the actuated joints about the base centre"),
    Parameter("l1", 0.30, "m", "length of the upper arm (actuated link)"),
    Parameter("l2", 0.80, "m", "length of the parallelogram forearm"),
    Parameter("r_p", 0.05, "m", "radius of the leg attachments on the platform"),
    Parameter("w_pi", 0.060, "m", "parallelogram width"),
    Parameter("r_i", 0.0035, "m", "inner radius of the forearm tubes"),
    Parameter("r_o", 0.005, "m", "outer radius of the forearm tubes"),
    Parameter("rho", 2000.0, "kg/m^3", "density of the forearm tubes"),
    Parameter("m_1", 0.40, "kg", "mass of the upper arm"),
    Parameter(
        "l1_cog", 0.15, "m", "distance from the actuated joint to the upper arm's centre of gravity (mid-length)"
    ),
    Parameter("I1_xx", 1e-5, "kg m^2", "upper arm inertia about its own axis, frame J_i1"),
    Parameter("I1_yy", 0.012, "kg m^2", "upper arm inertia about the actuated axis (slender rod, m l1^2/3)"),
    Parameter("I1_zz", 0.012, "kg m^2", "upper arm inertia about z of frame J_i1"),
    Parameter("I_rotor", 2e-3, "kg m^2", "actuator rotor inertia about its axis"),
    Parameter("m_e", 0.30, "kg", "mass of the platform"),
    Parameter("I_e_xx", 1.875e-4, "kg m^2", "platform inertia about X (disc, m r_p^2/4)"),
    Parameter("I_e_yy", 1.875e-4, "kg m^2", "platform inertia about Y (disc, m r_p^2/4)"),
    Parameter("I_e_zz", 3.75e-4, "kg m^2", "platform inertia about Z (disc, m r_p^2/2)"),
    Parameter("k_a", 2000.0, "N m/rad", "commanded actuator stiffness"),
    Parameter(
        "c_rigid",
        1e-12,
        "rad/(N m)",
        "compliance of ideally rigid constrained directions in K_F (modes: exact unless set)",
        (0.0, 1e-6),
    ),
)


EFFECTS = (
    "actuator_loss",
    "rod_compliance",
    "lower_link_compliance",
    "transmission_compliance",
    "payload_mass",
    "rotor_inertia",
    "swinging_rods",
    "gravity_preload",
)

# only the values that differ from the catalogue's (eigentwist/description/effects.py)
EFFECT_VALUES = {
    "r_o_l1": {"default": 0.015, "doc": "outer radius of the upper arm tube"},
    "r_i_l1": {"default": 0.013, "doc": "inner radius of the upper arm tube (below r_o_l1)"},
}


def describe(bodies: str = "measured") -> RobotDescription:
    """The Delta description with its specified values as defaults.

    bodies : ``"measured"`` (the upper arm's ``m_1``, ``l1_cog``, ``I1_*``, parameters of
        their own) or ``"shapes"``: the upper arm as a uniform rod along l1 (and an empty
        hub plus its I1_xx about its own axis), the specified arm at l1 = 0.30 m, its mass
        and inertia following l1 (robot ``delta_shapes``, generated on first use;
        :mod:`.lower_link`).
    """
    parameters = lower_link.parameters(PARAMETERS, bodies, "upper arm") + effect_parameters(EFFECTS, EFFECT_VALUES)
    p = {q.name: q.symbol for q in parameters}
    upper_arm, upper_arm_checks = lower_link.inertia(p, bodies, "upper arm")
    rod = dict(r_i=p["r_i"], r_o=p["r_o"], rho=p["rho"], w_pi=p["w_pi"])
    forearm = parallelogram_inertia(rod["r_i"], rod["r_o"], rod["rho"], p["l2"])
    legs = []
    for k in range(3):
        phi = 2 * sp.pi * k / 3
        u = (sp.cos(phi), sp.sin(phi), 0)  # outward radial direction
        s = (-sp.sin(phi), sp.cos(phi), 0)  # actuator axis, u x s = e_z
        legs.append(
            rrpirr_leg(
                f"leg {k + 1}",
                tuple(p["R"] * c for c in u),
                u,
                s,
                tuple(p["r_p"] * c for c in u),
                p["l1"],
                p["l2"],
                upper_arm,
                forearm,
                w_pi=p["w_pi"],
            )
        )
    platform = sp.diag(p["I_e_xx"], p["I_e_yy"], p["I_e_zz"], p["m_e"], p["m_e"], p["m_e"])
    return RobotDescription(
        name="delta" if bodies == "measured" else "delta_shapes",
        title="Delta robot (3-RR(Pi)RR)",
        parameters=parameters,
        legs=tuple(legs),
        l1=p["l1"],
        l2=p["l2"],
        lower_link_inertia=upper_arm,
        rod=rod,
        ee_inertia=platform,
        ee_compliance=None,
        x_ref=(0.0, 0.0, -0.75),
        actuator_stiffness=p["k_a"],
        rigid_compliance=p["c_rigid"],
        workspace=((-0.2, 0.2), (-0.2, 0.2), (-0.95, -0.60)),
        source="description in eigentwist/robots/delta.py; method DOI 10.1016/j.mechmachtheory.2019.103775",
        effects=EFFECTS,
        # the catalogue's presets: actuator_loss carries the Heli4's measured eta_a = 0.82
        presets=dict(PRESETS),
        constraints=(
            tube(p["r_i"], p["r_o"], "the forearm tubes")
            + upper_arm_checks
            + triangle_inequality(p["I_e_xx"], p["I_e_yy"], p["I_e_zz"], "the end-effector")
        ),
    )
