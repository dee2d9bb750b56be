"""Each gallery robot's frequencies at home, generation time and throughput on fresh poses
(one thread), next to the shipped hexapod's measured in the same rounds.

    PYTHONPATH=. python benchmarks/gallery.py [--n N] [--repeat R] [--generate] [--backend c] [--threads T]

For each description file in ``examples/robots/``: with ``--generate``, times
``render_robot`` (derivation, CSE and both backends rendered, nothing written; wall and CPU
time); prints the bare model's frequencies (``"none"``: k_a only, on the platform's allowed
twists) at home; and times poses -> frequencies through ``eigentwist.load(PATH,
backend=..., threads=1)``. Every repetition draws **new** random poses of the workspace box
(N reachable ones, drawn once as a pool and split), so that no memo of an earlier
call can answer; a lower-mobility robot's rate includes its followers' Newton solve, a
URDF-form robot's its legs' numeric IK. Figures are poses per CPU-second of the process
(``time.process_time``, BLAS on one thread), the best of R repetitions: a shared machine
stretches wall time, not CPU time.
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
from eigentwist.runtime.userfile import describe_file  # noqa: E402

GALLERY = Path(__file__).resolve().parent.parent / "examples" / "robots"


def fresh_batches(ev, box: np.ndarray, n: int, repeat: int, model: str = "none", seed: int = 0) -> list:
    """``repeat`` disjoint batches of ``n`` reachable poses (uniform in ``box``, the
    unreachable ones dropped): no two calls see the same poses."""
    rng = np.random.default_rng(seed)
    pool = np.empty((0, len(box)))
    while len(pool) < n * repeat:
        draw = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((2 * n * repeat, len(box)))
        pool = np.concatenate([pool, draw[ev.valid(draw, model)]])
    return [pool[k * n : (k + 1) * n] for k in range(repeat)]


def paired_rates(
    evaluators: list, n: int, repeat: int, model: str = "none", seed: int = 0, clock=time.process_time
) -> list:
    """Best poses per CPU-second (``clock``: ``time.perf_counter`` for wall seconds, the
    measure of several threads) of each ``(ev, box)``'s ``ev.frequencies(poses, model)``,
    their batches interleaved (one batch of each in turn, ``repeat`` rounds, new poses every
    batch): a ratio of two rates is measured under the same load of a shared machine."""
    batches = [fresh_batches(ev, box, n, repeat + 1, model, seed) for ev, box in evaluators]
    for (ev, _), mine in zip(evaluators, batches):
        ev.frequencies(mine.pop()[:64], model)
    best = [float("inf")] * len(evaluators)
    for k in range(repeat):
        for j, (ev, _) in enumerate(evaluators):
            t0 = clock()
            ev.frequencies(batches[j][k], model)
            best[j] = min(best[j], clock() - t0)
    return [n / b for b in best]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="poses per batch")
    ap.add_argument("--repeat", type=int, default=3, help="batches (each of new poses); the best is kept")
    ap.add_argument("--generate", action="store_true", help="also time render_robot")
    ap.add_argument("--backend", default="c")
    ap.add_argument("--only", default="", help="comma-separated robot file stems (default: all)")
    ap.add_argument("--threads", type=int, default=1, help="the evaluators' threads; above 1, poses per wall-second")
    args = ap.parse_args(argv)
    if args.threads == 1:
        clock, unit = time.process_time, "CPU-s"
    else:  # several threads: wall seconds
        clock, unit = time.perf_counter, f"s, {args.threads} threads"
    hexa = eigentwist.load("hexapod", backend=args.backend, threads=args.threads)
    hexa_box = np.array(hexa.robot.workspace)
    only = {s for s in args.only.split(",") if s}
    drawn = 0
    for path in sorted(GALLERY.glob("*.py")):
        if only and path.stem not in only:
            continue
        robot = describe_file(path)
        gen = ""
        if args.generate:
            from eigentwist.codegen.generate import render_robot

            t0, c0 = time.perf_counter(), time.process_time()
            render_robot(robot)
            gen = f"generation {time.perf_counter() - t0:.1f} s wall, {time.process_time() - c0:.1f} s CPU"
            c0 = time.process_time()
            render_robot(robot, backends=("numpy",))
            gen += f" (NumPy module alone {time.process_time() - c0:.1f} s CPU); "
        ev = eigentwist.load(str(path), backend=args.backend, threads=args.threads, progress=None)
        home = ev.frequencies(np.array([robot.x_ref]), "none")[0]
        rate, ref = paired_rates(
            [(ev, np.array(robot.workspace)), (hexa, hexa_box)], args.n, args.repeat, seed=drawn, clock=clock
        )
        drawn += 1  # the hexapod's poses new for every robot as well
        print(
            f"{robot.name}: {gen}at home {np.round(home, 2).tolist()} Hz (k_a only); "
            f"{rate:,.0f} poses per {unit} ({rate / ref:.1%} of the hexapod's {ref:,.0f}, interleaved)",
            flush=True,
        )


if __name__ == "__main__":
    main()
