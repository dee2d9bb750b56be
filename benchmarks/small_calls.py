"""Fixed cost of a call: CPU time per ``frequencies`` and ``modes`` call of 1, 8 and 64 new poses.

    PYTHONPATH=. python benchmarks/small_calls.py [--calls 400] [--rounds 3]

Shipped robots on the C backend, one thread; each call on its own reachable poses (drawn
uniformly in the workspace box, batches with an unreachable pose dropped), best of
``--rounds`` rounds of ``time.process_time`` (CPU time: a shared machine stretches wall
time). In the same run, the same batches through the C pass alone (``CKernels.fused``, its
inputs built beforehand): what a call costs beyond it is the evaluator's handling. Runs
against any tree (``PYTHONPATH=<tree>``): it uses the public API and ``Evaluator.kernels``.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402

ROBOTS = (("heli4", "paper"), ("heli4", "rigid"), ("hexapod", "none"), ("delta", "paper"))


def _best(calls, rounds: int) -> float:
    """Best over ``rounds`` of the CPU seconds per call of ``calls`` (zero-argument functions)."""
    best = float("inf")
    for _ in range(rounds):
        t0 = time.process_time()
        for call in calls:
            call()
        best = min(best, (time.process_time() - t0) / len(calls))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=400, help="calls per size (each on new poses)")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print("robot, model | poses | frequencies us | modes us | C pass us | frequencies / C pass")
    for name, model in ROBOTS:
        ev = eigentwist.load(name, backend="c", threads=1)
        box = np.array(ev.robot.workspace)
        rng = np.random.default_rng(0)
        stiffness = ev.stiffness_model(model)
        p = ev.inputs(model)
        for n in (1, 8, 64):
            pools = [box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, len(box))) for _ in range(2 * args.calls)]
            pools = [P for P in pools if ev.valid(P, model).all()][: args.calls]
            raw_inputs = [(P, {**p, **ev.kernel_pose_inputs(P)}) for P in pools]
            ev.frequencies(pools[0], model)
            freq = _best([lambda P=P: ev.frequencies(P, model) for P in pools], args.rounds)
            modes = _best([lambda P=P: ev.modes(P, model) for P in pools], args.rounds)
            raw = _best(
                [
                    lambda P=P, pp=pp: ev.kernels.fused(
                        P[:, 0], P[:, 1], P[:, 2], pp, matrices=(), model=stiffness, status=True, normalize=True
                    )
                    for P, pp in raw_inputs
                ],
                args.rounds,
            )
            print(
                f"{name}, {model} | {n} | {freq * 1e6:.0f} | {modes * 1e6:.0f} | {raw * 1e6:.0f} | {freq / raw:.2f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
