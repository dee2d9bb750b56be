"""The compiled-code cache under concurrency and damage (compiled tier): two processes
building at once compile once, a damaged library is rebuilt, an unsafe directory is refused."""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import stat
import sys

import pytest

import eigentwist.runtime.ccompile as ccompile

from .conftest import skip_tier

pytestmark = pytest.mark.compiled
SOURCE = "int et_tiny_answer(void) { return 42; }\n"


@pytest.fixture
def cc(tmp_path):
    """A compiler wrapper that logs every compilation (:func:`slow_cc`: one that also takes its time)."""
    return _logging_cc(tmp_path, ":")


@pytest.fixture
def slow_cc(tmp_path):
    """A compiler wrapper that logs every compilation and takes a second over it (widens races)."""
    return _logging_cc(tmp_path, "sleep 1")


def _logging_cc(tmp_path, delay: str):
    try:
        real = ccompile.find_compiler()
    except ccompile.CompilerNotFoundError as exc:
        skip_tier("compiled", str(exc))
    log = tmp_path / "compilations.log"
    wrapper = tmp_path / "bin" / "logging-cc"
    wrapper.parent.mkdir()
    wrapper.write_text(f"""#!/bin/sh
case " $* " in *" -shared "*) echo "$$" >> '{log}'; {delay} ;; esac
exec '{real}' "$@"
""")
    wrapper.chmod(0o755)
    return str(wrapper), log


def _flags():
    return ccompile.flag_sets()[-1][1]


def _build_and_load(cc, directory, barrier, queue):
    barrier.wait()
    path = ccompile.build_library(SOURCE, "tiny", cc, _flags(), directory)
    queue.put((str(path), ctypes.CDLL(str(path)).et_tiny_answer()))


def test_two_processes_compile_once(slow_cc, tmp_path):
    cc, log = slow_cc
    directory = tmp_path / "cache"
    ctx = multiprocessing.get_context("fork" if sys.platform.startswith("linux") else "spawn")
    barrier, queue = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_build_and_load, args=(cc, directory, barrier, queue)) for _ in range(2)]
    for p in procs:
        p.start()
    results = [queue.get(timeout=120) for _ in procs]
    for p in procs:
        p.join(timeout=60)
        assert p.exitcode == 0
    assert len(log.read_text().split()) == 1  # one compilation for both
    assert results[0] == results[1] and results[0][1] == 42
    assert not [p.name for p in directory.iterdir() if p.name.endswith(".tmp") or p.suffix == ".c"]


@pytest.mark.parametrize("damage", ["truncate", "flip", "delete digest"])
def test_damaged_library_is_rebuilt(cc, tmp_path, damage):
    cc, log = cc
    path = ccompile.build_library(SOURCE, "tiny", cc, _flags(), tmp_path / "cache")
    digest = path.with_name(path.name + ".sha256")
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "flip":
        path.write_bytes(data[:100] + bytes([data[100] ^ 0xFF]) + data[101:])
    else:
        digest.unlink()
    again = ccompile.build_library(SOURCE, "tiny", cc, _flags(), tmp_path / "cache")
    assert again == path and len(log.read_text().split()) == 2  # rebuilt
    assert digest.read_text().strip() == ccompile.library_digest(again)
    assert ctypes.CDLL(str(again)).et_tiny_answer() == 42
    ccompile.build_library(SOURCE, "tiny", cc, _flags(), tmp_path / "cache")
    assert len(log.read_text().split()) == 2  # intact now: reused


def test_cache_directory_is_private(cc, tmp_path):
    cc, _ = cc
    directory = tmp_path / "new" / "cache"
    path = ccompile.build_library(SOURCE, "tiny", cc, _flags(), directory)
    assert stat.S_IMODE(os.stat(directory).st_mode) == 0o700
    assert not stat.S_IMODE(os.stat(path).st_mode) & 0o022


@pytest.mark.parametrize("who", ["o+w", "g+w"])
def test_directory_writable_by_others_is_refused(cc, tmp_path, who):
    cc, log = cc
    directory = tmp_path / "shared"
    path = ccompile.build_library(SOURCE, "tiny", cc, _flags(), directory)
    bit = stat.S_IWOTH if who == "o+w" else stat.S_IWGRP
    directory.chmod(0o700 | bit)
    with pytest.raises(
        ccompile.UnsafeCacheError,
        match=rf"refusing the compiled-code cache directory {directory}: "
        "it is writable by others",
    ):
        ccompile.build_library(SOURCE, "tiny", cc, _flags(), directory)
    directory.chmod(0o700)
    path.chmod(0o777)
    with pytest.raises(ccompile.UnsafeCacheError, match="library .* writable by others"):
        ccompile.build_library(SOURCE, "tiny", cc, _flags(), directory)
    assert len(log.read_text().split()) == 1


def test_unsafe_cache_is_one_line_on_the_command_line(cc, tmp_path, monkeypatch, capsys):
    from eigentwist.cli.main import main

    directory = tmp_path / "shared"
    directory.mkdir(mode=0o777)
    directory.chmod(0o777)
    monkeypatch.setenv("EIGENTWIST_CACHE", str(directory))
    assert main(["matrices", "--backend", "c"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "writable by others" in err, err


def test_a_helper_library_is_built_and_bound_once_or_kept_as_none(monkeypatch):
    """``library_once``: the first call builds and binds, later calls return what it kept
    (no second build, no second binding); where no compiler builds the library, None is kept
    and nothing is bound or kept loaded."""
    from eigentwist.runtime import ccompile

    built, bound = [], []
    library = object()
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: built.append((source, name)) or library)

    def bind(lib):
        bound.append(lib)
        return "function"

    kept, libraries = [], []
    for _ in range(3):
        assert ccompile.library_once(kept, libraries, "int f(void);", "f", bind) == "function"
    assert built == [("int f(void);", "f")] and bound == [library] and libraries == [library] and kept == ["function"]
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: built.append(name) or None)
    kept, libraries = [], []
    assert ccompile.library_once(kept, libraries, "int g(void);", "g", bind) is None
    assert ccompile.library_once(kept, libraries, "int g(void);", "g", bind) is None
    assert kept == [None] and libraries == [] and bound == [library] and built[1:] == ["g"]
