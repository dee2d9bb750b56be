"""A Tricept: three actuated UPS legs and a passive central U-P leg (eigentwist's gallery).

Base in the plane z = 0, z up, the platform above. UPS leg i (base angles a_i = 90, 210,
330 deg): a universal joint at B_i = R_b (cos a_i, sin a_i, 0), its first axis the radial
direction (fixed in the base), its second the spider's y; an actuated prismatic joint along
the leg (s_i = |A_i - B_i|, axial stiffness k_a); a spherical joint at A_i = R_p (cos a_i,
sin a_i, 0) in the platform frame. Leg frame R_i = Rz(a_i) Rx(alpha_i) Ry(beta_i), its z axis
from B_i to A_i; cylinder and piston both turn with it. The central leg is passive (no
actuator: a constraint only): a universal joint at the base origin (first axis base x,
second the spider's y), a passive prismatic joint along its axis (rho), and its piston fixed
to the platform: the platform frame is the central leg's tip frame, origin p = rho R_c z,
orientation R_c = Rx(alpha_c) Ry(beta_c). The pose is p (x, y, z in m,
:class:`~eigentwist.description.pose.LowerMobilityPose`); the orientation follows from the
central leg's closures (solved per pose). Units: m, kg, kg m^2, N/m. Values illustrative.
Home (0, 0, 0.70) m. Load: ``eigentwist.load("examples/robots/tricept.py")``.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.pose import LowerMobilityPose
from eigentwist.description.shapes import Shape

ANGLES = (90, 210, 330)
BOUNDS = (-1.0, 1.0)
PARAMETERS = (
    Parameter("R_b", 0.35, "m", "radius of the UPS legs' U-joint centres B_i on the base"),
    Parameter("R_p", 0.15, "m", "radius of the S-joint centres A_i in the platform frame"),
    Parameter("k_a", 5.0e7, "N/m", "axial stiffness of each UPS actuator"),
    Parameter("m_c", 4.0, "kg", "UPS cylinder mass"),
    Parameter("c_c", 0.18, "m", "UPS cylinder centre of mass: (0, 0, c_c) in the leg frame"),
    Parameter("I_c_t", 0.070, "kg m^2", "UPS cylinder inertia about its centre of mass, transverse"),
    Parameter("I_c_a", 0.004, "kg m^2", "UPS cylinder inertia about its centre of mass, axial"),
    Parameter("m_r", 2.0, "kg", "UPS piston mass"),
    Parameter("c_r", 0.22, "m", "UPS piston centre of mass: A_i - c_r z_leg"),
    Parameter("I_r_t", 0.034, "kg m^2", "UPS piston inertia about its centre of mass, transverse"),
    Parameter("I_r_a", 0.0008, "kg m^2", "UPS piston inertia about its centre of mass, axial"),
    Parameter("m_t", 6.0, "kg", "central tube mass"),
    Parameter("c_t", 0.22, "m", "central tube centre of mass: (0, 0, c_t) in the central-leg frame"),
    Parameter("I_t_t", 0.100, "kg m^2", "central tube inertia about its centre of mass, transverse"),
    Parameter("I_t_a", 0.012, "kg m^2", "central tube inertia about its centre of mass, axial"),
    Parameter("m_q", 3.0, "kg", "central piston mass (fixed to the platform)"),
    Parameter("c_q", 0.25, "m", "central piston centre of mass: (0, 0, -c_q) in the platform frame"),
    Parameter("I_q_t", 0.060, "kg m^2", "central piston inertia about its centre of mass, transverse"),
    Parameter("I_q_a", 0.002, "kg m^2", "central piston inertia about its centre of mass, axial"),
    Parameter("m_pl", 12.0, "kg", "platform mass"),
    Parameter("c_pl_x", 0.010, "m", "platform centre of mass in the platform frame, x", BOUNDS),
    Parameter("c_pl_y", -0.005, "m", "platform centre of mass in the platform frame, y", BOUNDS),
    Parameter("c_pl_z", -0.060, "m", "platform centre of mass in the platform frame, z", BOUNDS),
    Parameter("I_pl_xx", 0.120, "kg m^2", "platform inertia about its centre of mass, xx (platform frame)"),
    Parameter("I_pl_yy", 0.130, "kg m^2", "platform inertia about its centre of mass, yy"),
    Parameter("I_pl_zz", 0.080, "kg m^2", "platform inertia about its centre of mass, zz"),
    Parameter("I_pl_xy", 0.003, "kg m^2", "platform product of inertia xy (the matrix entry)", BOUNDS),
    Parameter("I_pl_xz", 0.001, "kg m^2", "platform product of inertia xz (the matrix entry)", BOUNDS),
    Parameter("I_pl_yz", -0.002, "kg m^2", "platform product of inertia yz (the matrix entry)", BOUNDS),
)
EX, EZ = sp.Matrix([1, 0, 0]), sp.Matrix([0, 0, 1])


def _ups(deg):
    """A UPS leg's closed form: s_i = |A_i - B_i| and the leg frame's axes (y: the U joint's
    second axis, normal to the radial first axis and to the leg)."""
    a = sp.pi * deg / 180
    er = sp.Matrix([sp.cos(a), sp.sin(a), 0])

    def geometry(position, rotation, p, q=None):
        B = p["R_b"] * er
        A = position + rotation * (p["R_p"] * er)
        v = A - B
        length = sp.sqrt(v.dot(v)) if q is None else q
        d = v / length
        n = d.cross(er)
        y = n / sp.sqrt(n.dot(n))
        return {"B": B, "A": A, "length": length, "er": er, "x": y.cross(d), "y": y, "d": d, "reach": d.dot(er)}

    return geometry


def _central(position, rotation, p, q=None):
    """The central leg's closed form: its U joint's axes, its prismatic joint along the
    platform's z axis, and its closures: the platform's y axis normal to base x (the U
    joint fixes the spin) and the origin p on the leg's axis (p normal to the platform's x
    and y axes)."""
    xc, yc = rotation[:, 0], rotation[:, 1]
    rho = sp.sqrt(position.dot(position)) if q is None else q
    return {
        "O": sp.zeros(3, 1),
        "p": position,
        "rho": rho,
        "ex": EX,
        "xc": xc,
        "yc": yc,
        "zc": position / rho,
        "reach": position[0] / sp.sqrt(position.dot(position)),
        "spin": yc[0],
        "axis_x": position.dot(xc),
        "axis_y": position.dot(yc),
    }


def _body(mass, com, transverse, axial) -> sp.Matrix:
    return Shape(mass, sp.Matrix(com), sp.diag(transverse, transverse, axial)).spatial()


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    ups_joints = (
        ChainJoint("U", ("er", "y"), "B", doc="base universal joint"),
        ChainJoint("P", ("d",), actuated=True, doc="actuated prismatic joint"),
        ChainJoint("S", (), "A", doc="platform spherical joint"),
    )
    ups_bodies = (
        ChainBody("cylinder", 1, _body(p["m_c"], (0, 0, p["c_c"]), p["I_c_t"], p["I_c_a"]), ("x", "y", "d"), "B"),
        ChainBody("piston", 2, _body(p["m_r"], (0, 0, -p["c_r"]), p["I_r_t"], p["I_r_a"]), ("x", "y", "d"), "A"),
    )
    legs = tuple(
        ChainLeg(f"leg {i + 1} (UPS)", ups_joints, ups_bodies, _ups(a), checks=("reach",)) for i, a in enumerate(ANGLES)
    )
    central = ChainLeg(
        "central leg (U-P, passive)",
        (
            ChainJoint("U", ("ex", "yc"), "O", doc="base universal joint"),
            ChainJoint("P", ("zc",), doc="passive prismatic joint, its piston fixed to the platform"),
            ChainJoint("virtual", ("xc",), "p", doc="tilting the platform about its x axis: constrained"),
            ChainJoint("virtual", ("yc",), "p", doc="tilting the platform about its y axis: constrained"),
            ChainJoint("virtual", ("zc",), "p", doc="spinning the platform about the leg: constrained"),
        ),
        (ChainBody("tube", 1, _body(p["m_t"], (0, 0, p["c_t"]), p["I_t_t"], p["I_t_a"]), ("xc", "yc", "zc"), "O"),),
        _central,
        checks=("reach",),
        closures=("spin", "axis_x", "axis_y"),
        coordinate="rho",
    )
    c = sp.Matrix([p["c_pl_x"], p["c_pl_y"], p["c_pl_z"]])
    I_pl = sp.Matrix(
        [
            [p["I_pl_xx"], p["I_pl_xy"], p["I_pl_xz"]],
            [p["I_pl_xy"], p["I_pl_yy"], p["I_pl_yz"]],
            [p["I_pl_xz"], p["I_pl_yz"], p["I_pl_zz"]],
        ]
    )
    platform = Shape(p["m_pl"], c, I_pl).spatial() + _body(p["m_q"], (0, 0, -p["c_q"]), p["I_q_t"], p["I_q_a"])
    return ChainRobot(
        name="tricept",
        title="Tricept: 3 UPS legs and a passive central U-P leg (gallery, illustrative)",
        parameters=PARAMETERS,
        legs=legs + (central,),
        platform_inertia=platform,
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, 0.70),
        pose=("x", "y", "z"),
        workspace=((-0.10, 0.10), (-0.10, 0.10), (0.60, 0.80)),
        pose_space=LowerMobilityPose(("x", "y", "z")),
        source="examples/robots/tricept.py (eigentwist gallery); illustrative values",
    )
