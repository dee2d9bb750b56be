"""Papercuts a new user met: each one line and to the point, none silent."""

from __future__ import annotations

import inspect
import shlex
import sys

import pytest

import eigentwist
from eigentwist.cli.main import join_negative_percentages, main
from eigentwist.codegen.generate import GENERATED

README = GENERATED.parent.parent / "README.md"


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("eigentwist: compiling")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ------------------------------------------------------------ the modal extra
def test_missing_modal_extra_names_the_install_command(capsys, monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "pyuff", None)  # as if the modal extra were not installed
    code, _, err = run(capsys, "synth", "--truth", "paper", "--k-a", "1000", "--uff", str(tmp_path / "c"))
    assert code == 2
    line = one_error_line(err)
    assert "pip install 'eigentwist[modal]'" in line and "pyuff" in line


def test_identify_without_the_modal_extra(capsys, monkeypatch, tmp_path):
    pytest.importorskip("pyuff")
    code, _, _ = run(
        capsys, "synth", "--truth", "paper", "--k-a", "1000", "--uff", str(tmp_path / "c"), "--dataset", "55"
    )
    assert code == 0
    monkeypatch.setitem(sys.modules, "pyuff", None)
    monkeypatch.setitem(sys.modules, "sdypy", None)
    code, _, err = run(capsys, "identify", str(tmp_path / "c" / "manifest.csv"))
    assert code == 2 and "pip install 'eigentwist[modal]'" in one_error_line(err)


# ----------------------------------------------------------- percentages
def test_damping_error_names_damping(capsys, tmp_path):
    code, _, err = run(
        capsys, "synth", "--truth", "paper", "--k-a", "1000", "--uff", str(tmp_path / "c"), "--damping", "150%"
    )
    line = one_error_line(err)
    assert code == 2 and "damping '150%'" in line and "noise" not in line


def test_zero_sigma_is_refused(capsys):
    code, _, err = run(capsys, "synth", "--truth", "paper", "--k-a", "1000", "--noise", "1%", "--sigma", "0%")
    assert code == 2 and "sigma '0%'" in one_error_line(err)


def test_zero_noise_says_which_sigma_it_writes(capsys):
    code, out, err = run(capsys, "synth", "--truth", "paper", "--k-a", "1000", "--noise", "0%", "--modes", "x")
    line = one_error_line(err)
    assert code == 0 and "--noise 0%" in line and "2 %" in line and "--sigma" in line
    header, row = out.strip().splitlines()
    cells = dict(zip(header.split(","), row.split(",")))
    assert float(cells["sigma_hz"]) == pytest.approx(0.02 * float(cells["freq_hz"]), rel=1e-9)
    code, out, _ = run(
        capsys, "synth", "--truth", "paper", "--k-a", "1000", "--noise", "0%", "--sigma", "1%", "--modes", "x"
    )
    assert code == 0
    header, row = out.strip().splitlines()
    cells = dict(zip(header.split(","), row.split(",")))
    assert float(cells["sigma_hz"]) == pytest.approx(0.01 * float(cells["freq_hz"]), rel=1e-9)


def test_negative_noise_is_named(capsys):
    code, _, err = run(capsys, "synth", "--truth", "paper", "--k-a", "1000", "--noise", "-2%")
    line = one_error_line(err)
    assert code == 2 and "'-2%'" in line and "expected one argument" not in line


def test_only_negative_percentages_are_joined():
    assert join_negative_percentages(["--noise", "-2%"]) == ["--noise=-2%"]
    assert join_negative_percentages(["--sigma", "-0.5%", "x"]) == ["--sigma=-0.5%", "x"]
    pose = ["--pose", "-0.1", "0", "-0.6"]
    assert join_negative_percentages(pose) == pose
    assert join_negative_percentages(["--noise=-2%"]) == ["--noise=-2%"]


# ------------------------------------------------------------ files and names
def test_uff_file_given_to_compare_points_to_identify(capsys, tmp_path):
    path = tmp_path / "setting_01.uff"
    path.write_text("    -1\n    58\nsome FRF\n    -1\n")
    code, _, err = run(capsys, "compare", str(path))
    line = one_error_line(err)
    assert code == 2 and "UFF" in line and "eigentwist identify" in line and "single column" not in line


def test_add_suggests_the_close_effect(capsys):
    code, _, err = run(capsys, "diagnose", "paper", "--add", "actuator_los@2")
    assert code == 2 and "did you mean actuator_loss?" in one_error_line(err)


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"eigentwist {eigentwist.__version__}"


def test_version_and_help_import_no_sympy():
    """``eigentwist --version`` answers before the subcommands, SymPy or NumPy are imported;
    ``--help`` and ``COMMAND --help`` list the commands without SymPy, SciPy or matplotlib."""
    import subprocess
    import sys

    code = (
        "import contextlib, io, sys; from eigentwist.cli.main import main\n"
        "heavy = ('sympy', 'scipy', 'matplotlib', 'numpy')\n"
        "def loaded(): return sorted(m for m in heavy if m in sys.modules)\n"
        "for argv in (['--debug', '--version'], ['--help'], ['diagnose', '--help']):\n"
        "    text = io.StringIO()\n"
        "    with contextlib.redirect_stdout(text):\n"
        "        try:\n            main(argv)\n"
        "        except SystemExit as e:\n            assert e.code == 0\n"
        "    print(argv[-1], text.getvalue().count('diagnose') > 0, loaded())\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == [
        "--version False []",
        "--help True ['numpy']",
        "--help True ['numpy']",
    ]


def test_version_only_before_a_command():
    from eigentwist.cli.main import version_only

    assert version_only(["--version"]) and version_only(["--debug", "--version"])
    assert not version_only(["matrices", "--version"]) and not version_only(["-h", "--version"])
    assert not version_only([])


# ------------------------------------------------------------------ stale text
def test_readme_does_not_say_hexapod_sensitivity_is_missing():
    text = README.read_text()
    assert "Not yet for the hexapod" not in text
    assert "`sensitivity` and `optimize` take\nthe hexapod too" in text


def test_compare_help_says_what_phi_does(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    out = capsys.readouterr().out
    assert "not used yet" not in out and "MAC" in out.split("Separator")[0]


def test_report_help_names_campaign_manifests(capsys):
    with pytest.raises(SystemExit):
        main(["report", "--help"])
    out = capsys.readouterr().out
    assert "MANIFEST.csv" in out and "campaign" in out


def test_matrices_does_not_disown_its_own_frequencies(capsys):
    code, out, _ = run(capsys, "matrices", "--robot", "hexapod")
    assert code == 0 and "not this model's frequencies" not in out
    assert "has the same frequencies here" in out  # K_F = K_R: the numbers are equal
    code, out, _ = run(capsys, "matrices")
    assert code == 0 and "for reference, the rigid model from the printed M and K_R" in out


def test_stabilisation_legend_describes_the_markers():
    from eigentwist.modal import plots

    source = inspect.getsource(plots)
    assert "grey: physical pole" not in source and "grey: pole not yet stable" in source


@pytest.mark.parametrize("command", ["matrices", "synth", "sweep", "sensitivity", "optimize", "diagnose", "compare"])
def test_help_examples_follow_the_robot(capsys, command):
    with pytest.raises(SystemExit):
        main([command, "--robot", "hexapod", "--help"])
    out = capsys.readouterr().out
    block = out.split("examples (hexapod):")[1].split("\n\n")[0]
    assert "-0.625" not in block and "l2=" not in block and "--robot hexapod" in block


def test_hexapod_help_example_runs(capsys):
    with pytest.raises(SystemExit):
        main(["matrices", "--robot", "hexapod", "--help"])
    block = capsys.readouterr().out.split("examples (hexapod):")[1].split("\n\n")[0]
    line = [ln for ln in block.splitlines() if "--json" in ln][0]
    code, out, _ = run(capsys, *shlex.split(line.split("#")[0])[1:])
    assert code == 0 and '"robot": "hexapod"' in out
