"""A 3-PRS spindle head (illustrative dimensions), as joint lists: eigentwist's gallery.

Three vertical columns at radius R_b (base angles 90, 210, 330 deg, z up), each with a
slider (the actuated prismatic joint, height s), a revolute joint on the slider whose axis
is tangent to the base circle, a rod of length L and a spherical joint on the platform at
radius R_p. Each leg keeps its spherical joint in the plane of its column (one constraint
wrench per leg), so the platform has three freedoms: z, rot_x, rot_y are commanded, and
x, y, rot_z (its parasitic motions) follow from the legs' closures, solved per pose by
eigentwist's damped Newton method. Units: m, kg, N. Values illustrative (a small 3-PRS
head in the range of published prototypes), not from a data sheet. Home: z = 0.60 m.
Load: ``eigentwist.load("examples/robots/prs3.py")`` or ``--robot examples/robots/prs3.py``.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.effects import effect_parameters
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.pose import LowerMobilityPose
from eigentwist.description.screw import cross, spatial_inertia

ANGLES = (90, 210, 330)
PARAMETERS = (
    Parameter("R_b", 0.30, "m", "radius of the columns"),
    Parameter("R_p", 0.15, "m", "radius of the platform's spherical joints"),
    Parameter("L", 0.40, "m", "length of each rod (revolute to spherical joint)"),
    Parameter("m_pl", 8.0, "kg", "mass of the platform (spindle head)"),
    Parameter("I_pl_xx", 0.06, "kg m^2", "platform inertia about X at its origin (= its centre of mass)"),
    Parameter("I_pl_zz", 0.09, "kg m^2", "platform inertia about Z at its origin"),
    Parameter("m_s", 2.5, "kg", "mass of each slider (a point mass on the revolute joint)"),
    Parameter("m_r", 1.2, "kg", "mass of each rod (slender, uniform)"),
    Parameter("k_a", 5.0e7, "N/m", "axial stiffness of each ball-screw actuator"),
    Parameter(
        "c_rigid",
        1e-12,
        "rad/(N m)",
        "compliance of ideally rigid constrained directions in K_F (modes: exact unless set)",
        (0.0, 1e-6),
    ),
) + effect_parameters(("actuator_loss", "payload_mass"), {"m_p": 1.0})


def _geometry(deg):
    """One leg's closed form: slider height s from the pose, its joints' points and axes."""
    a = sp.pi * deg / 180
    er, u, ez = sp.Matrix([sp.cos(a), sp.sin(a), 0]), sp.Matrix([-sp.sin(a), sp.cos(a), 0]), sp.Matrix([0, 0, 1])

    def geometry(position, rotation, p, q=None):
        b = p["R_b"] * er
        top = position + rotation * (p["R_p"] * er)
        rho = er.dot(top) - p["R_b"]  # radial offset of the S joint from the column
        s = top[2] - sp.sqrt(p["L"] ** 2 - rho**2) if q is None else q
        c = b + s * ez  # the revolute joint on the slider
        d = (top - c) / p["L"]
        return {
            "b": b,
            "c": c,
            "top": top,
            "s": s,
            "d": d,
            "u": u,
            "n": cross(d, u),
            "ez": ez,
            "reach": rho / p["L"],
            "off_plane": u.dot(top),
        }

    return geometry


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    joints = (
        ChainJoint("P", ("ez",), actuated=True, doc="slider on its column"),
        ChainJoint("R", ("u",), "c", doc="revolute joint on the slider, tangent to the base circle"),
        ChainJoint("S", (), "top", doc="spherical joint on the platform"),
        ChainJoint("virtual", ("ez",), "b", doc="swinging the leg's plane about its column: constrained"),
    )
    rod = p["m_r"] * p["L"] ** 2 / 3  # slender rod about its end
    bodies = (
        ChainBody("slider", 1, spatial_inertia(p["m_s"], sp.zeros(3, 1), sp.zeros(3, 3)), ("d", "u", "n"), "c"),
        ChainBody(
            "rod",
            2,
            spatial_inertia(p["m_r"], sp.Matrix([p["L"] / 2, 0, 0]), sp.diag(0, rod, rod)),
            ("d", "u", "n"),
            "c",
        ),
    )
    legs = tuple(
        ChainLeg(
            f"leg {i + 1}", joints, bodies, _geometry(a), checks=("reach",), closures=("off_plane",), coordinate="s"
        )
        for i, a in enumerate(ANGLES)
    )
    return ChainRobot(
        name="prs3",
        title="3-PRS spindle head (gallery, illustrative)",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), sp.diag(p["I_pl_xx"], p["I_pl_xx"], p["I_pl_zz"])),
        actuator_stiffness=p["k_a"],
        x_ref=(0.60, 0.0, 0.0),
        pose=("z", "rot_x", "rot_y"),
        workspace=((0.55, 0.65), (-0.15, 0.15), (-0.15, 0.15)),
        pose_space=LowerMobilityPose(("z", "rot_x", "rot_y")),
        source="examples/robots/prs3.py (eigentwist gallery); illustrative values",
        effects=("actuator_loss", "payload_mass"),
        rigid_compliance=p["c_rigid"],
    )
