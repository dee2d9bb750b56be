"""Newton's iterations of legs solved numerically: from the description's reference against
from the predicted start (:func:`eigentwist.runtime.levenberg_marquardt.predicted_start`).

    PYTHONPATH=.:benchmarks python benchmarks/newton_start.py [--n 20000] [--repeat 8] [--only rus6,upu3]

For each gallery robot whose legs are in URDF form: CPU µs a pose (``time.process_time``,
one thread, the C driver, ``CKernels.newton``) of the iterations alone on ``--n`` reachable
poses of the workspace box, **new poses every repetition**, the two starts alternated within
each repetition (the same poses for both: a same-run comparison on a shared machine); the
median over ``--repeat`` repetitions. From the reference the first damping is ``LAMBDA0``,
from the guess ``GUESS_LAMBDA0``, as :func:`~eigentwist.runtime.levenberg_marquardt.solve`
runs them. Also the largest difference of the converged coordinates (rad; m for P) and the
share of poses that converged from each start.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402
from eigentwist.runtime.completion import padded_references  # noqa: E402
from eigentwist.runtime.levenberg_marquardt import GUESS_LAMBDA0, MAX_ITERATIONS, TOL  # noqa: E402
from gallery import GALLERY, fresh_batches  # noqa: E402

NUMERIC = ("rus6", "upu3")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="poses per repetition")
    ap.add_argument("--repeat", type=int, default=8, help="repetitions, each on new poses")
    ap.add_argument("--only", default=",".join(NUMERIC), help="comma-separated robot file stems")
    args = ap.parse_args(argv)
    for stem in [s for s in args.only.split(",") if s]:
        ev = eigentwist.load(str(Path(GALLERY) / f"{stem}.py"), backend="c", threads=1, progress=None)
        completion, kernels = ev.completion, ev.kernels
        reference = np.array(padded_references(ev.robot.legs), dtype=float)
        guess = completion.predictor()
        times = {"reference": [], "predicted": []}
        gap, converged = 0.0, {"reference": 0, "predicted": 0}
        for k, poses in enumerate(fresh_batches(ev, np.array(ev.robot.workspace), args.n, args.repeat)):
            x = completion.poses(poses, {})
            kp = completion.closure_inputs(x, completion.resolver.resolve(len(x), {}, "none"))
            starts = {
                "reference": (np.broadcast_to(reference, (len(x),) + reference.shape).copy(), None),
                "predicted": (guess(x), GUESS_LAMBDA0),
            }
            order = list(starts) if k % 2 == 0 else list(starts)[::-1]
            solved = {}
            for name in order:
                q0, lam = starts[name]
                t0 = time.process_time()
                solved[name] = kernels.newton(q0, kp, MAX_ITERATIONS, TOL, threads=1, lambda0=lam)
                times[name].append((time.process_time() - t0) / len(x) * 1e6)
            ok = {name: (norm < TOL).all(-1) for name, (_, norm) in solved.items()}
            both = ok["reference"] & ok["predicted"]
            gap = max(gap, float(np.abs(solved["reference"][0] - solved["predicted"][0])[both].max(initial=0.0)))
            for name in converged:
                converged[name] += int(ok[name].sum())
        total = args.n * args.repeat
        ref, pred = np.median(times["reference"]), np.median(times["predicted"])
        print(
            f"{stem}: Newton from the reference {ref:.2f} µs/pose, from the predicted start {pred:.2f} "
            f"({pred / ref:.2f}x); converged {converged['reference'] / total:.1%} and "
            f"{converged['predicted'] / total:.1%}; largest difference {gap:.1e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
