"""``Evaluator.valid`` on the C pass: every reachable pose's parallel check exact, or screened.

    PYTHONPATH=. python benchmarks/valid_screen.py [--n 50000] [--repeat 3] [--robots NAME ...]

For each robot (a shipped name or a description file), one thread, model ``none``: poses per
CPU-second of the status-only pass followed by the exact parallel check of every reachable
pose (``ev.checks.valid(poses, p, status)``), of ``ev.valid`` (the pass solves the model and
only the poses below the parallel screen get the exact check), and of ``ev.frequencies`` on
the valid poses; new poses of the workspace box every call, best of ``--repeat``.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=50000, help="poses per call")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--robots", nargs="+", default=["hexapod", "heli4", "examples/robots/rus6.py", "examples/robots/upu3.py"]
    )
    args = parser.parse_args()
    print("robot | every pose exact (poses/s) | screened | frequencies")
    for name in args.robots:
        ev = eigentwist.load(name, backend="c", threads=1, progress=None)
        box = np.array(ev.robot.workspace)
        rng = np.random.default_rng(1)

        def draw():
            return box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((args.n, len(box)))

        ev.valid(draw()[:100], "none")
        best = {"exact": np.inf, "screen": np.inf, "freq": np.inf}
        for _ in range(args.repeat):
            t0 = time.process_time()
            poses = ev.completion.poses(draw(), {})
            p = ev.resolver.resolve(len(poses), {}, "none")
            ev.checks.valid(poses, p, ev.c_route.run(poses, p, matrices=())["status"])
            best["exact"] = min(best["exact"], (time.process_time() - t0) / args.n)
            P = draw()
            t0 = time.process_time()
            ev.valid(P, "none")
            best["screen"] = min(best["screen"], (time.process_time() - t0) / args.n)
            fresh = draw()
            fresh = fresh[ev.valid(fresh, "none")][1:]  # not the array valid solved: no memo answers
            t0 = time.process_time()
            ev.frequencies(fresh, "none")
            best["freq"] = min(best["freq"], (time.process_time() - t0) / len(fresh))
        print(f"{name} | {1 / best['exact']:.3g} | {1 / best['screen']:.3g} | {1 / best['freq']:.3g}", flush=True)


if __name__ == "__main__":
    main()
