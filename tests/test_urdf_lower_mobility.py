"""A lower-mobility platform whose legs are in URDF form: ``tests/descriptions/prs3_urdf.py``.

The gallery's 3-PRS with its legs written as serial chains (``SerialLeg``), which name no
closures: the platform's followers (x, y, rot_z) come from the legs' loop closures, solved
together with the joint coordinates. Checked at the home pose and three random poses:

- against its closed-form twin (``examples/robots/prs3.py``, followers from its legs' named
  closures): the completed poses to 1e-12 m/rad, the rigid model's M and K on the allowed
  twists and the frequencies to 1e-10 relative, three modes (the platform's freedoms);
- against Pinocchio (``tests/pinocchio_model.py``: each leg a Pinocchio tree whose closure
  Pinocchio solves itself; E the null space of its legs' constraint rows): E^T M E,
  E^T K_R E and the frequencies to 1e-8 relative;
- d f / d L (the rods' length moves the followers and every joint) against central
  differences of the frequencies to 1e-6 relative;
- a pose the rods cannot reach is unreachable, its followers unsolved.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

import eigentwist  # noqa: E402
from eigentwist.runtime.errors import UnreachablePoseError  # noqa: E402
from scipy.linalg import null_space  # noqa: E402

from .conftest import random_poses  # noqa: E402
from .pinocchio_model import PinocchioRobot, eigen_frequencies, from_description, rotation_vector_matrix  # noqa: E402

HERE = Path(__file__).resolve().parent
URDF = HERE / "descriptions" / "prs3_urdf.py"
TWIN = HERE.parent / "examples" / "robots" / "prs3.py"


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module")
def pair():
    ev = eigentwist.load(str(URDF), backend="numpy", progress=None)
    twin = eigentwist.load(str(TWIN), backend="numpy", progress=None)
    poses = np.vstack([ev.robot.x_ref, random_poses(ev.robot, 3, seed=31)])
    return ev, twin, poses


@pytest.mark.derives
def test_urdf_legs_give_the_followers_of_the_closed_form_twin(pair):
    ev, twin, poses = pair
    full, full_twin = np.asarray(ev.completion.poses(poses)), np.asarray(twin.completion.poses(poses))
    np.testing.assert_allclose(full, full_twin, rtol=0, atol=1e-12)
    assert np.abs(full[1:, :2]).min() > 1e-4  # the followers x, y move off home (m): a real test
    (M, K), (Mt, Kt) = ev.stiffness(poses, "none"), twin.stiffness(poses, "none")
    assert M.shape == (len(poses), 3, 3)
    assert _rel(M, Mt) < 1e-10 and _rel(K, Kt) < 1e-10
    f, ft = ev.frequencies(poses, "none"), twin.frequencies(poses, "none")
    assert f.shape == (len(poses), 3) and f.min() > 100.0  # three modes, no spurious zero
    assert np.max(np.abs(f / ft - 1)) < 1e-10


@pytest.mark.derives
def test_a_closed_form_leg_beside_urdf_legs(pair):
    """Leg 1 in closed form (its IK and its closure named), legs 2 and 3 in URDF form: the
    twin's followers, joints and frequencies."""
    from .descriptions import prs3_urdf

    ev, twin, poses = pair
    mixed = eigentwist.load(prs3_urdf.describe("prs3_mixed", closed_form=(0,)), backend="numpy", progress=None)
    full_mixed, full_twin = np.asarray(mixed.completion.poses(poses)), np.asarray(twin.completion.poses(poses))
    np.testing.assert_allclose(full_mixed, full_twin, rtol=0, atol=1e-12)
    q = mixed.joint_angles(poses)  # (N, legs, 2): leg 1's slider height and its padded 0
    np.testing.assert_allclose(q[:, 0], np.c_[twin.joint_angles(poses)[:, 0, 0], 0 * poses[:, 0]], atol=1e-12)
    np.testing.assert_allclose(q[:, 1:], ev.joint_angles(poses)[:, 1:], atol=1e-12)
    f, ft = mixed.frequencies(poses, "none"), twin.frequencies(poses, "none")
    assert np.max(np.abs(f / ft - 1)) < 1e-10


@pytest.mark.derives
def test_urdf_lower_mobility_equals_pinocchio(pair):
    ev, _, poses = pair
    p = dict(ev.defaults)
    full = np.asarray(ev.completion.poses(poses))
    pr = PinocchioRobot(from_description(ev.robot, p, ev.joint_angles(ev.robot.x_ref)[0], full[0]))
    mats, f_et = ev.matrices(poses, "none"), ev.frequencies(poses, "none")
    worst = {"M": 0.0, "K_R": 0.0, "f": 0.0}
    for k, pose in enumerate(full):
        rigid = pr.matrices(pose[:3], rotation_vector_matrix(pose[3:6]), c_act=[1 / p["k_a"]] * 3, stiffness="actuated")
        rows = np.vstack([st["G"][leg.virtual] for leg, st in zip(pr.legs, rigid["states"])])
        E = null_space(rows)
        assert E.shape[1] == 3
        M, K = E.T @ rigid["M"] @ E, E.T @ rigid["K"] @ E
        worst["M"] = max(worst["M"], _rel(E.T @ mats["M"][k] @ E, M))
        worst["K_R"] = max(worst["K_R"], _rel(E.T @ mats["K_R"][k] @ E, K))
        worst["f"] = max(worst["f"], float(np.max(np.abs(f_et[k] / eigen_frequencies(M, K) - 1))))
    print(f"prs3_urdf: max relative deviation from Pinocchio {worst}")
    assert max(worst.values()) < 1e-8, worst


@pytest.mark.derives
def test_urdf_lower_mobility_sensitivity(pair):
    ev, _, poses = pair
    x = poses[1:2]
    exact = ev.sensitivities(x, wrt=("L",), model="none")[0, :, 0]
    L = ev.defaults["L"]
    h = 1e-5 * L
    diff = (ev.frequencies(x, "none", L=L + h) - ev.frequencies(x, "none", L=L - h))[0] / (2 * h)
    np.testing.assert_allclose(exact, diff, rtol=1e-6)
    assert np.abs(exact).min() > 1e-3  # Hz/m: the rods' length moves every mode


@pytest.mark.derives
def test_a_pose_the_rods_cannot_reach_is_unreachable(pair):
    ev, twin, poses = pair
    # tilted 2.5 rad about x: leg 1's spherical joint 0.42 m from its column, beyond the rod's 0.40 m
    far = [0.60, 2.5, 0.0]
    for robot in (ev, twin):
        assert robot.pose_status([poses[0], far], "none")["status"].tolist() == ["reachable", "unreachable"]
    full = np.asarray(ev.completion.poses(np.array([far])))
    assert np.isnan(full[0, [0, 1, 5]]).all()  # no closed loop: no followers
    with pytest.raises(UnreachablePoseError, match=r"x, y, rot_z did not converge"):
        ev.frequencies(far, "none")


@pytest.mark.parametrize("commanded, refused", [(("z", "rot_x", "rot_y"), False), (("z", "rot_x"), True)])
def test_loop_closures_must_fix_every_follower(commanded, refused):
    """Each PRS leg's closure has one row more than its coordinates (3 position rows, slider
    and revolute joint): three legs fix three followers, not four."""
    import dataclasses

    from eigentwist.description.pose import LowerMobilityPose
    from eigentwist.errors import DescriptionError
    from eigentwist.symbolic.kinematics import inverse_kinematics, loop_closure

    from .descriptions import prs3_urdf

    robot = dataclasses.replace(prs3_urdf.describe(), pose=commanded, pose_space=LowerMobilityPose(commanded))
    q_all = inverse_kinematics(robot)[2]
    if refused:
        with pytest.raises(
            DescriptionError, match=r"has 4 followers \(x, y, rot_y, rot_z\) and the legs' loop closures fix 3"
        ):
            loop_closure(robot, q_all)
    else:
        assert loop_closure(robot, q_all)[1]["residual"][0] == (3, 3)
