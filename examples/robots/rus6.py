"""A rotary hexapod (6-RUS; illustrative dimensions) in URDF form, with no closed-form IK:
eigentwist's gallery.

Six legs, each an actuated revolute joint on the base (motor axis tangent to the base
circle, radius R_b, motors in pairs at 75/105, 195/225, 315/345 deg, z up), a crank of
length l_c (pointing outward at angle 0), a universal joint, a rod of length l_r and a
spherical joint on the platform at radius R_p (at 40, 140, 160, 260, 280, 20 deg, leg i
to point i). Each joint's origin and axes are given in its parent body's frame (URDF
form); eigentwist solves the loop closures by a damped Newton method from ``reference``
(the legs' assembly at home, cranks up). The platform is free in 6 DoF (pose x, y, z in m
and the rotation vector in rad). Units: m, kg, N m/rad. Values illustrative (a small
motion platform with servo motors), not from a data sheet.
Load: ``eigentwist.load("examples/robots/rus6.py")`` or ``--robot examples/robots/rus6.py``.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainRobot
from eigentwist.description.effects import effect_parameters
from eigentwist.description.serial import Body, Joint, SerialLeg
from eigentwist.description.screw import spatial_inertia

BASE = (75, 105, 195, 225, 315, 345)
PLATFORM = (40, 140, 160, 260, 280, 20)
PARAMETERS = (
    Parameter("R_b", 0.18, "m", "radius of the motor axes' joints"),
    Parameter("R_p", 0.12, "m", "radius of the platform S joints"),
    Parameter("l_c", 0.06, "m", "crank length"),
    Parameter("l_r", 0.25, "m", "rod length (U joint to S joint)"),
    Parameter("m_pl", 3.0, "kg", "mass of the platform (centre of mass at its origin)"),
    Parameter("I_pl", 0.015, "kg m^2", "platform inertia about X and Y at its origin"),
    Parameter("I_pl_zz", 0.025, "kg m^2", "platform inertia about Z at its origin"),
    Parameter("m_c", 0.15, "kg", "mass of each crank (slender, uniform)"),
    Parameter("I_m", 2.0e-5, "kg m^2", "each motor's rotor inertia about its axis"),
    Parameter("m_r", 0.10, "kg", "mass of each rod (slender, uniform)"),
    Parameter("k_a", 3.0e3, "N m/rad", "torsional stiffness of each servo motor and its gearbox"),
) + effect_parameters(("actuator_loss", "payload_mass"), {"m_p": 0.5})


def _slender(mass, length, axis):
    """A slender uniform link from its frame origin along ``axis`` (0: x, 2: z)."""
    com = sp.zeros(3, 1)
    com[axis] = length / 2
    I = sp.diag(*[0 if k == axis else mass * length**2 / 3 for k in range(3)])
    return spatial_inertia(mass, com, I)


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    legs = []
    for i, (b_deg, a_deg) in enumerate(zip(BASE, PLATFORM)):
        t, a = sp.pi * b_deg / 180, sp.pi * a_deg / 180
        up, tangent = sp.Matrix([0, 0, 1]), sp.Matrix([-sp.sin(t), sp.cos(t), 0])
        frame = sp.Matrix.hstack(up, tangent, up.cross(tangent))  # x up, y tangent, z inward
        crank = _slender(p["m_c"], -p["l_c"], 2) + sp.diag(0, p["I_m"], 0, 0, 0, 0)
        legs.append(
            SerialLeg(
                f"leg {i + 1}",
                joints=(
                    Joint(
                        "R",
                        origin=(p["R_b"] * sp.cos(t), p["R_b"] * sp.sin(t), 0),
                        rotation=frame,
                        axes=((0, 1, 0),),
                        actuated=True,
                        name="motor, axis tangent to the base circle",
                    ),
                    Joint("U", origin=(0, 0, -p["l_c"]), axes=((0, 1, 0), (0, 0, 1)), name="crank-rod joint"),
                    Joint("S", origin=(p["l_r"], 0, 0), name="platform spherical joint"),
                ),
                bodies=(Body("crank", 1, crank), Body("rod", 2, _slender(p["m_r"], p["l_r"], 0))),
                attachment=(p["R_p"] * sp.cos(a), p["R_p"] * sp.sin(a), 0),
                reference=(-0.388, -0.220, -0.279 if i % 2 == 0 else 0.279),
            )
        )
    return ChainRobot(
        name="rus6",
        title="rotary hexapod 6-RUS (gallery, URDF form, illustrative)",
        parameters=PARAMETERS,
        legs=tuple(legs),
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), sp.diag(p["I_pl"], p["I_pl"], p["I_pl_zz"])),
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, 0.22, 0.0, 0.0, 0.0),
        workspace=((-0.03, 0.03), (-0.03, 0.03), (0.20, 0.24), (-0.1, 0.1), (-0.1, 0.1), (-0.15, 0.15)),
        source="examples/robots/rus6.py (eigentwist gallery); illustrative values",
        effects=("actuator_loss", "payload_mass"),
    )
