"""``examples/urdf/rr_pr_strut.py`` written by hand: the same three legs as joint lists.

The RR arm and the PR arm as :class:`~eigentwist.description.serial.SerialLeg` joints with
their links' inertias from shapes (slender uniform rods along the link frames' x axes;
the slider a point mass with 2e-4 kg m^2 about each axis), and the passive strut as a U
joint, a prismatic piston and a spherical joint with the cylinder's and piston's inertias
moved to their joint frames by hand (parallel axes). The URDF files state the same
robot: ``tests/test_urdf_robot.py`` compares the two.
"""

from pathlib import Path

import sympy as sp

from eigentwist.description.chain import ChainRobot
from eigentwist.description.pose import PointPose
from eigentwist.description.screw import spatial_inertia
from eigentwist.description.serial import Body, Joint, SerialLeg
from eigentwist.description.shapes import point_mass, slender_rod
from eigentwist.runtime.userfile import describe_file

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "urdf" / "rr_pr_strut.py"

LIFT = (Joint("virtual", origin=(0, 1, 0), axes=((1, 0, 0),)),)
EZ, EY, EX = ((0, 0, 1),), ((0, 1, 0),), ((1, 0, 0),)


def _rod_at(mass, x, transverse):
    """A body along its frame's x axis: mass (kg) at x (m), transverse inertia (kg m^2) about its centre."""
    return spatial_inertia(mass, sp.Matrix([x, 0, 0]), sp.diag(0, 1, 1) * (transverse + mass * x**2))


def describe() -> ChainRobot:
    """The hand-written robot with the URDF description's parameters, x_ref and workspace."""
    shipped = describe_file(EXAMPLE)
    p = {q.name: q.symbol for q in shipped.parameters}
    r = lambda n: sp.Rational(n, 100)  # noqa: E731  (m)
    rr = SerialLeg(
        "leg 1 (RR)",
        (
            Joint("R", origin=(-p["d"] / 2, 0, 0), axes=EZ, actuated=True),
            Joint("R", origin=(r(18), 0, 0), axes=EZ),
            Joint("S", origin=(r(22), 0, 0)),
        )
        + LIFT,
        (
            Body("proximal", 1, slender_rod(r(18), sp.Rational(3, 10)).spatial()),
            Body("distal", 2, slender_rod(r(22), sp.Rational(1, 4)).spatial()),
        ),
        attachment=(0, 0, 0),
        reference=(2.038, -1.620),
        stiffness=p["k_r"],
    )
    pr = SerialLeg(
        "leg 2 (PR)",
        (
            Joint("P", origin=(p["d"] / 2, 0, 0), axes=EY, actuated=True),
            Joint("R", axes=EZ),
            Joint("S", origin=(r(20), 0, 0)),
        )
        + LIFT,
        (
            Body("slider", 1, spatial_inertia(sp.Rational(2, 5), sp.zeros(3, 1), sp.eye(3) * sp.Rational(2, 10000))),
            Body("link", 2, slender_rod(r(20), sp.Rational(1, 5)).spatial()),
        ),
        attachment=(0, 0, 0),
        reference=(0.09, 2.214),
        stiffness=p["k_p"],
    )
    strut = SerialLeg(
        "leg 3 (passive strut)",
        (
            Joint(
                "U",
                origin=(0, r(55), r(40)),
                rotation=sp.Matrix([[0, 5, 0], [-3, 0, -4], [-4, 0, 3]]) / 5,
                axes=EY + EZ,
            ),
            Joint("P", axes=EX),
            Joint("S"),
        ),
        (
            Body("cylinder", 1, _rod_at(sp.Rational(1, 2), r(10), sp.Rational(2, 1000))),
            Body("piston", 2, _rod_at(sp.Rational(3, 10), -r(8), sp.Rational(8, 10000))),
        ),
        attachment=(0, 0, 0),
        reference=(0.0, 0.0, 0.5),
    )
    return ChainRobot(
        name="rr_pr_strut_by_hand",
        title="point driven by an RR and a PR arm, passive strut (joint lists)",
        parameters=shipped.parameters,
        legs=tuple(leg.chain_leg() for leg in (rr, pr, strut)),
        platform_inertia=point_mass(p["m_e"]).spatial(),
        actuator_stiffness=p["k_r"],
        x_ref=shipped.x_ref,
        pose=shipped.pose,
        workspace=shipped.workspace,
        pose_space=PointPose(("x", "y")),
    )
