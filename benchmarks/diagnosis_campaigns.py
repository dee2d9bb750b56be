"""The diagnosis over noise seeds, and its CPU time (recorded in benchmarks/README.md).

    nice python benchmarks/diagnosis_campaigns.py                 # everything (about 30 min of CPU)
    python benchmarks/diagnosis_campaigns.py --seeds 3 --no-cases --no-clean --no-timing

* the single-fault cases (``tests/diagnosis_cases.py``: ``CASES``), 10 noise seeds each: right
  in n of 10 (``tests/test_diagnose_seeds.py`` runs the first few seeds of each);
* two-fault campaigns (``tests/diagnosis_cases.py``: ``hexapod_struts``,
  ``heli4_actuator_transmission``), 10 noise seeds each: right in n of 10, the CPU time of
  each diagnosis and whether the subset search changed the stepwise result;
* the clean campaigns (truth = baseline, 0.5 % and 2 % noise, 20 seeds each): nothing added;
* CPU time (``time.process_time``, BLAS on one thread, after a warm-up on other data) of
  ``diagnose`` on the paper's measurements from ``rigid`` (``eigentwist diagnose paper``), and
  of the README walkthrough (30 rows, a hidden payload) on three noise seeds.
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
from eigentwist.diagnose.measurements import paper_measurements  # noqa: E402
from tests import diagnosis_cases as cases  # noqa: E402


def two_faults(n: int) -> None:
    if n <= 0:
        return
    for name, (robot, case) in cases.TWO_FAULTS.items():
        ev = eigentwist.load(robot, backend="auto")
        right, cpu, changed = 0, [], 0
        for seed in range(n):
            t = time.process_time()
            d, ok, why = case(ev, seed)
            cpu.append(time.process_time() - t)
            right += ok
            changed += bool(getattr(d, "search", None) and d.search.changed)
            print(f"  {name} seed {seed}: {'right' if ok else 'WRONG'} {cpu[-1]:.1f} s CPU; {why}", flush=True)
        print(
            f"{name}: right in {right}/{n} seeds; search changed the stepwise result in {changed}; "
            f"CPU per diagnosis {min(cpu):.1f}-{max(cpu):.1f} s (median {sorted(cpu)[len(cpu) // 2]:.1f} s)",
            flush=True,
        )


def single_faults(n: int) -> None:
    ev = eigentwist.load("heli4", backend="auto")
    for name, case in cases.CASES.items():
        results = cases.run(case, ev, range(n))
        wrong = [(seed, why) for seed, ok, why in results if not ok]
        print(f"{name}: right in {n - len(wrong)}/{n} seeds" + (f"; wrong: {wrong}" if wrong else ""), flush=True)


def clean(n: int) -> None:
    ev = eigentwist.load("heli4", backend="auto")
    for noise, offset in ((0.005, 0), (0.02, 1000)):
        ok = sum(cases.baseline_truth(ev, offset + s, noise)[1] for s in range(n))
        print(f"truth = baseline, noise {noise:.1%}: nothing added in {ok}/{n} seeds", flush=True)


def timing() -> None:
    ev = eigentwist.load("heli4", backend="auto")
    # a warm-up on other data (imports, the compiled kernels): the timed calls then meet cold
    # content-keyed memos, as a first diagnosis of their data does
    other = synth("paper+payload_mass:m_p=0.2", cases.KA, cases.POSES, cases.XYZ, 0.005, seed=99, ev=ev)
    diagnose(other, "paper", ev=ev)
    t = time.process_time()
    d = diagnose(paper_measurements(ev), "rigid", ev=ev)
    cpu = time.process_time() - t
    print(f"paper's measurements from rigid: {cpu:.2f} s CPU (one run); selected {', '.join(d.selected)}", flush=True)
    cpus = []
    for seed in (3, 4, 5):  # new data for every repetition
        walk = synth("paper+payload_mass:m_p=0.35", cases.KA, cases.POSES, cases.XYZ, 0.005, seed=seed, ev=ev)
        t = time.process_time()
        d = diagnose(walk, "paper", ev=ev)
        cpus.append(time.process_time() - t)
    print(
        f"README walkthrough from paper (seeds 3, 4, 5): {', '.join(f'{c:.2f}' for c in cpus)} s CPU; "
        f"selected {', '.join(d.selected) or 'nothing'}",
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--clean-seeds", type=int, default=20)
    ap.add_argument("--no-cases", action="store_true")
    ap.add_argument("--no-clean", action="store_true")
    ap.add_argument("--no-timing", action="store_true")
    args = ap.parse_args()
    if not args.no_timing:
        timing()
    if not args.no_cases:
        single_faults(args.seeds)
    two_faults(args.seeds)
    if not args.no_clean:
        clean(args.clean_seeds)


if __name__ == "__main__":
    main()
