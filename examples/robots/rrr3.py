"""A planar 3-RRR parallel robot (illustrative dimensions), as joint lists: eigentwist's gallery.

Three legs in the base plane z = 0, each an actuated revolute joint at radius R_b (base
angles 90, 210, 330 deg), a proximal link of length l1, an elbow revolute joint, a distal
link of length l2 and a revolute joint on the platform at radius R_p; every axis is
parallel to z. The platform moves in the plane (pose x, y in m, rot_z in rad): each leg has
three freedoms and three constraint wrenches (a force along z, moments about x and y), the
null space of which is the platform's three allowed twists. Elbows on the + branch
(``ELBOW``): the description's choice of assembly. Units: m, kg, N m/rad. Values
illustrative (a table-top planar robot with direct-drive motors), not from a data sheet.
Load: ``eigentwist.load("examples/robots/rrr3.py")`` or ``--robot examples/robots/rrr3.py``.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.effects import effect_parameters
from eigentwist.description.pose import PlanarPose
from eigentwist.description.screw import spatial_inertia

ANGLES = (90, 210, 330)
ELBOW = 1  # +1 or -1: which of the two elbow positions each leg takes
PARAMETERS = (
    Parameter("R_b", 0.35, "m", "radius of the actuated base joints"),
    Parameter("R_p", 0.10, "m", "radius of the platform joints"),
    Parameter("l1", 0.25, "m", "length of each proximal link"),
    Parameter("l2", 0.25, "m", "length of each distal link"),
    Parameter("m_pl", 1.5, "kg", "mass of the platform"),
    Parameter("I_pl_zz", 0.006, "kg m^2", "platform inertia about Z at its origin (= its centre of mass)"),
    Parameter("I_pl_xx", 0.003, "kg m^2", "platform inertia about X and Y at its origin"),
    Parameter("m1", 0.5, "kg", "mass of each proximal link (slender, uniform)"),
    Parameter("m2", 0.4, "kg", "mass of each distal link (slender, uniform)"),
    Parameter("k_a", 1.5e4, "N m/rad", "torsional stiffness of each actuated joint (motor and drive)"),
    Parameter("c_rigid", 1e-12, "rad/(N m)", "compliance of the ideally rigid constrained directions", (0.0, 1e-6)),
) + effect_parameters(("actuator_loss", "payload_mass"), {"m_p": 0.5})


def _geometry(deg):
    """One leg's closed form: the two-link IK of the actuated angle and the joints' points."""
    a = sp.pi * deg / 180
    ez = sp.Matrix([0, 0, 1])

    def geometry(position, rotation, p, q=None):
        A = p["R_b"] * sp.Matrix([sp.cos(a), sp.sin(a), 0])
        top = position + rotation * (p["R_p"] * sp.Matrix([sp.cos(a), sp.sin(a), 0]))
        d = top - A
        D = sp.sqrt(d[0] ** 2 + d[1] ** 2)
        reach = (p["l1"] ** 2 + D**2 - p["l2"] ** 2) / (2 * p["l1"] * D)
        theta = sp.atan2(d[1], d[0]) + ELBOW * sp.acos(reach) if q is None else q
        e1 = sp.Matrix([sp.cos(theta), sp.sin(theta), 0])
        C = A + p["l1"] * e1
        e2 = (top - C) / p["l2"]
        return {
            "A": A,
            "C": C,
            "top": top,
            "top_y": top + sp.Matrix([0, 1, 0]),
            "theta": theta,
            "reach": reach,
            "e1": e1,
            "n1": ez.cross(e1),
            "e2": e2,
            "n2": ez.cross(e2),
            "ez": ez,
            "ex": sp.Matrix([1, 0, 0]),
            "ey": sp.Matrix([0, 1, 0]),
        }

    return geometry


def _link(mass, length, axes, origin, after):
    inertia = mass * length**2 / 3  # slender link about its first joint
    return ChainBody(
        origin, after, spatial_inertia(mass, sp.Matrix([length / 2, 0, 0]), sp.diag(0, inertia, inertia)), axes, origin
    )


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    joints = (
        ChainJoint("R", ("ez",), "A", actuated=True, doc="actuated base joint"),
        ChainJoint("R", ("ez",), "C", doc="elbow"),
        ChainJoint("R", ("ez",), "top", doc="platform joint"),
        ChainJoint("virtual", ("ex",), "top", doc="tilting about x: constrained"),
        ChainJoint("virtual", ("ey",), "top", doc="tilting about y: constrained"),
        ChainJoint("virtual", ("ex",), "top_y", doc="with the first: lifting along z, constrained"),
    )
    bodies = (_link(p["m1"], p["l1"], ("e1", "n1", "ez"), "A", 1), _link(p["m2"], p["l2"], ("e2", "n2", "ez"), "C", 2))
    legs = tuple(
        ChainLeg(f"leg {i + 1}", joints, bodies, _geometry(a), checks=("reach",), coordinate="theta")
        for i, a in enumerate(ANGLES)
    )
    return ChainRobot(
        name="rrr3",
        title="planar 3-RRR (gallery, illustrative)",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), sp.diag(p["I_pl_xx"], p["I_pl_xx"], p["I_pl_zz"])),
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, 0.0),
        pose=("x", "y", "rot_z"),
        workspace=((-0.05, 0.05), (-0.05, 0.05), (-0.3, 0.3)),
        pose_space=PlanarPose(),
        source="examples/robots/rrr3.py (eigentwist gallery); illustrative values",
        effects=("actuator_loss", "payload_mass"),
        rigid_compliance=p["c_rigid"],
    )
