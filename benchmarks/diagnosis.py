"""Figures of the diagnosis cases: each case right in n of 10 seeds; the time of a 30-row diagnosis.

    python benchmarks/diagnosis.py              # every case, 10 seeds, and the timings
    python benchmarks/diagnosis.py --cases bad_row,four_rows --seeds 20

The cases are those of ``tests/test_diagnose_seeds.py`` (``tests/diagnosis_cases.py``).
Timings: CPU time of the process (``time.process_time``, best of 3, BLAS on one thread), so
that other work on the machine does not inflate them; the walkthrough's 30-row file from
the ``rigid`` model (28 candidates: the full catalogue, each leg-level effect also on each
leg alone) and from ``paper`` (25).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import eigentwist  # noqa: E402
from eigentwist.diagnose import diagnose, synth  # noqa: E402
from tests import diagnosis_cases as cases  # noqa: E402


def seeds(ev, names, n) -> None:
    for name in names:
        results = cases.run(cases.CASES[name], ev, range(n))
        print(f"{name}: right in {sum(ok for _, ok, _ in results)}/{n} seeds")
        for seed, ok, why in results:
            if not ok:
                print(f"    seed {seed}: {why}")
    for noise in (0.005, 0.02):
        offset = {0.005: 0, 0.02: 1000}[noise]
        ok = sum(cases.baseline_truth(ev, offset + s, noise)[1] for s in range(2 * n))
        print(f"truth = baseline, noise {noise:.1%}: nothing added in {ok}/{2 * n} seeds")


def timing() -> None:
    for backend in ("c", "numpy"):
        ev = eigentwist.load("heli4", backend=backend)
        meas = synth(
            "paper+payload_mass:m_p=0.35",
            (250, 500, 1000, 2000, 4000),
            ((0, 0, -0.625), (0.06, -0.04, -0.6)),
            ("x", "y", "z"),
            0.005,
            seed=3,
            ev=ev,
        )
        for baseline in ("rigid", "paper"):
            best = float("inf")
            for _ in range(3):
                t = time.process_time()
                d = diagnose(meas, baseline, ev=ev)
                best = min(best, time.process_time() - t)
            print(
                f"30-row diagnosis, backend {backend}, from {baseline} ({len(d.ranking)} candidates): "
                f"{best:.2f} s CPU; selected {', '.join(d.selected)}"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(cases.CASES))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--no-timing", action="store_true")
    args = ap.parse_args()
    seeds(eigentwist.load("heli4", backend="auto"), [c for c in args.cases.split(",") if c], args.seeds)
    if not args.no_timing:
        timing()


if __name__ == "__main__":
    main()
