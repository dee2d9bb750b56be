"""Where a report comes from: eigentwist version, date, command line, and the
SHA-256 of every input file, so that a reader can check that the report belongs to the data.
"""

from __future__ import annotations

import csv
import datetime
import hashlib
from pathlib import Path

__all__ = ["provenance", "sha256_file", "input_files"]


def sha256_file(path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def input_files(data=None, robot: str | None = None) -> list[Path]:
    """The files a report reads: the measurement CSV (or a campaign manifest and every file
    its ``file`` column names), a robot description file given as a path, in that order."""
    out: list[Path] = []
    if data is not None:
        path = Path(data)
        out.append(path)
        try:
            with open(path, newline="", encoding="utf-8-sig") as fh:
                rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
            header = [c.strip() for c in rows[0]] if rows else []
            if "file" in header:
                k = header.index("file")
                for r in rows[1:]:
                    if len(r) > k and r[k].strip():
                        f = path.parent / r[k].strip()
                        if f.is_file() and f not in out:
                            out.append(f)
        except (OSError, UnicodeDecodeError, IndexError):
            pass
    if robot and str(robot).endswith(".py") and Path(robot).is_file():
        out.append(Path(robot))
    return out


def provenance(command: str, data=None, robot: str | None = None, now=None) -> dict:
    """``{"version", "date" (UTC, ISO 8601), "command", "files": [{"path", "sha256", "bytes"}]}``."""
    from .. import __version__

    now = now or datetime.datetime.now(datetime.timezone.utc)
    files = [
        {"path": str(p), "sha256": sha256_file(p), "bytes": p.stat().st_size}
        for p in input_files(data, robot)
        if p.is_file()
    ]
    return {"version": __version__, "date": now.strftime("%Y-%m-%d %H:%M:%S UTC"), "command": command, "files": files}
