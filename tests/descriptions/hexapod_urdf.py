"""The shipped hexapod (6-UPS) with its legs in URDF form: no closed-form IK.

Each leg: a U joint at the base point b (joint frame: x up, y along the base circle's
tangent, the strut along x), a prismatic actuator along the strut, and a spherical joint
at the platform point a. Newton starts from the strut standing straight up, 0.8 m long.
"""

import sympy as sp

from eigentwist.description.chain import ChainRobot
from eigentwist.description.serial import Body, Joint, SerialLeg
from eigentwist.robots import hexapod
from eigentwist.description.screw import spatial_inertia


def _strut(mass, distance, inertia):
    transverse = inertia + mass * distance**2
    return spatial_inertia(mass, sp.Matrix([distance, 0, 0]), sp.diag(0, transverse, transverse))


def describe(name="hexapod_urdf"):
    shipped = hexapod.describe()
    p = {q.name: q.symbol for q in shipped.parameters}
    legs = []
    for i, (b_deg, a_deg) in enumerate(zip(hexapod.BASE_ANGLES, hexapod.PLATFORM_ANGLES)):
        tb, ta = sp.pi * b_deg / 180, sp.pi * a_deg / 180
        up, tangent = sp.Matrix([0, 0, 1]), sp.Matrix([-sp.sin(tb), sp.cos(tb), 0])
        frame = sp.Matrix.hstack(up, tangent, up.cross(tangent))
        legs.append(
            SerialLeg(
                f"leg {i + 1}",
                joints=(
                    Joint(
                        "U",
                        origin=(p["R_b"] * sp.cos(tb), p["R_b"] * sp.sin(tb), 0),
                        rotation=frame,
                        axes=((0, 1, 0), (0, 0, 1)),
                        name="base universal joint",
                    ),
                    Joint("P", axes=((1, 0, 0),), actuated=True, name="prismatic actuator"),
                    Joint("S", name="platform spherical joint"),
                ),
                bodies=(
                    Body("cylinder", 1, _strut(p["m_cyl"], p["d_cyl"], p["I_cyl"])),
                    Body("piston", 2, _strut(p["m_pis"], -p["d_pis"], p["I_pis"])),
                ),
                attachment=(p["R_p"] * sp.cos(ta), p["R_p"] * sp.sin(ta), 0),
                reference=(0.0, 0.0, 0.8),
            )
        )
    return ChainRobot(
        name=name,
        title="hexapod (6-UPS), legs in URDF form",
        parameters=shipped.parameters,
        legs=tuple(legs),
        platform_inertia=shipped.platform_inertia,
        actuator_stiffness=shipped.actuator_stiffness,
        x_ref=shipped.x_ref,
        workspace=shipped.workspace,
        effects=shipped.effects,
        custom_effects=shipped.custom_effects,
    )
