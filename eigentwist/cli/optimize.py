"""``eigentwist optimize``: the design that maximises the worst-case lowest natural frequency."""

from __future__ import annotations

import argparse
import json
import re

import numpy as np

from .common import CliError, add_backend_option, add_jacobian_option, eprint, format_table, parse_sets

HELP = "maximise the worst-case lowest natural frequency over the workspace (exact gradients)"
EPILOG = """examples:
  eigentwist optimize --maximize worst-omega1 --vary l2=0.45:0.65 --vary r_o=0.004:0.006
  eigentwist optimize --vary l2=0.45:0.65 --constraint "moving-mass<=0.9" --grid 4
  eigentwist optimize --robot delta --model rigid --vary l1=0.15:0.3 --pose 0 0 -0.5 --pose 0.05 0 -0.5

Epigraph formulation: maximise t subject to f_k(p, x_j) >= t for every pose x_j and the
lowest --track modes k (one constraint per mode of a cluster), over the --vary box, with
SciPy's SLSQP (default) or trust-constr. Gradients are design sensitivities from central
differences of the generated matrices (eigenvalue perturbation, clusters of repeated
frequencies included; nothing derived at run time), or with --jacobian exact the generated
sensitivity kernel (derived on first use for the varied parameters and cached). \
Poses: --pose (repeatable) or a --grid N per axis of
the robot's workspace box (default 3); poses unreachable anywhere in the box are dropped.

The masses and inertias (kg, kg m, kg m^2) that are parameters of their own stay at their
values while the lengths move (a Delta's upper arm: l1 moves, m_1 and I1_* do not); a line
after the table names them (JSON: held_fixed). Vary them too to move them.

moving-mass (kg): the translational apparent mass at the reference pose x_ref, the mean of
the diagonal of M's translational 3x3 block (Eq. 12), with its exact gradient.
"""


def add_parser(sub):
    p = sub.add_parser(
        "optimize", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--robot", default="heli4", help="robot description (default: heli4)")
    add_backend_option(p)
    p.add_argument(
        "--pose",
        nargs="+",
        type=float,
        action="append",
        metavar="X",
        help="a workspace pose (repeatable): X Y Z (m) for a 3-DoF robot, X Y Z ROT_X ROT_Y ROT_Z "
        "(m, rad: rotation vector) for a 6-DoF robot (hexapod); default: --grid",
    )
    p.add_argument(
        "--k-a",
        type=float,
        dest="k_a",
        metavar="KA",
        help="commanded actuator stiffness in the robot's unit: N m/rad (revolute) or N/m (prismatic)",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="fix a design parameter in SI units, e.g. --set m_p=0.3 (repeatable)",
    )
    p.add_argument("--model", default="paper", help="preset (rigid, paper) or comma-separated effects (default: paper)")
    p.add_argument(
        "--maximize",
        default="worst-omega1",
        choices=("worst-omega1",),
        help="objective: the lowest natural frequency's minimum over the poses (default)",
    )
    p.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="NAME=LO:HI",
        help="a design variable and its range in SI units, e.g. --vary l2=0.45:0.65 (repeatable)",
    )
    p.add_argument(
        "--constraint",
        action="append",
        default=[],
        metavar="QUANTITY<=VALUE",
        help="e.g. moving-mass<=0.9 (kg); also >= (repeatable)",
    )
    p.add_argument(
        "--grid",
        type=int,
        default=None,
        metavar="N",
        help="N poses per axis of the workspace box (default 3 when no --pose is given)",
    )
    p.add_argument("--method", default="SLSQP", choices=("SLSQP", "trust-constr"), help="SciPy solver")
    p.add_argument("--track", type=int, default=2, help="lowest modes per pose in the epigraph (default 2)")
    p.add_argument("--maxiter", type=int, default=100, help="solver iterations (default 100)")
    add_jacobian_option(
        p,
        "gradients: central differences of the matrices (default: nothing derived) or the "
        "generated sensitivity kernel (derived and cached on first use)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def parse_vary(items):
    from ..design import Vary

    out = []
    for item in items:
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        try:
            if not (sep and sep2 and name.strip()):
                raise ValueError
            out.append(Vary(name.strip(), float(lo), float(hi)))
        except ValueError:
            raise CliError(f"--vary {item!r}: expected NAME=LO:HI with LO < HI, e.g. --vary l2=0.45:0.65") from None
    if not out:
        raise CliError("--vary: give at least one design variable, e.g. --vary l2=0.45:0.65")
    return out


def parse_constraints(items):
    from ..design import Constraint
    from ..design.optimize import QUANTITIES

    out = []
    for item in items:
        m = re.fullmatch(r"\s*([\w-]+)\s*(<=|>=)\s*([-+0-9.eE]+)\s*", item)
        if not m or m.group(1) not in QUANTITIES:
            raise CliError(f"--constraint {item!r}: expected QUANTITY<=VALUE with QUANTITY in {', '.join(QUANTITIES)}")
        out.append(Constraint(m.group(1), m.group(2), float(m.group(3))))
    return out


def _poses(args, ev) -> np.ndarray:
    from .poses import pose_argument

    robot = ev.robot
    if args.pose:
        if args.grid:
            raise CliError("give either --pose or --grid, not both")
        return np.array([pose_argument(ev, values) for values in args.pose])
    n = args.grid or 3
    if n < 1:
        raise CliError(f"--grid {n}: expected a positive number of poses per axis")
    axes = [np.linspace(lo, hi, n) if n > 1 else np.array([(lo + hi) / 2]) for lo, hi in robot.workspace]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(robot.pose))


def compute(args, progress=None):
    from ..description.effects import resolve_model
    from ..design import optimize_worst_case
    from ..runtime import load

    ev = load(args.robot, backend=args.backend)
    params = parse_sets(args.set)
    if args.k_a is not None:
        params["k_a"] = args.k_a
    vary = parse_vary(args.vary)
    constraints = parse_constraints(args.constraint)
    effects = resolve_model(args.model, ev.robot)
    poses = _poses(args, ev)
    res = optimize_worst_case(
        ev,
        vary,
        poses,
        effects,
        params,
        constraints,
        method=args.method,
        jacobian=args.jacobian,
        n_track=args.track,
        maxiter=args.maxiter,
        progress=progress,
    )
    return ev, effects, res


def run(args) -> int:
    from .common import say
    import time

    from ..design.fixed import held_fixed, held_fixed_line

    t0 = time.perf_counter()
    ev, effects, res = compute(args, progress=eprint)
    elapsed = time.perf_counter() - t0
    units = {name: ev.parameters[name].unit for name in res.values}
    if args.json:
        print(
            json.dumps(
                dict(
                    robot=ev.robot.name,
                    model=list(effects),
                    values=res.values,
                    units=units,
                    worst_hz=res.worst_hz,
                    start=res.start,
                    start_worst_hz=res.start_worst_hz,
                    poses=res.poses.tolist(),
                    f1_hz=res.f1_hz.tolist(),
                    active=res.active,
                    constraints=res.constraints,
                    success=res.success,
                    message=res.message,
                    nit=res.nit,
                    evaluations=res.evaluations,
                    dropped_poses=res.dropped_poses,
                    seconds=elapsed,
                    held_fixed=held_fixed(ev, list(res.values), effects),
                )
            )
        )
        return 0
    say(
        f"{ev.robot.name}, model {', '.join(effects)}: maximise the worst-case f1 over {len(res.poses)} poses"
        + (f" ({res.dropped_poses} dropped: unreachable in the box)" if res.dropped_poses else "")
    )
    say(
        f"solver: {args.method}, {res.nit} iterations, {res.evaluations} kernel evaluations, {elapsed:.1f} s; "
        f"{'converged' if res.success else 'NOT converged'}: {res.message}\n"
    )
    rows = [[name, f"{res.start[name]:.6g}", f"{value:.6g}", units[name]] for name, value in res.values.items()]
    say(format_table(["parameter", "start", "best", "unit"], rows))
    line = held_fixed_line(ev, list(res.values), effects, parse_sets(args.set))
    if line:
        say(f"note: {line}")
    say(f"\nworst-case f1: {res.start_worst_hz:.6g} Hz at the start -> {res.worst_hz:.6g} Hz")
    for name, value in res.constraints.items():
        say(f"{name}: {value:.6g} kg")
    say("\nf1 per pose at the best design (Hz):")
    pose_units = ["m"] * 3 + ["rad"] * (res.poses.shape[1] - 3)
    say(
        format_table(
            [f"{n} ({u})" for n, u in zip(ev.robot.pose, pose_units)] + ["f1 (Hz)"],
            [[f"{c:.4g}" for c in pose] + [f"{f:.6g}"] for pose, f in zip(res.poses, res.f1_hz)],
        )
    )
    say("\nactive constraints:")
    for a in res.active:
        say(f"  {a}")
    return 0
