"""Sensitivity throughput (all parameters, C, one thread), generation, compile and memory.

    PYTHONPATH=. python benchmarks/sensitivity.py                  # Heli4 and Delta, warm cache
    PYTHONPATH=. python benchmarks/sensitivity.py --cold --n 2000  # fresh cache: generation + compile

For each robot and the paper model: the time to generate (SymPy: derive, CSE of M and K,
the reverse sweep, render) and compile (gcc, the kernel split into functions of ``CHUNK``
statements) the C kernel that ``Evaluator.sensitivities`` uses for every parameter of the
description (:mod:`eigentwist.codegen.adjoint`), the peak resident memory of this process
and of the compiler, then, best of 5 repetitions (the methods alternated within each), each
on its own ``--n`` random workspace poses:

- ``Evaluator.frequencies`` (the baseline: IK, M, K_F, eigen-solve, C backend),
- ``Evaluator.sensitivities`` (checks, M and K, eigen-solve, one weighting of the kernel
  per mode, cluster-aware dω/dp),
- ``Evaluator.sensitivities(lowest=1)`` (the lowest mode's derivatives only: one weighting
  of the kernel a pose; what a study of the lowest frequency asks for),
- ``Evaluator.sensitivities(method="differences")`` (central differences of the matrices,
  the same eigenvalue perturbation; nothing generated),

as poses/s and as the ratio to the baseline of the same run. One thread (BLAS and OpenMP
on one thread; the C code is single-threaded), so CPU time (``time.process_time``) is the
core's time even on a shared machine; generation and compile: wall clock and CPU time of
the process and of the compiler (children).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _best(fn, pose_sets) -> float:
    """Best CPU time per pose of ``fn(poses)`` over the pose sets, one call each (one thread:
    CPU time is the time a core spent)."""
    best = float("inf")
    for poses in pose_sets:
        t = time.process_time()
        fn(poses)
        best = min(best, (time.process_time() - t) / len(poses))
    return best


def run(robot: str, n: int, wrt_kind: str) -> dict:
    import numpy as np

    import eigentwist
    from eigentwist.cli.sensitivity import default_wrt
    from eigentwist.codegen.sensitivity import CHUNK
    from eigentwist.description.effects import resolve_model
    from eigentwist.runtime.sensitivity import sensitivity_kernels

    ev = eigentwist.load(robot, backend="c")
    wrt = tuple(ev.parameters) if wrt_kind == "all" else default_wrt(ev, resolve_model("paper", ev.robot))
    rng = np.random.default_rng(16)
    lo = np.array([a for a, _ in ev.robot.workspace])
    hi = np.array([b for _, b in ev.robot.workspace])
    sets = []
    for _ in range(6):  # the first set warms the kernels; each repetition gets new poses
        poses = lo + (hi - lo) * rng.random((n, len(lo)))
        sets.append(poses[ev.valid(poses)])
    poses = sets[0]

    t, c, k = time.perf_counter(), time.process_time(), _children_cpu()
    kind = ev.stiffness_model("paper")  # the model every timed call below asks for (the hexapod's: rigid)
    sensitivity_kernels(ev, wrt, progress=lambda m: print("   ", m, file=sys.stderr, flush=True), kind=kind)
    gen = dict(
        wall_s=time.perf_counter() - t,
        python_cpu_s=time.process_time() - c,
        compiler_cpu_s=_children_cpu() - k,
        python_peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        compiler_peak_mb=resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
    )

    for fn in (
        ev.frequencies,
        lambda x: ev.sensitivities(x, wrt),
        lambda x: ev.sensitivities(x, wrt, lowest=1),
        lambda x: ev.sensitivities(x, wrt, method="differences"),
    ):
        fn(sets[0])
    # the methods alternate within each repetition, so each ratio compares the same minutes
    # of a shared machine
    methods = {
        "freq": ev.frequencies,
        "sens": lambda x: ev.sensitivities(x, wrt),
        "low": lambda x: ev.sensitivities(x, wrt, lowest=1),
        "diff": lambda x: ev.sensitivities(x, wrt, method="differences"),
    }
    best = {k: float("inf") for k in methods}
    for poses in sets[1:]:
        for k, fn in methods.items():
            best[k] = min(best[k], _best(fn, [poses]))
    t_freq, t_sens, t_low, t_diff = best["freq"], best["sens"], best["low"], best["diff"]
    return dict(
        robot=robot,
        wrt=len(wrt),
        chunk=CHUNK,
        poses=len(poses),
        generate_and_compile=gen,
        frequencies=1 / t_freq,
        sensitivities=1 / t_sens,
        lowest=1 / t_low,
        differences=1 / t_diff,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default="heli4,delta")
    ap.add_argument("--n", type=int, default=2000, help="random workspace poses (unreachable ones dropped)")
    ap.add_argument(
        "--wrt",
        choices=("all", "default"),
        default="all",
        help="every parameter, or the CLI's default list (eigentwist sensitivity without --wrt)",
    )
    ap.add_argument("--cold", action="store_true", help="a fresh cache directory: time generation and compile")
    args = ap.parse_args()
    if args.cold:
        os.environ["EIGENTWIST_CACHE"] = tempfile.mkdtemp(prefix="eigentwist-bench-")
    for robot in args.robots.split(","):
        r = run(robot, args.n, args.wrt)
        g = r["generate_and_compile"]
        print(f"{robot}: {r['wrt']} parameters, {r['poses']} poses, C backend, one thread")
        print(
            f"  kernel {'generated and compiled' if args.cold else 'loaded'} in {g['wall_s']:.1f} s wall "
            f"({g['python_cpu_s']:.1f} s Python CPU, {g['compiler_cpu_s']:.1f} s compiler CPU; "
            f"{r['chunk']} statements per C function; peak memory {g['python_peak_mb']:.0f} MB Python, "
            f"{g['compiler_peak_mb']:.0f} MB compiler)"
        )
        print(f"  frequencies (baseline)      {r['frequencies']:10.4g} poses/s")
        print(
            f"  Evaluator.sensitivities     {r['sensitivities']:10.4g} poses/s  "
            f"({r['sensitivities'] / r['frequencies']:.3f}x)"
        )
        print(f"  ... lowest=1                {r['lowest']:10.4g} poses/s  ({r['lowest'] / r['frequencies']:.3f}x)")
        print(
            f"  ... method='differences'    {r['differences']:10.4g} poses/s  "
            f"({r['differences'] / r['frequencies']:.3f}x)"
        )


if __name__ == "__main__":
    main()
