"""Cost of the exact rigid-constraint condensation on the default route.

CPU time per ``ev.frequencies`` call, Heli4, same poses, same run: the default (exact)
route against the penalty route (the evaluator's ``_route`` disabled: K_F with c_rigid =
1e-12 rad/(N m)), for a model whose legs have no rigid direction (``paper``: the exact
route is K_F with c_rigid = 0, no extra work) and one with rigid directions
(``actuator_loss,ee_compliance``: the compliance form on the admissible motions), on both
backends, 30 and 2000 poses; and the largest relative change of a finite frequency.

    PYTHONPATH=. python benchmarks/exact_constraints.py
"""

from __future__ import annotations

import time

import numpy as np

import eigentwist


def _cpu(fn, repeat: int) -> float:
    fn()
    t = time.process_time()
    for _ in range(repeat):
        fn()
    return (time.process_time() - t) / repeat


def main() -> None:
    rng = np.random.default_rng(0)
    for backend in ("c", "numpy"):
        ev = eigentwist.load("heli4", backend=backend)
        lo = np.array([a for a, _ in ev.robot.workspace])
        hi = np.array([b for _, b in ev.robot.workspace])
        for n in (30, 2000):
            P = lo + (hi - lo) * (0.25 + 0.5 * rng.random((n, 3)))
            for model in ("paper", "actuator_loss,ee_compliance"):
                repeat = 50 if n == 30 else 5
                f = ev.frequencies(P, model)
                exact = _cpu(lambda: ev.frequencies(P, model), repeat)
                ev.solver.route = lambda effects, params: (params, False)  # the penalty route of before
                try:
                    g = ev.frequencies(P, model)
                    penalty = _cpu(lambda: ev.frequencies(P, model), repeat)
                finally:
                    del ev.solver.route
                finite = f < 1e5
                print(
                    f"{backend:5s} N={n:5d} {model:28s} exact {exact * 1e3:7.2f} ms  penalty {penalty * 1e3:7.2f} ms"
                    f"  ({exact / penalty:4.1f}x)  max |df/f| {np.abs(f[finite] / g[finite] - 1).max():.1e}"
                )


if __name__ == "__main__":
    main()
