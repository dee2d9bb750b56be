"""Rendering a robot's generated files: the code printers' term order; the matrices' CSE.

    PYTHONPATH=. python benchmarks/render.py                      # every shipped robot, 3 rounds
    PYTHONPATH=. python benchmarks/render.py --robots heli4 --rounds 5
    PYTHONPATH=. python benchmarks/render.py --cse --robots heli4,examples/robots/rus6.py

For each robot: derive and CSE once (``render_robot``'s stages), then render the NumPy
module, the C source and the C header from those stages, alternately with the printers in
SymPy's stored term order (``PRINT_ORDER = "none"``, what ``eigentwist generate`` uses) and
in the printers' default (``"lex"``, every sum re-sorted as it is printed). CPU time
(``time.process_time``), best of ``--rounds``, and the ratio in the same run. The two texts
differ only in the order of terms and factors; each order's text is the same in every round.

``--cse``: for each robot (a shipped name or a description file), derive once, then time the
two kernels that hold the matrices built the way ``cse_kernels`` builds them (one CSE of
``matrices_lever``, the ``matrices`` kernel its part) against one CSE of each, alternated,
SymPy's cache cleared before each, CPU time, best of ``--rounds``; the statements of each
kernel both ways.
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


def _description(name: str):
    from eigentwist.robots import get
    from eigentwist.runtime.userfile import describe_file

    return describe_file(name) if name.endswith(".py") else get(name)


def _matrix_kernels(model, shared: bool) -> dict:
    """The kernels holding the matrices, one CSE (``matrices_kernels``) or one each:
    {name: statements}."""
    from eigentwist.codegen.generate import KERNEL_DOCS, SYMMETRIC, joints_per_leg, matrices_kernels, pose_split
    from eigentwist.codegen.kernel import Output, build_kernel

    if shared:
        matrices, fused = matrices_kernels(model)
        kernels = [*fused, matrices]
    else:
        position, rotation = pose_split(model)
        params = list(model.inputs) + [s.name for s in position] + rotation
        nq = joints_per_leg(model)
        kernels = []
        for name, extra in (("matrices_lever", [("lever", model.outputs["jacobians"]["lever"])]), ("matrices", [])):
            outs = [Output(k, sh, ex, symmetric=k in SYMMETRIC) for k, (sh, ex) in model.outputs["matrices"].items()]
            outs += [Output(k, sh, ex) for k, (sh, ex) in extra]
            doc = KERNEL_DOCS[name]
            kernels.append(build_kernel(name, doc, model.program, outs, [], model.joints, params, nq))
    return {k.name: sum(item[0] == "let" for item in k.body) for k in kernels}


def cse(names: list[str], rounds: int) -> None:
    """``--cse``: one CSE of the matrices and levers against one each (module doc)."""
    from sympy.core.cache import clear_cache

    from eigentwist.symbolic import derive

    print(f"{'robot':28s} {'one CSE [s]':>12s} {'one each [s]':>13s} {'ratio':>6s}  statements (one CSE / one each)")
    for name in names:
        model = derive(_description(name))
        if "lever" not in model.outputs["jacobians"]:
            print(f"{name:28s} no levers: one CSE of the matrices either way")
            continue
        best = {True: float("inf"), False: float("inf")}
        counts = {}
        for k in range(rounds):
            for shared in (True, False) if k % 2 == 0 else (False, True):
                clear_cache()
                t = time.process_time()
                counts[shared] = _matrix_kernels(model, shared)
                best[shared] = min(best[shared], time.process_time() - t)
        sizes = ", ".join(f"{n} {counts[True][n]}/{counts[False][n]}" for n in counts[True])
        print(f"{name:28s} {best[True]:12.2f} {best[False]:13.2f} {best[True] / best[False]:6.2f}  {sizes}")


def main(argv=None) -> int:
    from eigentwist.codegen.generate import cse_kernels
    from eigentwist.robots import NAMES, get
    from eigentwist.symbolic import derive

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(NAMES), help="comma-separated shipped robots (--cse: or files)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cse", action="store_true", help="time the matrices' and levers' CSE (module doc)")
    args = ap.parse_args(argv)
    if args.cse:
        cse(args.robots.split(","), args.rounds)
        return 0
    print(f"{'robot':10s} {'derive+CSE [s]':>15s} {'render, none [s]':>17s} {'render, lex [s]':>16s} {'lex/none':>9s}")
    for name in args.robots.split(","):
        t = time.process_time()
        model = derive(get(name))
        kernels, fused = cse_kernels(model)
        stages = {"model": model, "kernels": kernels, "fused": fused}
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
