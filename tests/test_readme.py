"""The README's commands run as written and print the figures it states.

Every ```sh and ```python block of README.md runs, block after block, in one temporary
directory (later blocks may use files earlier ones wrote) with an ``eigentwist`` executable
on PATH that runs the console script's ``main`` from this checkout (and each python block
as ``python block.py`` runs it) in a process forked from one that has imported the package
(``tests/command_server.py``: a fresh process without the second of imports each command
would repeat). Each command must exit 0, and every figure in its trailing comment -- a
number (or a list ``a, b, c``, ``a +- b``, or a range ``a-b``) followed by a unit, e.g.
``# RMS 14.8 %`` -- must appear in its output within the stated rounding (a range: some output
number inside it). Durations (unit ``s``) depend on the machine and are not checked.

Markers, HTML comments just above a block (between it and the previous block):

* ``<!-- doc-test: skip (reason) -->``: the block is not run (the test says why);
* ``<!-- doc-test: replace "OLD" "NEW" (reason) -->``: run the block with OLD replaced by
  NEW (smaller sizes); the replacement must apply.

New README sections are picked up by themselves; a block that cannot run must say so.
"""

from __future__ import annotations

import math
import os
import re
import stat
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from . import command_server

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MARKER = re.compile(r"<!--\s*doc-test:\s*(skip|replace)\s*(.*?)\s*-->")
REPLACE = re.compile(r'"([^"]*)"\s+"([^"]*)"\s*\((.+)\)$')
NUM = r"-?\d+(?:\.\d+)?"
UNIT = r"(%|Hz|kg|MB|N m/rad|N/m|m)(?![\w/])"  # not s: durations depend on the machine
RANGE = re.compile(rf"(?<![\d.])({NUM})\s*(?:-|–|\.\.\.)\s*(\d+(?:\.\d+)?)\s*(?:s|{UNIT})")
FIGURE = re.compile(rf"({NUM}(?:\s*(?:,|\+-|±)\s*{NUM})*)\s*{UNIT}")
OUTPUT_NUMBER = re.compile(r"-?\d+(?:\.(\d+))?(?:[eE]([-+]?\d+))?")
TIMEOUT = 300

# every block runs once per test run, in the session fixture ``results``; the module is one
# unit of work for one xdist worker (tests/conftest.py: the scheduler)
pytestmark = pytest.mark.slow


@dataclass
class Block:
    """A fenced block of the README: language, first line number, text, markers."""

    lang: str
    line: int
    text: str
    skip: str | None = None
    replace: list = field(default_factory=list)

    @property
    def id(self) -> str:
        return f"line{self.line}-{self.lang}"

    def runnable_text(self) -> str:
        text = self.text
        for old, new, _ in self.replace:
            assert old in text, f"README line {self.line}: doc-test replace {old!r} does not apply"
            text = text.replace(old, new)
        return text


def parse_blocks(markdown: str) -> list[Block]:
    """The sh and python blocks with the markers above each."""
    blocks, pending, current = [], [], None
    for k, line in enumerate(markdown.splitlines(), start=1):
        if current is not None:
            if line.strip() == "```":
                blocks.append(current)
                current = None
            else:
                current.text += line + "\n"
            continue
        m = MARKER.search(line)
        if m:
            pending.append((m.group(1), m.group(2), k))
        elif line.startswith("```"):
            lang = line[3:].strip()
            current = Block(lang if lang in ("sh", "python") else "other", k + 1, "")
            for kind, arg, at in pending:
                if kind == "skip":
                    assert arg.startswith("(") and arg.endswith(")"), f"README line {at}: skip needs a (reason)"
                    current.skip = arg[1:-1]
                else:
                    r = REPLACE.match(arg)
                    assert r, f'README line {at}: expected replace "OLD" "NEW" (reason)'
                    current.replace.append(r.groups())
            pending = []
    assert current is None, "README ends inside a code block"
    return [b for b in blocks if b.lang in ("sh", "python")]


def commands(text: str) -> list[tuple[str, str]]:
    """(command, trailing comment) per command of an sh block; comment lines dropped."""
    out, buf = [], ""
    for raw in text.splitlines():
        if not buf and (not raw.strip() or raw.lstrip().startswith("#")):
            continue
        if raw.rstrip().endswith("\\"):
            buf += raw.rstrip()[:-1] + " "
            continue
        line = buf + raw
        buf = ""
        cmd, _, comment = line.partition(" #")
        out.append((cmd.strip(), comment.strip()))
    return out


def figures(comment: str) -> list[str]:
    """The numbers stated with a unit in a comment, as written (``"14.8"``; a range as
    ``"0.1..0.3"``); durations (``s``) are left out."""
    out = []
    for m in RANGE.finditer(comment):
        if not m.group(0).rstrip().endswith(" s") and not m.group(0).endswith("s"):
            out.append(f"{m.group(1)}..{m.group(2)}")
    rest = RANGE.sub(" ", comment)
    return out + [n for m in FIGURE.finditer(rest) for n in re.findall(NUM, m.group(1))]


def _half_unit(decimals: str | None, exponent: str | None) -> float:
    return 0.5 * 10.0 ** (-(len(decimals) if decimals else 0)) * 10.0 ** int(exponent or 0)


def shows(output: str, figure: str) -> bool:
    """Whether ``output`` holds a number that rounds like ``figure`` (their rounding
    intervals overlap)."""
    lo_text, _, hi_text = figure.partition("..")
    hi_text = hi_text or lo_text
    lo = float(lo_text) - _half_unit(lo_text.partition(".")[2] or None, None)
    hi = float(hi_text) + _half_unit(hi_text.partition(".")[2] or None, None)
    for m in OUTPUT_NUMBER.finditer(output):
        x = float(m.group(0))
        tol = _half_unit(m.group(1), m.group(2)) + 1e-9 * abs(x)
        if math.isfinite(x) and lo - tol <= x <= hi + tol:
            return True
    return False


BLOCKS = parse_blocks(README.read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def workdir(tmp_path_factory):
    """A temporary directory, and an environment with the ``eigentwist`` executable first on
    PATH and ``python-script`` beside it (clients of ``tests/command_server.py``, started here
    with that environment)."""
    work = tmp_path_factory.mktemp("readme")
    bin_dir = work / ".bin"
    bin_dir.mkdir()
    env = {
        **os.environ,
        "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
        "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
        "MPLBACKEND": "Agg",
    }
    socket_path = str(bin_dir / "eigentwist.sock")
    server = subprocess.Popen(
        [sys.executable, str(ROOT / "tests" / "command_server.py"), socket_path],
        cwd=work,
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert server.stdout.readline().strip() == "ready", "tests/command_server.py did not start"
    for program, name in (("eigentwist", "eigentwist"), ("python", "python-script")):
        client = bin_dir / name
        client.write_text(command_server.client_script(sys.executable, socket_path, program))
        client.chmod(client.stat().st_mode | stat.S_IXUSR)
    yield work, env
    server.stdin.close()
    server.wait(timeout=30)


@pytest.fixture(scope="session")
def results(workdir):
    """Run every block in README order once per test run; block id -> list of (command,
    comment, process). Under xdist the module is one unit of ``tests/conftest.py``'s
    scheduler, so one worker runs the README."""
    return _run_blocks(*workdir)


def _run_blocks(work, env) -> dict:
    out = {}
    for block in BLOCKS:
        if block.skip:
            continue
        text = block.runnable_text()
        if block.lang == "python":
            script = work / f"block_{block.line}.py"
            script.write_text(text)
            runs = [(f"python {script.name}", "", [str(work / ".bin" / "python-script"), script.name])]
        else:
            runs = [(cmd, comment, ["bash", "-c", cmd]) for cmd, comment in commands(text)]
        out[block.id] = [
            (cmd, comment, subprocess.run(argv, cwd=work, env=env, capture_output=True, text=True, timeout=TIMEOUT))
            for cmd, comment, argv in runs
        ]
    return out


def test_markers_are_explicit():
    for block in BLOCKS:
        assert block.skip is None or block.skip.strip(), f"README line {block.line}: skip without a reason"
    assert any(b.skip for b in BLOCKS) and any(not b.skip for b in BLOCKS)


def test_figure_parser():
    assert figures("RMS 14.8 %, all rows fail") == ["14.8"]
    assert figures("payload_mass first, m_p = 0.349 +- 0.003 kg") == ["0.349", "0.003"]
    assert figures("exit 1, naming stale files") == []
    assert figures("23.502, 26.321, 45.796 Hz: from M and K_R, 3x3") == ["23.502", "26.321", "45.796"]
    assert shows("max 32.95 %", "32.9") and not shows("max 33.05 %", "32.9") and shows("m_p = 0.3493", "0.349")
    assert figures("0.1-0.3 s per setting") == [] and figures("stays 4.8–5.0 Hz higher") == ["4.8..5.0"]
    assert shows("4.93 Hz", "4.8..5.0") and not shows("5.2 Hz", "4.8..5.0")


@pytest.mark.parametrize("block", BLOCKS, ids=[b.id for b in BLOCKS])
def test_readme_block(block, results):
    if block.skip:
        pytest.skip(f"README line {block.line}: {block.skip}")
    for cmd, comment, proc in results[block.id]:
        assert proc.returncode == 0, (
            f"README line {block.line}: `{cmd}` exited {proc.returncode}:\n{proc.stderr[-2000:]}"
        )
        assert "Traceback" not in proc.stderr, f"`{cmd}`:\n{proc.stderr[-2000:]}"
        output = proc.stdout + proc.stderr
        missing = [f for f in figures(comment) if not shows(output, f)]
        assert not missing, (
            f"README line {block.line}: `{cmd}` states {missing} ({comment!r}); output:\n{output[-3000:]}"
        )


WIDTH = 100  # characters per line of a command's default output


def _default_output(cmd: str) -> bool:
    """A command whose stdout is for people: not JSON, not --details, not redirected or piped."""
    return not re.search(r"--json|--details|--help|[>|]", cmd)


def test_width_checker():
    assert _default_output("eigentwist diagnose paper") and not _default_output("eigentwist diagnose x --json")
    assert not _default_output("eigentwist sweep --random 3 > out.txt")


def test_no_default_output_line_is_wider_than_100_characters(results):
    """Every README command's default output (the runs of ``results``, not repeated) fits in
    100 columns: long lists wrap or become footnotes."""
    wide = []
    for block in BLOCKS:
        if block.skip or block.lang != "sh":
            continue
        for cmd, _, proc in results[block.id]:
            if not _default_output(cmd):
                continue
            for line in proc.stdout.splitlines():
                if len(line) > WIDTH:
                    wide.append(f"README line {block.line}: `{cmd[:60]}`: {len(line)} characters: {line[:80]}...")
    assert not wide, "\n".join(wide)
