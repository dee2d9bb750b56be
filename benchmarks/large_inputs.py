"""`eigentwist compare` and `diagnose` on large measurement files: wall and CPU time, peak RSS.

Writes a measurement CSV of N rows (random poses within 3 cm of the Heli4's x_ref, k_a in
{500, 1000, 2000, 4000} N m/rad, the three lowest modes by rank, the paper model's
frequencies with 1 % noise), then runs the command in a fresh process under
``/usr/bin/time -v``. Usage::

    python benchmarks/large_inputs.py compare 1000000
    python benchmarks/large_inputs.py diagnose 10000 --baseline rigid

Figures: benchmarks/README.md ("Large measurement files").
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def write_csv(path: Path, n: int, seed: int = 0) -> None:
    """N rows of synthetic measurements (unique poses: no duplicate rows)."""
    import eigentwist

    ev = eigentwist.load("heli4", backend="numpy")
    rng = np.random.default_rng(seed)
    n_poses = n // 3 + 1
    poses = np.asarray(ev.robot.x_ref) + rng.uniform(-0.03, 0.03, (n_poses, 3))
    k_a = rng.choice([500.0, 1000.0, 2000.0, 4000.0], n_poses)
    freq = ev.frequencies(poses, "paper", k_a=k_a)[:, :3] * (1 + 0.01 * rng.standard_normal((n_poses, 3)))
    with open(path, "w") as fh:
        fh.write("k_a,mode,freq_hz,x,y,z\n")
        for row in range(n):
            i, j = divmod(row, 3)
            fh.write(f"{k_a[i]:g},{j + 1},{freq[i, j]:.6f},{poses[i, 0]:.6f},{poses[i, 1]:.6f},{poses[i, 2]:.6f}\n")


def run(command: str, n: int, extra: list[str]) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / f"m{n}.csv"
        write_csv(data, n)
        res = subprocess.run(
            ["/usr/bin/time", "-v", sys.executable, "-m", "eigentwist", command, str(data), *extra],
            capture_output=True,
            text=True,
        )
    if res.returncode != 0:
        raise SystemExit(res.stderr[-2000:])
    field = lambda name: re.search(rf"{name}: (.+)", res.stderr).group(1).strip()  # noqa: E731
    wall = field(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\)").split(":")
    return {
        "rows": n,
        "wall_s": sum(float(v) * 60**k for k, v in enumerate(reversed(wall))),
        "cpu_s": float(field("User time \\(seconds\\)")) + float(field("System time \\(seconds\\)")),
        "peak_rss_mb": int(field("Maximum resident set size \\(kbytes\\)")) / 1024,
    }


if __name__ == "__main__":
    command, n, *extra = sys.argv[1:]
    print(run(command, int(n), extra))
