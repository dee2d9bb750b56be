"""The machine's own ceiling for thread scaling: K independent one-thread processes at once.

    PYTHONPATH=. python benchmarks/processes.py [--n 200000] [--repeat 3] [--procs 8 16]
        [--robots NAME:MODEL ...]

Each process loads the robot on the C backend with ``threads=1``, draws its own new reachable
poses (:func:`gallery.fresh_batches`, a seed per process), waits at a common start, then times
``--repeat`` calls of ``frequencies``. Printed per robot and count K: the aggregate poses per
wall-second (every process's poses over the span from the first start to the last end) and
its ratio to one process alone, with the mean of each process's best call. Processes share no
interpreter, GIL, allocator or pool, so the ratio at K is what the cores, their clock under K
busy cores and the memory allow: the bound that ``benchmarks/threads.py``'s ratio at K threads
is read against.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import multiprocessing as mp  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _worker(name: str, model: str, n: int, repeat: int, seed: int, barrier, results) -> None:
    import eigentwist
    from gallery import fresh_batches

    ev = eigentwist.load(name, backend="c", threads=1, progress=None)
    batches = fresh_batches(ev, np.array(ev.robot.workspace), n, repeat + 1, model, seed=seed)
    ev.frequencies(batches.pop()[:256], model)
    barrier.wait()
    start = time.perf_counter()  # CLOCK_MONOTONIC: one clock for every process of the machine
    best = float("inf")
    for P in batches:
        t0 = time.perf_counter()
        ev.frequencies(P, model)
        best = min(best, time.perf_counter() - t0)
    results.put((start, time.perf_counter(), best))


def run(name: str, model: str, n: int, repeat: int, procs: int) -> tuple[float, float]:
    """(aggregate poses per wall-second, mean of the processes' best-call rates) of ``procs``
    processes at once."""
    ctx = mp.get_context("spawn")
    barrier, results = ctx.Barrier(procs), ctx.Queue()
    workers = [
        ctx.Process(target=_worker, args=(name, model, n, repeat, 1 + k, barrier, results)) for k in range(procs)
    ]
    for w in workers:
        w.start()
    got = [results.get() for _ in workers]
    for w in workers:
        w.join()
    span = max(g[1] for g in got) - min(g[0] for g in got)
    return procs * repeat * n / span, float(np.mean([n / g[2] for g in got]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200000, help="poses per call")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--robots", nargs="+", default=["hexapod:none"])
    parser.add_argument("--procs", type=int, nargs="+", default=[2], help="the process counts compared with one")
    args = parser.parse_args()
    counts = [1] + [k for k in args.procs if k != 1]
    print("robot, model | processes | aggregate poses/s (wall) | ratio to one | mean best call per process (poses/s)")
    for spec in args.robots:
        name, model = spec.rsplit(":", 1)
        one = None
        for k in counts:
            rate, each = run(name, model, args.n, args.repeat, k)
            one = one or rate
            print(f"{name}, {model} | {k} | {rate:.3g} | {rate / one:.2f} | {each:.3g}", flush=True)


if __name__ == "__main__":
    main()
