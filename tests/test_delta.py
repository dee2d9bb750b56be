"""The Delta robot from a description alone: symmetry and full rank."""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist

from .conftest import random_poses, workspace_grid


@pytest.fixture(scope="module")
def delta():
    return eigentwist.load("delta", backend="numpy")


@pytest.mark.parametrize("z", [-0.65, -0.75, -0.9])
def test_horizontal_frequencies_equal_on_the_central_axis(delta, z):
    for model in ("rigid", "paper"):
        f = delta.frequencies([0.0, 0.0, z], model)[0]
        assert f[1] == pytest.approx(f[0], rel=1e-9)


def test_rotation_by_120_degrees_leaves_frequencies_unchanged(delta):
    phi = 2 * np.pi / 3
    Rz = np.array([[np.cos(phi), -np.sin(phi), 0], [np.sin(phi), np.cos(phi), 0], [0, 0, 1]])
    poses = random_poses(delta.robot, 8, seed=12)
    for model in ("rigid", "paper"):
        f = delta.frequencies(poses, model)
        np.testing.assert_allclose(delta.frequencies(poses @ Rz.T, model), f, rtol=1e-9)
        np.testing.assert_allclose(delta.frequencies(poses @ Rz, model), f, rtol=1e-9)


def test_flexible_model_full_rank_and_translations_lowest(delta):
    grid = workspace_grid(delta.robot, 3)
    K = delta.matrices(grid, "paper")["K_F"]
    assert np.linalg.eigvalsh(K).min() > 0
    modes = delta.modes(grid, "paper")
    # the three lowest modes are translations: largest eigentwist component in x, y or z
    assert (modes.direction[:, :3] >= 3).all()
    assert (modes.direction[:, 3:] < 3).all()
    assert (modes.freq_hz[:, 2] * 3 < modes.freq_hz[:, 3]).all()


def test_delta_has_no_ee_compliance_effect(delta):
    assert "ee_compliance" not in delta.effects
    with pytest.raises(ValueError, match="ee_compliance"):
        delta.frequencies(delta.robot.x_ref, "rigid,ee_compliance")


def test_diagnosis_finds_hidden_payload_on_delta(delta):
    from eigentwist.diagnose import diagnose, synth

    poses = [[0.0, 0.0, -0.75], [0.12, -0.05, -0.70]]
    meas = synth(
        "paper+payload_mass:m_p=0.25",
        k_a=[250, 500, 1000, 2000, 4000],
        poses=poses,
        modes=("x", "y", "z"),
        noise="0.5%",
        seed=4,
        robot="delta",
        ev=delta,
    )
    d = diagnose(meas, baseline="paper", ev=delta)
    first = d.ranking[0]
    assert first.effect == "payload_mass" or "payload_mass" in first.indistinguishable_from
    pm = next(c for c in d.ranking if c.effect == "payload_mass")
    assert abs(pm.params["m_p"] - 0.25) <= 3 * pm.param_std["m_p"]
    assert "payload_mass" in d.selected and d.explained
    assert d.final.rms_pct < 1.0


@pytest.mark.slow  # > ~8 s: make test, not make test-fast
def test_every_command_takes_robot_delta(tmp_path, capsys):
    import json

    from eigentwist.cli.main import main

    data = tmp_path / "delta.csv"
    assert (
        main(
            [
                "synth",
                "--robot",
                "delta",
                "--truth",
                "paper+payload_mass:m_p=0.2",
                "--k-a",
                "500,2000",
                "--pose",
                "0",
                "0",
                "-0.75",
                "--modes",
                "x,y,z",
                "--seed",
                "1",
                "-o",
                str(data),
            ]
        )
        == 0
    )
    assert main(["matrices", "--robot", "delta", "--json"]) == 0
    out = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert out["robot"] == "delta" and len(out["joint_angles_deg"]) == 3
    assert main(["compare", str(data), "--robot", "delta", "--model", "paper"]) == 0
    assert main(["diagnose", str(data), "--robot", "delta", "--baseline", "paper", "--json"]) == 0
    assert main(["sweep", "--robot", "delta", "--random", "200", "--seed", "2", "-o", str(tmp_path / "sw")]) == 0
    assert main(["report", str(data), "--robot", "delta", "-o", str(tmp_path / "r.html")]) == 0
    assert "Delta" in (tmp_path / "r.html").read_text()
