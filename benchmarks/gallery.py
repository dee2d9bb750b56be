"""Figures of issue 21: each gallery robot's frequencies at home, generation time and C
throughput (one core).

    PYTHONPATH=. python benchmarks/gallery.py [N]

For each description file in ``examples/robots/``: times ``render_robot`` (derivation,
CSE and both backends rendered, nothing written), prints the rigid model's frequencies
(``"rigid"``: k_a only, on the platform's allowed twists) and the flexible 6x6 of M and
K_F (the constraint wrenches' compliance c_rigid) at home, and times poses -> rigid
frequencies through ``eigentwist.load(PATH, backend="c", threads=1)`` over N random
poses of the workspace box (a lower-mobility robot's include its followers' Newton solve).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import eigentwist
from eigentwist.codegen.generate import render_robot
from eigentwist.runtime.eigen import frequencies_hz, generalized_eigh
from eigentwist.runtime.userfile import describe_file

GALLERY = Path(__file__).resolve().parent.parent / "examples" / "robots"


def main(n: int = 20000) -> None:
    for path in sorted(GALLERY.glob("*.py")):
        robot = describe_file(path)
        t0 = time.perf_counter()
        render_robot(robot)
        gen = time.perf_counter() - t0
        ev = eigentwist.load(str(path), backend="c", threads=1, progress=None)
        home = np.array([robot.x_ref])
        rigid = ev.frequencies(home, "rigid")[0]
        mats = ev.matrices(home, "rigid")
        flexible = frequencies_hz(generalized_eigh(mats["K_F"], mats["M"])[0])[0]
        box = np.array(robot.workspace)
        poses = box[:, 0] + (box[:, 1] - box[:, 0]) * np.random.default_rng(0).random((n, len(box)))
        ok = ev.valid(poses, "rigid")
        poses = poses[ok]
        ev.frequencies(poses[:100], "rigid")
        t0 = time.perf_counter()
        ev.frequencies(poses, "rigid")
        rate = len(poses) / (time.perf_counter() - t0)
        print(f"{robot.name}: generation {gen:.1f} s; rigid at home {np.round(rigid, 2).tolist()} Hz; "
              f"flexible (M, K_F) {np.round(flexible, 1).tolist()} Hz; C one core {rate:,.0f} poses/s "
              f"({len(poses)} reachable poses)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20000)
