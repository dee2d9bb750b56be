"""The compare / diagnose / synth commands as scripts use them: JSON keys, plots, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from eigentwist.cli.main import main


def run_main(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.slow  # > ~8 s: make test, not make test-fast
def test_diagnose_json_keys(capsys):
    code, out, _ = run_main(capsys, "diagnose", "paper", "--json")
    assert code == 0
    d = json.loads(out)
    for key in ("baseline", "ranking", "selected", "steps", "final", "next_measurement"):
        assert key in d
    assert {"effects", "rms_pct", "max_pct"} <= set(d["baseline"])
    for c in d["ranking"]:
        assert {
            "effect",
            "params",
            "param_std",
            "rms_pct",
            "max_pct",
            "aicc",
            "p_value",
            "indistinguishable_from",
        } <= set(c)
        assert isinstance(c["indistinguishable_from"], list)
    for s in d["steps"]:
        assert {"effects", "rms_pct", "max_pct"} <= set(s)
    assert {"effects", "rms_pct", "max_pct", "explained"} <= set(d["final"])
    assert isinstance(d["final"]["explained"], bool)
    assert d["baseline"]["effects"] == ["actuator_loss"] and round(d["baseline"]["rms_pct"], 1) == 13.6
    assert d["ranking"][0]["effect"] == "ee_compliance" and d["selected"][0] == "ee_compliance"
    assert d["steps"][0]["effects"] == ["actuator_loss"] and d["final"]["rms_pct"] < 5
    assert d["selected"] == ["ee_compliance", "servo_damping"]  # damped frequencies: the servo damping
    assert {"pose", "k_a", "mode", "between"} <= set(d["next_measurement"])
    # ties at every step and at the end, plausibility, outliers, the stated uncertainty
    for c in d["ranking"]:
        assert isinstance(c["plausible"], bool) and set(c["plausible_range"]) == set(c["params"])
        assert all(len(r) == 2 and r[0] <= r[1] for r in c["plausible_range"].values())
    assert all(isinstance(s["alternatives"], list) for s in d["steps"])
    assert d["steps"][1]["alternatives"] == ["ee_coupling"]
    assert d["final"]["alternatives"] == [["actuator_loss", "ee_coupling", "servo_damping"]]
    assert d["outliers"] == []  # the k_a = 125 rows are a pattern
    assert d["uncertainty"]["verdict"] in (
        "consistent",
        "understated",
        "overstated",
        "too few rows",
        "cannot be judged",
    )
    assert d["uncertainty"]["birge_ratio"] == pytest.approx((d["final"]["chi2"] / d["final"]["dof"]) ** 0.5)
    # the damping the data support, and the measurement that separates the lag that fits as well
    s = d["answer"]["damping_support"]
    assert [x["effect"] for x in s["supported"]] == ["servo_damping"]
    assert {x["effect"] for x in s["not_supported"]} == {"servo_delay", "structural_loss"}
    assert {"pose", "k_a", "mode", "quantity", "predicted", "separation_sigma"} <= set(s["measurement"])
    assert d["answer"]["damping"].startswith("Damping supported: servo_damping")


def test_diagnose_text_add_and_plot(capsys, tmp_path):
    png = tmp_path / "steps.png"
    code, out, _ = run_main(capsys, "diagnose", "paper", "--add", "ee_compliance", "--plot", str(png), "--rows")
    assert code == 0
    assert "Effects added by hand" in out and "+ee_compliance" in out and "k_E_rot" in out
    assert "where it fails" in out and "residual pattern" in out and "criteria" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_compare_json_and_plot(capsys, tmp_path):
    png = tmp_path / "fig6.png"
    code, out, _ = run_main(capsys, "compare", "paper", "--model", "rigid", "--json", "--plot", str(png))
    assert code == 0
    d = json.loads(out)
    assert round(d["rms_pct"], 1) == 13.6 and round(d["max_pct"], 1) == 32.9 and len(d["rows"]) == 16
    assert {"measured_hz", "predicted_hz", "error_pct", "error_sigma", "fails"} <= set(d["rows"][0])
    assert png.read_bytes()[:4] == b"\x89PNG"
    code, out, _ = run_main(capsys, "compare", "paper", "--model", "paper")
    assert code == 0 and "RMS error 4.17 %" in out and "FAILS" in out


@pytest.mark.parametrize(
    "args, words",
    [
        (["compare", "{bad}"], "line 1, column 'flux'"),
        (["compare", "{missing}"], "no such file"),
        (["compare", "paper", "--model", "warp"], "warp"),
        (["compare", "paper", "--robot", "nonexistent"], "nonexistent"),
        (["compare", "{rot}", "--model", "rigid"], "no mode along rx"),
        (["diagnose", "paper", "--baseline", "warp"], "warp"),
        (["diagnose", "paper", "--add", "ee_compliance", "--baseline", "paper"], "already in the model"),
        (["diagnose", "paper", "--alpha", "2"], "--alpha"),
        (["synth", "--truth", "paper", "--k-a", "fast"], "not a number"),
        (["synth", "--truth", "paper", "--k-a", "100", "--poses", "0,0"], "X,Y,Z"),
    ],
)
def test_errors_are_one_line(capsys, tmp_path, args, words):
    bad = tmp_path / "bad.csv"
    bad.write_text("k_a,mode,freq_hz,flux\n1000,x,15,1\n")
    rot = tmp_path / "rot.csv"
    rot.write_text("k_a,mode,freq_hz\n1000,rx,150\n")
    args = [a.format(bad=bad, missing=tmp_path / "none.csv", rot=rot) for a in args]
    code, _, err = run_main(capsys, *args)
    assert code == 2 and len(err.strip().splitlines()) == 1 and words in err, err


def test_no_traceback_end_to_end(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("k_a,mode,freq_hz\n1000,x,-15\n")
    r = subprocess.run([sys.executable, "-m", "eigentwist", "diagnose", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "bad.csv, line 2, column 'freq_hz': negative value" in r.stderr


@pytest.mark.parametrize("command", ["compare", "diagnose", "synth"])
def test_help_explains_inputs_with_units_and_examples(capsys, command):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    out = capsys.readouterr().out
    assert "N m/rad" in out and "example" in out and "--robot" in out
    if command != "synth":
        assert "sigma_hz" in out and "Hz" in out and "mode" in out


def test_other_robot(capsys, tmp_path):
    data = tmp_path / "delta.csv"
    code, _, _ = run_main(
        capsys,
        "synth",
        "--robot",
        "delta",
        "--truth",
        "rigid+transmission_compliance:k_t=3000",
        "--k-a",
        "125,500,2000,4000",
        "--poses",
        "0,0,-0.75 0.1,0,-0.7",
        "--seed",
        "2",
        "-o",
        str(data),
    )
    assert code == 0
    code, out, _ = run_main(capsys, "diagnose", str(data), "--robot", "delta", "--json")
    assert code == 0
    d = json.loads(out)
    assert d["robot"] == "delta" and d["selected"][:1] == ["transmission_compliance"] and d["final"]["explained"]
    code, _, err = run_main(capsys, "compare", "paper", "--robot", "delta")
    assert code == 2 and "no shipped measurements" in err
