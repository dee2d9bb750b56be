"""The command line as scripts use it: JSON keys, exit codes, one-line errors."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from eigentwist.cli.main import main


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "eigentwist", *args], capture_output=True, text=True)


def test_matrices_json_keys_and_values(capsys):
    assert main(["matrices", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("pose", "k_a", "joint_angles_deg", "M", "K_R", "K_F", "freq_rigid_hz", "freq_flexible_hz",
                "eigentwists_rigid", "eigentwists_flexible"):
        assert key in out
    assert np.shape(out["M"]) == (6, 6) and np.shape(out["eigentwists_flexible"]) == (6, 6)
    assert np.shape(out["eigentwists_rigid"]) == (3, 3) and len(out["freq_rigid_hz"]) == 3
    assert len(out["joint_angles_deg"]) == 4
    # paper: Eqs. 54 and 59
    assert abs(out["freq_rigid_hz"][0] - 23.5) <= 0.05 and abs(out["freq_flexible_hz"][0] - 20.7) <= 0.05


def test_matrices_options(capsys):
    assert main(["matrices", "--pose", "0.02", "0", "-0.6", "--k-a", "1000", "--set", "l2=0.55", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pose"] == [0.02, 0.0, -0.6] and out["k_a"] == 1000.0


def test_errors_are_one_line_without_traceback():
    r = run_cli("matrices", "--pose", "0", "0", "-3")
    assert r.returncode == 2
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "unreachable" in r.stderr
    r = run_cli("matrices", "--set", "nope=1")
    assert r.returncode == 2 and "nope" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("--debug", "matrices", "--set", "nope=1")
    assert "Traceback" in r.stderr


def test_generate_check_passes_on_fresh_tree():
    r = run_cli("generate", "--check")
    assert r.returncode == 0, r.stdout + r.stderr


def test_generate_check_names_stale_files(tmp_path, monkeypatch, capsys):
    import eigentwist.codegen.generate as gen

    monkeypatch.setattr(gen, "GENERATED", tmp_path)
    (tmp_path / "heli4_numpy.py").write_text("# stale\n")
    from eigentwist.cli import generate as gcli

    monkeypatch.setattr(gcli, "__name__", gcli.__name__)
    import eigentwist.codegen.generate as g2

    files = g2.render_all(["heli4"])
    assert set(g2.stale(files, tmp_path)) == set(files) and "heli4_numpy.py" in files
    g2.write(files, tmp_path)
    assert g2.stale(files, tmp_path) == []


def test_reproduce_main_job(capsys):
    assert main(["reproduce"]) == 0
    out = capsys.readouterr().out
    assert "Eq. 58 K_F" in out and "Table E.2" in out and "within print rounding" in out
