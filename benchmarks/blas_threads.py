"""CPU and wall time of ``frequencies`` with the BLAS library's default threads, and with one.

    PYTHONPATH=. python benchmarks/blas_threads.py [--n 200000] [--calls 5] [--threads 1 2]
        [--robots NAME ...]

The other benchmarks set ``OMP_NUM_THREADS=OPENBLAS_NUM_THREADS=MKL_NUM_THREADS=1``; a user's
process usually does not. Here each robot runs in a child process per setting (the BLAS reads
it at load): ``frequencies`` (model ``none``, C backend, the evaluator's ``--threads``) on
``--calls`` batches of new reachable poses, reporting user CPU and wall µs per pose. CPU well
above wall on one evaluator thread means BLAS threads spinning beside the evaluator's.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ONE = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def child(name: str, n: int, calls: int, threads: int) -> None:
    """Time ``calls`` calls on new poses in this process; print ``user wall`` (µs a pose)."""
    import numpy as np

    import eigentwist

    sys.path.insert(0, str(HERE))
    from gallery import fresh_batches

    ev = eigentwist.load(name, backend="c", threads=threads, progress=None)
    batches = fresh_batches(ev, np.array(ev.robot.workspace), n, calls + 1)
    ev.frequencies(batches.pop()[:256])
    r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    for poses in batches:
        ev.frequencies(poses)
    r1, t1 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    total = n * calls
    print((r1.ru_utime - r0.ru_utime) / total * 1e6, (t1 - t0) / total * 1e6)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200000, help="poses per call")
    parser.add_argument("--calls", type=int, default=5)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="the evaluator's threads")
    parser.add_argument("--robots", nargs="+", default=["examples/robots/rus6.py", "hexapod"])
    parser.add_argument("--child", nargs=2, metavar=("ROBOT", "THREADS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], args.n, args.calls, int(args.child[1]))
        return
    print("robot | evaluator threads | BLAS default: user / wall µs a pose | BLAS one thread: user / wall")
    default = {k: v for k, v in os.environ.items() if k not in ONE}
    for name in args.robots:
        for threads in args.threads:
            cells = []
            command = [sys.executable, __file__, "--n", str(args.n), "--calls", str(args.calls)]
            for env in (default, {**default, **ONE}):
                out = subprocess.run(
                    command + ["--child", name, str(threads)],
                    env=env,
                    capture_output=True,
                    text=True,
                    check=True,
                ).stdout.split()
                cells.append(f"{float(out[-2]):.2f} / {float(out[-1]):.2f}")
            print(f"{name} | {threads} | {cells[0]} | {cells[1]}", flush=True)


if __name__ == "__main__":
    main()
