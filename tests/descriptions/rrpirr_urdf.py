"""An RR(Pi)RR robot (the Heli4, the Delta) with its legs in URDF form: no closed-form IK.

Per leg, from the base: R at B_i about s_i (joint frame x = u_i, y = s_i, z = e_z; the
lower link along x), R at the elbow l1 along x, the parallelogram Pi (its bar l2 along
x turns about z: coordinate q3), R about -x (s_i4) and R about y (s_i) at the platform
point, and the twist of restriction about z there. The loop closes on the point a_i and
the platform's orientation (attachment frame = the first joint frame). Bodies: the
lower link with its rotor only (the IK is what these descriptions test).
"""

import sympy as sp

from eigentwist.description.chain import ChainRobot
from eigentwist.description.serial import Body, Joint, SerialLeg


def urdf_robot(shipped, name: str, reference: dict) -> ChainRobot:
    """``shipped`` (a RobotDescription with RR(Pi)RR legs) with URDF legs; ``reference``
    maps a leg index to its (q1, q2, q3) on the shipped branch (rad)."""
    legs = []
    for i, leg in enumerate(shipped.legs):
        u, s = sp.Matrix(leg.radial), sp.Matrix(leg.axis)
        frame = sp.Matrix.hstack(u, s, u.cross(s))
        q1, q2, q3 = reference[i]
        legs.append(
            SerialLeg(
                leg.name,
                joints=(
                    Joint("R", origin=leg.base, rotation=frame, axes=((0, 1, 0),), actuated=True),
                    Joint("R", origin=(shipped.l1, 0, 0), axes=((0, 1, 0),)),
                    Joint("Pi", axes=((0, 0, 1),), bar=(shipped.l2, 0, 0)),
                    Joint("R", axes=((-1, 0, 0),)),
                    Joint("R", axes=((0, 1, 0),)),
                    Joint("virtual", axes=((0, 0, 1),)),
                ),
                bodies=(Body("J1", 1, shipped.lower_link_inertia),),
                attachment=leg.attachment,
                attachment_rotation=frame,
                reference=(q1, q2, q3, 0.0, -(q1 + q2)),
            )
        )
    return ChainRobot(
        name=name,
        title=f"{shipped.title}, legs in URDF form",
        parameters=shipped.parameters,
        legs=tuple(legs),
        platform_inertia=shipped.ee_inertia,
        actuator_stiffness=shipped.actuator_stiffness,
        x_ref=shipped.x_ref,
        pose=("x", "y", "z"),
        workspace=shipped.workspace,
        rigid_compliance=shipped.rigid_compliance,
        pose_space=shipped.pose_space,
    )


def heli4():
    from eigentwist.robots import heli4 as h

    ref = {0: (0.46, 1.64, 0.0), 1: (0.46, 1.64, 0.0), 2: (0.2, 1.94, 0.0), 3: (0.2, 1.94, 0.0)}
    return urdf_robot(h.describe(), "heli4_urdf", ref)


def delta():
    from eigentwist.robots import delta as d

    return urdf_robot(d.describe(), "delta_urdf", {k: (0.27, 1.88, 0.0) for k in range(3)})
