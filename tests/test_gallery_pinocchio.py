"""The gallery (examples/robots/) against Pinocchio as an independent engine.

Each gallery robot through the harness of ``tests/pinocchio_model.py`` (legs as Pinocchio
trees, their loop closures solved by Pinocchio's own Newton on its forward kinematics, the
platform a free body, ``crba`` and the frame Jacobians reduced through the loop-closure
velocity map), at 20 random reachable poses: on the platform's allowed twists E, the null
space of Pinocchio's constraint rows (its legs' virtual joints' rows of the velocity map,
from scipy's null_space: no eigentwist code), E^T M E and E^T K_R E equal eigentwist's to
1e-8 relative, and so do the rigid model's frequencies. (The 6x6 M and K_R outside the
allowed twists depend on where each engine puts a leg's twist of restriction, which moves
with the platform in a Pinocchio tree: only the allowed block is the robot's.) A 3-PRS
pose is eigentwist's completed pose (its followers from the legs' closures): Pinocchio's
closure solve, with the virtual joints' rates left free, finds them at zero only if the
followers are right (checked).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

import eigentwist  # noqa: E402
from scipy.linalg import null_space  # noqa: E402

from .conftest import random_poses  # noqa: E402
from .pinocchio_model import PinocchioRobot, eigen_frequencies, from_description, rotation_vector_matrix  # noqa: E402

GALLERY = Path(__file__).resolve().parent.parent / "examples" / "robots"
RTOL = 1e-8
N_POSES = 20


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _virtual_angles(pr, qs) -> list:
    """|angle| (rad) of every leg's virtual joints in Pinocchio's closure solution: zero
    where the platform pose is one the legs allow (a 3-PRS's followers right)."""
    out = []
    for tree, q in zip(pr.legs, qs):
        for j, joint in enumerate(tree.leg.joints):
            if joint.kind == "virtual":
                jid = tree.model.getJointId(f"j{j}")
                out.append(abs(float(q[tree.model.joints[jid].idx_q])))
    return out


#: each leg's actuated-joint stiffness parameter (None: a passive leg), from the robots' specification
#: (shared/mechanisms-spec.md for the legs that differ), not from the descriptions
STIFFNESS = {
    "five_bar": ("k_a", "k_a"),
    "five_bar_tube": ("k_a", "k_a"),
    "rrr_rrr_prr": ("k_r", "k_r", "k_p"),
    "tricept": ("k_a", "k_a", "k_a", None),
}
#: the robots whose platform is a point: its freedoms are the translations it is given
POINT = {"five_bar": (3, 4), "five_bar_tube": (3, 4)}


@pytest.mark.derives  # the gallery's files are generated with SymPy on first use (make test, not test-fast)
@pytest.mark.parametrize(
    "name", ("prs3", "rrr3", "linear_delta", "upu3", "rus6", "five_bar", "rrr_rrr_prr", "tricept", "five_bar_tube")
)
def test_gallery_equals_pinocchio(name):
    ev = eigentwist.load(str(GALLERY / f"{name}.py"), backend="numpy", progress=None)
    p = dict(ev.defaults)
    six = len(ev.robot.pose_space.inputs) > 3
    ref = np.asarray(ev.completion.poses(np.array([ev.robot.x_ref])))[0]
    pr = PinocchioRobot(from_description(ev.robot, p, ev.joint_angles(ev.robot.x_ref)[0], ref if six else ref[:3]))
    c_act = [1 / p[k] if k else 1.0 for k in STIFFNESS.get(name, ("k_a",) * len(ev.robot.legs))]
    poses = random_poses(ev.robot, 3 * N_POSES, seed=21)
    poses = poses[ev.valid(poses, "none")][:N_POSES]
    assert len(poses) == N_POSES
    full = np.asarray(ev.completion.poses(poses))
    mats = ev.matrices(poses, "none")
    f_et = ev.frequencies(poses, "none")
    worst = {"M": 0.0, "K_R": 0.0, "f": 0.0, "virtual_angle": 0.0, "point": 0.0}
    for k, pose in enumerate(full):
        R = rotation_vector_matrix(pose[3:6]) if six else None
        rigid = pr.matrices(pose[:3], R, c_act=c_act, stiffness="actuated")
        rows = np.vstack([st["G"][leg.virtual] for leg, st in zip(pr.legs, rigid["states"])] + [np.zeros((0, 6))])
        if name in POINT:  # a point's freedoms: its translations, which the legs must allow
            E = np.eye(6)[:, POINT[name]]
            worst["point"] = max(worst["point"], float(np.abs(rows @ E).max() / np.abs(rows).max()))
        else:
            E = null_space(rows) if len(rows) else np.eye(6)
        assert E.shape[1] == len(ev.pose_names)
        M, K = E.T @ rigid["M"] @ E, E.T @ rigid["K"] @ E
        f = eigen_frequencies(M, K)
        worst["M"] = max(worst["M"], _rel(M, E.T @ mats["M"][k] @ E))
        worst["K_R"] = max(worst["K_R"], _rel(K, E.T @ mats["K_R"][k] @ E))
        worst["f"] = max(worst["f"], float(np.max(np.abs(f - f_et[k]) / f_et[k])))
        worst["virtual_angle"] = max(worst["virtual_angle"], max(_virtual_angles(pr, rigid["q"]), default=0.0))
    print(f"{name}: max relative deviation from Pinocchio {worst}")
    assert max(worst.values()) < RTOL, f"{name}: relative deviations {worst}"
