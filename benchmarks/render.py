"""Rendering a robot's generated files: the code printers' term order.

    PYTHONPATH=. python benchmarks/render.py                      # every shipped robot, 3 rounds
    PYTHONPATH=. python benchmarks/render.py --robots heli4 --rounds 5

For each robot: derive and CSE once (``render_robot``'s stages), then render the NumPy
module, the C source and the C header from those stages, alternately with the printers in
SymPy's stored term order (``PRINT_ORDER = "none"``, what ``eigentwist generate`` uses) and
in the printers' default (``"lex"``, every sum re-sorted as it is printed). CPU time
(``time.process_time``), best of ``--rounds``, and the ratio in the same run. The two texts
differ only in the order of terms and factors; each order's text is the same in every round.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _render(name: str, stages: dict, order: str) -> tuple[float, dict]:
    from eigentwist.codegen import c_source, numpy_backend
    from eigentwist.codegen.generate import render_robot

    saved = c_source.PRINT_ORDER, numpy_backend.PRINT_ORDER
    c_source.PRINT_ORDER = numpy_backend.PRINT_ORDER = order
    try:
        t = time.process_time()
        files = render_robot(name, stages=stages)
        return time.process_time() - t, files
    finally:
        c_source.PRINT_ORDER, numpy_backend.PRINT_ORDER = saved


def main(argv=None) -> int:
    from eigentwist.codegen.generate import fused_kernels_for, kernels_for
    from eigentwist.robots import NAMES, get
    from eigentwist.symbolic import derive

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(NAMES), help="comma-separated shipped robots")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"{'robot':10s} {'derive+CSE [s]':>15s} {'render, none [s]':>17s} {'render, lex [s]':>16s} {'lex/none':>9s}")
    for name in args.robots.split(","):
        t = time.process_time()
        model = derive(get(name))
        stages = {"model": model, "kernels": kernels_for(model), "fused": fused_kernels_for(model)}
        prepared = time.process_time() - t
        best = {"none": float("inf"), "lex": float("inf")}
        texts: dict = {}
        for k in range(args.rounds):
            for order in ("none", "lex") if k % 2 == 0 else ("lex", "none"):
                dt, files = _render(name, stages, order)
                best[order] = min(best[order], dt)
                if texts.setdefault(order, files) != files:
                    raise SystemExit(f"{name}: the {order!r} render differs between rounds")
        print(f"{name:10s} {prepared:15.2f} {best['none']:17.2f} {best['lex']:16.2f} {best['lex'] / best['none']:9.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
