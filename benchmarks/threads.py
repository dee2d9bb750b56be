"""Thread scaling of the public path: wall time of ``frequencies`` with 1 and more threads.

    PYTHONPATH=. python benchmarks/threads.py [--n 200000] [--repeat 3] [--robots NAME:MODEL ...]
        [--threads 2 4 8 16] [--newton-chunk 4096] [--chunk 4096]

For each robot (a shipped name or a description file) and model: the C backend with
``threads=1`` and each count of ``--threads``, **new** reachable poses every call
(:func:`gallery.fresh_batches`), the counts interleaved, best of ``--repeat``; prints poses per
wall-second of each and its ratio to one thread, the minor page faults per timed call at the
largest count (the process's, every thread's: a fault's cost depends on the kernel or sandbox
underneath) and the load average before and after (a speed-up is only seen where the cores are
free). Goal: at least 1.8 on 2 cores, 10 on 16; ``benchmarks/processes.py`` measures the
machine's own bound for the same counts.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gallery import fresh_batches  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200000, help="poses per call")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--robots", nargs="+", default=["hexapod:none", "examples/robots/rus6.py:none"])
    parser.add_argument("--threads", type=int, nargs="+", default=[2], help="the thread counts compared with one")
    parser.add_argument(
        "--newton-chunk", type=int, default=None, help="poses per chunk of numeric IK (completion.NEWTON_CHUNK)"
    )
    parser.add_argument(
        "--chunk",
        type=int,
        default=None,
        help="poses per chunk of a rigid model on allowed twists that turn with the pose (mode_solver.CHUNK)",
    )
    args = parser.parse_args()
    if args.newton_chunk:
        from eigentwist.runtime import completion

        completion.NEWTON_CHUNK = args.newton_chunk
    if args.chunk:
        from eigentwist.runtime import mode_solver

        mode_solver.CHUNK = args.chunk
    counts = [1] + [t for t in args.threads if t != 1]
    print(
        "robot, model | "
        + " | ".join(f"{t} thr. (poses/s, wall)" for t in counts)
        + " | "
        + " | ".join(f"ratio {t}" for t in counts[1:])
        + " | faults/call | load average"
    )
    for spec in args.robots:
        name, model = spec.rsplit(":", 1)
        evs = {t: eigentwist.load(name, backend="c", threads=t, progress=None) for t in counts}
        batches = fresh_batches(
            evs[counts[-1]], np.array(evs[1].robot.workspace), args.n, len(counts) * args.repeat + 1, model, seed=1
        )
        warm = batches.pop()[:256]
        for ev in evs.values():
            ev.frequencies(warm, model)
        best = {t: float("inf") for t in evs}
        faults = 0
        load0 = os.getloadavg()[0]
        for _ in range(args.repeat):  # interleaved: a busy phase of a shared machine hits every count
            for t, ev in evs.items():
                P = batches.pop()
                f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
                t0 = time.perf_counter()
                ev.frequencies(P, model)
                best[t] = min(best[t], time.perf_counter() - t0)
                if t == counts[-1]:
                    faults += resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
        rate = {t: args.n / best[t] for t in counts}
        print(
            f"{name}, {model} | "
            + " | ".join(f"{rate[t]:.3g}" for t in counts)
            + " | "
            + " | ".join(f"{rate[t] / rate[1]:.2f}" for t in counts[1:])
            + f" | {faults / args.repeat:.0f}"
            + f" | {load0:.1f} -> {os.getloadavg()[0]:.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
