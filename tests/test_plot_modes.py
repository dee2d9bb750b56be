"""``eigentwist plot modes``: the lowest mode shapes as a GIF for slides, an animated SVG."""

from __future__ import annotations

import re

import numpy as np
import pytest

import eigentwist
from eigentwist.cli.main import main
from eigentwist.plots.animate import mode_frames, modes_svg


def test_gif_frames_move_the_platform(tmp_path, capsys):
    from PIL import Image

    out = tmp_path / "modes.gif"
    assert main(["plot", "modes", "--gif", "-o", str(out), "--k-a", "500", "--modes", "2"]) == 0
    assert "wrote" in capsys.readouterr().out
    im = Image.open(out)
    assert im.format == "GIF" and im.n_frames >= 12
    frames = []
    for k in (0, im.n_frames // 4):  # rest and a quarter period: the largest displacement
        im.seek(k)
        frames.append(np.asarray(im.convert("RGB"), dtype=float))
    assert np.mean(np.abs(frames[0] - frames[1]).sum(axis=-1) > 30) > 0.002


def test_svg_animates_each_mode_between_the_displaced_shapes():
    """The SMIL key frames are the rest shape and +-1 times the displacement, which is the
    eigentwist's v + omega x a_i at each attachment (checked against the evaluator directly)."""
    ev = eigentwist.load("heli4", backend="numpy")
    pose = [0.0, 0.0, -0.625]
    svg = modes_svg(ev, pose, "paper", k_a=2000.0)
    assert svg.count("<animate ") == 3 * (1 + ev.n_legs) and "<script" not in svg and "https:" not in svg
    g, modes = mode_frames(ev, pose, "paper", k_a=2000.0)
    m = ev.modes(np.array([pose]), "paper", k_a=2000.0)
    for k, mode in enumerate(modes):
        w = m.eigentwists[0][:, k]
        d = w[3:] + np.cross(w[:3], g.attachment - g.pose)
        scale = 0.2 * g.l2 / np.max(np.linalg.norm(d, axis=1))
        assert np.allclose(mode["displacement"], scale * d, atol=1e-12)
        assert mode["freq_hz"] == pytest.approx(m.freq_hz[0, k], rel=1e-12)
    assert re.search(r"mode 1: [\d.]+ Hz, mostly", svg)


def test_bad_options_are_one_line_errors(capsys):
    assert main(["plot", "modes", "--modes", "0"]) == 2
    assert "--modes 0" in capsys.readouterr().err
