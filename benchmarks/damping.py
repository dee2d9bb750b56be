"""Damping: the paper's diagnosis before and after, the servo's alternatives, the damping
effects' seeded study and the damped modes' throughput.

    PYTHONPATH=. python benchmarks/damping.py                   # everything
    PYTHONPATH=. python benchmarks/damping.py --skip-seeds      # without the seeded study (~minutes)
    PYTHONPATH=. python benchmarks/damping.py --throughput-only # section 4 alone (~1 minute)
    PYTHONPATH=. python benchmarks/damping.py --exact-routes    # the exact condensation's C routes
    PYTHONPATH=. python benchmarks/damping.py --loss-routes     # a loss factor: C and NumPy solvers

1. ``diagnose paper`` with the embedded data as the paper took them (``kind`` = damped: counted
   from camera frames of step responses) and the same values read as undamped natural
   frequencies (the reading without damping): chi2/nu, RMS, the selected effects, c_a.
2. The paper's final model (actuator_loss, ee_compliance; k_E_rot and k_E_lin fitted) with the
   stated c_a = 3 N m s/rad, with c_a fitted, with a torque lag t_d fitted beside c_a = 3 and
   with both fitted: chi2/nu, RMS, the values and where the model is stable.
3. The seeded study of the damping effects (tests/test_diagnose.py's scenarios, seeds 4, 5, 6).
4. Poses/s of ``Evaluator.modes`` with and without servo damping, same run, CPU time
   (``time.process_time``), fresh random poses for every repetition (each pose its own k_a,
   so no two rows share a condition), best of 5 interleaved repetitions, NumPy and C backends;
   models ``rigid``, ``paper`` (no rigid direction: the fused C pass solves the damped modes
   itself) and the paper's final ``actuator_loss,ee_compliance`` (the exact condensation) (the C backend
   solves the damped modes by its compiled driver, :mod:`eigentwist.runtime.c_damped`).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import eigentwist  # noqa: E402
from eigentwist.diagnose import diagnose, paper_measurements, synth  # noqa: E402
from eigentwist.diagnose.fit import fit  # noqa: E402

PAPER = ("actuator_loss", "ee_compliance")
X_REF = np.array([0.0, 0.0, -0.625])


def _line(label, f):
    vals = ", ".join(f"{k} = {v:.4g} ± {f.std[k]:.2g}" for k, v in f.values.items())
    return f"| {label} | {f.reduced_chi2:.2f} | {f.rms_pct:.2f} | {vals} |"


def paper_before_after(ev):
    print("## 1. diagnose paper: damped (as measured) and read as undamped\n")
    print("| data read as | chi2/nu | RMS % | selected | c_a (N m s/rad) |\n|---|---|---|---|---|")
    meas = paper_measurements(ev)
    undamped = meas.subset(np.arange(len(meas)))
    undamped.kind = ("undamped",) * len(meas)
    for label, m in (("undamped (no damping)", undamped), ("damped (step responses)", meas)):
        t = time.process_time()
        d = diagnose(m, "rigid", ev=ev)
        f = d.final
        c = f"{f.values['c_a']:.2f} ± {f.std['c_a']:.2f}" if "c_a" in f.values else "-"
        print(
            f"| {label} | {f.reduced_chi2:.2f} | {f.rms_pct:.2f} | {', '.join(d.selected)} | {c} |"
            f" <!-- {time.process_time() - t:.1f} s CPU -->"
        )


def servo_alternatives(ev):
    print("\n## 2. The paper's final model with servo damping and a torque lag\n")
    print("| model | chi2/nu | RMS % | fitted |\n|---|---|---|---|")
    meas = paper_measurements(ev)
    k_e = ("k_E_rot", "k_E_lin")
    print(_line("no damping", fit(meas, PAPER, ev, k_e)))
    print(_line("c_a = 3 (stated)", fit(meas, PAPER + ("servo_damping",), ev, k_e, fixed={"c_a": 3.0})))
    print(_line("c_a fitted", fit(meas, PAPER + ("servo_damping",), ev, k_e + ("c_a",))))
    lag = fit(
        meas, PAPER + ("servo_damping", "servo_delay"), ev, k_e + ("t_d",), fixed={"c_a": 3.0}, start={"t_d": 1e-3}
    )
    print(_line("c_a = 3, t_d fitted", lag))
    both = fit(meas, PAPER + ("servo_damping", "servo_delay"), ev, k_e + ("c_a", "t_d"), start={"t_d": 1e-3})
    print(_line("c_a and t_d fitted", both))
    ka = np.array([1000.0, 2000.0, 2200.0, 2400.0, 3000.0, 4000.0])
    for label, f in (("c_a = 3, t_d fitted", lag), ("both fitted", both)):
        m = ev.modes(
            np.tile(X_REF, (len(ka), 1)), PAPER + ("servo_damping", "servo_delay"), k_a=ka, vectors=False, **f.fixed
        )
        print(
            f"\n{label}: stable at k_a = {ka[m.stable].tolist()}, unstable at {ka[~m.stable].tolist()} "
            f"(c_a / t_d = {f.fixed.get('c_a', 3.0) / f.fixed['t_d']:.0f} N m/rad)"
        )


def seeded_study(ev):
    from test_diagnose import KA, MEASURED, NOISE, POSES, SCENARIOS

    print("\n## 3. Seeded study of the damping effects (seeds 4, 5, 6)\n")
    print("| effect | found in | CPU s |\n|---|---|---|")
    for effect in ("servo_damping", "servo_delay", "structural_loss"):
        truth, baseline, _, k_a = SCENARIOS[effect]
        t = time.process_time()
        found = 0
        for seed in (4, 5, 6):
            meas = synth(truth, k_a or KA, POSES, ("x", "y", "z"), NOISE, seed=seed, ev=ev, **MEASURED[effect])
            d = diagnose(meas, baseline, ev=ev)
            found += effect in d.selected or any(effect in s.alternatives for s in d.steps)
        print(f"| {effect} | {found}/3 | {time.process_time() - t:.1f} |")


def throughput(reps: int = 5):
    print("\n## 4. Poses/s of Evaluator.modes, one thread, CPU time (each pose its own k_a)\n")
    print("| backend | model | undamped | damped | ratio |\n|---|---|---|---|---|")
    rng = np.random.default_rng(1)
    n = 4096

    def fresh():  # new poses and k_a for every repetition (no cache of an earlier call helps)
        poses = np.column_stack(
            [rng.uniform(-0.08, 0.08, n), rng.uniform(-0.08, 0.08, n), rng.uniform(-0.68, -0.58, n)]
        )
        return poses, rng.uniform(125.0, 4000.0, n)

    for backend in ("numpy", "c"):
        ev = eigentwist.load("heli4", backend=backend, threads=1)
        for base in ("rigid", "paper", ",".join(PAPER)):  # the fused pass's two routes, the exact condensation
            best = {}
            for _ in range(reps):  # the two models interleaved, best CPU time of each
                for model in (base, base + ",servo_damping"):
                    poses, ka = fresh()
                    ev.modes(poses[:64], model, k_a=ka[:64], vectors=False)
                    t = time.process_time()
                    ev.modes(poses, model, k_a=ka, vectors=False)
                    best[model] = min(best.get(model, np.inf), time.process_time() - t)
            rates = [n / best[m] for m in (base, base + ",servo_damping")]
            print(f"| {backend} | {base} | {rates[0]:.3g} | {rates[1]:.3g} | {rates[1] / rates[0]:.2f} |")


def _two_routes(ev, rng, models, sizes, route_names, use, params: dict, reps: int):
    """Best CPU seconds per call of ``ev.modes`` on new poses and k_a for each model and of two
    routes, interleaved: ``use(True)`` switches to the second route of ``route_names``,
    ``use(False)`` to the first; ``sizes`` are (poses per call, calls) pairs. Prints a row per
    size and model."""
    for n, calls in sizes:
        best = {}
        for _ in range(reps):
            for model in models:
                for route in route_names:
                    use(route == route_names[1])
                    t = time.process_time()
                    for _ in range(calls):
                        poses = np.column_stack(
                            [rng.uniform(-0.08, 0.08, n), rng.uniform(-0.08, 0.08, n), rng.uniform(-0.68, -0.58, n)]
                        )
                        ev.modes(poses, model, k_a=rng.uniform(125.0, 4000.0, n), vectors=False, **params)
                    best[model, route] = min(best.get((model, route), np.inf), (time.process_time() - t) / calls)
        for model in models:
            a, b = (best[model, route] for route in route_names)
            rates = f"{n / a:.3g} ({a * 1e3:.2f} ms) | {n / b:.3g} ({b * 1e3:.2f} ms)"
            print(f"| {n} | {model} | {rates} | {a / b:.2f} |")


def exact_routes(reps: int = 7):
    """The exact condensation's two C-backend routes in one process, interleaved: its own C pass
    and the route with Python between the kernels (``one_pass_takes`` off), poses/s."""
    from eigentwist.runtime import damped_modes as dm

    print("\n## The exact condensation: its C pass against the Python route, one thread, CPU time\n")
    print("| poses per call | model | Python route | one C pass | ratio |\n|---|---|---|---|---|")
    ev = eigentwist.load("heli4", backend="c", threads=1)
    takes = dm.one_pass_takes

    def use(on: bool):
        dm.one_pass_takes = takes if on else (lambda *a: False)

    models = (",".join(PAPER), ",".join(PAPER) + ",servo_damping")
    try:
        _two_routes(ev, np.random.default_rng(1), models, ((4096, 1), (64, 40)), ("python", "pass"), use, {}, reps)
    finally:
        dm.one_pass_takes = takes


def loss_routes(reps: int = 7):
    """A structural loss factor on the C backend: the complex C solver against the NumPy one
    (``damped._compiled`` off for the NumPy route), interleaved in one process, poses/s."""
    from eigentwist.runtime import damped

    print("\n## A structural loss factor: the complex C solver against NumPy's, one thread, CPU time\n")
    print("| poses per call | model | NumPy solver | C solver | ratio |\n|---|---|---|---|---|")
    ev = eigentwist.load("heli4", backend="c", threads=1)
    compiled = damped._compiled

    def use(on: bool):
        damped._compiled = compiled if on else (lambda *a: False)

    models = ("paper,structural_loss", "damped,structural_loss", ",".join(PAPER) + ",structural_loss")
    try:
        _two_routes(
            ev, np.random.default_rng(2), models, ((4096, 1), (64, 20)), ("numpy", "c"), use, {"eta_s": 0.05}, reps
        )
    finally:
        damped._compiled = compiled


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-seeds", action="store_true")
    ap.add_argument("--skip-throughput", action="store_true")
    ap.add_argument("--throughput-only", action="store_true")
    ap.add_argument("--exact-routes", action="store_true", help="the exact condensation's two C routes alone")
    ap.add_argument("--loss-routes", action="store_true", help="a loss factor: the C and NumPy solvers alone")
    args = ap.parse_args()
    if args.exact_routes or args.loss_routes:
        if args.exact_routes:
            exact_routes()
        if args.loss_routes:
            loss_routes()
        return
    if args.throughput_only:
        throughput()
        return
    ev = eigentwist.load("heli4", backend="auto")
    paper_before_after(ev)
    servo_alternatives(ev)
    if not args.skip_seeds:
        seeded_study(ev)
    if not args.skip_throughput:
        throughput()


if __name__ == "__main__":
    main()
