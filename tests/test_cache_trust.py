"""One trust rule for the cache: generated files are imported or compiled only from private
directories and only when they match their recorded SHA-256; anything missing, truncated or
altered is regenerated with one line on stderr (eigentwist/runtime/ccompile.py, userfile.py)."""

from __future__ import annotations

import os
import stat

import pytest

import eigentwist.codegen.generate as generate
from eigentwist.robots import get
from eigentwist.runtime import ccompile
from eigentwist.runtime import userfile
from eigentwist.runtime.memo import NewestKept
from eigentwist.runtime.userfile import generated_modules, import_numpy_module

NUMPY = "VALUE = 42\n"
C_SOURCE = "int et_value(void) { return 42; }\n"


@pytest.fixture
def renders():
    """(backends, stages) of each stand-in render, in order."""
    return []


@pytest.fixture
def cache(tmp_path, monkeypatch, renders):
    root = tmp_path / "fresh" / "cache"
    monkeypatch.setenv("EIGENTWIST_CACHE", str(root))
    calls = []

    def render(description, progress=None, backends=None, stages=None, **kw):  # stands in for the SymPy derivation
        calls.append(description.name)
        renders.append((tuple(backends), stages))
        if stages is not None:
            stages.setdefault("model", object())
            if "c" in backends:
                stages["fused"] = object()
        texts = {"numpy": NUMPY, "c": C_SOURCE}
        return {f"{description.name}_{FILES[b]}": texts[b] for b in backends}

    monkeypatch.setattr(generate, "render_robot", render)
    monkeypatch.setattr(userfile, "_STAGES", NewestKept(userfile.STAGES_KEPT))
    return root, calls


FILES = {"numpy": "numpy.py", "c": "c.c"}


def test_each_backend_rendered_when_first_asked_for_from_one_derivation(cache, renders):
    said = []
    directory, texts = generated_modules(get("heli4"), "k4", said.append, backends=("numpy",))
    assert texts == {"heli4_numpy.py": NUMPY} and not (directory / "heli4_c.c").exists()
    assert said[0] == f"generating the evaluators of 'heli4' (first use; cached in {directory})"
    ((backends, stages),) = renders
    assert backends == ("numpy",) and "model" in stages
    _, texts = generated_modules(get("heli4"), "k4", said.append)  # the C source: from the kept stages
    assert said[2] == f"generating the C source of 'heli4' (first use; cached in {directory})"
    assert texts == {"heli4_numpy.py": NUMPY, "heli4_c.c": C_SOURCE}
    assert renders[1][0] == ("c",) and renders[1][1] is stages
    generated_modules(get("heli4"), "k4")
    assert len(renders) == 2  # both cached now
    assert "k4" not in userfile._STAGES  # the C source rendered: nothing more to keep


def test_stages_kept_for_the_newest_descriptions_only(cache, renders):
    keys = [f"s{k}" for k in range(userfile.STAGES_KEPT + 1)]
    for key in keys:
        generated_modules(get("heli4"), key, backends=("numpy",))
    assert list(userfile._STAGES) == keys[1:]
    first, last = renders[0][1], renders[-1][1]
    generated_modules(get("heli4"), keys[0], backends=("c",))  # dropped: derived again
    generated_modules(get("heli4"), keys[-1], backends=("c",))  # kept: reused
    assert renders[-2][1] is not first and renders[-1][1] is last


def _mode(path):
    return stat.S_IMODE(os.stat(path).st_mode)


def test_generated_once_into_private_directories(cache, capsys):
    root, calls = cache
    directory, texts = generated_modules(get("heli4"), "k1")
    assert calls == ["heli4"] and texts == {"heli4_numpy.py": NUMPY, "heli4_c.c": C_SOURCE}
    for level in (root, root / "descriptions", directory):
        assert _mode(level) == 0o700, level
    assert generated_modules(get("heli4"), "k1") == (directory, texts) and calls == ["heli4"]
    assert capsys.readouterr().err == ""
    module = import_numpy_module(texts["heli4_numpy.py"], directory / "heli4_numpy.py")
    assert module.VALUE == 42


@pytest.mark.parametrize("damage", ["truncate", "append code", "delete", "delete digest"])
def test_damaged_file_is_regenerated_not_imported(cache, capsys, damage):
    root, calls = cache
    directory, _ = generated_modules(get("heli4"), "k2")
    path = directory / "heli4_numpy.py"
    if damage == "truncate":
        path.write_text(NUMPY[:5])
    elif damage == "append code":
        path.write_text(NUMPY + "raise SystemExit('planted code ran')\n")
    elif damage == "delete":
        path.unlink()
    else:
        path.with_name(path.name + ".sha256").unlink()
    capsys.readouterr()
    _, texts = generated_modules(get("heli4"), "k2")
    assert calls == ["heli4", "heli4"] and texts["heli4_numpy.py"] == NUMPY and path.read_text() == NUMPY
    err = capsys.readouterr().err.strip().splitlines()
    why = {
        "truncate": "does not match its recorded SHA-256 (truncated or altered)",
        "append code": "does not match its recorded SHA-256 (truncated or altered)",
        "delete digest": "has no recorded SHA-256",
    }
    if damage == "delete":
        assert err == []  # a missing file is simply generated
    else:
        assert err == [f"eigentwist: the cached file {path} {why[damage]}: regenerating it"]


@pytest.mark.parametrize("level", ["root", "descriptions", "leaf", "file"])
def test_nothing_is_read_from_a_place_others_may_write(cache, level):
    root, calls = cache
    directory, _ = generated_modules(get("heli4"), "k3")
    target = {
        "root": root,
        "descriptions": root / "descriptions",
        "leaf": directory,
        "file": directory / "heli4_numpy.py",
    }[level]
    target.chmod(_mode(target) | stat.S_IWOTH)
    with pytest.raises(ccompile.UnsafeCacheError, match="writable by others"):
        generated_modules(get("heli4"), "k3")
    target.chmod(_mode(target) & ~stat.S_IWOTH)
    assert generated_modules(get("heli4"), "k3")[1]["heli4_numpy.py"] == NUMPY and calls == ["heli4"]


def test_read_verified_contract(tmp_path):
    directory = tmp_path / "private"
    directory.mkdir(mode=0o700)
    path = ccompile.write_verified(directory / "kernel.c", b"int x;\n")
    assert ccompile.read_verified(path) == b"int x;\n"
    path.write_bytes(b"int y;\n")  # same length, other bytes
    assert ccompile.read_verified(path) is None
    assert ccompile.read_verified(directory / "absent.c") is None


def test_shipped_files_are_checked_before_import_or_compile(tmp_path, monkeypatch):
    """A generated file of eigentwist/generated is imported or compiled only when it matches
    ``<robot>.sha256`` beside it (written by ``eigentwist generate``): one byte changed, or
    the digest missing, is an error naming the file."""
    from eigentwist.codegen.generate import GENERATED, digests_text

    for robot in ("heli4", "delta", "hexapod"):
        names = [f"{robot}_numpy.py", f"{robot}_c.c", f"{robot}_c.h"]
        want = digests_text({n: (GENERATED / n).read_text(encoding="utf-8") for n in names})
        assert (GENERATED / f"{robot}.sha256").read_text(encoding="utf-8") == want
    for name in ("heli4_numpy.py", "heli4_c.c"):
        path = tmp_path / name
        path.write_bytes((GENERATED / name).read_bytes())
        (tmp_path / "heli4.sha256").write_bytes((GENERATED / "heli4.sha256").read_bytes())
        assert ccompile.read_shipped(path) == path.read_bytes()
        path.write_bytes(path.read_bytes() + b"\n")
        with pytest.raises(ccompile.DamagedFileError) as exc:
            ccompile.read_shipped(path)
        assert str(exc.value) == (
            f"the generated file {path} does not match its recorded SHA-256 (heli4.sha256): "
            "the installation is damaged or edited; reinstall eigentwist, or run `eigentwist "
            "generate` in a source checkout"
        )
        (tmp_path / "heli4.sha256").unlink()
        with pytest.raises(ccompile.DamagedFileError, match=rf"{name} has no recorded SHA-256"):
            ccompile.read_shipped(path)


def test_a_checked_file_is_remembered_by_path_time_and_size(tmp_path):
    """Checked once per process and file version: another file of the same size and time is
    checked on its own."""
    good, bad = tmp_path / "heli4_numpy.py", tmp_path / "heli4_c.c"
    good.write_bytes(b"VALUE = 1\n")
    bad.write_bytes(b"VALUE = 2\n")
    from eigentwist.codegen.generate import digests_text

    (tmp_path / "heli4.sha256").write_text(digests_text({good.name: "VALUE = 1\n", bad.name: "VALUE = 3\n"}))
    os.utime(bad, ns=(good.stat().st_atime_ns, good.stat().st_mtime_ns))
    assert ccompile.read_shipped(good) == b"VALUE = 1\n"
    with pytest.raises(ccompile.DamagedFileError, match="heli4_c.c does not match"):
        ccompile.read_shipped(bad)
