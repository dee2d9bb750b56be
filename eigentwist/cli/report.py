"""``eigentwist report [DATA.csv] [-o report.html]``: one self-contained HTML report."""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from .common import MODEL_SYNTAX, declare_outputs, add_backend_option, add_set_option, format_table, progress

HELP = "write a self-contained HTML report: model, paper reproduction, comparison, diagnosis"
EPILOG = """examples:
  eigentwist report                          # Heli4 with the paper's embedded measurements -> report.html
  eigentwist report my_data.csv -o out.html --model paper --baseline rigid
  eigentwist report delta_data.csv --robot delta
  eigentwist report --set l2=0.60 -o l2_060.html  # a design change: the parameter table shows l2 = 0.6

DATA.csv: one measured natural frequency per row, columns k_a (N m/rad, or N/m for a prismatic actuator), mode (1..6 or
x, y, z, rx, ry, rz), freq_hz (Hz), optional x, y, z (m), sigma_hz (Hz) and parameter columns.
DATA may also be a modal-test campaign's MANIFEST.csv (UFF files, see `eigentwist identify --help`;
needs the modal extra): its modes are identified first, as `eigentwist identify` does, and the
report adds a campaign section (stabilisation diagrams, FRF fits, MAC):
  eigentwist report campaign/manifest.csv -o campaign.html --baseline paper
"""


def add_parser(sub):
    p = sub.add_parser(
        "report", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("data", nargs="?", help="measurement CSV (default: the robot's embedded measurements)")
    p.add_argument("-o", "--output", default="report.html", help="HTML file to write (default: report.html)")
    p.add_argument(
        "--robot",
        default="heli4",
        help="robot: a shipped name (heli4, delta, hexapod) or a description file PATH.py defining describe() "
        "(default: heli4)",
    )
    p.add_argument("--model", default="paper", help=f"model compared with the data: {MODEL_SYNTAX} (default: paper)")
    p.add_argument("--baseline", default="rigid", help="where the diagnosis starts, same syntax (default: rigid)")
    add_backend_option(p)
    add_set_option(p)
    declare_outputs(p, output="html")
    p.set_defaults(func=run)


def run(args) -> int:
    from .common import say
    from ..diagnose.values import changed_text
    from ..report import build_report, write_report

    from ..runtime import load
    from .common import CliError, model_and_values

    ev = load(args.robot, backend=args.backend)
    effects, values = model_and_values(args.model, args.set, ev)
    baseline, base_values = model_and_values(args.baseline, args.set, ev, "--baseline")
    for name, value in base_values.items():
        if values.get(name, value) != value:
            raise CliError(f"--model and --baseline set {name} to {values[name]:g} and {value:g}: give it once")
    rep = build_report(
        args.data,
        robot=args.robot,
        model=effects,
        baseline=baseline,
        backend=args.backend,
        progress=progress,
        values={**values, **base_values},
        command=" ".join(["eigentwist", *map(shlex.quote, getattr(args, "argv", None) or ["report"])]),
    )
    path = write_report(args.output, rep)
    d = rep.diagnosis
    rows = [
        [
            "compared model",
            " + ".join(rep.model),
            rep.comparison["summary"]["rms_pct"],
            rep.comparison["summary"]["max_pct"],
        ]
    ]
    for k, s in enumerate(d["steps"]):
        rows.append([f"diagnosis step {k}", " + ".join(s["effects"]) or "(no effect)", s["rms_pct"], s["max_pct"]])
    say(format_table(["", "effects", "RMS error [%]", "max error [%]"], rows, ".3g"))
    say(changed_text(rep.parameters, rep.robot))
    if rep.reproduction:
        say(f"paper reproduction: {rep.reproduction['summary']}")
    say("\n".join(rep.answer.get("lines", [])))
    say(f"report written to {Path(path).resolve()}")
    return 0
