"""A whole robot from URDF files, its numeric-IK legs differing: ``examples/urdf/rr_pr_strut.py``.

Three legs read from their URDF files through Pinocchio's parser, each solved by Newton's
method and each of its own kind: an RR arm (2 coordinates, an actuated revolute joint), a
PR arm (2 coordinates, an actuated prismatic joint, its own stiffness) and a passive
telescopic strut (3 coordinates, no actuator), on a point end-effector (two modes).

- The URDF legs are the legs written by hand (``tests/descriptions/rr_pr_strut.py``:
  joint lists, inertias from shapes): unit twists, chain end and spatial inertias equal at
  random joint coordinates (1e-12), with no derivation.
- The derived, generated model against Pinocchio (``tests/pinocchio_model.py``: each leg a
  Pinocchio tree whose closure Pinocchio solves itself, ``crba`` reduced through the legs'
  velocity maps) at 6 poses: E^T M E, E^T K_R E (E the point's translations x, y) and the
  frequencies to 1e-8 relative; the legs' constraint rows annihilate E.
- The assembly branch recorded at x_ref closes every loop (padded coordinates at zero);
  d f / d d (the base spacing moves two legs' mountings: an implicit derivative through
  the numeric IK) equals central differences to 1e-6 relative.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

pin = pytest.importorskip("pinocchio")

import eigentwist  # noqa: E402
from eigentwist.description.serial import ROTATION_TOL, Joint  # noqa: E402
from eigentwist.errors import DescriptionError  # noqa: E402
from eigentwist.runtime.userfile import describe_file  # noqa: E402
from eigentwist.symbolic.leg import leg_screws  # noqa: E402
from eigentwist.symbolic.program import Program  # noqa: E402

from .conftest import random_poses  # noqa: E402
from .descriptions import rr_pr_strut  # noqa: E402
from .pinocchio_model import PinocchioRobot, eigen_frequencies, from_description  # noqa: E402

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "urdf" / "rr_pr_strut.py"
RTOL = 1e-8
N_POSES = 6


def _example():
    return describe_file(EXAMPLE)


def _legs_evaluator(robot):
    """``values -> [(unit twists, chain end) per leg]`` of ``robot``'s legs (their screws, no derivation)."""
    pose = robot.pose_space
    prog = Program()
    for v in list(pose.program_inputs) + [p.symbol for p in robot.parameters]:
        prog.declare(v)
    outs = []
    for i, leg in enumerate(robot.legs, start=1):
        q = tuple(prog.declare(v) for v in leg.kinematics.symbols(str(i)))
        ls = leg_screws(prog, leg, q, pose, str(i))
        outs.append(sp.Matrix.vstack(*[ls.twists[k] for k in ls.keys], sp.Matrix(ls.vectors["end_p"])))
    return lambda values: [np.array(prog.evaluate(values, o), dtype=float) for o in outs]


def test_urdf_legs_are_the_hand_written_legs():
    urdf, hand = _example(), rr_pr_strut.describe()
    assert [len(leg.kinematics.coordinates) for leg in urdf.legs] == [2, 2, 3]
    assert [leg.actuated is not None for leg in urdf.legs] == [True, True, False]
    d = urdf.defaults
    mine, theirs = _legs_evaluator(urdf), _legs_evaluator(hand)
    rng = np.random.default_rng(30)
    for _ in range(3):
        q = rng.uniform(-1.0, 1.0, (3, 3)) + [[2.0, -1.6, 0], [0.1, 2.2, 0], [0, 0, 0.5]]
        values = {
            **d,
            "x": 0.0,
            "y": 0.25,
            "z": 0.0,
            **{f"R_{i}{j}": float(i == j) for i in range(3) for j in range(3)},
        }
        values.update({f"q{m + 1}_{i + 1}": q[i, m] for i in range(3) for m in range(3)})
        for a, b in zip(mine(values), theirs(values)):
            np.testing.assert_allclose(a, b, atol=1e-12)  # twists, then the chain's end
    subs = {sp.Symbol(k, real=True): v for k, v in d.items()}
    for leg_u, leg_h in zip(urdf.legs, hand.legs):
        assert len(leg_u.bodies) == len(leg_h.bodies)
        for a, b in zip(leg_u.bodies, leg_h.bodies):
            np.testing.assert_allclose(
                np.array(a.inertia.subs(subs), dtype=float), np.array(b.inertia.subs(subs), dtype=float), atol=1e-12
            )


@pytest.fixture(scope="module")
def ev():
    return eigentwist.load(str(EXAMPLE), backend="numpy", progress=None)


@pytest.mark.derives
def test_urdf_robot_equals_pinocchio(ev):
    p = dict(ev.defaults)
    assert ev.assembly()["q"][:2, 2].tolist() == [0.0, 0.0]  # the arms' padded coordinates
    ref = np.asarray(ev.completion.poses(np.array([ev.robot.x_ref])))[0]
    pr = PinocchioRobot(from_description(ev.robot, p, ev.joint_angles(ev.robot.x_ref)[0], ref[:3]))
    c_act = [1 / p["k_r"], 1 / p["k_p"], 1.0]  # the strut: passive (no actuated joint, never read)
    poses = random_poses(ev.robot, N_POSES, seed=30)
    full = np.asarray(ev.completion.poses(poses))
    mats, f_et = ev.matrices(poses, "none"), ev.frequencies(poses, "none")
    E = np.eye(6)[:, 3:5]  # the point's translations x, y
    worst = {"M": 0.0, "K_R": 0.0, "f": 0.0, "point": 0.0}
    rel = lambda a, b: float(np.max(np.abs(a - b)) / np.max(np.abs(b)))  # noqa: E731
    for k, pose in enumerate(full):
        rigid = pr.matrices(pose[:3], None, c_act=c_act, stiffness="actuated")
        rows = np.vstack([st["G"][leg.virtual] for leg, st in zip(pr.legs, rigid["states"])])
        worst["point"] = max(worst["point"], float(np.abs(rows @ E).max() / np.abs(rows).max()))
        M, K = E.T @ rigid["M"] @ E, E.T @ rigid["K"] @ E
        worst["M"] = max(worst["M"], rel(E.T @ mats["M"][k] @ E, M))
        worst["K_R"] = max(worst["K_R"], rel(E.T @ mats["K_R"][k] @ E, K))
        worst["f"] = max(worst["f"], float(np.max(np.abs(f_et[k] / eigen_frequencies(M, K) - 1))))
    print(f"rr_pr_strut: max relative deviation from Pinocchio {worst}")
    assert max(worst.values()) < RTOL, worst


@pytest.mark.derives
def test_urdf_robot_sensitivity_through_numeric_ik(ev):
    x = np.array([[0.02, 0.24]])
    exact = ev.sensitivities(x, wrt=("d",), model="none")[0, :, 0]
    h = 1e-5 * ev.defaults["d"]
    d = ev.defaults["d"]
    diff = (ev.frequencies(x, "none", d=d + h) - ev.frequencies(x, "none", d=d - h))[0] / (2 * h)
    np.testing.assert_allclose(exact, diff, rtol=1e-6)
    assert np.abs(exact).min() > 1.0  # Hz/m: the spacing moves both modes


@pytest.mark.parametrize("stretch, refused", [(0.25 * ROTATION_TOL, False), (ROTATION_TOL, True)])
def test_a_joint_rotation_must_be_a_rotation(stretch, refused):
    """R^T R - I of diag(1 + e, 1, 1) is 2e + e^2: within ROTATION_TOL at e = tol/4, beyond at e = tol."""
    R = sp.diag(1 + sp.Float(stretch, 30), 1, 1)
    if refused:
        with pytest.raises(DescriptionError, match=r"joint 'mount'.* is not a rotation .*expected orthonormal"):
            Joint("R", axes=((0, 0, 1),), rotation=R, name="mount")
    else:
        Joint("R", axes=((0, 0, 1),), rotation=R, name="mount")
    assert (
        Joint("R", axes=((0, 0, 1),), rotation=sp.diag(sp.Symbol("s"), 1, 1)).rotation is not None
    )  # expressions pass


@pytest.mark.derives
def test_matrices_command_gives_each_legs_coordinates_in_its_units(ev, capsys):
    """`eigentwist matrices --json`: each leg's own coordinates (no padding) and units."""
    import json

    from eigentwist.cli.main import main

    assert ev.leg_joint_units == (("rad", "rad"), ("m", "rad"), ("rad", "rad", "m"))
    args = ["matrices", "--robot", str(EXAMPLE), "--backend", "numpy", "--pose", "0", "0.25", "--model", "none"]
    assert main(args + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["leg_joint_units"]["leg 2 (PR)"] == ["m", "rad"]
    q = out["joint_coordinates"]
    assert [len(v) for v in q.values()] == [2, 2, 3]
    assert q["leg 2 (PR)"][0] == pytest.approx(0.25 - np.sqrt(0.2**2 - 0.12**2), abs=1e-12)  # the slider under P
    assert q["leg 3 (passive strut)"][2] == pytest.approx(0.5, abs=1e-12)  # |P - C|: the strut's length
    assert main(args) == 0
    assert "leg 2 (PR) (m, rad): 0.090000, 2.214297" in " ".join(capsys.readouterr().out.split())  # lines wrap


@pytest.mark.derives
def test_a_robot_of_urdf_legs_is_drawn_from_its_joints_to_its_attachment(ev, tmp_path):
    from eigentwist.plots.robot import plot_modes, robot_geometry

    home = np.array([0.0, 0.25])
    g = robot_geometry(ev, home)
    d = ev.defaults["d"]
    # the example's docstring: the RR arm's shoulder at A1 = (-d/2, 0, 0), the slider at x = +d/2 in
    # the base plane, the strut's base joint at C = (0, 0.55, 0.40) m
    np.testing.assert_allclose(g.base[0], [-d / 2, 0.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(g.base[1][[0, 2]], [d / 2, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(g.base[2], [0.0, 0.55, 0.40], rtol=0, atol=1e-12)
    np.testing.assert_allclose(g.attachment, np.tile([0.0, 0.25, 0.0], (3, 1)), rtol=0, atol=1e-12)  # all meet at P
    path = tmp_path / "modes.png"
    plot_modes(ev, home, path, model="none", k_a=None, n_modes=2)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
