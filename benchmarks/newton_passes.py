"""Closure evaluations per block of 64 poses of numeric IK's Newton iterations, for each
threshold below which a (pose, leg) takes the undamped step at once (``levenberg_marquardt.EARLY``).

    PYTHONPATH=.:benchmarks python benchmarks/newton_passes.py [--n 4096] [--only rus6,upu3]
        [--early 1e-12,1e-11,1e-10,1e-9,1e-8,1e-7]

For each gallery robot whose legs are in URDF form: ``--n`` new reachable poses of the
workspace box, each block of 64 poses (the C driver's block) iterated from the predicted start
by :func:`eigentwist.runtime.levenberg_marquardt._iterate` (the NumPy iterations, the C
driver's rule per (pose, leg)) with ``EARLY`` set to each value in turn; prints the mean number
of closure evaluations a block (the start, the damped passes of its slowest lane, the undamped
steps), which the C driver also makes a block, and the share of poses converged. ``EARLY`` =
TOL (1e-12) is the rule of damped steps down to TOL, then the undamped step.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402
from eigentwist.runtime import levenberg_marquardt as lm  # noqa: E402
from eigentwist.runtime.completion import take  # noqa: E402
from gallery import GALLERY, fresh_batches  # noqa: E402

BLOCK = 64  # the C driver's block of poses


def evaluations(closure, start: np.ndarray, p: dict, early: float) -> tuple[float, float]:
    """(mean closure evaluations a block of BLOCK poses, share converged) of
    :func:`~eigentwist.runtime.levenberg_marquardt._iterate` from ``start`` with ``EARLY`` =
    ``early``."""
    calls = [0]

    def counted(q, pp):
        calls[0] += 1
        return closure(q, pp)

    saved, lm.EARLY = lm.EARLY, early
    try:
        per_block, converged = [], 0
        for b0 in range(0, len(start), BLOCK):
            rows = slice(b0, min(len(start), b0 + BLOCK))
            calls[0] = 0
            _, norm = lm._iterate(counted, start[rows], take(p, rows), lm.MAX_ITERATIONS, lm.TOL, lm.GUESS_LAMBDA0)
            per_block.append(calls[0])
            converged += int((norm < lm.TOL).all(-1).sum())
    finally:
        lm.EARLY = saved
    return float(np.mean(per_block)), converged / len(start)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=4096, help="poses (new, reachable)")
    ap.add_argument("--only", default="rus6,upu3", help="comma-separated robot file stems")
    ap.add_argument("--early", default="1e-12,1e-11,1e-10,1e-9,1e-8,1e-7", help="comma-separated thresholds")
    args = ap.parse_args(argv)
    thresholds = [float(v) for v in args.early.split(",") if v]
    for stem in [s for s in args.only.split(",") if s]:
        ev = eigentwist.load(str(Path(GALLERY) / f"{stem}.py"), backend="numpy", progress=None)
        completion = ev.completion
        (poses,) = fresh_batches(ev, np.array(ev.robot.workspace), args.n, 1)
        x = completion.poses(poses, {})
        p = completion.closure_inputs(x, completion.resolver.resolve(len(x), {}, "none"))
        start = completion.predictor()(x)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            rows = [(early, *evaluations(completion.kernels.loop_closure, start, p, early)) for early in thresholds]
        print(
            f"{stem}: closure evaluations a block of {BLOCK} poses: "
            + ", ".join(f"EARLY {e:g}: {m:.2f} ({c:.1%} converged)" for e, m, c in rows),
            flush=True,
        )


if __name__ == "__main__":
    main()
