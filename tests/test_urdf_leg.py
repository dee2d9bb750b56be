"""A leg read from a URDF file (Pinocchio's parser) is the leg written by hand.

The hexapod's leg 1 in URDF form (``tests/descriptions/hexapod_urdf.py``: a U joint at the
base, a prismatic strut, a spherical joint at the platform) written as the URDF a CAD
exporter gives (the U joint as two revolute joints, the links' inertials at their centres
of mass) and placed in the base frame by the description: at random joint coordinates its
unit twists, the chain's end and its bodies' spatial inertias equal the hand-written leg's
(1e-12); the parser's refusals name what is wrong.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

pytest.importorskip("pinocchio")

from eigentwist.description.pose import RigidPose  # noqa: E402
from eigentwist.description.urdf import urdf_leg  # noqa: E402
from eigentwist.robots import hexapod  # noqa: E402
from eigentwist.symbolic.leg import leg_screws  # noqa: E402
from eigentwist.symbolic.program import Program  # noqa: E402

from .descriptions import hexapod_urdf  # noqa: E402


def _urdf(d: dict) -> str:
    """The strut as a CAD exporter writes it (SI units; inertias at the centres of mass)."""

    def inertial(m, x, i):
        return (
            f'<inertial><origin xyz="{x} 0 0"/><mass value="{m}"/>'
            f'<inertia ixx="0" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>'
        )

    limit = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
    return f"""<robot name="strut">
  <link name="mount"/>
  <link name="cross"/>
  <link name="cylinder">{inertial(d["m_cyl"], d["d_cyl"], d["I_cyl"])}</link>
  <link name="piston">{inertial(d["m_pis"], -d["d_pis"], d["I_pis"])}</link>
  <link name="ball"/>
  <joint name="u_first" type="revolute"><parent link="mount"/><child link="cross"/><axis xyz="0 1 0"/>{limit}</joint>
  <joint name="u_second" type="revolute"><parent link="cross"/><child link="cylinder"/>\
<axis xyz="0 0 1"/>{limit}</joint>
  <joint name="stroke" type="prismatic"><parent link="cylinder"/><child link="piston"/>\
<axis xyz="1 0 0"/>{limit}</joint>
  <joint name="to_ball" type="fixed"><parent link="piston"/><child link="ball"/></joint>
</robot>"""


def _leg_from_urdf(text, d):
    shipped = hexapod_urdf.describe().legs[0].kinematics.leg
    return shipped, urdf_leg(
        text,
        "leg 1",
        actuated="stroke",
        end="ball",
        base_origin=shipped.joints[0].origin,
        base_rotation=shipped.joints[0].rotation,
        attachment=shipped.attachment,
        reference=shipped.reference,
    )


def _evaluator(leg):
    """``values -> (unit twists 6x6, chain end 3)`` of ``leg`` (its screws derived once)."""
    chain = leg.chain_leg()
    pose = RigidPose()
    prog = Program()
    q = tuple(prog.declare(v) for v in chain.kinematics.symbols("1"))
    for v in list(pose.program_inputs) + [p.symbol for p in hexapod.describe().parameters]:
        prog.declare(v)
    ls = leg_screws(prog, chain, q, pose, "1")
    out = sp.Matrix.vstack(*[ls.twists[k] for k in ls.keys], sp.Matrix(ls.vectors["end_p"]))
    return lambda values: np.array(prog.evaluate(values, out), dtype=float)


def test_urdf_leg_is_the_hand_written_leg():
    d = hexapod.describe().defaults
    shipped, leg = _leg_from_urdf(_urdf(d), d)
    assert [j.kind for j in leg.joints] == ["R", "R", "P", "S"] and leg.joints[2].actuated
    mine, theirs = _evaluator(leg), _evaluator(shipped)
    rng = np.random.default_rng(30)
    for _ in range(3):
        q = rng.uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.0])
        values = {
            **d,
            "q1_1": q[0],
            "q2_1": q[1],
            "q3_1": q[2],
            "x": 0.0,
            "y": 0.0,
            "z": 0.8,
            **{f"R_{i}{j}": float(i == j) for i in range(3) for j in range(3)},
        }
        np.testing.assert_allclose(mine(values), theirs(values), atol=1e-12)  # twists, then the chain's end
    subs = {sp.Symbol(k, real=True): v for k, v in d.items()}
    for mine, theirs in zip(leg.bodies, shipped.bodies):
        a = np.array(mine.inertia.subs(subs), dtype=float)
        b = np.array(theirs.inertia.subs(subs).subs({s: d[s.name] for s in theirs.inertia.free_symbols}), dtype=float)
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_urdf_refusals_name_the_problem():
    d = hexapod.describe().defaults
    text = _urdf(d)
    with pytest.raises(ValueError, match=r"actuated joint 'slider' is not in the URDF \(its joints: u_first"):
        urdf_leg(text, "leg 1", actuated="slider", attachment=(0, 0, 0), reference=(0, 0, 0.8))
    branched = text.replace(
        '<parent link="cylinder"/><child link="piston"/>', '<parent link="cross"/><child link="piston"/>'
    )
    with pytest.raises(ValueError, match="expected one serial chain"):
        urdf_leg(branched, "leg 1", actuated="stroke", attachment=(0, 0, 0), reference=(0, 0, 0.8))
    with pytest.raises(FileNotFoundError, match="no_such.urdf"):
        urdf_leg("no_such.urdf", "leg 1", actuated="stroke", attachment=(0, 0, 0), reference=(0, 0, 0.8))
