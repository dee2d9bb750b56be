"""Figures of the gallery: each gallery robot's frequencies at home, generation time and C
throughput (one core).

    PYTHONPATH=. python benchmarks/gallery.py [N]

For each description file in ``examples/robots/``: times ``render_robot`` (derivation,
CSE and both backends rendered, nothing written; wall and CPU time: a shared machine
stretches the wall time), prints the bare model's frequencies
(``"none"``: k_a only, on the platform's allowed twists) at home, and times poses ->
frequencies through ``eigentwist.load(PATH, backend="c", threads=1)`` over N random poses
of the workspace box (reachable ones; a lower-mobility robot's include its followers'
Newton solve, a URDF-form robot's its legs' numeric IK), best of 7 runs.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import eigentwist
from eigentwist.codegen.generate import render_robot
from eigentwist.runtime.userfile import describe_file

GALLERY = Path(__file__).resolve().parent.parent / "examples" / "robots"


def main(n: int = 20000) -> None:
    for path in sorted(GALLERY.glob("*.py")):
        robot = describe_file(path)
        t0, c0 = time.perf_counter(), time.process_time()
        render_robot(robot)
        gen, gen_cpu = time.perf_counter() - t0, time.process_time() - c0
        ev = eigentwist.load(str(path), backend="c", threads=1, progress=None)
        home = np.array([robot.x_ref])
        rigid = ev.frequencies(home, "none")[0]
        box = np.array(robot.workspace)
        poses = box[:, 0] + (box[:, 1] - box[:, 0]) * np.random.default_rng(0).random((n, len(box)))
        poses = poses[ev.valid(poses, "none")]
        ev.frequencies(poses[:100], "none")
        times = []
        for _ in range(7):                      # best of 7: a shared machine deschedules us
            t0 = time.perf_counter()
            ev.frequencies(poses, "none")
            times.append(time.perf_counter() - t0)
        rate = len(poses) / min(times)
        print(f"{robot.name}: generation {gen:.1f} s wall, {gen_cpu:.1f} s CPU; at home {np.round(rigid, 2).tolist()} Hz (k_a only); "
              f"C one core {rate:,.0f} poses/s ({len(poses)} reachable poses)", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20000)
