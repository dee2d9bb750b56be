"""A point driven by an RR arm and a PR arm, carried by a passive strut: legs from URDF files.

Three legs that differ, each read from the URDF file of its serial chain beside this file
(:func:`eigentwist.description.urdf.urdf_leg`, Pinocchio's parser), all meeting the
end-effector P, a point mass in the base plane z = 0, in one spherical joint:

- ``rr_arm.urdf``: a planar RR arm at A1 = (-d/2, 0, 0), its shoulder actuated (torsional
  stiffness k_r), links 0.18 m and 0.22 m, elbow to the left of A1 -> P (2 coordinates);
- ``pr_arm.urdf``: a slider along y at x = +d/2, actuated (axial stiffness k_p), carrying a
  revolute joint and a 0.20 m link to P, P above the slider (2 coordinates);
- ``strut.urdf``: a passive telescopic strut (U joint, prismatic piston) from C = (0, 0.55,
  0.40) m to P: no actuator and no constraint, its mass only (3 coordinates).

The point moves in the base plane (``PointPose(("x", "y"))``: two modes); each arm's
spherical joint is followed by one virtual joint (a rotation about x one metre along the
tip frame's y, which with the spherical joint's own rotation about x is the lift along z
that the planar arm does not have). What the files cannot say is here: where each chain
sits (``base_origin``, ``base_rotation``), which joint is actuated and its stiffness, the
attachment (P itself) and the reference configuration. Units: m, kg, rad, N/m, N m/rad.
Values illustrative. Home (0, 0.25) m. Load: ``eigentwist.load("examples/urdf/rr_pr_strut.py")``.
"""

from pathlib import Path

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.chain import ChainRobot
from eigentwist.description.pose import PointPose
from eigentwist.description.serial import Joint
from eigentwist.description.shapes import point_mass
from eigentwist.description.urdf import urdf_leg

HERE = Path(__file__).resolve().parent
PARAMETERS = (
    Parameter("d", 0.24, "m", "distance between the RR arm's shoulder (x = -d/2) and the PR arm's rail (x = +d/2)"),
    Parameter("k_r", 2000.0, "N m/rad", "torsional stiffness of the RR arm's actuated shoulder"),
    Parameter("k_p", 1.0e5, "N/m", "axial stiffness of the PR arm's actuated slider"),
    Parameter("m_e", 0.5, "kg", "end-effector: a point mass at P"),
)
#: the lift along z a planar arm does not have: with its spherical joint's rotation about x
LIFT = (Joint("virtual", origin=(0, 1, 0), axes=((1, 0, 0),), name="lift along z: constrained"),)
#: the strut's frame (columns): x from C down to P at home, y along the base x axis (the U joint's first axis)
STRUT_AXES = sp.Matrix([[0, 5, 0], [-3, 0, -4], [-4, 0, 3]]) / 5


def describe() -> ChainRobot:
    p = {q.name: q.symbol for q in PARAMETERS}
    legs = (
        urdf_leg(
            HERE / "rr_arm.urdf",
            "leg 1 (RR)",
            actuated="shoulder",
            end="tip",
            base_origin=(-p["d"] / 2, 0, 0),
            attachment=(0, 0, 0),
            virtual=LIFT,
            reference=(2.038, -1.620),
            stiffness=p["k_r"],
        ),
        urdf_leg(
            HERE / "pr_arm.urdf",
            "leg 2 (PR)",
            actuated="slide",
            end="tip",
            base_origin=(p["d"] / 2, 0, 0),
            attachment=(0, 0, 0),
            virtual=LIFT,
            reference=(0.09, 2.214),
            stiffness=p["k_p"],
        ),
        urdf_leg(
            HERE / "strut.urdf",
            "leg 3 (passive strut)",
            actuated=None,
            end="ball",
            base_origin=(0, sp.Rational(55, 100), sp.Rational(40, 100)),
            base_rotation=STRUT_AXES,
            attachment=(0, 0, 0),
            reference=(0.0, 0.0, 0.5),
        ),
    )
    return ChainRobot(
        name="rr_pr_strut",
        title="point driven by an RR and a PR arm, passive strut (legs from URDF files)",
        parameters=PARAMETERS,
        legs=tuple(leg.chain_leg() for leg in legs),
        platform_inertia=point_mass(p["m_e"]).spatial(),
        actuator_stiffness=p["k_r"],
        x_ref=(0.0, 0.25),
        pose=("x", "y"),
        workspace=((-0.04, 0.04), (0.22, 0.28)),
        pose_space=PointPose(("x", "y")),
        source="examples/urdf/rr_pr_strut.py and its URDF files; illustrative values",
    )
