"""One ``--set NAME=VALUE`` (and ``NAME@N=VALUE``) for every command that
evaluates the model; ``--model PRESET:NAME=VALUE``; the values used shown in every output;
precedence CSV column > --set > the robot's default."""

from __future__ import annotations

import json

import numpy as np
import pytest

from eigentwist.cli.common import CliError, parse_sets
from eigentwist.cli.main import main

# their fixtures are diagnoses of 7-11 s: make test, not make test-fast
pytestmark = pytest.mark.slow


def run_json(capsys, *argv) -> dict:
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def changed(out: dict) -> dict:
    return {p["name"]: (p["value"], p["source"]) for p in out["parameters"] if p["differs"]}


# ------------------------------------------------------------------ the parser
def test_parse_sets_accepts_per_leg_spelling():
    assert parse_sets(["l2=0.60", "eta_a@3=0.5", "k_t@01=9e3"]) == {"l2": 0.6, "eta_a@3": 0.5, "k_t@1": 9000.0}


@pytest.mark.parametrize(
    "item, words",
    [
        ("l2", "expected NAME=VALUE"),
        ("=0.5", "expected NAME=VALUE"),
        ("l2=abc", "not a number"),
        ("l2=nan", "not finite"),
        ("eta_a@0=0.5", "leg '0' is not a leg number"),
        ("eta_a@x=0.5", "leg 'x' is not a leg number"),
        ("eta_a@-1=0.5", "is not a leg number"),
        ("2l=0.5", "is not a parameter name"),
    ],
)
def test_parse_sets_rejects_malformed_items(item, words):
    with pytest.raises(CliError, match=words):
        parse_sets([item])


def test_parse_sets_rejects_a_name_given_twice():
    with pytest.raises(CliError, match="already set"):
        parse_sets(["l2=0.5", "l2=0.6"])


@pytest.mark.parametrize(
    "argv",
    [
        ["compare", "paper"],
        ["diagnose", "paper", "--add", "ee_compliance"],
        ["matrices"],
        ["synth", "--truth", "paper", "--k-a", "500"],
        ["report", "-o", "r.html"],
        ["sweep", "--grid", "1", "1", "1", "-o", "sw"],
    ],
)
def test_every_evaluating_command_accepts_set_and_names_an_unknown_parameter(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main([*argv, "--set", "l3=0.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "unknown parameter 'l3'" in err and "did you mean l" in err


# ------------------------------------------------------------- used values shown
def test_compare_set_changes_the_prediction_and_is_shown(capsys):
    base = run_json(capsys, "compare", "paper", "--model", "rigid")
    out = run_json(capsys, "compare", "paper", "--model", "rigid", "--set", "l2=0.60")
    assert out["rms_pct"] != pytest.approx(base["rms_pct"])
    assert changed(out) == {"l2": (0.6, "given")} and changed(base) == {}
    row = next(p for p in out["parameters"] if p["name"] == "l2")
    assert row["default"] == 0.53 and row["unit"] == "m"
    assert main(["compare", "paper", "--model", "rigid", "--set", "l2=0.60"]) == 0
    assert "l2 = 0.6 m (default 0.53, given)" in capsys.readouterr().out


def test_model_accepts_the_truth_syntax(capsys):
    a = run_json(capsys, "compare", "paper", "--model", "paper:l2=0.60")
    b = run_json(capsys, "compare", "paper", "--model", "paper", "--set", "l2=0.60")
    assert a["rms_pct"] == b["rms_pct"] and changed(a) == {"l2": (0.6, "given")}
    c = run_json(capsys, "compare", "paper", "--model", "rigid,payload_mass:m_p=0.5")
    assert c["model"] == ["actuator_loss", "payload_mass"] and changed(c) == {"m_p": (0.5, "given")}
    assert main(["compare", "paper", "--model", "paper:l2=0.6", "--set", "l2=0.5"]) == 2
    assert "give it once" in capsys.readouterr().err


def test_matrices_json_parameters(capsys):
    out = run_json(capsys, "matrices", "--set", "l2=0.55", "--model", "rigid,payload_mass", "--set", "m_p=0.5")
    assert changed(out) == {"l2": (0.55, "given"), "m_p": (0.5, "given")}


def test_per_leg_value_reaches_the_evaluator(capsys):
    """The parser passes ``eta_a@3`` on by that name; the evaluator decides whether it knows it."""
    code = main(["matrices", "--set", "eta_a@3=0.5", "--json"])
    captured = capsys.readouterr()
    if code == 0:  # per-leg values implemented in the evaluator
        assert changed(json.loads(captured.out))["eta_a@3"] == (0.5, "given")
    else:
        assert code == 2 and "eta_a@3" in captured.err and len(captured.err.strip().splitlines()) == 1


def test_precedence_csv_column_then_set_then_default(tmp_path, capsys, ev):
    path = tmp_path / "d.csv"
    path.write_text("k_a,mode,freq_hz,l2\n1000,x,15,0.55\n2000,x,20,\n")
    out = run_json(capsys, "compare", str(path), "--model", "rigid", "--set", "l2=0.60")
    pred = [r["predicted_hz"] for r in out["rows"]]
    direct = [ev.frequencies(ev.robot.x_ref, "rigid", k_a=k, l2=l2)[0, 0] for k, l2 in ((1000.0, 0.55), (2000.0, 0.60))]
    assert np.allclose(pred, direct, rtol=1e-12)
    row = next(p for p in out["parameters"] if p["name"] == "l2")
    assert row["source"] == "data column" and row["value"] is None and row["range"] == [0.55, 0.6]


def test_diagnose_set_gives_the_model_values(capsys):
    out = run_json(capsys, "diagnose", "paper", "--set", "l2=0.60", "--add", "ee_compliance")
    base = run_json(capsys, "diagnose", "paper", "--add", "ee_compliance")
    assert out["baseline"]["rms_pct"] != pytest.approx(base["baseline"]["rms_pct"])
    rows = {p["name"]: p for p in out["parameters"]}
    assert rows["l2"]["value"] == 0.6 and rows["l2"]["source"] == "given"
    assert rows["k_E_rot"]["source"] == "fitted"
    assert main(["diagnose", "paper", "--set", "l2=0.60"]) == 0
    out = capsys.readouterr().out
    assert "l2 = 0.6 m (default 0.53, given)" in out.split("\n\n")[0] + out.split("\n\n")[1]


def test_diagnose_set_is_the_start_of_a_fitted_parameter(monkeypatch, ev):
    """``fit`` starts a fitted parameter at its given (``--set``) value, not the default."""
    import importlib

    import scipy.optimize

    from eigentwist.diagnose import paper_measurements

    fitmod = importlib.import_module("eigentwist.diagnose.fit")

    starts = []
    real = scipy.optimize.least_squares

    def spy(fun, x0, **kwargs):
        starts.append(np.exp(x0))
        return real(fun, x0, **kwargs)

    monkeypatch.setattr(scipy.optimize, "least_squares", spy)  # fit() imports it where it runs
    fitmod.fit(
        paper_measurements(ev),
        ("actuator_loss", "ee_compliance", "rod_compliance"),
        ev,
        ("k_E_rot",),
        fixed={"k_E_rot": 321.0},
        explore=(),
    )
    assert starts[0][0] == pytest.approx(321.0)


def test_synth_set_reaches_the_truth(capsys, tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["synth", "--truth", "paper", "--k-a", "500", "--noise", "0", "-o", str(a)]) == 0
    assert main(["synth", "--truth", "paper", "--k-a", "500", "--noise", "0", "--set", "l2=0.60", "-o", str(b)]) == 0
    assert "l2 = 0.6 m (default 0.53, given)" in capsys.readouterr().out
    assert a.read_text() != b.read_text()


def test_report_table_shows_the_used_values(capsys, tmp_path):
    html = tmp_path / "r.html"
    assert main(["report", "--set", "l2=0.60", "-o", str(html)]) == 0
    text = html.read_text()
    cell = text[text.index("<code>l2</code>") :].split("</tr>")[0]
    assert ">0.6 " in cell and "default 0.53" in cell and ">0.53<" not in cell
