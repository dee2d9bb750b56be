"""The diagnosis' Jacobian kinds side by side, cold and warm, as a user runs them.

    PYTHONPATH=. python benchmarks/diagnosis_kinds.py            # every case, both kinds
    PYTHONPATH=. python benchmarks/diagnosis_kinds.py --cases paper,walkthrough

Each case is ``eigentwist diagnose ...`` run as a separate process (the command line, NumPy
backend, one thread), for each Jacobian kind (``--jacobian differences`` / ``exact``) with its
own fresh ``EIGENTWIST_CACHE``: the **cold** run first (a new user's first diagnosis: the exact
kind derives and renders its sensitivity kernel there), then the **warm** run (a second process
on the same cache). Printed: CPU time of the child process (user + system, s: a shared machine
inflates wall time, not CPU time), wall time, and whether the two kinds selected the same
effects. The cases:

* ``paper``: the paper's embedded measurements from the rigid model (``diagnose paper``);
* ``walkthrough``: the README's 30-row synthetic campaign (paper + a 0.35 kg payload, 5 k_a x
  2 poses x 3 directions, 0.5 % noise, seed 3) from ``--baseline paper``;
* ``per-leg``: the same campaign with leg 3's actuator weakened (``actuator_loss@3``,
  eta_a@3 = 0.5) instead of the payload, from ``--baseline paper``;
* ``hexapod``: the hexapod with an 8 kg payload (2 k_a x 2 poses x 6 modes, 0.2 % noise).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WALK = [
    "--k-a",
    "250,500,1000,2000,4000",
    "--pose",
    "0",
    "0",
    "-0.625",
    "--pose",
    "0.06",
    "-0.04",
    "-0.6",
    "--modes",
    "x,y,z",
    "--noise",
    "0.5%",
    "--seed",
    "3",
]
HEX = [
    "--robot",
    "hexapod",
    "--k-a",
    "1e7,2e7",
    "--poses",
    "0,0,0.8,0,0,0;0.05,0,0.78,0,0.05,0.1",
    "--modes",
    "1,2,3,4,5,6",
    "--noise",
    "0.2%",
    "--seed",
    "1",
]
CASES = {
    "paper": (None, ["paper"]),
    "walkthrough": (["--truth", "paper+payload_mass:m_p=0.35", *WALK], ["{csv}", "--baseline", "paper"]),
    "per-leg": (["--truth", "paper+actuator_loss@3:eta_a@3=0.5", *WALK], ["{csv}", "--baseline", "paper"]),
    "hexapod": (["--truth", "paper+payload_mass:m_p=8", *HEX], ["{csv}", "--robot", "hexapod", "--baseline", "paper"]),
}


def _env(cache: Path) -> dict:
    env = dict(
        os.environ,
        EIGENTWIST_CACHE=str(cache),
        OMP_NUM_THREADS="1",
        OPENBLAS_NUM_THREADS="1",
        MKL_NUM_THREADS="1",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    return env


def _cli(args, env) -> tuple[float, float, str]:
    """(CPU s, wall s, stdout) of one ``python -m eigentwist ARGS`` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-m", "eigentwist", *args], env=env, check=True, capture_output=True, text=True
    ).stdout
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated subset of " + ", ".join(CASES))
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="et-kinds-") as tmp:
        tmp = Path(tmp)
        for case in args.cases.split(","):
            synth_args, diag_args = CASES[case]
            csv = tmp / f"{case}.csv"
            if synth_args:
                _cli(["synth", *synth_args, "-o", str(csv)], _env(tmp / "synth-cache"))
            selected = {}
            for kind in ("differences", "exact"):
                env = _env(tmp / f"cache-{case}-{kind}")
                cmd = ["diagnose", *[a.format(csv=csv) for a in diag_args], "--jacobian", kind, "--json"]
                for run in ("cold", "warm"):
                    cpu, wall, out = _cli(cmd, env)
                    selected[kind] = json.loads(out)["final"]["effects"]
                    rows.append((case, kind, run, cpu, wall))
                    print(f"{case:12s} {kind:12s} {run:5s} CPU {cpu:6.1f} s  wall {wall:6.1f} s", flush=True)
            print(
                f"{case:12s} same selection: {selected['differences'] == selected['exact']} "
                f"({', '.join(selected['differences'])})",
                flush=True,
            )
    print("\n| case | Jacobian | cold CPU (s) | warm CPU (s) |\n|---|---|---|---|")
    for case in dict.fromkeys(r[0] for r in rows):
        for kind in ("differences", "exact"):
            cold, warm = (next(r[3] for r in rows if r[:3] == (case, kind, run)) for run in ("cold", "warm"))
            print(f"| {case} | {kind} | {cold:.1f} | {warm:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
