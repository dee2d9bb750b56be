"""The sweep package has one job per module and its errors speak the library's language
(not the command line's): no runtime error quotes a command-line flag."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import eigentwist
from eigentwist.runtime import InputError
from eigentwist.runtime import sweep as sw

RUNTIME = Path(eigentwist.__file__).parent / "runtime"
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z-]+")


def _error_strings(path: Path):
    """String constants inside ``raise ...(...)`` statements of a module."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None:
            for sub in ast.walk(node.exc):
                if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
                    yield sub.lineno, sub.value


@pytest.mark.parametrize("path", sorted(RUNTIME.rglob("*.py")), ids=lambda p: str(p.relative_to(RUNTIME)))
def test_runtime_errors_quote_no_command_line_flag(path):
    flags = [(line, text) for line, text in _error_strings(path) if FLAG.search(text)]
    assert not flags, f"{path.name}: runtime errors quote CLI flags: {flags}"


def test_sweep_modules_stay_small():
    sizes = {p.name: len(p.read_text().splitlines()) for p in (RUNTIME / "sweep").glob("*.py")}
    assert len(sizes) >= 6 and max(sizes.values()) < 300, sizes


def test_make_spec_takes_numbers_not_command_line_text():
    with pytest.raises(InputError, match="is text") as err:
        sw.make_spec("heli4", k_a="500:4000:8")
    assert "--" not in str(err.value)
