"""A translational 3-UPU (Tsai's manipulator; illustrative dimensions) in URDF form, with no
closed-form IK: eigentwist's gallery.

Three legs, each a universal joint on the base at radius R_b (base angles 90, 210, 330 deg,
z up), an actuated prismatic strut and a universal joint on the platform at radius R_p.
The base U joint's first axis is tangent to the base circle; the platform U joint's axes are
parallel to the base joint's in reverse order, so each leg constrains one rotation (a couple
along the normal of its two U axes) and the platform translates (pose x, y, z in m). Each
joint's origin and axes are given in its parent body's frame (URDF form); eigentwist solves
the loop closures by a damped Newton method from ``reference`` (the legs' assembly at home).
Units: m, kg, N/m. Values illustrative (a desktop-sized 3-UPU), not from a data sheet.
Load: ``eigentwist.load("examples/robots/upu3.py")`` or ``--robot examples/robots/upu3.py``.
"""

import math

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainRobot
from eigentwist.description.effects import effect_parameters
from eigentwist.description.pose import TranslationPose
from eigentwist.description.serial import Body, Joint, SerialLeg
from eigentwist.description.screw import spatial_inertia

ANGLES = (90, 210, 330)
HOME = 0.30  # m: platform height at home
R_B, R_P = 0.25, 0.10  # m: the defaults of R_b and R_p, to place the reference assembly
PARAMETERS = (
    Parameter("R_b", R_B, "m", "radius of the base U joints"),
    Parameter("R_p", R_P, "m", "radius of the platform U joints"),
    Parameter("m_pl", 1.5, "kg", "mass of the platform (a disk, centre of mass at its origin)"),
    Parameter("I_pl", 0.004, "kg m^2", "platform inertia about X and Y at its origin"),
    Parameter("I_pl_zz", 0.008, "kg m^2", "platform inertia about Z at its origin"),
    Parameter("m_cyl", 0.8, "kg", "mass of each strut's cylinder (on the base U joint, slender)"),
    Parameter("l_cyl", 0.20, "m", "length of each cylinder, from the base U joint"),
    Parameter("m_rod", 0.3, "kg", "mass of each strut's rod (on the platform U joint, slender)"),
    Parameter("l_rod", 0.20, "m", "length of each rod, from the platform U joint"),
    Parameter("k_a", 3.0e6, "N/m", "axial stiffness of each prismatic actuator"),
    Parameter(
        "c_rigid",
        1e-12,
        "rad/(N m)",
        "compliance of ideally rigid constrained directions in K_F (modes: exact unless set)",
        (0.0, 1e-6),
    ),
) + effect_parameters(("actuator_loss", "payload_mass"), {"m_p": 0.2})


def _slender(mass, length):
    """A slender uniform strut along x from its frame origin (kg, kg m^2 about the origin)."""
    inertia = mass * length**2 / 3
    return spatial_inertia(mass, sp.Matrix([length / 2, 0, 0]), sp.diag(0, inertia, inertia))


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    tilt = math.atan2(R_B - R_P, HOME)  # the strut's inward lean at home (rad)
    legs = []
    for i, deg in enumerate(ANGLES):
        t = sp.pi * deg / 180
        up, tangent = sp.Matrix([0, 0, 1]), sp.Matrix([-sp.sin(t), sp.cos(t), 0])
        frame = sp.Matrix.hstack(up, tangent, up.cross(tangent))  # x up, y tangent, z inward
        legs.append(
            SerialLeg(
                f"leg {i + 1}",
                joints=(
                    Joint(
                        "U",
                        origin=(p["R_b"] * sp.cos(t), p["R_b"] * sp.sin(t), 0),
                        rotation=frame,
                        axes=((0, 1, 0), (0, 0, 1)),
                        name="base universal joint (first axis tangent)",
                    ),
                    Joint("P", axes=((1, 0, 0),), actuated=True, name="prismatic strut"),
                    Joint("U", axes=((0, 0, 1), (0, 1, 0)), name="platform universal joint (axes in reverse order)"),
                    Joint("virtual", axes=((1, 0, 0),), name="rotation about the vertical: constrained"),
                ),
                bodies=(
                    Body("cylinder", 1, _slender(p["m_cyl"], p["l_cyl"])),
                    Body("rod", 2, _slender(p["m_rod"], -p["l_rod"])),
                ),
                attachment=(p["R_p"] * sp.cos(t), p["R_p"] * sp.sin(t), 0),
                attachment_rotation=frame,
                reference=(-tilt, 0.0, math.hypot(R_B - R_P, HOME), 0.0, tilt),
            )
        )
    return ChainRobot(
        name="upu3",
        title="translational 3-UPU (gallery, URDF form, illustrative)",
        parameters=PARAMETERS,
        legs=tuple(legs),
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), sp.diag(p["I_pl"], p["I_pl"], p["I_pl_zz"])),
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, HOME),
        pose=("x", "y", "z"),
        workspace=((-0.05, 0.05), (-0.05, 0.05), (0.25, 0.35)),
        pose_space=TranslationPose(),
        source="examples/robots/upu3.py (eigentwist gallery); illustrative values",
        effects=("actuator_loss", "payload_mass"),
        rigid_compliance=p["c_rigid"],
    )
