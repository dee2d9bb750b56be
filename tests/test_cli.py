"""The command line as scripts use it: JSON keys, exit codes, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from eigentwist.cli.main import main


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "eigentwist", *args], capture_output=True, text=True)


def test_matrices_json_keys_and_values(capsys):
    assert main(["matrices", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in (
        "pose",
        "k_a",
        "joint_angles_deg",
        "M",
        "K_R",
        "K_F",
        "freq_rigid_hz",
        "freq_flexible_hz",
        "eigentwists_rigid",
        "eigentwists_flexible",
    ):
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


@pytest.mark.derives
@pytest.mark.derives
def test_generate_check_passes_on_fresh_tree(monkeypatch, capsys, rendered):
    # the command's path for one robot on the checked-in tree, with this run's render of the
    # Heli4 (conftest ``rendered``: rendering again would only repeat tests/test_generated.py)
    import eigentwist.codegen.generate as gen

    heli4 = {k: v for k, v in rendered.items() if k.startswith("heli4_")}
    monkeypatch.setattr(
        gen, "render_all", lambda robots, **kw: heli4 if list(robots) == ["heli4"] else pytest.fail(robots)
    )
    assert main(["generate", "--check", "--robot", "heli4"]) == 0, capsys.readouterr()
    assert "up to date" in capsys.readouterr().out


@pytest.mark.derives
def test_generate_check_names_stale_files(tmp_path, monkeypatch, capsys, rendered):
    import eigentwist.codegen.generate as gen

    monkeypatch.setattr(gen, "GENERATED", tmp_path)
    (tmp_path / "heli4_numpy.py").write_text("# stale\n")
    from eigentwist.cli import generate as gcli

    monkeypatch.setattr(gcli, "__name__", gcli.__name__)
    import eigentwist.codegen.generate as g2

    files = {k: v for k, v in rendered.items() if k.startswith("heli4_")}  # = g2.render_all(["heli4"]): conftest
    assert set(g2.stale(files, tmp_path)) == set(files) and "heli4_numpy.py" in files
    g2.write(files, tmp_path)
    assert g2.stale(files, tmp_path) == []


def test_reproduce_main_job(capsys):
    assert main(["reproduce"]) == 0
    out = capsys.readouterr().out
    assert "Eq. 58 K_F" in out and "Table E.2" in out and "within print rounding" in out


# ------------------------------------------ what the commands print: frequencies, pipes, errors, warnings
def test_matrices_rigid_prints_the_frequencies_of_its_printed_matrices():
    """The rigid model's frequencies are those of the printed M, K_R (3x3 translational
    subsets), and the output says so; no flexible frequencies of another model."""
    from eigentwist.runtime.eigen import frequencies_hz, generalized_eigh

    r = run_cli("matrices", "--model", "rigid", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    M, K_R = np.array(out["M"]), np.array(out["K_R"])
    expected = frequencies_hz(generalized_eigh(K_R[None, 3:, 3:], M[None, 3:, 3:])[0])[0]
    assert out["kind"] == "rigid" and np.allclose(out["freq_hz"], expected, rtol=1e-9)
    assert "3x3 translational" in out["frequencies_from"]
    K_F = np.array(out["K_F"])
    flex = frequencies_hz(generalized_eigh(K_F[None], M[None])[0])[0]
    assert np.allclose(out["freq_flexible_hz"], flex, rtol=1e-9)  # of the printed K_F, not the paper model's
    text = run_cli("matrices", "--model", "rigid").stdout.replace("\n  ", " ")  # lines wrap at 100 columns
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("natural frequencies of this"))
    line = " ".join([lines[k]] + [ln.strip() for ln in lines[k + 1 : k + 3] if ln.startswith("  ")])  # wrapped
    assert "rigid model (from M and K_R, 3x3 translational subsets)" in line
    assert ", ".join(f"{f:.3f}" for f in expected) in line


def test_matrices_flexible_prints_its_own_frequencies():
    out = json.loads(run_cli("matrices", "--json").stdout)
    assert out["kind"] == "flexible" and out["freq_hz"] == pytest.approx(out["freq_flexible_hz"], rel=1e-9)


@pytest.mark.slow  # > ~8 s: make test, not make test-fast
def test_piping_into_head_is_no_error():
    """``eigentwist compare paper | head -1``: the reader has gone when the output comes
    (the command's output goes through the CLI's one writer, whichever command it is)."""
    import os

    read, write = os.pipe()
    os.close(read)  # deterministic: every write meets a closed pipe
    try:
        r = subprocess.run(
            [sys.executable, "-m", "eigentwist", "compare", "paper", "--model", "rigid"],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
        )
    finally:
        os.close(write)
    assert r.returncode == 0 and "Broken pipe" not in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert r.stderr == ""


def test_c_backend_without_compiler_is_one_line(tmp_path):
    import os

    env = {**os.environ, "CC": str(tmp_path / "no-such-cc"), "EIGENTWIST_CACHE": str(tmp_path)}
    r = subprocess.run(
        [sys.executable, "-m", "eigentwist", "matrices", "--backend", "c"], capture_output=True, text=True, env=env
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip()] and "no C compiler found" in r.stderr


@pytest.mark.parametrize(
    "argv, hint",
    [
        (["compare", "paper", "--model", "rigid,rod_complience"], "did you mean rod_compliance?"),
        (["compare", "paper", "--model", "papr"], "did you mean paper?"),
        (["matrices", "--set", "E_rdo=1e11"], "did you mean E_rod?"),
        (["compare", "paper", "--robot", "heli5"], "did you mean heli4?"),
        (["synth", "--truth", "paper+payload_mas", "--k-a", "500"], "did you mean payload_mass?"),
        (["synth", "--truth", "paper", "--k-a", "500", "--modes", "xx"], "did you mean x?"),
    ],
)
def test_typos_suggest_the_closest_name(argv, hint, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and hint in err, err


def test_pose_outside_the_workspace_box_warns(capsys):
    assert main(["matrices", "--pose", "0.12", "0", "-0.6"]) == 0
    err = capsys.readouterr().err
    assert "outside heli4's documented workspace box" in err and "x in [-0.1, 0.1]" in err
    assert main(["matrices", "--pose", "0.05", "0", "-0.6"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_unreachable_pose_says_which_heights_are_reachable(capsys, ev):
    assert main(["matrices", "--pose", "0", "0", "-3"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "reachable, non-singular heights are z in [" in err
    lo, hi = (float(v) for v in err.split("z in [")[1].split("]")[0].split(","))
    assert lo < -0.70 and hi > -0.55  # the workspace box lies inside
    assert ev.valid([[0, 0, lo + 1e-3], [0, 0, hi - 1e-3]]).all()
    assert not ev.valid([[0, 0, lo - 1e-3], [0, 0, hi + 1e-3]]).any()


@pytest.mark.compiled
def test_first_c_compile_says_so(tmp_path):
    import os

    from eigentwist.runtime import ccompile

    try:
        ccompile.find_compiler()
    except ccompile.CompilerNotFoundError as exc:
        pytest.skip(f"compiled tier skipped: {exc}")
    # the messages, not the optimiser, are under test: a compiler that builds at -O0 (the
    # flags' last -O wins) takes seconds instead of gcc -O3's ten
    cc = tmp_path / "cc-O0"
    cc.write_text(f'#!/bin/sh\nexec "{ccompile.find_compiler()}" "$@" -O0\n')
    cc.chmod(0o755)
    env = {**os.environ, "EIGENTWIST_CACHE": str(tmp_path / "cache"), "CC": str(cc)}
    cmd = [sys.executable, "-m", "eigentwist", "matrices", "--backend", "c", "--json"]
    first = subprocess.run(cmd, capture_output=True, text=True, env=env)
    assert first.returncode == 0 and "compiling heli4_c" in first.stderr
    assert first.stderr.count("\n") == 1 or all("compiling" in ln for ln in first.stderr.splitlines())
    again = subprocess.run(cmd, capture_output=True, text=True, env=env)
    assert again.returncode == 0 and "compiling" not in again.stderr


def test_every_command_defaults_to_the_backend_of_load(monkeypatch, capsys):
    """--backend defaults to auto (as eigentwist.load), or to EIGENTWIST_BACKEND; a bad value
    is one error line naming it and the variable."""
    import argparse

    from eigentwist.cli.main import build_parser

    def defaults():
        sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
        return {
            name: next((a.default for a in parser._actions if "--backend" in a.option_strings), None)
            for name, parser in sub.choices.items()
        }

    monkeypatch.delenv("EIGENTWIST_BACKEND", raising=False)
    found = {name: d for name, d in defaults().items() if d is not None}
    assert {"diagnose", "compare", "matrices", "report", "reproduce", "sweep", "optimize"} <= set(found)
    assert set(found.values()) == {"auto"}, found
    monkeypatch.setenv("EIGENTWIST_BACKEND", "numpy")
    assert set(d for d in defaults().values() if d is not None) == {"numpy"}
    assert build_parser().parse_args(["reproduce"]).backend == "numpy"
    monkeypatch.setenv("EIGENTWIST_BACKEND", "cuda")
    with pytest.raises(SystemExit):
        build_parser().parse_args(["reproduce"])
    assert "unknown backend 'cuda' (from EIGENTWIST_BACKEND)" in capsys.readouterr().err


PROCESS_STATE = """
import contextlib, gc, io, os, sys
from eigentwist.cli.main import main
sys.argv = ["eigentwist", "matrices", "--json"]
with contextlib.redirect_stdout(io.StringIO()):
    main()
from threadpoolctl import threadpool_info
blas = [i["num_threads"] for i in threadpool_info() if i.get("internal_api") == "openblas"]
print(os.environ.get("OPENBLAS_NUM_THREADS"), min(blas) if blas else "none", gc.get_freeze_count() > 0)
"""


@pytest.mark.parametrize("given", [None, "2"])
def test_a_commands_own_process_runs_blas_on_one_thread_and_freezes_its_start_up_objects(given):
    import os

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given:
        env["OPENBLAS_NUM_THREADS"] = given  # the user's choice wins
    out = subprocess.run(
        [sys.executable, "-c", PROCESS_STATE], env=env, capture_output=True, text=True, check=True
    ).stdout.split()
    want = given or "1"
    assert out[0] == want and out[2] == "True"
    assert out[1] in ("none", want)  # OpenBLAS's threads where NumPy links it


def test_main_called_with_arguments_leaves_its_process_as_it_is(capsys, monkeypatch):
    import gc
    import os

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    frozen = gc.get_freeze_count()
    assert main(["matrices", "--json"]) == 0
    assert "OPENBLAS_NUM_THREADS" not in os.environ and gc.get_freeze_count() <= frozen  # nothing frozen anew
