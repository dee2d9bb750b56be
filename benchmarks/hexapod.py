"""Figures of the hexapod: the hexapod's frequencies, generation time, C throughput (one core).

    PYTHONPATH=. python benchmarks/hexapod.py [N]

Times ``render_robot("hexapod")`` (derivation, CSE and both backends rendered, nothing
written), prints the six natural frequencies (Hz) at home and at a tilted pose with the
default model (``paper``: the actuator loss eta_a = 0.82) and without any effect, and
times poses -> six frequencies through ``eigentwist.load("hexapod")`` on one core
(``threads=1``): the C backend's fused pass and the NumPy backend, same poses, same run.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import eigentwist
from eigentwist.robots import get
from eigentwist.codegen.generate import render_robot

HOME = [0.0, 0.0, 0.80, 0.0, 0.0, 0.0]
TILTED = [0.02, -0.03, 0.78, 0.05, -0.04, 0.1]


def poses(n: int, seed: int = 0) -> np.ndarray:
    """``n`` random poses in the hexapod's workspace box (m, rad)."""
    rng = np.random.default_rng(seed)
    box = np.array(get("hexapod").workspace)
    return box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, 6))


def best_of(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(n: int = 200_000) -> None:
    timings: dict = {}
    t0 = time.perf_counter()
    render_robot("hexapod", timings=timings)
    t = timings["hexapod"]
    print(
        f"generation: {time.perf_counter() - t0:.1f} s (derive {t['derive_s']:.1f} s, CSE {t['cse_s']:.1f} s, "
        f"render {t['emit_s']:.1f} s)"
    )
    c = eigentwist.load("hexapod", backend="c", threads=1)
    py = eigentwist.load("hexapod", backend="numpy")
    np.set_printoptions(precision=2, suppress=True, linewidth=120)
    for model in ("paper", "none"):
        for name, p in (("home", HOME), ("tilted", TILTED)):
            f = c.frequencies(p, model)[0]
            assert np.allclose(f, py.frequencies(p, model)[0], rtol=1e-10)
            print(f"{model:5s} {name:6s} {p}: {f} Hz")
    P = poses(n)
    c.frequencies(P[:1000])
    t_c = best_of(lambda: c.frequencies(P))
    m = min(n, 50_000)
    t_np = best_of(lambda: py.frequencies(P[:m]), repeat=1) * n / m
    print(f"C fused pass, one core: {n / t_c:,.0f} poses/s to six frequencies ({n} poses in {t_c:.3f} s)")
    print(f"NumPy backend: {n / t_np:,.0f} poses/s (timed on {m} poses); C / NumPy = {t_np / t_c:.1f}x")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200_000)
