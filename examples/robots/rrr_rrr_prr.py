"""A planar 3-DOF platform on legs that differ: RRR, RRR and PRR (eigentwist's gallery).

Legs 1 and 2: an actuated revolute joint at B1 = (-b_x, -b_y), B2 = (+b_x, -b_y)
(theta_i, the absolute angle of the proximal link from +x, torsional stiffness k_r), an
elbow revolute joint C_i and a revolute joint at P_i on the platform. Leg 3: an actuated
prismatic joint along the rail y = y_r (coordinate s along +x, axial stiffness k_p), a
revolute joint on the slider S = (s, y_r) and a revolute joint at P3 on the platform. The
platform joints lie at radius r_p, angles 210, 330 and 90 deg in the platform frame; every
axis is parallel to z. Pose (x, y, rot_z): the platform frame's origin (m) and rotation
(rad). Branches: leg 1's elbow right of B1 -> P1, leg 2's left of B2 -> P2 (both below
their leg lines); the slider on the -x side of P3. Links slender and uniform; the slider
translates only. Units: m, kg, N m/rad, N/m. Values illustrative. Home (0, 0, 0).
Load: ``eigentwist.load("examples/robots/rrr_rrr_prr.py")``.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.pose import PlanarPose
from eigentwist.description.screw import spatial_inertia
from eigentwist.description.shapes import slender_rod

PARAMETERS = (
    Parameter("b_x", 0.35, "m", "base joints of the RRR legs: B1 = (-b_x, -b_y), B2 = (+b_x, -b_y)"),
    Parameter("b_y", 0.20, "m", "base joints of the RRR legs: their distance below the x axis"),
    Parameter("r_p", 0.10, "m", "radius of the platform joints (angles 210, 330, 90 deg, platform frame)"),
    Parameter("l1", 0.25, "m", "RRR proximal link length"),
    Parameter("m1", 0.60, "kg", "RRR proximal link mass (slender, uniform)"),
    Parameter("l2", 0.22, "m", "RRR distal link length, elbow to P_i"),
    Parameter("m2", 0.40, "kg", "RRR distal link mass (slender, uniform)"),
    Parameter("k_r", 1.0e4, "N m/rad", "torsional stiffness of each actuated RRR base joint"),
    Parameter("y_r", 0.20, "m", "the PRR rail: the line y = y_r, direction +x, origin (0, y_r)"),
    Parameter("m_s", 1.20, "kg", "slider mass (translates only), centre of mass at its revolute joint S"),
    Parameter("I_s", 1.0e-3, "kg m^2", "slider inertia about z (it does not rotate)"),
    Parameter("k_p", 2.0e6, "N/m", "axial stiffness of the actuated prismatic joint"),
    Parameter("l3", 0.35, "m", "PRR link length, S to P3"),
    Parameter("m3", 0.50, "kg", "PRR link mass (slender, uniform)"),
    Parameter("m_pl", 1.50, "kg", "platform mass"),
    Parameter("c_x", 0.010, "m", "platform centre of mass, x in the platform frame", (-1.0, 1.0)),
    Parameter("c_y", -0.005, "m", "platform centre of mass, y in the platform frame", (-1.0, 1.0)),
    Parameter("I_pl", 4.0e-3, "kg m^2", "platform inertia about z at its centre of mass"),
)
EZ, EX, EY = sp.Matrix([0, 0, 1]), sp.Matrix([1, 0, 0]), sp.Matrix([0, 1, 0])


def _platform_point(position, rotation, p, deg):
    g = sp.pi * deg / 180
    return position + rotation * (p["r_p"] * sp.Matrix([sp.cos(g), sp.sin(g), 0]))


def _rrr(side, deg, branch):
    """An RRR leg's closed form: theta_i from the two-link IK on its branch (+1: elbow left
    of B_i -> P_i), its joints' points and the links' axes."""

    def geometry(position, rotation, p, q=None):
        B = sp.Matrix([side * p["b_x"], -p["b_y"], 0])
        P = _platform_point(position, rotation, p, deg)
        dv = P - B
        D = sp.sqrt(dv[0] ** 2 + dv[1] ** 2)
        reach = (p["l1"] ** 2 + D**2 - p["l2"] ** 2) / (2 * p["l1"] * D)
        theta = sp.atan2(dv[1], dv[0]) + branch * sp.acos(reach) if q is None else q
        e1 = sp.Matrix([sp.cos(theta), sp.sin(theta), 0])
        C = B + p["l1"] * e1
        e2 = (P - C) / p["l2"]
        return {
            "B": B,
            "C": C,
            "P": P,
            "P_y": P + EY,
            "theta": theta,
            "reach": reach,
            "e1": e1,
            "n1": EZ.cross(e1),
            "e2": e2,
            "n2": EZ.cross(e2),
            "ez": EZ,
            "ex": EX,
            "ey": EY,
        }

    return geometry


def _prr(position, rotation, p, q=None):
    """The PRR leg's closed form: the slider's s on the -x side of P3, its points and axes."""
    P = _platform_point(position, rotation, p, 90)
    reach = (p["y_r"] - P[1]) / p["l3"]
    s = P[0] - sp.sqrt(p["l3"] ** 2 - (p["y_r"] - P[1]) ** 2) if q is None else q
    S = sp.Matrix([s, p["y_r"], 0])
    e3 = (P - S) / p["l3"]
    return {
        "S": S,
        "P": P,
        "P_y": P + EY,
        "s": s,
        "reach": reach,
        "e3": e3,
        "n3": EZ.cross(e3),
        "ez": EZ,
        "ex": EX,
        "ey": EY,
    }


def _closing(point):
    """The three virtual joints of a planar leg ending at ``point``: tilts about x and y and,
    with the first, lifting along z (its constraint wrenches hold the platform in the plane)."""
    return (
        ChainJoint("virtual", ("ex",), point, doc="tilting about x: constrained"),
        ChainJoint("virtual", ("ey",), point, doc="tilting about y: constrained"),
        ChainJoint("virtual", ("ex",), f"{point}_y", doc="with the first: lifting along z, constrained"),
    )


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    rrr_joints = (
        ChainJoint("R", ("ez",), "B", actuated=True, doc="actuated base joint"),
        ChainJoint("R", ("ez",), "C", doc="elbow"),
        ChainJoint("R", ("ez",), "P", doc="platform joint"),
    ) + _closing("P")
    rrr_bodies = (
        ChainBody("proximal", 1, slender_rod(p["l1"], p["m1"]).spatial(), ("e1", "n1", "ez"), "B"),
        ChainBody("distal", 2, slender_rod(p["l2"], p["m2"]).spatial(), ("e2", "n2", "ez"), "C"),
    )
    prr_joints = (
        ChainJoint("P", ("ex",), actuated=True, doc="actuated slider on the rail"),
        ChainJoint("R", ("ez",), "S", doc="revolute joint on the slider"),
        ChainJoint("R", ("ez",), "P", doc="platform joint"),
    ) + _closing("P")
    slider = spatial_inertia(p["m_s"], sp.zeros(3, 1), sp.diag(0, 0, p["I_s"]))
    prr_bodies = (
        ChainBody("slider", 1, slider, ("ex", "ey", "ez"), "S"),
        ChainBody("link", 2, slender_rod(p["l3"], p["m3"]).spatial(), ("e3", "n3", "ez"), "S"),
    )
    legs = (
        ChainLeg("leg 1 (RRR)", rrr_joints, rrr_bodies, _rrr(-1, 210, -1), checks=("reach",), coordinate="theta"),
        ChainLeg("leg 2 (RRR)", rrr_joints, rrr_bodies, _rrr(+1, 330, +1), checks=("reach",), coordinate="theta"),
        ChainLeg("leg 3 (PRR)", prr_joints, prr_bodies, _prr, checks=("reach",), coordinate="s", stiffness=p["k_p"]),
    )
    c = sp.Matrix([p["c_x"], p["c_y"], 0])
    platform = spatial_inertia(
        p["m_pl"], c, sp.diag(0, 0, p["I_pl"]) + p["m_pl"] * ((c.T * c)[0] * sp.eye(3) - c * c.T)
    )
    return ChainRobot(
        name="rrr_rrr_prr",
        title="planar RRR-RRR-PRR platform (gallery, illustrative)",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=platform,
        actuator_stiffness=p["k_r"],
        x_ref=(0.0, 0.0, 0.0),
        pose=("x", "y", "rot_z"),
        workspace=((-0.04, 0.04), (-0.04, 0.04), (-0.20, 0.20)),
        pose_space=PlanarPose(),
        source="examples/robots/rrr_rrr_prr.py (eigentwist gallery); illustrative values",
    )
