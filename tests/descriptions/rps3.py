"""A 3-RPS platform whose legs check their strokes under a name of their own (``"stroke"``).

Base revolute joints at radius R_b (angles 90, 210, 330 deg, axes tangent to the circle),
actuated prismatic struts, spherical joints on the platform at radius R_p. Each leg keeps
its spherical joint in its plane (one constraint wrench), so the platform commands z,
rot_x, rot_y and its x, y, rot_z follow. At z = 0 every leg lies in the base plane: the
actuators cannot resist a vertical motion (a parallel singularity). A strut is within its
stroke when its length lies in [s_min, s_max] (the check ``stroke`` within [-1, 1]).
Units: m, kg, N/m. Home z = 0.40 m.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.pose import LowerMobilityPose
from eigentwist.description.screw import cross, spatial_inertia

ANGLES = (90, 210, 330)
PARAMETERS = (
    Parameter("R_b", 0.30, "m", "radius of the base revolute joints"),
    Parameter("R_p", 0.15, "m", "radius of the platform's spherical joints"),
    Parameter("s_min", 0.10, "m", "shortest strut"),
    Parameter("s_max", 0.60, "m", "longest strut"),
    Parameter("m_pl", 5.0, "kg", "mass of the platform"),
    Parameter("I_pl", 0.05, "kg m^2", "platform inertia about each axis at its origin"),
    Parameter("m_s", 1.0, "kg", "mass of each strut, a point 0.1 m from its base joint"),
    Parameter("k_a", 2.0e7, "N/m", "axial stiffness of each strut"),
    Parameter("c_rigid", 1e-12, "rad/(N m)", "compliance of the ideally rigid constrained directions", (0.0, 1e-6)),
)


def _geometry(deg):
    a = sp.pi * deg / 180
    er, u, ez = sp.Matrix([sp.cos(a), sp.sin(a), 0]), sp.Matrix([-sp.sin(a), sp.cos(a), 0]), sp.Matrix([0, 0, 1])

    def geometry(position, rotation, p, q=None):
        b = p["R_b"] * er
        top = position + rotation * (p["R_p"] * er)
        d = top - b
        length = sp.sqrt(d.dot(d)) if q is None else q
        e = d / length
        mid, half = (p["s_min"] + p["s_max"]) / 2, (p["s_max"] - p["s_min"]) / 2
        return {
            "b": b,
            "top": top,
            "length": length,
            "e": e,
            "u": u,
            "n": cross(e, u),
            "ez": ez,
            "stroke": (length - mid) / half,
            "off_plane": u.dot(top),
        }

    return geometry


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    joints = (
        ChainJoint("R", ("u",), "b", doc="base revolute joint, tangent to the base circle"),
        ChainJoint("P", ("e",), actuated=True, doc="strut"),
        ChainJoint("S", (), "top", doc="spherical joint on the platform"),
        ChainJoint("virtual", ("ez",), "b", doc="swinging the leg's plane about the vertical: constrained"),
    )
    bodies = (
        ChainBody("strut", 1, spatial_inertia(p["m_s"], sp.Matrix([0.1, 0, 0]), sp.zeros(3, 3)), ("e", "u", "n"), "b"),
    )
    legs = tuple(
        ChainLeg(f"leg {i + 1}", joints, bodies, _geometry(a), checks=("stroke",), closures=("off_plane",))
        for i, a in enumerate(ANGLES)
    )
    return ChainRobot(
        name="rps3_stroke",
        title="3-RPS with stroke checks",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), p["I_pl"] * sp.eye(3)),
        actuator_stiffness=p["k_a"],
        x_ref=(0.40, 0.0, 0.0),
        pose=("z", "rot_x", "rot_y"),
        workspace=((0.30, 0.50), (-0.1, 0.1), (-0.1, 0.1)),
        pose_space=LowerMobilityPose(("z", "rot_x", "rot_y")),
        effects=(),
        rigid_compliance=p["c_rigid"],
    )
