"""Fixed cost of a call: CPU time per ``frequencies`` and ``modes`` call of 1, 8 and 64 new poses.

    PYTHONPATH=. python benchmarks/small_calls.py [--calls 400] [--rounds 3]

Shipped robots on the C backend, one thread; each call on its own reachable poses (drawn
uniformly in the workspace box, batches with an unreachable pose dropped), best of
``--rounds`` rounds of ``time.process_time`` (CPU time: a shared machine stretches wall
time), each round over every robot and size in turn. In the same run, the same batches
through the C pass alone (``CKernels.fused``, its inputs built beforehand): what a call costs
beyond it is the evaluator's handling. Runs against any tree (``PYTHONPATH=<tree>``): it uses
the public API and ``Evaluator.kernels``.
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


def _per_call(calls) -> float:
    """CPU seconds per call of ``calls`` (zero-argument functions), run once each."""
    t0 = time.process_time()
    for call in calls:
        call()
    return (time.process_time() - t0) / len(calls)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=400, help="calls per size (each on new poses)")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    cases = []  # (label, {"frequencies" | "modes" | "C pass": calls})
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
            calls = {
                "frequencies": [lambda ev=ev, P=P, m=model: ev.frequencies(P, m) for P in pools],
                "modes": [lambda ev=ev, P=P, m=model: ev.modes(P, m) for P in pools],
                "C pass": [
                    lambda ev=ev, P=P, pp=pp, s=stiffness: ev.kernels.fused(
                        P[:, 0], P[:, 1], P[:, 2], pp, matrices=(), model=s, status=True, normalize=True
                    )
                    for P, pp in raw_inputs
                ],
            }
            cases.append((f"{name}, {model} | {n}", calls))
    # the rounds interleave every case, so that a slow phase of a shared machine hits all of them
    best = [dict.fromkeys(calls, float("inf")) for _, calls in cases]
    for _ in range(args.rounds):
        for (_, calls), b in zip(cases, best):
            for kind, batch in calls.items():
                b[kind] = min(b[kind], _per_call(batch))
    print("robot, model | poses | frequencies us | modes us | C pass us | frequencies / C pass")
    for (label, _), b in zip(cases, best):
        f, m, raw = b["frequencies"], b["modes"], b["C pass"]
        print(f"{label} | {f * 1e6:.0f} | {m * 1e6:.0f} | {raw * 1e6:.0f} | {f / raw:.2f}")


if __name__ == "__main__":
    main()
