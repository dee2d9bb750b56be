"""The diagnosis with exact Jacobians against central differences.

    PYTHONPATH=. python benchmarks/diagnosis_jacobian.py                 # C and NumPy backends
    PYTHONPATH=. python benchmarks/diagnosis_jacobian.py --backends c --repeat 1

Two data sets, each diagnosed from the ``rigid`` baseline (what ``eigentwist diagnose``
does by default): the paper's embedded measurements (``eigentwist diagnose paper``) and a
synthetic 30-row campaign (``paper`` + a 0.35 kg payload, 5 k_a values x 2 poses x 3
directions, 0.5 % noise, seed 3: the one ``benchmarks/diagnosis.py`` times).

For each backend: the **cold** run first (a fresh cache directory, so the exact run
generates, and for C compiles, the sensitivity kernel of the catalogue's fitted
parameters; the evaluator's own library is compiled before the clock starts), then the
**warm** runs, best of ``--repeat``, with ``fit.EXACT_JACOBIAN`` False (central
differences) and True (exact). Printed: CPU time of the process and the compiler (a shared
machine inflates wall time, not CPU time), the fits by Jacobian kind (exact, or
differences with the reason), the batched evaluations (nfev), the selected effects and the
largest relative difference of a fitted value between the two kinds. One thread.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import collections
import importlib
import resource
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


class _Recorder:
    """Collects every fit objective of a diagnosis (its Jacobian kind and evaluations)."""

    def __init__(self, fit_module):
        self.module = fit_module
        self.original = fit_module._Objective
        self.objectives: list = []
        recorder = self

        class Recording(self.original):
            def __init__(self, *a, **k):
                super().__init__(*a, **k)
                recorder.objectives.append(self)

        self.recording = Recording

    def __enter__(self):
        self.objectives.clear()
        self.module._Objective = self.recording
        return self

    def __exit__(self, *exc):
        self.module._Objective = self.original

    def summary(self) -> str:
        kinds = collections.Counter("exact" if o.exact else f"differences ({o.fallback[:60]})" for o in self.objectives)
        nfev = sum(o.nfev for o in self.objectives)
        return f"{len(self.objectives)} fits: " + ", ".join(f"{n} {k}" for k, n in kinds.items()) + f"; nfev {nfev}"


def _data(ev):
    from eigentwist.diagnose import synth
    from eigentwist.diagnose.measurements import paper_measurements

    return {
        "paper data": paper_measurements(ev),
        "synthetic 30 rows": synth(
            "paper+payload_mass:m_p=0.35",
            (250, 500, 1000, 2000, 4000),
            ((0, 0, -0.625), (0.06, -0.04, -0.6)),
            ("x", "y", "z"),
            0.005,
            seed=3,
            ev=ev,
        ),
    }


def _fitted(d) -> dict:
    return dict(d.final.values)


def _run(meas, ev, exact: bool, rec: _Recorder):
    from eigentwist.diagnose import diagnose

    fit_module = importlib.import_module("eigentwist.diagnose.fit")

    fit_module.EXACT_JACOBIAN = exact
    with rec:
        t = _cpu()
        d = diagnose(meas, "rigid", ev=ev)
        cpu = _cpu() - t
    return cpu, d, rec.summary()


def _cpu() -> float:
    """CPU seconds of this process and its finished children (the compiler): robust to a shared machine."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + r.ru_utime + r.ru_stime


def bench(backend: str, repeat: int) -> None:
    import eigentwist

    fit_module = importlib.import_module("eigentwist.diagnose.fit")
    from eigentwist.runtime import sensitivity as sens

    os.environ["EIGENTWIST_CACHE"] = tempfile.mkdtemp(prefix="eigentwist-bench-")
    sens._MEMORY.clear()
    ev = eigentwist.load("heli4", backend=backend)
    rec = _Recorder(fit_module)
    for name, meas in _data(ev).items():
        print(f"{name} ({len(meas)} rows), backend {backend}, from rigid:")
        if name == "paper data":  # the first exact run pays the generation
            cpu, d, what = _run(meas, ev, True, rec)
            print(f"  cold cache, exact:        {cpu:7.2f} s CPU  {what}; selected {', '.join(d.selected)}")
        runs = {}
        for exact in (False, True):
            best = None
            for _ in range(repeat):
                cpu, d, what = _run(meas, ev, exact, rec)
                if best is None or cpu < best[0]:
                    best = (cpu, d, what)
            runs[exact] = best
            label = "exact" if exact else "central differences"
            print(f"  warm cache, {label:20s} {best[0]:7.2f} s CPU  {best[2]}; selected {', '.join(best[1].selected)}")
        a, b = _fitted(runs[False][1]), _fitted(runs[True][1])
        same = runs[False][1].selected == runs[True][1].selected
        diff = max((abs(b[k] - a[k]) / max(abs(a[k]), 1e-300) for k in a if k in b), default=0.0)
        print(
            f"  speed-up (differences / exact, warm): {runs[False][0] / runs[True][0]:.2f}x; same selection: "
            f"{same}; largest relative difference of a fitted value: {diff:.1e}"
        )
    fit_module.EXACT_JACOBIAN = True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--backends", default="c,numpy")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    for backend in args.backends.split(","):
        bench(backend, args.repeat)


if __name__ == "__main__":
    main()
