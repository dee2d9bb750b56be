"""The repository tracks its project files only: at its root, the package, its tests,
benchmarks, notebooks, examples, CI and the files that build and describe it; nothing a
run writes there (a sweep's chunks, a command's log) is committed."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TOP_LEVEL = {
    ".ci",
    ".gitattributes",
    ".gitignore",
    "Makefile",
    "README.md",
    "benchmarks",
    "eigentwist",
    "examples",
    "notebooks",
    "pyproject.toml",
    "tests",
}


def tracked_top_level() -> set:
    """The first path component of every file git tracks in this checkout."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: the tracked files are git's")
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    return {name.split("/", 1)[0] for name in out.decode().split("\0") if name}


def test_only_project_files_are_tracked_at_the_root():
    stray = tracked_top_level() - TOP_LEVEL
    assert not stray, f"files tracked at the repository root that no project file is: {sorted(stray)}"
