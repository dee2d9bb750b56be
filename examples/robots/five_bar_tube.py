"""A planar five-bar whose proximal links are aluminium tubes: eigentwist's gallery.

The five-bar of ``five_bar.py`` (same names, pose, branch, home and workspace), except that
each proximal link is a hollow circular tube of outer and inner radii r_o, r_i and density
rho (:func:`eigentwist.description.shapes.tube`): its mass rho pi (r_o^2 - r_i^2) l1 and
its inertia m1 (l1^2/12 + (r_o^2 + r_i^2)/4) about its centre of mass follow l1, so that
the sensitivities and ``optimize`` move them with the link's length. Distal links slender
and uniform.

The five-bar (2 DOF), its end-effector a point:

Two RRR legs in the base plane z = 0: an actuated revolute joint at A1 = (-d/2, 0) and
A2 = (+d/2, 0) (coordinate theta_i, the absolute angle of the proximal link from +x), a
proximal link of length l1 to the elbow C_i, a distal link of length l2 to the
end-effector P, where the two distal links meet in one passive revolute joint; every axis
is parallel to z. The end-effector is a point mass (no rotation of its own): the pose
is P's (x, y) (:class:`~eigentwist.description.pose.PointPose`), two modes. Working mode
"elbows out": C1 to the left of A1 -> P, C2 to the right of A2 -> P. Units: m, kg,
kg/m^3, N m/rad. Values illustrative. Home (0, 0.30) m.
Load: ``eigentwist.load("examples/robots/five_bar_tube.py")``.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.pose import PointPose
from eigentwist.description.constraints import tube as tube_radii
from eigentwist.description.shapes import point_mass, slender_rod, tube

#: (base joint's side of the origin along x, elbow branch: +1 left of A_i -> P, -1 right)
LEGS = ((-1, +1), (+1, -1))
PARAMETERS = (
    Parameter("d", 0.20, "m", "distance between the two base joints; A1 = (-d/2, 0), A2 = (+d/2, 0)"),
    Parameter("l1", 0.18, "m", "proximal link length (both legs), A_i to the elbow C_i"),
    Parameter("l2", 0.26, "m", "distal link length (both legs), C_i to the end-effector P"),
    Parameter("r_o", 0.015, "m", "outer radius of each proximal tube"),
    Parameter("r_i", 0.012, "m", "inner radius of each proximal tube"),
    Parameter("rho", 2700.0, "kg/m^3", "density of the proximal tubes (aluminium)"),
    Parameter("m2", 0.25, "kg", "distal link mass (slender, uniform)"),
    Parameter("m_e", 0.50, "kg", "end-effector: a point mass at P"),
    Parameter("k_a", 2000.0, "N m/rad", "torsional stiffness of each actuated base joint"),
)


def _geometry(side, branch):
    """One leg's closed form: the two-link IK of theta_i and the joints' points."""
    ez = sp.Matrix([0, 0, 1])

    def geometry(position, rotation, p, q=None):
        A = sp.Matrix([side * p["d"] / 2, 0, 0])
        P = position
        dv = P - A
        D = sp.sqrt(dv[0] ** 2 + dv[1] ** 2)
        reach = (p["l1"] ** 2 + D**2 - p["l2"] ** 2) / (2 * p["l1"] * D)
        theta = sp.atan2(dv[1], dv[0]) + branch * sp.acos(reach) if q is None else q
        e1 = sp.Matrix([sp.cos(theta), sp.sin(theta), 0])
        C = A + p["l1"] * e1
        e2 = (P - C) / p["l2"]
        return {
            "A": A,
            "C": C,
            "P": P,
            "P_y": P + sp.Matrix([0, 1, 0]),
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


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    joints = (
        ChainJoint("R", ("ez",), "A", actuated=True, doc="actuated base joint"),
        ChainJoint("R", ("ez",), "C", doc="elbow"),
        ChainJoint("R", ("ez",), "P", doc="the distal links' common joint at P"),
        ChainJoint("virtual", ("ex",), "P", doc="tilting about x: constrained"),
        ChainJoint("virtual", ("ey",), "P", doc="tilting about y: constrained"),
        ChainJoint("virtual", ("ex",), "P_y", doc="with the first: lifting along z, constrained"),
    )
    bodies = (
        ChainBody("proximal", 1, tube(p["l1"], p["r_o"], p["r_i"], p["rho"]).spatial(), ("e1", "n1", "ez"), "A"),
        ChainBody("distal", 2, slender_rod(p["l2"], p["m2"]).spatial(), ("e2", "n2", "ez"), "C"),
    )
    legs = tuple(
        ChainLeg(f"leg {i + 1}", joints, bodies, _geometry(side, branch), checks=("reach",), coordinate="theta")
        for i, (side, branch) in enumerate(LEGS)
    )
    return ChainRobot(
        name="five_bar_tube",
        title="planar five-bar with tube proximal links (gallery, illustrative)",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=point_mass(p["m_e"]).spatial(),
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.30),
        pose=("x", "y"),
        workspace=((-0.08, 0.08), (0.22, 0.36)),
        pose_space=PointPose(("x", "y")),
        constraints=tube_radii(p["r_i"], p["r_o"], "each proximal tube"),
        source="examples/robots/five_bar_tube.py (eigentwist gallery); illustrative values",
    )
