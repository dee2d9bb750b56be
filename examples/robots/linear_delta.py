"""A linear Delta (three vertical prismatic columns with parallelograms; illustrative
dimensions), as joint lists: eigentwist's gallery.

Three vertical columns at radius R_b (base angles 90, 210, 330 deg, z up), each with a
slider (the actuated prismatic joint, height s) carrying a parallelogram of rods of length L
down to the platform's attachment at radius R_p. Each leg is P R (Pi) R R (the RR(Pi)RR
leg of the Heli4 and Delta with the rotary lower link replaced by a slider): the slider, the
parallelogram's swing about its near bar (axis tangent to the base circle), the
parallelogram (a curvilinear translation), and the far bar's two revolute joints; one
constraint wrench per leg (a couple), so the platform translates. The parallelogram's two
rods are one fictitious rod of double mass riding on the far bar, as the paper models them
(Eqs. 26-29). Units: m, kg, N/m. Values illustrative (a 3-D-printer-sized linear Delta).
Load: ``eigentwist.load("examples/robots/linear_delta.py")`` or ``--robot`` with the path.
"""

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg, ChainRobot
from eigentwist.description.effects import effect_parameters
from eigentwist.description.pose import TranslationPose
from eigentwist.description.screw import cross, spatial_inertia

ANGLES = (90, 210, 330)
PARAMETERS = (
    Parameter("R_b", 0.20, "m", "radius of the columns"),
    Parameter("R_p", 0.04, "m", "radius of the platform's attachments (far bar centres)"),
    Parameter("L", 0.30, "m", "length of the parallelogram's rods"),
    Parameter("m_pl", 0.6, "kg", "mass of the platform with its tool"),
    Parameter("m_s", 0.3, "kg", "mass of each slider with its near bar (a point mass at its joint)"),
    Parameter("m_r", 0.05, "kg", "mass of each of a parallelogram's two rods (slender, uniform)"),
    Parameter("k_a", 2.0e5, "N/m", "axial stiffness of each belt-driven slider"),
    Parameter("c_rigid", 1e-12, "rad/(N m)", "compliance of the ideally rigid constrained direction", (0.0, 1e-6)),
) + effect_parameters(("actuator_loss", "payload_mass"), {"m_p": 0.1})


def _geometry(deg):
    """One leg's closed form: the slider height from the pose, the parallelogram's axes."""
    ang = sp.pi * deg / 180
    er, s, ez = (
        sp.Matrix([sp.cos(ang), sp.sin(ang), 0]),
        sp.Matrix([-sp.sin(ang), sp.cos(ang), 0]),
        sp.Matrix([0, 0, 1]),
    )

    def geometry(position, rotation, p, q=None):
        b = p["R_b"] * er
        a = position + p["R_p"] * er  # the far bar's centre (translating platform)
        D = a - b
        reach = sp.sqrt(D.dot(er) ** 2 + D.dot(s) ** 2) / p["L"]
        height = D[2] + sp.sqrt(p["L"] ** 2 - D.dot(er) ** 2 - D.dot(s) ** 2) if q is None else q
        c = b + height * ez  # the slider, above the platform
        r2 = (a - c) / p["L"]  # rod direction
        c3 = sp.sqrt(1 - r2.dot(s) ** 2)
        w = (r2 - r2.dot(s) * s) / c3  # the parallelogram plane's direction
        return {
            "c": c,
            "a": a,
            "pC": c + p["L"] / 2 * r2,
            "height": height,
            "reach": reach,
            "s": s,
            "ez": ez,
            "w": w,
            "r2": r2,
            "s3": c3 * s - r2.dot(s) * w,
            "n": cross(s, w),
            "n2": cross(r2, c3 * s - r2.dot(s) * w),
        }

    return geometry


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    joints = (
        ChainJoint("P", ("ez",), actuated=True, doc="slider on its column"),
        ChainJoint("R", ("s",), "c", doc="swing of the parallelogram about its near bar"),
        ChainJoint(
            "Pi",
            ("s3",),
            "c",
            swing=("n2", p["L"]),
            doc="parallelogram: the far bar's curvilinear "
            "translation, its rods swinging about n2 (near pivots at the slider)",
        ),
        ChainJoint("R", ("w",), "a", doc="twist of the rods about each other"),
        ChainJoint("R", ("s",), "a", doc="far bar on the platform"),
        ChainJoint("virtual", ("n",), "a", doc="rotation of the far bar out of its plane: constrained"),
    )
    rod = 2 * p["m_r"] * p["L"] ** 2 / 12  # two rods as one of double mass, about its centre
    bodies = (
        ChainBody("slider", 1, spatial_inertia(p["m_s"], sp.zeros(3, 1), sp.zeros(3, 3)), ("r2", "s3", "n2"), "c"),
        ChainBody(
            "rods", 3, spatial_inertia(2 * p["m_r"], sp.zeros(3, 1), sp.diag(0, rod, rod)), ("r2", "s3", "n2"), "pC"
        ),
    )
    legs = tuple(
        ChainLeg(f"leg {i + 1}", joints, bodies, _geometry(a), checks=("reach",), coordinate="height")
        for i, a in enumerate(ANGLES)
    )
    return ChainRobot(
        name="linear_delta",
        title="linear Delta (gallery, illustrative)",
        parameters=PARAMETERS,
        legs=legs,
        platform_inertia=spatial_inertia(p["m_pl"], sp.zeros(3, 1), sp.diag(4e-4, 4e-4, 6e-4) * p["m_pl"] / 0.6),
        actuator_stiffness=p["k_a"],
        x_ref=(0.0, 0.0, 0.0),
        pose=("x", "y", "z"),
        workspace=((-0.05, 0.05), (-0.05, 0.05), (-0.05, 0.05)),
        pose_space=TranslationPose(),
        source="examples/robots/linear_delta.py (eigentwist gallery); illustrative values",
        effects=("actuator_loss", "payload_mass"),
        rigid_compliance=p["c_rigid"],
    )
