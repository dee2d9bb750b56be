"""The code, its docs, tests, benchmarks, notebooks and examples say what things are, not
which ticket brought them: no issue number anywhere in the text the repository ships
(the history belongs to the commit messages).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCANNED = (
    "eigentwist",
    "tests",
    "benchmarks",
    "notebooks",
    "examples",
    ".ci",
    "README.md",
    "pyproject.toml",
    "Makefile",
)
TEXT = {
    ".py",
    ".md",
    ".ipynb",
    ".jinja",
    ".toml",
    ".c",
    ".h",
    ".txt",
    ".cfg",
    ".ini",
    ".yml",
    ".yaml",
    ".json",
    ".sh",
    ".html",
    ".css",
    ".js",
    "",
}
SKIPPED = {"__pycache__", "mutants", "build", "dist"}  # and hidden or *.egg-info folders (caches, tools)
#: "issue" or "issues" in any case, then a space or a line break or nothing, an optional "#", the number
ISSUE = re.compile(r"\bissues?\s?#?\d+", re.IGNORECASE)


def _files():
    for name in SCANNED:
        top = ROOT / name
        if top.is_file():
            yield top
        elif top.is_dir():
            for path in sorted(top.rglob("*")):
                parts = path.relative_to(top).parts[:-1]
                if (
                    path.is_file()
                    and path.suffix in TEXT
                    and not any(p in SKIPPED or p.startswith(".") or p.endswith(".egg-info") for p in parts)
                ):
                    yield path


def mentions(text: str) -> list[tuple[int, str]]:
    """``(line number, matched text)`` of every issue number in ``text``."""
    return [(text.count("\n", 0, m.start()) + 1, m.group(0).replace("\n", " ")) for m in ISSUE.finditer(text)]


# the samples are templates ("{}": the number; ``found``: the text before it and its line),
# so that this file's own source holds no match
@pytest.mark.parametrize(
    "template, number, found",
    [
        ("rigid constraints (issue {})", 20, [("issue ", 1)]),
        ("# Issue {}.1: one --set", 12, [("Issue ", 1)]),
        ("after issues {}–16", 10, [("issues ", 1)]),
        ("see issue #{}", 7, [("issue #", 1)]),
        ("the 3x3 subsets, issue\n{}), independent", 21, [("issue ", 1)]),
        ("ISSUE{} and\n\nissue {}", 3, [("ISSUE", 1), ("issue ", 3)]),
        ("a tissue {} mm thick; issues with {} rows; issue-free; issue_{}_names; issue\n\n{}", 3, []),
    ],
)
def test_the_pattern_finds_issue_numbers_and_nothing_else(template, number, found):
    text = template.replace("{}", str(number))
    assert mentions(text) == [(line, f"{before}{number}") for before, line in found]


def _texts(path: Path):
    """``(label, text)``: the file, or each cell of a notebook (its JSON splits a wrapped line)."""
    text = path.read_text(encoding="utf-8", errors="replace")
    if path.suffix != ".ipynb":
        yield str(path.relative_to(ROOT)), text
        return
    for k, cell in enumerate(json.loads(text)["cells"]):
        source = cell["source"]
        yield f"{path.relative_to(ROOT)} cell {k}", source if isinstance(source, str) else "".join(source)


def test_no_issue_numbers_in_the_repository():
    files = list(_files())
    assert len(files) > 100 and any(p.suffix == ".ipynb" for p in files), f"{len(files)} files scanned under {ROOT}"
    bad = [f"{label}:{line}: {m}" for p in files for label, text in _texts(p) for line, m in mentions(text)]
    assert not bad, "issue numbers (history belongs in commit messages):\n  " + "\n  ".join(bad)
