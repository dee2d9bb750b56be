"""A planar 3-RPR with radial struts at home: its legs name no check (``checks=()``).

Base revolute joints at radius R_b, platform revolute joints at radius R_p on the same
angles (90, 210, 330 deg), every axis along z; the actuated prismatic strut between them
(coordinate: its length, m). At home (x = y = rot_z = 0) every strut points at the
centre: the actuators cannot resist a rotation about z (a parallel singularity); turned
by rot_z the struts leave the centre and the platform is stiff again. Units: m, kg, N/m.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.pose import PlanarPose
from eigentwist.description.screw import spatial_inertia

ANGLES = (90, 210, 330)
PARAMETERS = (
    Parameter("R_b", 0.40, "m", "radius of the base joints"),
    Parameter("R_p", 0.10, "m", "radius of the platform joints"),
    Parameter("m_pl", 2.0, "kg", "mass of the platform"),
    Parameter("I_pl", 0.01, "kg m^2", "platform inertia about each axis at its origin"),
    Parameter("m_s", 0.5, "kg", "mass of each strut, a point at its base joint"),
    Parameter("k_a", 1.0e6, "N/m", "axial stiffness of each strut"),
    Parameter("c_rigid", 1e-12, "rad/(N m)", "compliance of the ideally rigid constrained directions", (0.0, 1e-6)),
)


def _geometry(deg):
    a = sp.pi * deg / 180
    er = sp.Matrix([sp.cos(a), sp.sin(a), 0])
    ez = sp.Matrix([0, 0, 1])

    def geometry(position, rotation, p, q=None):
        A = p["R_b"] * er
        top = position + rotation * (p["R_p"] * er)
        d = top - A
        length = sp.sqrt(d.dot(d)) if q is None else q
        e = d / length
        return {
            "A": A,
            "top": top,
            "top_y": top + sp.Matrix([0, 1, 0]),
            "length": length,
            "e": e,
            "n": ez.cross(e),
            "ez": ez,
            "ex": sp.Matrix([1, 0, 0]),
            "ey": sp.Matrix([0, 1, 0]),
        }

    return geometry


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    joints = (
        ChainJoint("R", ("ez",), "A", doc="base joint"),
        ChainJoint("P", ("e",), actuated=True, doc="strut"),
        ChainJoint("R", ("ez",), "top", doc="platform joint"),
        ChainJoint("virtual", ("ex",), "top"),
        ChainJoint("virtual", ("ey",), "top"),
        ChainJoint("virtual", ("ex",), "top_y"),
    )
    bodies = (ChainBody("strut", 1, spatial_inertia(p["m_s"], sp.zeros(3, 1), sp.zeros(3, 3)), ("e", "n", "ez"), "A"),)
    legs = tuple(ChainLeg(f"leg {i + 1}", joints, bodies, _geometry(a)) for i, a in enumerate(ANGLES))
    return ChainRobot(
        name="rpr3_radial",
        title="planar 3-RPR, radial struts at home",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), p["I_pl"] * sp.eye(3)),
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, 0.3),
        pose=("x", "y", "rot_z"),
        workspace=((-0.05, 0.05), (-0.05, 0.05), (-0.5, 0.5)),
        pose_space=PlanarPose(),
        effects=(),
        rigid_compliance=p["c_rigid"],
    )
