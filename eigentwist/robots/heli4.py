"""The Heli4 robot (4-RR(Pi)RR), as analysed by Hoevenaars, Krut & Herder (2020).

Sources: Table 1, Eqs. 22-31, 34, Appendix A (corrected), C, D of the paper
(DOI 10.1016/j.mechmachtheory.2019.103775) and ``heli4-facts.md`` (base geometry,
frames, the rod modulus E = 170 GPa, misprints).
"""

from __future__ import annotations

import sympy as sp

from ..description import Coupling, EECompliance, Parameter, RobotDescription, triangle_inequality, tube
from ..description.effects import PRESETS, effect_parameters
from ..description.rrpirr import rrpirr_leg
from ..description.formulas import parallelogram_inertia
from . import lower_link

INF = float("inf")

PARAMETERS = (
    # geometry (Table 1, App. A, facts file)
    Parameter("R", 0.135, "m", "radius of the actuated joints about the base centre (facts file)"),
    Parameter("l1", 0.20, "m", "length of the lower link (Table 1)"),
    Parameter("l2", 0.53, "m", "length of the parallelogram (Table 1)"),
    Parameter("r", 0.048, "m", "radial offset of the leg attachments on the traveling plates (App. A)"),
    Parameter("d", 0.078, "m", "height of the lower traveling plate attachments above the EE origin (App. A)"),
    Parameter("h", 0.060, "m", "extra height of the upper traveling plate attachments, legs 3 and 4 (App. A)"),
    Parameter("w_pi", 0.055, "m", "parallelogram width (Table 1)"),
    # parallelogram rods (Table 1, Eqs. 27-29, App. C)
    Parameter("r_i", 0.0035, "m", "inner radius of the rods (Table 1)"),
    Parameter("r_o", 0.005, "m", "outer radius of the rods (Table 1)"),
    Parameter("rho", 2000.0, "kg/m^3", "density of the rods (Table 1)"),
    # lower link with rotor (Eqs. 21-23)
    Parameter("m_1", 0.479, "kg", "mass of the lower link (Eq. 23)"),
    Parameter(
        "l1_cog", 0.0612, "m", "distance from the actuated joint to the lower link's centre of gravity (Table 1)"
    ),
    Parameter("I1_xx", 0.0003, "kg m^2", "lower link inertia about x of frame J_i1 (Eq. 23)"),
    Parameter("I1_yy", 0.0044, "kg m^2", "lower link inertia about the actuated axis (Eq. 23)"),
    Parameter("I1_zz", 0.0042, "kg m^2", "lower link inertia about z of frame J_i1 (Eq. 23)"),
    Parameter("I_rotor", 4.1e-3, "kg m^2", "actuator rotor inertia about its axis (Eq. 22)"),
    # end-effector assembly (Eq. 31)
    Parameter("m_e", 0.592, "kg", "mass of the end-effector assembly (Eq. 31)"),
    Parameter("I_e_xx", 0.009, "kg m^2", "EE inertia about X (Eq. 31)"),
    Parameter("I_e_yy", 0.009, "kg m^2", "EE inertia about Y (Eq. 31)"),
    Parameter("I_e_zz", 0.001, "kg m^2", "EE inertia about Z (Eq. 31, printed to one digit)"),
    # actuators (Eqs. 34, 42)
    Parameter("k_a", 2000.0, "N m/rad", "commanded actuator stiffness (Table 2)"),
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
    "ee_compliance",
    "ee_coupling",
    "lower_link_compliance",
    "transmission_compliance",
    "payload_mass",
    "rotor_inertia",
    "swinging_rods",
    "gravity_preload",
    "servo_damping",
    "servo_delay",
    "structural_loss",
)

# The effects declare their parameters (eigentwist/description/effects.py); the Heli4's
# values are the catalogue's defaults (App. B, C, D and the facts file: E_rod = 170 GPa,
# k_E_rot = 500 N m/rad and k_E_lin = 100/0.77e-3 N/m reproduce Eq. 58).
# The paper's servos: "a damping of 3 Nm s/rad was added to the actuator controllers" (Sec. 4).
EFFECT_VALUES: dict = {"c_a": 3.0}


def describe(bodies: str = "measured") -> RobotDescription:
    """The Heli4 description with the paper's values as defaults.

    bodies : ``"measured"`` (the paper's Eq. 23 lower link: ``m_1``, ``l1_cog``, ``I1_*``,
        parameters of their own) or ``"shapes"``: the lower link as a uniform rod along l1
        and a hub at the actuated joint, fitted to be Eq. 23's body at l1 = 0.20 m, so that
        its mass and inertia follow l1 (robot ``heli4_shapes``, generated on first use;
        :mod:`.lower_link`). The rods' inertia follows l2, r_i, r_o and rho in both (Eqs.
        27-29); the end-effector's and the rotor's stay measured.
    """
    parameters = lower_link.parameters(PARAMETERS, bodies, "lower link") + effect_parameters(EFFECTS, EFFECT_VALUES)
    p = {q.name: q.symbol for q in parameters}
    R, r, d, h = p["R"], p["r"], p["d"], p["h"]
    ex, ey = (1, 0, 0), (0, 1, 0)
    neg = lambda v: tuple(-c for c in v)  # noqa: E731
    # (u_i, s_i, a_i) with u_i x s_i = e_z (facts file)
    layout = (
        ("leg 1", ex, ey, (r, 0, d)),
        ("leg 2", neg(ex), neg(ey), (-r, 0, d)),
        ("leg 3", ey, neg(ex), (0, r, d + h)),
        ("leg 4", neg(ey), ex, (0, -r, d + h)),
    )
    body1, body1_checks = lower_link.inertia(p, bodies, "lower link")
    rod = dict(r_i=p["r_i"], r_o=p["r_o"], rho=p["rho"], w_pi=p["w_pi"])
    parallelogram = parallelogram_inertia(rod["r_i"], rod["r_o"], rod["rho"], p["l2"])
    # legs 1, 2 attach to plate A (lower traveling plate), legs 3, 4 to plate B (upper);
    # each an RR(Pi)RR joint list with the lower link (J1) and the parallelogram (C3)
    plates = ("plate_A", "plate_A", "plate_B", "plate_B")
    legs = tuple(
        rrpirr_leg(
            name,
            tuple(R * c for c in u),
            u,
            s,
            a,
            p["l1"],
            p["l2"],
            body1,
            parallelogram,
            platform_body=body,
            w_pi=p["w_pi"],
        )
        for (name, u, s, a), body in zip(layout, plates)
    )
    # the tool body T couples to plate A through a rotation about Y through the
    # lower plate centre (k_E_rot) and to plate B through a translation along Y (k_E_lin)
    couplings = (
        Coupling(
            "plate_A",
            (0, 0, d),
            ((0, 1, 0, 0, 0, 0),),
            (p["k_E_rot"],),
            doc="rotation about Y through the lower traveling plate centre (App. D, k_E_rot)",
        ),
        Coupling(
            "plate_B", (0, 0, d), ((0, 0, 0, 0, 1, 0),), (p["k_E_lin"],), doc="translation along Y (App. D, k_E_lin)"
        ),
    )
    ee = sp.diag(p["I_e_xx"], p["I_e_yy"], p["I_e_zz"], p["m_e"], p["m_e"], p["m_e"])
    c_rot = sp.diag(0, 1 / (p["k_E_rot"] / 2), 0, 0, 0, 0)  # Eqs. 45, 46
    c_lin = sp.diag(0, 0, 0, 0, 1 / (p["k_E_lin"] / 2), 0)  # Eqs. 47, 48
    return RobotDescription(
        name="heli4" if bodies == "measured" else "heli4_shapes",
        title="Heli4 (4-RR(Pi)RR), Hoevenaars, Krut & Herder 2020",
        parameters=parameters,
        legs=legs,
        l1=p["l1"],
        l2=p["l2"],
        lower_link_inertia=body1,
        rod=rod,
        ee_inertia=ee,
        # lower traveling plate centre at EE origin + [0, 0, d] (facts file)
        ee_compliance=EECompliance(origin=(0, 0, d), per_leg={0: c_rot, 1: c_rot, 2: c_lin, 3: c_lin}),
        couplings=couplings,
        tool_body="tool",
        x_ref=(0.0, 0.0, -0.625),
        actuator_stiffness=p["k_a"],
        rigid_compliance=p["c_rigid"],
        workspace=((-0.1, 0.1), (-0.1, 0.1), (-0.70, -0.55)),
        source="Hoevenaars, Krut & Herder (2020), DOI 10.1016/j.mechmachtheory.2019.103775",
        effects=EFFECTS,
        # the catalogue's presets: actuator_loss carries the Heli4's measured eta_a = 0.82
        # plus "damped": the paper's model with the stated servo damping (its measured frequencies
        # are damped ones, counted from step responses)
        presets={**PRESETS, "damped": PRESETS["paper"] + ("servo_damping",)},
        constraints=(
            tube(p["r_i"], p["r_o"], "the parallelogram rods")
            + body1_checks
            + triangle_inequality(p["I_e_xx"], p["I_e_yy"], p["I_e_zz"], "the end-effector")
        ),
    )
