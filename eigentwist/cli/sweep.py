"""``eigentwist sweep``: natural frequencies over designs x k_a x workspace poses, in chunks."""

from __future__ import annotations

import argparse

from .common import (
    MODEL_SYNTAX,
    CliError,
    declare_outputs,
    add_backend_option,
    add_set_option,
    eprint,
    format_table,
    model_and_values,
    progress,
)

HELP = "sweep designs, k_a and workspace poses in chunks of bounded memory (.npz or Parquet)"
EPILOG = """examples:
  eigentwist sweep --grid 10 10 10 --k-a 500:4000:8 --vary l2=0.45:0.60:16 -o l2_sweep --lowest
  eigentwist sweep --random 1000000 --seed 1 --backend c -o poses.parquet
  eigentwist sweep --random 100000 --vary l1=0.18,0.2,0.22 --engine dask --workers 2 -o out
  eigentwist sweep --grid 5 5 5 --engine dask --scheduler tcp://10.0.0.5:8786 -o out

Rows are the Cartesian product designs x k_a x poses (poses fastest). Units: poses and
box in m, k_a in the robot's unit (N m/rad revolute, N/m prismatic actuators), \
design parameters in SI units (see `eigentwist matrices`),
frequencies in Hz. Values: a list A,B,C or a range LO:HI:N (N values, ends included).
Unreachable or singular poses do not stop the sweep: their rows are NaN, reachable=0.

Output: a directory with manifest.json, chunk-NNNNNN.npz (arrays pose, k_a, design,
freq_hz, direction, reachable, pose_index, case) and lowest.npz; or, for OUT.parquet,
one Parquet file (columns x, y, z, k_a, <varied>, f1_hz.., dir1.., reachable,
pose_index, case) and OUT.lowest.parquet. Read either with
eigentwist.runtime.sweep.load_sweep(OUT). Parquet needs pip install "eigentwist[parquet]",
the dask engine pip install "eigentwist[dask]".
"""


def add_parser(sub):
    p = sub.add_parser(
        "sweep", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--robot",
        default="heli4",
        help="robot: a shipped name (heli4, delta, hexapod) or a description file PATH.py defining describe() "
        "(default: heli4)",
    )
    add_backend_option(p)
    p.add_argument("--model", default="paper", help=f"{MODEL_SYNTAX} (default: paper)")
    poses = p.add_mutually_exclusive_group()
    poses.add_argument(
        "--grid",
        nargs="+",
        type=int,
        metavar="N",
        help="regular grid of poses over the box, ends included, one count per pose coordinate: NX NY NZ "
        "(a 6-DoF robot: six counts, or three for positions with the rotation mid-box); "
        "an axis of 1 point sits mid-box (default: 5 5 5; hexapod 3 per axis)",
    )
    poses.add_argument("--random", type=int, metavar="N", help="N uniform random poses in the box")
    p.add_argument("--seed", type=int, default=0, help="seed of --random (default: 0)")
    p.add_argument(
        "--box",
        nargs="+",
        type=float,
        metavar="LO HI",
        help="workspace box of the poses: XLO XHI YLO YHI ZLO ZHI in m; a 6-DoF robot (hexapod) adds "
        "ROT_XLO ROT_XHI ROT_YLO ROT_YHI ROT_ZLO ROT_ZHI in rad (default: the robot's workspace)",
    )
    p.add_argument(
        "--k-a",
        dest="k_a",
        metavar="VALUES",
        help="commanded actuator stiffness (N m/rad revolute, N/m prismatic): 500,1000,2000 or 500:4000:8 "
        "(default: the robot's)",
    )
    p.add_argument(
        "--vary",
        action="extend",
        nargs="+",
        default=[],
        metavar="NAME=VALUES",
        help="design parameter to vary, SI units: l2=0.45:0.60:16 or l2=0.5,0.55 (repeatable)",
    )
    add_set_option(
        p,
        help="fix a design parameter for every row, SI units: NAME=VALUE, e.g. --set m_e=0.6, or one "
        "leg's NAME@N=VALUE, e.g. --set eta_a@3=0.5 (repeatable)",
    )
    p.add_argument(
        "--chunk-size",
        type=int,
        default=None,
        metavar="ROWS",
        help="rows per chunk, bounds the memory (default: 65536: about 400 MB peak RSS with the "
        "NumPy backend, 230 MB with C)",
    )
    p.add_argument(
        "--engine",
        default="inprocess",
        choices=("inprocess", "dask"),
        help="where chunks run: this process, or a Dask cluster (default: inprocess)",
    )
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786 (default: a local cluster)"
    )
    p.add_argument(
        "--workers", type=int, metavar="N", help="worker processes of the local Dask cluster (default: one per CPU)"
    )
    p.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help="output: a directory of .npz chunks, or a file ending in .parquet",
    )
    p.add_argument(
        "--overwrite", "--force", action="store_true", dest="overwrite", help="replace an existing sweep at OUT"
    )
    declare_outputs(p, force=False, output="")
    p.add_argument(
        "--lowest",
        action="store_true",
        help="print per design the worst-case lowest frequency over the poses and where it occurs",
    )
    p.add_argument(
        "--top",
        type=int,
        default=20,
        metavar="N",
        help="with --lowest, print the N designs with the highest worst case (default: 20)",
    )
    p.set_defaults(func=run)


def spec_from_args(args):
    from ..runtime.sweep import DEFAULT_CHUNK_SIZE, make_spec
    from .sweep_args import parse_values, parse_vary

    if args.engine == "inprocess" and (args.scheduler or args.workers):
        raise CliError("--scheduler and --workers apply to --engine dask")
    if args.scheduler and args.workers:
        raise CliError("--workers sizes the local cluster: it cannot be combined with --scheduler")
    from ..diagnose.evaluators import evaluator

    effects, fixed = model_and_values(args.model, args.set, evaluator(args.robot))
    return make_spec(
        args.robot,
        model=",".join(effects) or "none",
        backend=args.backend,
        grid=args.grid,
        random=args.random,
        seed=args.seed,
        box=args.box,
        k_a=None if args.k_a is None else parse_values(args.k_a, f"--k-a {args.k_a!r}"),
        vary=[parse_vary(item) for item in args.vary],
        fixed=fixed,
        chunk_size=args.chunk_size or DEFAULT_CHUNK_SIZE,
    )


def lowest_table(low: dict, spec, top: int) -> str:
    """Designs sorted by worst-case lowest frequency, best first, at most ``top`` rows; a
    model with damping adds the lowest damped frequency and the least damped mode (its
    damping ratio and mode number) over the poses."""
    import numpy as np

    from ..runtime.evaluator import AXES
    from ..runtime.sweep.columns import pose_columns

    order = np.argsort(-np.nan_to_num(low["freq_hz"], nan=-np.inf), kind="stable")[: max(top, 0)]
    rows = []
    for c in order:
        where = "-" if low["pose_index"][c] < 0 else "[" + ", ".join(f"{v:.4f}" for v in low["pose"][c]) + "]"
        label = AXES[low["direction"][c]] if low["direction"][c] >= 0 else "-"
        rows.append(
            [
                *low["design"][c],
                low["k_a"][c],
                low["freq_hz"][c],
                label,
                where,
                f"{low['n_reachable'][c] / spec.n_poses:.1%}",
            ]
        )
        if "damped_hz" in low:
            found = low["damping_ratio_mode"][c] >= 0
            least = f"{low['damping_ratio'][c]:.3g} (mode {low['damping_ratio_mode'][c] + 1})" if found else "-"
            rows[-1][-1:-1] = [low["damped_hz"][c], least]
    unit = "m, rad" if any(c.startswith("rot") for c in pose_columns(spec)) else "m"
    headers = [*spec.design_names, "k_a", "lowest Hz", "mode 1", f"at pose ({unit})", "reachable"]
    if "damped_hz" in low:
        headers[-1:-1] = ["lowest damped Hz", "least zeta"]
    return format_table(headers, rows)


def fixed_text(spec) -> str:
    """The parameters set for every row, beside the robot's defaults (one line)."""
    from ..description.effects import resolve_model
    from ..diagnose.evaluators import evaluator
    from ..diagnose.values import changed_text, used_parameters

    ev = evaluator(spec.robot)
    text = changed_text(used_parameters(ev, resolve_model(spec.model, ev.robot), dict(spec.fixed)), spec.robot)
    return text + (f"; varied: {', '.join(spec.design_names)}" if spec.design_names else "")


def run(args) -> int:
    from .common import say
    from ..runtime.sweep import OutputExistsError, open_writer, run_sweep

    spec = spec_from_args(args)
    try:
        writer = open_writer(args.output, spec, overwrite=args.overwrite)
    except OutputExistsError as exc:
        raise CliError(str(exc).replace("pass overwrite=True", "give --overwrite")) from None
    with progress(total=spec.n_rows, unit="row", unit_scale=True, desc="sweep") as bar:
        summary = run_sweep(
            spec,
            writer,
            engine=args.engine,
            scheduler=args.scheduler,
            workers=args.workers,
            on_chunk=lambda i, result: bar.update(len(result["case"])),
        )
    eprint(
        f"{spec.n_rows} rows ({spec.n_cases} designs x k_a, {spec.n_poses} poses) in {spec.n_chunks} chunks, "
        f"{summary.n_reachable / max(spec.n_rows, 1):.1%} reachable, {summary.seconds:.2f} s "
        f"({summary.rows_per_second:,.0f} poses/s, backend {summary.backend}, engine {args.engine}) -> {args.output}"
    )
    eprint(fixed_text(spec))
    if args.lowest:
        shown = min(args.top, spec.n_cases)
        say(
            f"worst-case lowest natural frequency over {spec.n_poses} poses, per design "
            f"({shown} of {spec.n_cases}, highest first; all in {args.output}):"
        )
        say(lowest_table(summary.lowest, spec, args.top))
    return 0
