"""The chain derivation reproduces the Heli4's RR(Pi)RR leg (issue 15, step 1 evidence).

One Heli4 leg written as a ChainLeg joint list (R, R, Pi, R, R and the virtual joint of
its twist of restriction) gives, through :func:`eigentwist.symbolic.chain.chain_screws`,
the same inverse-Jacobian rows and the same body terms of Eq. 12 as the Heli4's own
derivation (:func:`eigentwist.symbolic.leg.leg_screws`, its description's joint list),
at random joint angles (1e-12). The numbers of the hand-built leg that preceded both are
pinned in ``tests/data/chain_pin.npz`` (``tests/test_chain_equivalence.py``).
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from eigentwist.description import sym
from eigentwist.description.chain import ChainBody, ChainJoint, ChainLeg
from eigentwist.robots import get
from eigentwist.symbolic.chain import body_inertia, chain_screws
from eigentwist.symbolic.inertia import body_inertia_contribution, parallelogram_inertia
from eigentwist.symbolic.leg import leg_screws
from eigentwist.symbolic.program import Program

JOINTS = (ChainJoint("R", ("s",), "base", actuated=True), ChainJoint("R", ("s",), "elbow"),
          ChainJoint("Pi", ("s3",)), ChainJoint("R", ("s4",), "a"), ChainJoint("R", ("s",), "a"),
          ChainJoint("virtual", ("ch",), "a"))


def _both(leg_index: int):
    robot = get("heli4")
    prog = Program()
    q = tuple(prog.declare(sym(f"q{k}")) for k in (1, 2, 3))
    for p in robot.parameters:
        prog.declare(p.symbol)
    ls = leg_screws(prog, robot.legs[leg_index], q, "1")
    g = {"s": ls.vectors["s"], "s3": ls.vectors["s3"], "s4": ls.vectors["s4"], "a": ls.vectors["a"],
         "base": ls.frames["J1"][1], "elbow": ls.frames["E1"][1], "ch": ls.twists["c"][:3, 0]}
    for f in ("J1", "C3"):
        g.update({f"{f}{k}": ls.frames[f][0][:, k] for k in range(3)})
        g[f"{f}o"] = ls.frames[f][1]
    rod = robot.rod
    inertia = {"J1": robot.lower_link_inertia, "C3": parallelogram_inertia(rod["r_i"], rod["r_o"], rod["rho"], robot.l2)}
    bodies = tuple(ChainBody(f, n, inertia[f], (f"{f}0", f"{f}1", f"{f}2"), f"{f}o") for f, n in (("J1", 1), ("C3", 3)))
    leg = ChainLeg("leg", JOINTS, bodies, geometry=None)
    cs = chain_screws(prog, leg, g, sp.zeros(3, 1), "c")
    return robot, prog, q, ls, leg, cs, inertia


@pytest.mark.parametrize("leg_index", [0, 2])
def test_heli4_leg_as_a_joint_list(leg_index):
    robot, prog, q, ls, leg, cs, inertia = _both(leg_index)
    assert leg.freedoms == 5 and cs.actuated == 0
    pairs = [(ls.rows[k], cs.rows[i]) for i, k in enumerate((1, 2, 3, None, 5, "c")) if k is not None]
    pairs += [(body_inertia_contribution(prog, ls, {b.name: b for b in robot.legs[leg_index].bodies}[f], inertia[f], f"h{f}"),
               body_inertia(prog, cs, leg, b, sp.zeros(3, 1), f"c{f}")) for (f, n), b in zip((("J1", 1), ("C3", 3)), leg.bodies)]
    rng = np.random.default_rng(leg_index)
    for _ in range(2):
        values = {**robot.defaults, **dict(zip(q, rng.uniform([-0.6, 0.8, -0.3], [0.2, 1.8, 0.3])))}
        for ref, got in pairs:
            a = np.array(prog.evaluate(values, ref), dtype=float)
            b = np.array(prog.evaluate(values, got), dtype=float)
            assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()


def test_a_leg_needs_six_twists():
    robot, prog, q, ls, leg, cs, inertia = _both(0)
    short = ChainLeg("short", JOINTS[:5], (), geometry=None)
    with pytest.raises(ValueError, match="virtual"):
        chain_screws(prog, short, cs.geometry, sp.zeros(3, 1), "d")
