"""The public path against the raw kernel and the prepared pass, per robot, large batches.

    PYTHONPATH=. python benchmarks/public_path.py [--n 20000] [--repeat 5] [--robots hexapod:none heli4:paper]

For each robot and model, in one process, one thread, poses per CPU-second (best of
``--repeat``, **new** reachable poses every repetition, :func:`gallery.fresh_batches`):

* the raw kernel: ``CKernels.fused`` with the poses' inputs built beforehand, no checks;
* the prepared call: the pass ``Evaluator.modes`` prepares once per model and options
  (``ev.c_route.plan``), the pose checks included;
* the public path: ``Evaluator.frequencies``;

the three interleaved within each repetition (a shared machine's speed drifts).

Goal: the public path at most 1.1 times the raw kernel's time.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gallery import fresh_batches  # noqa: E402


def cpu_seconds(fn, item) -> float:
    """CPU seconds of ``fn(item)``."""
    t0 = time.process_time()
    fn(item)
    return time.process_time() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000, help="poses per call")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--robots", nargs="+", default=["hexapod:none", "heli4:paper", "delta:paper"])
    args = parser.parse_args()
    print("robot, model | raw kernel | prepared call | public path (poses/s) | public / raw (time)")
    for spec in args.robots:
        name, model = spec.split(":")
        ev = eigentwist.load(name, backend="c", threads=1)
        kernels, stiffness = ev.kernels, ev.stiffness_model(model)
        batches = fresh_batches(ev, np.array(ev.robot.workspace), args.n, 3 * args.repeat, model)
        params = ev.parameter_values(args.n, model)
        raw_args = [
            (P[:, 0].copy(), P[:, 1].copy(), P[:, 2].copy(), {**params, **ev.kernel_pose_inputs(P)})
            for P in batches[: args.repeat]
        ]
        plan = ev.c_route.plan(model, {}, "raise", "nan", False)
        if not plan:
            print(f"{name}, {model} | no prepared pass")
            continue
        call, columns = plan[0], plan[1]
        ev.frequencies(batches[-1][:64], model)
        ways = (
            (lambda a: kernels.fused(*a[:3], a[3], matrices=(), model=stiffness), raw_args),
            (lambda P: call([P.ctypes.data + 8 * k for k in range(columns)], len(P), 1), batches[args.repeat :]),
            (lambda P: ev.frequencies(P, model), batches[2 * args.repeat :]),
        )
        best = [float("inf")] * 3
        for r in range(args.repeat):  # the three interleaved, each on its own new poses
            for k, (fn, items) in enumerate(ways):
                best[k] = min(best[k], cpu_seconds(fn, items[r]))
        raw, prepared, public = (args.n / b for b in best)
        print(f"{name}, {model} | {raw:.3g} | {prepared:.3g} | {public:.3g} | {raw / public:.3f}")


if __name__ == "__main__":
    main()
