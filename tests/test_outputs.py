"""Outputs never replace an input, are written whole or not at all, and replace a file of
another kind only with --force (eigentwist/outputs.py, the commands' -o/--plot/--uff)."""

from __future__ import annotations

import os

import pytest

from eigentwist.cli.main import main
from eigentwist.outputs import OutputError, atomic_path, check_output, file_kind, write_atomic
from eigentwist.runtime.errors import InputError

CSV = "k_a,mode,freq_hz\n500,1,12.5\n"


@pytest.fixture
def data(tmp_path):
    path = tmp_path / "good.csv"
    path.write_text(CSV)
    return path


def _refused(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err, err
    return err


@pytest.mark.parametrize(
    "argv",
    [
        ["report", "{data}", "--baseline", "paper", "-o", "{data}"],
        ["compare", "{data}", "--plot", "{data}"],
        ["diagnose", "{data}", "--plot", "{data}"],
        ["identify", "{data}", "-o", "{data}"],
        ["report", "{data}", "-o", "{link}"],
        ["report", "{data}", "-o", "{hard}", "--force"],  # --force never destroys an input
    ],
)
def test_an_input_is_never_an_output(tmp_path, data, capsys, argv):
    (tmp_path / "link.csv").symlink_to(data)
    os.link(data, tmp_path / "hard.csv")
    argv = [a.format(data=data, link=tmp_path / "link.csv", hard=tmp_path / "hard.csv") for a in argv]
    _refused(capsys, argv, "is the input", str(data))
    assert data.read_text() == CSV


def test_the_robot_description_file_is_an_input_too(tmp_path, capsys):
    robot = tmp_path / "robot.py"
    robot.write_text("def describe():\n    raise SystemExit\n")
    _refused(
        capsys, ["synth", "--robot", str(robot), "--truth", "paper", "--k-a", "500", "-o", str(robot)], "is the input"
    )
    assert robot.read_text().startswith("def describe")


def test_another_kind_is_replaced_only_with_force(tmp_path, capsys):
    png = tmp_path / "figure.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00" * 16)
    argv = ["synth", "--truth", "paper", "--k-a", "500", "--modes", "1", "-o", str(png)]
    _refused(capsys, argv, "png file", "--force")
    assert png.read_bytes().startswith(b"\x89PNG")
    assert main([*argv, "--force"]) == 0
    assert png.read_text().startswith("k_a,mode,freq_hz")
    # a CSV replaces a CSV (re-running a command) without --force
    assert main(argv) == 0


def test_check_output_kinds(tmp_path):
    html, csv, empty = tmp_path / "a.html", tmp_path / "b.csv", tmp_path / "c"
    html.write_text("<!DOCTYPE html>\n<html></html>")
    csv.write_text(CSV)
    empty.write_text("")
    assert [file_kind(p) for p in (html, csv, empty, tmp_path)] == ["html", "text", "empty", "directory"]
    assert check_output(html, "html") == html and check_output(empty, "html") == empty
    with pytest.raises(OutputError, match="text file"):
        check_output(csv, "html")
    assert check_output(csv, "html", force=True) == csv
    with pytest.raises(OutputError, match="html file"):
        check_output(html, "csv")
    with pytest.raises(OutputError, match="a directory"):
        check_output(tmp_path, "image")
    assert check_output(tmp_path / "new.html", "html", inputs=[csv]).name == "new.html"


@pytest.mark.parametrize(
    "head, kind",
    [
        (b"\xef\xbb\xbf \n<!DOCTYPE html>\n<html>", "html"),  # BOM and blank lines first
        (b"<HTML><BODY></BODY></HTML>", "html"),
        (b"<svg xmlns='http://www.w3.org/2000/svg'/>", "svg"),
        (b"<?xml version='1.0'?>\n<svg/>", "svg"),
        (b"<?xml version='1.0'?>\n<root/>", "text"),
        (b"k_a,mode,freq_hz\n<svg\n", "text"),  # a word inside, not its start
        (b"GIF89a...", "gif"),
        (b"%PDF-1.7", "pdf"),
        (b"PK\x03\x04", "zip"),
        (b"PAR1", "parquet"),
        (b"\xff\xd8\xff\xe0", "jpeg"),
        (b"a,b\n\x00\x01", "binary"),
        (b"\xff\xfe\xfa", "binary"),
        (b"x" * 4095 + "\u00e9".encode(), "text"),  # a character cut at byte 4096
        (b"x" * 4096 + b"\x00", "text"),  # only the first 4096 bytes are read
    ],
)
def test_file_kind_from_the_first_bytes(tmp_path, head, kind):
    path = tmp_path / "f"
    path.write_bytes(head)
    assert file_kind(path) == kind


def test_refusals_say_what_and_why(tmp_path):
    data, csv, html = tmp_path / "d.csv", tmp_path / "e.csv", tmp_path / "r.html"
    data.write_text(CSV)
    csv.write_text(CSV)
    html.write_text("<html></html>")
    with pytest.raises(OutputError) as exc:
        check_output(data, "csv", inputs=[None, data])
    assert str(exc.value) == (
        f"-o {str(data)!r} is the input {str(data)!r}: writing there would destroy it; choose another output path"
    )
    with pytest.raises(OutputError) as exc:
        check_output(csv, "html", option="--plot")
    assert str(exc.value) == (
        f"--plot {str(csv)!r} exists and is a text file, not an html output: choose another "
        "path or pass --force to replace it"
    )
    with pytest.raises(OutputError) as exc:
        check_output(html, "csv")
    assert str(exc.value).endswith(
        "exists and is a html file, not a csv output: choose another path or pass --force to replace it"
    )
    with pytest.raises(OutputError, match=r"exists and is a directory, not a image output"):
        check_output(tmp_path, "image")
    with pytest.raises(InputError) as exc:
        check_output(csv, "pdf")
    assert str(exc.value) == "unknown output kind 'pdf': expected one of html, csv, image, directory"


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600)])
def test_a_new_file_gets_the_umasks_mode(tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        path = write_atomic(tmp_path / "new.csv", b"k_a\n")
    finally:
        os.umask(old)
    assert path.read_bytes() == b"k_a\n" and (path.stat().st_mode & 0o777) == mode
    write_atomic(path, "caf\u00e9\n")
    assert path.read_bytes() == "caf\u00e9\n".encode("utf-8")


def test_a_failed_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old\n")
    path.chmod(0o640)
    with pytest.raises(RuntimeError):
        with atomic_path(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert path.read_text() == "old\n" and os.listdir(tmp_path) == ["out.csv"]
    write_atomic(path, "new\n")
    assert path.read_text() == "new\n" and os.listdir(tmp_path) == ["out.csv"]
    assert (path.stat().st_mode & 0o777) == 0o640  # the replaced file's mode is kept


# ------------------------------------------------------------ typed errors on the command line
def test_user_errors_are_one_line_and_bugs_a_traceback(monkeypatch, capsys):
    """An EigentwistError (the user's doing) is one line, exit 2; anything else is a bug:
    its traceback and a line asking for a report, exit 1 (not "error: 'x'")."""
    import eigentwist.cli.matrices as matrices
    from eigentwist.errors import DescriptionError, EigentwistError, InputError

    assert issubclass(EigentwistError, ValueError)  # ``except ValueError`` keeps working
    assert issubclass(InputError, EigentwistError) and issubclass(DescriptionError, EigentwistError)

    def fails(exc):
        def run(args):
            raise exc

        return run

    for exc, code in (
        (InputError("pose 'x': expected a number"), 2),
        (KeyError("x"), 1),
        (ValueError("math domain error"), 1),
    ):
        monkeypatch.setattr(matrices, "run", fails(exc))
        assert main(["matrices"]) == code
        err = capsys.readouterr().err
        if code == 2:
            assert err == "eigentwist matrices: error: pose 'x': expected a number\n"
        else:
            assert "Traceback" in err and type(exc).__name__ in err and "please report" in err.splitlines()[-1]


def test_no_bare_value_error_is_raised_in_the_package():
    """Errors a user can cause are EigentwistError subclasses: no ``raise ValueError(`` left
    (the generated modules raise none either)."""
    import re
    from pathlib import Path

    import eigentwist

    root = Path(eigentwist.__file__).parent
    bare = [
        f"{p.relative_to(root)}:{n}"
        for p in root.rglob("*.py")
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if re.search(r"raise ValueError\(", line)
    ]
    assert bare == [], bare
