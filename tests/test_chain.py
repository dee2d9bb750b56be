"""Huang's method on joint lists: the rows are those of the inverse twist matrix.

:func:`eigentwist.symbolic.leg.leg_screws` builds each leg's unit twists from its joint
list (a table from the joint kind to its twists) and the inverse-Jacobian rows from
5x5 minors, never a 6x6 inverse. Checked here against independent computations at
random configurations:

* a Heli4 leg (R, R, Pi, R, R and its twist of restriction): the six rows stacked are
  the inverse of the matrix of the six unit twists (``numpy.linalg.inv``), 1e-12;
* a hexapod leg (U, P, S): the actuated row is the strut's line in Pluecker coordinates,
  ``[(r x s)^T, s^T]`` (r: the platform joint from the platform origin, s: the strut
  direction; the length rate of a rigid motion ``[omega; v]`` is ``s . (v + omega x r)``),
  and the leg's ``determinant`` is that of its six unit twists (``numpy.linalg.det``);
* a leg whose joints give fewer than six twists is refused, naming the virtual joint.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import sympy as sp

from eigentwist.description import sym
from eigentwist.robots import get
from eigentwist.symbolic.leg import leg_screws
from eigentwist.symbolic.program import Program


def _program(robot, joints):
    prog = Program()
    for s_ in list(joints) + list(robot.pose_space.program_inputs) + [p.symbol for p in robot.parameters]:
        prog.declare(s_)
    return prog


def _num(prog, values, expr) -> np.ndarray:
    return np.array(prog.evaluate(values, sp.Matrix(expr)), dtype=float)


@pytest.mark.parametrize("leg_index", [0, 2])
def test_heli4_rows_invert_the_twist_matrix(leg_index):
    robot = get("heli4")
    q = tuple(sym(f"q{k}") for k in (1, 2, 3))
    prog = _program(robot, q)
    ls = leg_screws(prog, robot.legs[leg_index], q, robot.pose_space, "1")
    assert ls.keys == [1, 2, 3, 4, 5, "c"]
    rng = np.random.default_rng(leg_index)
    for _ in range(2):
        values = {**robot.defaults, **{s_.name: v for s_, v in zip(q, rng.uniform([-0.6, 0.8, -0.3], [0.2, 1.8, 0.3]))}}
        T = np.hstack([_num(prog, values, ls.twists[k]) for k in ls.keys])
        rows = np.vstack([_num(prog, values, ls.rows[k]) for k in ls.keys])
        want = np.linalg.inv(T)
        assert np.abs(rows - want).max() <= 1e-12 * np.abs(want).max()


def test_hexapod_actuated_row_is_the_strut_line():
    robot = get("hexapod")
    leg = robot.legs[3]
    pose = robot.pose_space
    length = sym("l_4")
    prog = _program(robot, (length,))
    ls = leg_screws(prog, leg, (length,), pose, "4")
    rng = np.random.default_rng(4)
    for _ in range(2):
        x = np.array([0, 0, 0.8]) + rng.uniform(-0.05, 0.05, 3)
        angle, axis = rng.uniform(0.05, 0.15), rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        R = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
        d = {**robot.defaults}
        b_deg, a_deg = (130, 170)  # leg 4's joints
        b = d["R_b"] * np.array([np.cos(np.radians(b_deg)), np.sin(np.radians(b_deg)), 0])
        top = x + R @ (d["R_p"] * np.array([np.cos(np.radians(a_deg)), np.sin(np.radians(a_deg)), 0]))
        strut = top - b
        s = strut / np.linalg.norm(strut)
        values = {
            **d,
            "l_4": np.linalg.norm(strut),
            "x": x[0],
            "y": x[1],
            "z": x[2],
            **{f"R_{i}{j}": R[i, j] for i in range(3) for j in range(3)},
        }
        act = ls.keys[leg.kinematics.jacobian_rows[0]]
        want = np.concatenate([np.cross(top - x, s), s])
        assert np.abs(_num(prog, values, ls.rows[act]).ravel() - want).max() <= 1e-12
        T = np.hstack([_num(prog, values, ls.twists[k]) for k in ls.keys])
        det = float(prog.evaluate(values, ls.determinant))
        assert abs(det - np.linalg.det(T.T)) <= 1e-12 * abs(det)


def test_a_leg_needs_six_twists():
    robot = get("heli4")
    q = tuple(sym(f"q{k}") for k in (1, 2, 3))
    prog = _program(robot, q)
    short = replace(robot.legs[0], joints=robot.legs[0].joints[:5])
    with pytest.raises(ValueError, match="virtual"):
        leg_screws(prog, short, q, robot.pose_space, "1")
