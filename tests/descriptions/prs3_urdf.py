"""The gallery's 3-PRS (``examples/robots/prs3.py``) with its legs in URDF form: no closure named.

Each leg: a slider along its column (joint frame at the column's foot ``R_b e_r``, axes
e_r, the base circle's tangent u, e_z), a revolute joint about u on the slider, the rod
L along the turned z axis to the spherical joint on the platform at ``R_p e_r``, then the
leg's twist of restriction (a rotation about the rod frame's x axis through the revolute
joint). The platform commands z, rot_x, rot_y; its x, y, rot_z follow from the legs' loop
closures, solved with the joint coordinates. Parameters, platform and defaults: the
gallery file's (its effects left out). Newton starts from the home pose's legs.
``describe(closed_form=(0,))`` takes leg 1 in closed form from the gallery file, beside two
URDF-form legs.
"""

from pathlib import Path

import sympy as sp

from eigentwist.description.chain import ChainRobot
from eigentwist.description.pose import LowerMobilityPose
from eigentwist.description.screw import spatial_inertia
from eigentwist.description.serial import Body, Joint, SerialLeg
from eigentwist.runtime.userfile import describe_file

GALLERY = Path(__file__).resolve().parents[2] / "examples" / "robots" / "prs3.py"


def describe(name="prs3_urdf", closed_form=()):
    """The robot; the legs of 0-based indices ``closed_form`` taken in closed form from the
    gallery file instead (with their closures: legs that differ)."""
    twin = describe_file(GALLERY)
    p = {q.name: q.symbol for q in twin.parameters}
    d = twin.defaults
    rho = d["R_p"] - d["R_b"]  # the spherical joint's radial offset from the column at home
    height = (d["L"] ** 2 - rho**2) ** 0.5
    reference = (twin.x_ref[0] - height, float(sp.atan2(rho, height)))  # slider (m), rod angle (rad)
    rod = p["m_r"] * p["L"] ** 2 / 3  # slender rod about its end
    legs = []
    for i, deg in enumerate((90, 210, 330)):
        a = sp.pi * deg / 180
        er, u = sp.Matrix([sp.cos(a), sp.sin(a), 0]), sp.Matrix([-sp.sin(a), sp.cos(a), 0])
        legs.append(
            SerialLeg(
                f"leg {i + 1}",
                joints=(
                    Joint(
                        "P",
                        origin=tuple(p["R_b"] * er),
                        rotation=sp.Matrix.hstack(er, u, sp.Matrix([0, 0, 1])),
                        axes=((0, 0, 1),),
                        actuated=True,
                        name="slider",
                    ),
                    Joint("R", axes=((0, 1, 0),), name="revolute joint on the slider"),
                    Joint("S", origin=(0, 0, p["L"]), name="spherical joint on the platform"),
                    Joint("virtual", origin=(0, 0, -p["L"]), axes=((1, 0, 0),), name="swing of the leg's plane"),
                ),
                bodies=(
                    Body("slider", 1, spatial_inertia(p["m_s"], sp.zeros(3, 1), sp.zeros(3, 3))),
                    Body("rod", 2, spatial_inertia(p["m_r"], sp.Matrix([0, 0, p["L"] / 2]), sp.diag(rod, rod, 0))),
                ),
                attachment=tuple(p["R_p"] * er),
                reference=reference,
            )
            if i not in closed_form
            else twin.legs[i]
        )
    return ChainRobot(
        name=name,
        title="3-PRS, legs in URDF form",
        parameters=twin.parameters,
        legs=tuple(legs),
        platform_inertia=twin.platform_inertia,
        actuator_stiffness=twin.actuator_stiffness,
        x_ref=twin.x_ref,
        pose=twin.pose,
        workspace=twin.workspace,
        pose_space=LowerMobilityPose(twin.pose),
        rigid_compliance=twin.rigid_compliance,
    )
