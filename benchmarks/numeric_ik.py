"""C throughput with numeric (damped Newton) vs closed-form IK, and
the generation time of a robot whose legs are in URDF form.

    EIGENTWIST_CACHE=/tmp/c python benchmarks/numeric_ik.py [--n 20000] [--generate]

Throughput: poses/s on one core (``threads=1``), CPU time of the process
(``time.process_time``, best of 3, BLAS on one thread) of ``frequencies`` (paper model)
over random poses of the workspace box; the numeric IK's Newton iterations run in NumPy
around the generated C ``loop_closure`` kernel. ``--generate`` also times the derivation,
CSE and rendering of the URDF-form Heli4 and hexapod (``render_robot``, no compiling).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import eigentwist  # noqa: E402
from tests.conftest import random_poses  # noqa: E402
from tests.descriptions import hexapod_urdf, rrpirr_urdf  # noqa: E402


def cpu(fn, repeat: int = 3) -> float:
    """Best CPU time of ``fn(k)``, k = 0, 1, ...: each repeat gets its own poses (shifted by
    k nm), so that the evaluator's memo of the last Newton solution never serves a repeat."""
    best = float("inf")
    for k in range(repeat):
        t0 = time.process_time()
        fn(k)
        best = min(best, time.process_time() - t0)
    return best


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="poses per batch")
    ap.add_argument("--generate", action="store_true", help="also time the generation of the URDF-form robots")
    args = ap.parse_args(argv)
    quiet = lambda m: None  # noqa: E731
    cases = (("heli4", rrpirr_urdf.heli4), ("hexapod", hexapod_urdf.describe))
    for name, make in cases:
        if args.generate:
            from eigentwist.codegen.generate import render_robot

            t0 = time.process_time()
            render_robot(make())
            print(f"{name} (URDF legs): generation {time.process_time() - t0:.1f} s CPU")
        closed = eigentwist.load(name, backend="c", threads=1)
        numeric = eigentwist.load(make(), backend="c", threads=1, progress=quiet)
        poses = random_poses(closed.robot, args.n, seed=1)
        model = "rigid" if name == "heli4" else "paper"  # the URDF Heli4 has no rods, effects or couplings
        for label, ev in (("closed-form", closed), ("numeric", numeric)):
            t = cpu(lambda k: ev.frequencies(poses + 1e-9 * k, model))
            print(f"{name} {label} IK: {args.n / t:,.0f} poses/s ({model}, one core)")
        t_ik = cpu(lambda k: numeric.joint_angles(poses + 1e-9 * k))
        print(f"{name} numeric IK alone: {args.n / t_ik:,.0f} poses/s")


if __name__ == "__main__":
    main()
