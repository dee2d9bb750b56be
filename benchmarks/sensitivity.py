"""Sensitivity throughput (all parameters, one thread) and generation/compile time.

    PYTHONPATH=. python benchmarks/sensitivity.py                  # Heli4 and Delta, warm cache
    PYTHONPATH=. python benchmarks/sensitivity.py --cold --n 2000  # fresh cache: generation (+ compile)
    PYTHONPATH=. python benchmarks/sensitivity.py --method compare # reverse and forward kernels

For each robot: the time to generate the kernel of ``--method``: ``reverse`` (the adjoint
kernel that ``Evaluator.sensitivities`` uses: one backward sweep per mode, every
parameter; a NumPy module, nothing compiled) or ``forward`` (forward mode, one tangent per
parameter, C compiled in functions of ``CHUNK`` statements), or both (``compare``); then,
best of 3 repetitions, each on its own ``--n`` random workspace poses:

- ``Evaluator.frequencies`` (the baseline: IK, M, K_F, eigen-solve, C backend),
- the raw kernel (reverse: M, K and the gradients of 6 seeds per pose; forward: M, K and
  dM/dp, dK/dp for every parameter),
- ``Evaluator.sensitivities`` (checks, adjoint kernel, eigen-solve and cluster-aware dω/dp),
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


def run(robot: str, n: int, wrt_kind: str, method: str) -> dict:
    import numpy as np

    import eigentwist
    from eigentwist.cli.sensitivity import default_wrt
    from eigentwist.codegen.sensitivity import CHUNK
    from eigentwist.description.effects import resolve_model
    from eigentwist.runtime.adjoint import adjoint_kernel
    from eigentwist.runtime.sensitivity import sensitivity_kernels

    ev = eigentwist.load(robot, backend="c")
    wrt = tuple(ev.parameters) if wrt_kind == "all" else default_wrt(ev, resolve_model("paper", ev.robot))
    rng = np.random.default_rng(16)
    lo = np.array([a for a, _ in ev.robot.workspace])
    hi = np.array([b for _, b in ev.robot.workspace])
    sets = []
    for _ in range(4):  # the first set warms the kernels; each repetition gets new poses
        poses = lo + (hi - lo) * rng.random((n, 3))
        sets.append(poses[ev.valid(poses)])
    say = lambda m: print("   ", m, file=sys.stderr, flush=True)  # noqa: E731
    gen, kern = {}, {}
    for m in ("reverse", "forward") if method == "compare" else (method,):
        t, c, k = time.perf_counter(), time.process_time(), _children_cpu()
        kern[m] = adjoint_kernel(ev, progress=say) if m == "reverse" else sensitivity_kernels(ev, wrt, progress=say)
        gen[m] = dict(
            wall_s=time.perf_counter() - t, python_cpu_s=time.process_time() - c, compiler_cpu_s=_children_cpu() - k
        )

    def raw(m):
        def call(x):
            p = ev._with_pose(x, ev._params(len(x), {}, "paper"))
            if m == "forward":
                kern[m](x[:, 0], x[:, 1], x[:, 2], p)
            else:
                kern[m].matrices(x[:, 0], x[:, 1], x[:, 2], p)
                kern[m].gradient(x[:, 0], x[:, 1], x[:, 2], p, np.ones((len(x), 6, 63)))

        return call

    fns = {
        "frequencies": ev.frequencies,
        **{f"kernel_{m}": raw(m) for m in kern},
        "sensitivities": lambda x: ev.sensitivities(x, wrt),
        "differences": lambda x: ev.sensitivities(x, wrt, method="differences"),
    }
    for fn in fns.values():
        fn(sets[0])
    rates = {name: 1 / _best(fn, sets[1:]) for name, fn in fns.items()}
    return dict(robot=robot, wrt=len(wrt), chunk=CHUNK, poses=len(sets[1]), generate=gen, rates=rates)


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
    ap.add_argument("--method", choices=("reverse", "forward", "compare"), default="reverse")
    ap.add_argument("--cold", action="store_true", help="a fresh cache directory: time generation and compile")
    args = ap.parse_args()
    if args.cold:
        os.environ["EIGENTWIST_CACHE"] = tempfile.mkdtemp(prefix="eigentwist-bench-")
    for robot in args.robots.split(","):
        r = run(robot, args.n, args.wrt, args.method)
        print(f"{robot}: {r['wrt']} parameters, {r['poses']} poses, one thread")
        for m, g in r["generate"].items():
            print(
                f"  {m} kernel {'generated' if args.cold else 'loaded'} in {g['wall_s']:.1f} s wall "
                f"({g['python_cpu_s']:.1f} s Python CPU, {g['compiler_cpu_s']:.1f} s compiler CPU"
                + (f"; {r['chunk']} statements per C function)" if m == "forward" else "; NumPy, nothing compiled)")
            )
        base = r["rates"]["frequencies"]
        for name, rate in r["rates"].items():
            print(f"  {name:<28}{rate:10.4g} poses/s  ({rate / base:.4f}x)")


if __name__ == "__main__":
    main()
