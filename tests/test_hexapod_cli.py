"""Every command with ``--robot hexapod``: 6-DoF poses on the command line and
in CSV files (columns ``rot_x, rot_y, rot_z``), a hidden payload found by diagnose."""

from __future__ import annotations

import json

import numpy as np
import pytest

import eigentwist
from eigentwist.cli.main import main
from eigentwist.diagnose.measurements import load_measurements
from eigentwist.diagnose.select import diagnose
from eigentwist.diagnose.synth import synth
from eigentwist.runtime.sweep import load_sweep

TILTED = [0.02, -0.03, 0.78, 0.05, -0.04, 0.1]
POSES = "0,0,0.8,0,0,0;0.05,0,0.78,0,0.05,0.1"


def test_matrices_takes_six_coordinates(capsys):
    assert main(["matrices", "--robot", "hexapod", "--pose", *map(str, TILTED), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pose"] == TILTED and out["kind"] == "rigid" and len(out["freq_hz"]) == 6
    assert out["k_a_unit"] == "N/m" and len(out["leg_lengths_m"]) == 6
    f = eigentwist.load("hexapod", backend="numpy").frequencies(TILTED)[0]
    np.testing.assert_allclose(out["freq_hz"], f, rtol=1e-12)


def test_a_three_coordinate_pose_is_refused(capsys):
    assert main(["matrices", "--robot", "hexapod", "--pose", "0", "0", "0.8"]) == 2
    assert "hexapod takes 6 coordinates (x, y, z, rot_x, rot_y, rot_z), got 3" in capsys.readouterr().err


@pytest.mark.slow  # > ~8 s: make test, not make test-fast
def test_sweep_over_a_six_dimensional_box(tmp_path, capsys):
    out = tmp_path / "s.parquet"
    pytest.importorskip("pyarrow")
    box = ["-0.05", "0.05", "-0.05", "0.05", "0.75", "0.85", "-0.05", "0.05", "-0.05", "0.05", "-0.1", "0.1"]
    assert (
        main(
            [
                "sweep",
                "--robot",
                "hexapod",
                "--grid",
                "2",
                "1",
                "2",
                "1",
                "2",
                "1",
                "--box",
                *box,
                "-o",
                str(out),
                "--backend",
                "c",
            ]
        )
        == 0
    )
    import pyarrow.parquet as pq

    table = pq.read_table(out).to_pydict()
    assert {"x", "y", "z", "rot_x", "rot_y", "rot_z", "f6_hz"} <= set(table)
    assert sorted(set(table["rot_y"])) == [-0.05, 0.05] and set(table["rot_z"]) == {0.0}  # one point: mid-box
    poses = np.column_stack([table[c] for c in ("x", "y", "z", "rot_x", "rot_y", "rot_z")])
    f = eigentwist.load("hexapod", backend="numpy").frequencies(poses)
    np.testing.assert_allclose(np.column_stack([table[f"f{k}_hz"] for k in range(1, 7)]), f, rtol=1e-10)
    back = load_sweep(out)
    assert back.columns["pose"].shape == (8, 6) and back.lowest["pose"].shape == (1, 6)


def test_sweep_box_needs_twelve_numbers(tmp_path, capsys):
    assert main(["sweep", "--robot", "hexapod", "--box", "0", "1", "0", "1", "0", "1", "-o", str(tmp_path / "o")]) == 2
    assert "expected twelve finite numbers" in capsys.readouterr().err


def test_synth_writes_rotation_columns_and_compare_reads_them(tmp_path, capsys):
    data = tmp_path / "d.csv"
    assert (
        main(
            [
                "synth",
                "--robot",
                "hexapod",
                "--truth",
                "paper",
                "--k-a",
                "2e7",
                "--poses",
                POSES,
                "--modes",
                "1,2,3",
                "--noise",
                "0",
                "-o",
                str(data),
            ]
        )
        == 0
    )
    header = data.read_text().splitlines()[0].split(",")
    assert header[4:10] == ["x", "y", "z", "rot_x", "rot_y", "rot_z"]
    capsys.readouterr()
    assert main(["compare", "--robot", "hexapod", str(data), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert json.dumps(out).count("FAILS") == 0


def test_diagnose_finds_a_hidden_payload():
    """Truth: the default model plus an 8 kg payload at the platform origin, 0.2 % noise;
    diagnose names payload_mass and fits m_p within its standard error (2 sigma)."""
    ev = eigentwist.load("hexapod", backend="numpy")
    poses = [[0, 0, 0.8, 0, 0, 0], [0.05, 0, 0.78, 0, 0.05, 0.1]]
    meas = synth("paper+payload_mass:m_p=8", [1e7, 2e7], poses, [str(k) for k in range(1, 7)], "0.2%", seed=1, ev=ev)
    d = diagnose(meas, baseline="paper", ev=ev)
    final = d.to_json()["final"]
    assert "payload_mass" in final["effects"]
    m_p, s = final["params"]["m_p"], final["param_std"]["m_p"]
    assert abs(m_p - 8.0) <= 2 * s and s < 0.05 * 8.0


def test_report_draws_the_hexapod(tmp_path, capsys):
    data = tmp_path / "d.csv"
    assert (
        main(
            [
                "synth",
                "--robot",
                "hexapod",
                "--truth",
                "paper",
                "--k-a",
                "1e7,2e7",
                "--poses",
                POSES,
                "--modes",
                "1,2,3,4,5,6",
                "--noise",
                "0.2%",
                "-o",
                str(data),
            ]
        )
        == 0
    )
    html = tmp_path / "r.html"
    assert main(["report", "--robot", "hexapod", str(data), "-o", str(html)]) == 0
    text = html.read_text()
    assert "data:image/png;base64" in text and "Gough-Stewart" in text


def test_csv_rotation_columns_round_trip(tmp_path):
    ev = eigentwist.load("hexapod", backend="numpy")
    meas = synth("paper", [2e7], [TILTED], ["1"], 0.0, ev=ev)
    path = tmp_path / "m.csv"
    meas.to_csv(path)
    again = load_measurements(path, ev=ev)
    np.testing.assert_array_equal(again.poses, [TILTED])


def test_default_model_is_the_bare_strut_stiffness_and_is_named(capsys):
    """The Heli4's measured eta_a = 0.82 is not the hexapod's default: its
    ``paper`` model is k_a alone, and the actuator loss scales every frequency by sqrt(eta_a)
    (omega ~ sqrt(k) when the stiffness is k_a J^T J alone)."""
    assert main(["matrices", "--robot", "hexapod", "--pose", *map(str, TILTED), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["model_name"] == "paper" and out["model"] == []
    ev = eigentwist.load("hexapod", backend="numpy")
    lossy = ev.frequencies(TILTED, "actuator_loss", eta_a=0.82)[0]
    np.testing.assert_allclose(lossy, np.sqrt(0.82) * np.array(out["freq_hz"]), rtol=1e-10)
    assert main(["matrices", "--robot", "hexapod", "--pose", *map(str, TILTED)]) == 0
    text = " ".join(capsys.readouterr().out.split())  # wrapped at 100 columns
    assert "model: paper = (no effect: bare actuator stiffness k_a)" in text
