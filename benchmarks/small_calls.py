"""Fixed cost of a call: CPU time per ``frequencies`` call of 1 and of 64 new reachable poses.

    PYTHONPATH=. python benchmarks/small_calls.py

Shipped robots on the C backend, one thread; 400 calls per size, each on its own poses
(drawn uniformly in the workspace box, batches with an unreachable pose dropped), best of 3
rounds of ``time.process_time`` (CPU time: a shared machine stretches wall time).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import time  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402


def main() -> None:
    for name, model in (("heli4", "paper"), ("heli4", "rigid"), ("hexapod", "none"), ("delta", "paper")):
        ev = eigentwist.load(name, backend="c", threads=1)
        box = np.array(ev.robot.workspace)
        rng = np.random.default_rng(0)
        out = []
        for n in (1, 64):
            pools = [box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, len(box))) for _ in range(600)]
            pools = [P for P in pools if ev.valid(P, model).all()][:400]
            ev.frequencies(pools[0], model)
            best = float("inf")
            for _ in range(3):
                t0 = time.process_time()
                for P in pools:
                    ev.frequencies(P, model)
                best = min(best, (time.process_time() - t0) / len(pools))
            out.append(f"{n} pose(s): {best * 1e6:.0f} us")
        print(f"{name} {model}: " + "; ".join(out), flush=True)


if __name__ == "__main__":
    main()
