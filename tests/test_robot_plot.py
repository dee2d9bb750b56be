"""The robot picture: legs from the description and the generated IK, any robot."""

from __future__ import annotations

import io

import numpy as np
import pytest

import eigentwist
from eigentwist.plots import mode_displacements, plot_modes, robot_geometry

pytest.importorskip("matplotlib")

POSES = {"heli4": [(0.0, 0.0, -0.625), (0.06, -0.04, -0.6)], "delta": [(0.0, 0.0, -0.75), (0.1, 0.05, -0.7)]}
CASES = [(robot, pose) for robot, poses in POSES.items() for pose in poses]


@pytest.fixture(scope="module", params=sorted(POSES))
def ev(request):
    return eigentwist.load(request.param, backend="numpy")


def _numeric(vec, values):
    import sympy as sp

    m = sp.Matrix(vec)
    return np.array(m.subs({s: values[s.name] for s in m.free_symbols}), dtype=float).ravel()


@pytest.mark.parametrize("k", [0, 1])
def test_geometry_closes_every_leg_as_the_inverse_kinematics_says(ev, k):
    """Base B_i, elbow at l1 along r_i1(q1), attachment P + a_i at l2 from the elbow, sin q3 = (C - B).s / l2."""
    pose = np.array(POSES[ev.robot.name][k])
    g = robot_geometry(ev, pose)
    q = ev.joint_angles(pose)[0]
    values = ev.defaults
    assert len(g.legs) == len(ev.robot.legs)
    for i, leg in enumerate(ev.robot.legs):
        B, s, a = (_numeric(getattr(leg, n), values) for n in ("base", "axis", "attachment"))
        np.testing.assert_allclose(g.base[i], B, atol=1e-12)
        np.testing.assert_allclose(g.attachment[i], pose + a, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(g.elbow[i] - g.base[i]), g.l1, rtol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(g.attachment[i] - g.elbow[i]), g.l2, rtol=1e-9)
        np.testing.assert_allclose((g.attachment[i] - B) @ s, g.l2 * np.sin(q[i, 2]), atol=1e-9)


def test_a_translation_moves_every_attachment_alike(ev):
    g = robot_geometry(ev, ev.robot.x_ref)
    d = mode_displacements(g, [0, 0, 0, 1.0, 0, 0], ("rx", "ry", "rz", "x", "y", "z"))
    np.testing.assert_allclose(d, np.tile([1.0, 0, 0], (len(g.legs), 1)))
    d = mode_displacements(g, [0, 0, 1.0, 0, 0, 0], ("rx", "ry", "rz", "x", "y", "z"))  # rotation about Z
    np.testing.assert_allclose(d, np.cross([0, 0, 1.0], g.offsets))
    d3 = mode_displacements(g, [0, 1.0, 0], ("x", "y", "z"))  # rigid model: 3 entries
    np.testing.assert_allclose(d3, np.tile([0, 1.0, 0], (len(g.legs), 1)))


@pytest.mark.parametrize("robot, pose", CASES)
def test_drawn_legs_end_at_the_ik_attachment_points_and_the_png_decodes(robot, pose):
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    ev = eigentwist.load(robot, backend="numpy")
    fig = plot_modes(ev, pose)
    g = robot_geometry(ev, pose)
    axes3d = [ax for ax in fig.axes if ax.name == "3d"]
    assert len(axes3d) == 3
    for ax in axes3d:
        legs = {
            ln.get_gid(): np.array(ln.get_data_3d()).T
            for ln in ax.get_lines()
            if (ln.get_gid() or "").startswith("leg ")
        }
        assert sorted(legs) == sorted(f"leg {n}" for n in g.legs)
        for i, name in enumerate(g.legs):
            pts = legs[f"leg {name}"]
            np.testing.assert_allclose(pts[0], g.base[i], atol=1e-12)
            np.testing.assert_allclose(pts[1], g.elbow[i], atol=1e-12)
            np.testing.assert_allclose(pts[-1], g.attachment[i], atol=1e-12)
    titles = " ".join(ax.get_title() for ax in axes3d)
    modes = ev.modes(np.array([pose]), "paper")
    for k in range(3):
        assert f"mode {k + 1}: {modes.freq_hz[0, k]:.4g} Hz" in titles
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    assert buf.getvalue()[:8] == b"\x89PNG\r\n\x1a\n"
    img = mpimg.imread(io.BytesIO(buf.getvalue()), format="png")
    assert img.shape[0] > 300 and img.shape[1] > 600 and img.std() > 0.01


def test_no_robot_specific_drawing_code():
    """The drawing module names no robot: everything comes from the description."""
    from pathlib import Path

    import eigentwist.plots.robot as mod

    text = Path(mod.__file__).read_text(encoding="utf-8").lower()
    for word in ("heli4", "delta"):
        assert word not in text
