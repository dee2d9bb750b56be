"""``eigentwist compare``: a model beside measured natural frequencies, row by row."""

from __future__ import annotations

import argparse
import json

from .common import (
    MODEL_SYNTAX,
    CliError,
    add_backend_option,
    add_set_option,
    declare_outputs,
    model_and_values,
    progress,
)

HELP = "compare a model with measured natural frequencies (table, RMS/max error, Fig. 6 style plot)"
DATA_HELP = """DATA.csv: one measured frequency per row, header on line 1. Columns:
  k_a       commanded actuator stiffness, N m/rad (revolute) or N/m (prismatic) (required)
  mode      rank 1, 2, ... (1 = the model's lowest mode) or direction x, y, z, rx, ry, rz:
            the mode carrying the largest share of its energy along that axis (required)
  freq_hz   measured natural frequency, Hz (required)
  x, y, z   end-effector position in the base frame, m (optional; default the robot's x_ref)
  rot_x, rot_y, rot_z  the hexapod's rotation vector, rad (optional; default the robot's x_ref)
  sigma_hz  standard uncertainty, Hz (optional; default 2 % of freq_hz)
  <param>   any model parameter name (e.g. m_e, l2; per leg eta_a@3), SI units: overrides it
            for that row (and wins over --set); its effect must be in the model
  phi_x, phi_y, phi_z  measured mode shape at the sensor (optional, e.g. from `eigentwist identify`):
            rows are matched to model modes by shape (largest MAC), the table adds the MAC
  sensor_x, sensor_y, sensor_z  the sensor's offset from the end-effector origin, m (optional)
  kind      undamped (default: freq_hz is omega_n/2pi) or damped (omega_d/2pi: a free decay, a
            step response); each row is compared with the model's frequency of its kind
  damping_ratio  identified modal damping (optional): compared with the model's (a model with
            servo_damping, servo_delay or structural_loss), sigma_damping_ratio its uncertainty
            (default: the larger of 20 % of it and 0.005)
Separator ',', ';' or tab (with ';' or tab a decimal comma is accepted); UTF-8 (BOM
allowed) or UTF-16 with BOM. Two rows with the same pose, k_a and mode are an error.
Use `paper` as DATA to load the paper's measurements shipped with eigentwist
(Tables E.1/E.2: modes x and y at x_ref, k_a = 125 ... 4000 N m/rad)."""
EPILOG = (
    DATA_HELP
    + """

error = (predicted - measured) / measured (the paper's App. E); a row fails when
|predicted - measured| > 2 sigma. With mode-shape columns (phi_x, phi_y, phi_z, e.g. from
`eigentwist identify`), rows are matched to model modes by shape (largest MAC) and the
table adds the MAC between measured and model shape (transported to sensor_x/y/z).

examples:
  eigentwist compare paper --model rigid          # 13.6 % RMS, 32.9 % max
  eigentwist compare paper --model paper --plot fig6.png
  eigentwist compare paper --model paper --set l2=0.60     # same as --model paper:l2=0.60
  eigentwist compare data.csv --model rigid,ee_compliance,payload_mass --json
"""
)


def add_data_options(p: argparse.ArgumentParser) -> None:
    """DATA, --robot and --backend (shared with diagnose)."""
    p.add_argument("data", metavar="DATA.csv", help="measurements (see below), or `paper`")
    p.add_argument(
        "--robot",
        default="heli4",
        help="robot: a shipped name (heli4, delta, hexapod) or a description file PATH.py defining describe() "
        "(default: heli4)",
    )
    add_backend_option(p)
    add_set_option(p)


def add_parser(sub):
    p = sub.add_parser(
        "compare", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_data_options(p)
    p.add_argument("--model", default="paper", help=f"{MODEL_SYNTAX} (default: paper)")
    p.add_argument("--plot", metavar="FILE.png", help="write a Fig. 6 style plot")
    p.add_argument("--json", action="store_true", help="print one JSON object (rows, rms_pct, max_pct, failing)")
    declare_outputs(p, plot="image")
    p.set_defaults(func=run)


def load_data(args, values: dict | None = None):
    """(evaluator, measurements) from the DATA argument; errors become one line.

    ``values`` (SI, from ``--set``) fill blank parameter cells and check the poses.
    """
    from pathlib import Path

    from ..diagnose.measurements import load_measurements, paper_csv, parse_csv

    from .poses import warn_workspace

    ev = evaluator_of(args)
    if args.data == "paper" and not Path(args.data).exists():
        return ev, parse_csv(paper_csv(ev.robot.name), f"{ev.robot.name}_paper.csv", ev, values=values)
    if not Path(args.data).is_file():
        raise CliError(f"{args.data}: no such file (expected a CSV file of measurements, or `paper`)")
    meas = load_measurements(args.data, ev.robot.name, ev, values, progress=progress)
    warn_workspace(ev, meas.poses, getattr(args, "command", "compare"))
    return ev, meas


def evaluator_of(args):
    """The cached evaluator of ``--robot`` (a shipped name or a description file PATH.py)
    and ``--backend``; an unknown name is a one-line error with the closest names."""
    from ..diagnose.evaluators import evaluator

    return evaluator(args.robot, getattr(args, "backend", "numpy"))


def to_json(cmp, parameters: list) -> dict:
    from ..text import json_safe

    m = cmp.meas
    rows = [
        {
            "line": int(m.lines[i]),
            "k_a": m.k_a[i],
            "pose": m.poses[i].tolist(),
            "mode": m.mode[i],
            "model_mode": int(cmp.mode_index[i]) + 1,
            "measured_hz": m.freq_hz[i],
            "sigma_hz": m.sigma_hz[i],
            "predicted_hz": cmp.predicted[i],
            "error_pct": cmp.error_pct[i],
            "error_sigma": cmp.error_sigma[i],
            "fails": bool(cmp.failing[i]),
        }
        for i in range(len(m))
    ]
    if getattr(cmp, "mac", None) is not None:  # measured mode shapes
        for row, value in zip(rows, cmp.mac):
            row["mac"] = value
    if getattr(cmp, "zeta", None) is not None:  # the model's damping ratio of each row's mode
        for i, row in enumerate(rows):
            row["kind"], row["model_damping_ratio"] = m.kind[i], cmp.zeta[i]
    return json_safe(
        {
            "robot": m.robot,
            "source": m.source,
            "model": list(cmp.effects),
            "rows": rows,
            "rms_pct": cmp.rms_pct,
            "max_pct": cmp.max_pct,
            "chi2": cmp.chi2,
            "failing": cmp.where_it_fails(),
            "parameters": parameters,
        }
    )


def run(args) -> int:
    from .common import say
    from ..diagnose.compare import compare
    from ..diagnose.verdict import comparison_summary, comparison_table, failing_text

    from ..diagnose.values import changed_text, used_parameters

    effects, values = model_and_values(args.model, args.set, evaluator_of(args))
    ev, meas = load_data(args, values)
    cmp = compare(meas, effects, ev, values)
    parameters = used_parameters(ev, effects, values, meas)
    if args.plot:
        from ..diagnose.plots import plot_comparison

        plot_comparison(cmp, args.plot, ev)
    if args.json:
        print(json.dumps(to_json(cmp, parameters), allow_nan=False))
        return 0
    say(
        f"{meas.robot}: {len(meas)} measured frequencies from {meas.source}; model: "
        f"{', '.join(cmp.effects) or '(no effect)'} ({ev.stiffness_model(cmp.effects)})"
    )
    say(changed_text(parameters, meas.robot) + "\n")
    say(comparison_table(cmp))
    say("\n" + comparison_summary(cmp))
    say("where it fails:\n" + "\n".join("  " + t for t in failing_text(cmp)))
    if args.plot:
        say(f"plot: {args.plot}")
    return 0
