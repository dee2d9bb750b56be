"""``eigentwist synth``: measurement data from a truth model with a hidden effect and noise."""

from __future__ import annotations

import argparse

from .common import CliError, add_set_option, declare_outputs, eprint
from .synth_uff import UFF_EPILOG, add_uff_options, run_uff

HELP = "synthesize measurements from a truth model with a hidden effect and noise (CSV)"
EPILOG = """The truth is PRESET[+EFFECT[:PARAM=VALUE,...]]...; any item may set parameters (SI units),
e.g. paper:m_e=0.7; `none` is the bare model. --set NAME=VALUE sets a parameter of the
truth as well (as :NAME=VALUE on an item; one name both ways with different values is an
error). Rows: every pose x k_a x mode; measured value
f_true (1 + noise N(0,1)) from a generator seeded by (seed, noise level), so two noise levels
draw independently; sigma_hz = sigma x value, sigma = noise unless --sigma states it apart
(e.g. --noise 3% --sigma 1%: uncertainty understated). Output columns:
k_a, mode, freq_hz, sigma_hz, x, y, z (the input of compare and diagnose), and kind with
--kind damped.

examples:
  eigentwist synth --truth paper+transmission_compliance:k_t=8000 --k-a 125,250,500,1000,2000,4000 \\
      --poses "0,0,-0.625 -0.1,0,-0.55" --modes x,y,z --noise 0.5% --seed 1 -o data.csv
  eigentwist diagnose data.csv --baseline paper
  eigentwist synth --truth paper --extra-stiffness x=300 --k-a 125,500,2000 -o cable.csv   # not in the catalogue
"""


def add_parser(sub):
    p = sub.add_parser(
        "synth",
        help=HELP,
        description=HELP,
        epilog=EPILOG + UFF_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--truth", required=True, metavar="SPEC", help="PRESET[+EFFECT:PARAM=VALUE,...] (see below)")
    p.add_argument(
        "--k-a",
        dest="k_a",
        nargs="+",
        required=True,
        metavar="KA",
        help="commanded actuator stiffnesses, N m/rad (revolute) or N/m (prismatic) (space- or comma-separated)",
    )
    p.add_argument(
        "--poses",
        nargs="+",
        default=[],
        metavar="'X,Y,Z ...'",
        help="end-effector positions, m, each X,Y,Z (hexapod: X,Y,Z,ROT_X,ROT_Y,ROT_Z, m and rad), "
        "separated by spaces or ';' inside one quoted "
        "argument (a value starting with '-' must be quoted with others or given with --pose)",
    )
    p.add_argument(
        "--pose",
        nargs="+",
        type=float,
        action="append",
        default=[],
        metavar="X",
        help="one pose (repeatable), added to --poses: X Y Z, m; for a 6-DoF robot (hexapod) "
        "X Y Z ROT_X ROT_Y ROT_Z, m and rad (the rotation vector)",
    )
    p.add_argument(
        "--modes", default="x,y,z", help="mode labels, comma-separated: ranks or x,y,z,rx,ry,rz (default: x,y,z)"
    )
    p.add_argument(
        "--noise", default="0.5%", help="relative noise (standard deviation), e.g. 0.5%% or 0.005 (default: 0.5%%)"
    )
    p.add_argument(
        "--sigma",
        default=None,
        metavar="P%",
        help="relative standard uncertainty written to sigma_hz, e.g. 1%% (default: the --noise value)",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.add_argument(
        "--kind",
        choices=("undamped", "damped"),
        default="undamped",
        help="what freq_hz is: undamped (omega_n/2pi, the default) or damped (omega_d/2pi, a free decay); "
        "they differ where the truth has a damping effect (servo_damping, servo_delay, structural_loss)",
    )
    p.add_argument(
        "--extra-stiffness",
        action="append",
        default=[],
        metavar="AXIS=K",
        help="add a spring to ground at the EE origin, N/m (x,y,z) or N m/rad (rx,ry,rz): "
        "an effect outside the catalogue (repeatable)",
    )
    p.add_argument(
        "--robot",
        default="heli4",
        help="robot: a shipped name (heli4, delta, hexapod) or a description file PATH.py defining describe() "
        "(default: heli4)",
    )
    add_set_option(p)
    p.add_argument("-o", "--output", metavar="DATA.csv", help="write here (default: print to stdout)")
    add_uff_options(p)
    declare_outputs(p, output="csv", uff="directory")
    p.set_defaults(func=run)


def _numbers(items, what: str) -> list[float]:
    out = []
    for item in items:
        for text in filter(None, (t.strip() for t in item.split(","))):
            try:
                out.append(float(text))
            except ValueError:
                raise CliError(f"{what} {text!r} is not a number") from None
    return out


def _poses(items, single, names=("x", "y", "z")) -> list[list[float]] | None:
    texts = [t for item in items for t in item.replace(";", " ").split()]
    if not texts and not single:
        return None
    for p in single:
        if len(p) != len(names):
            raise CliError(
                f"--pose {' '.join(f'{v:g}' for v in p)}: expected {len(names)} coordinates ({', '.join(names)})"
            )
    poses = [list(p) for p in single]
    for item in texts:
        vals = _numbers([item], "--poses value")
        if len(vals) != len(names):
            example = "0,0,-0.625" if len(names) == 3 else "0,0,0.8,0,0,0.1"
            raise CliError(
                f"--poses {item!r}: expected {','.join(n.upper() for n in names)} "
                f"({'m' if len(names) == 3 else 'm and rad'}), e.g. {example}"
            )
        poses.append(vals)
    return poses


def _extra(items) -> dict:
    out = {}
    for item in items:
        axis, sep, value = item.partition("=")
        if not sep:
            raise CliError(f"--extra-stiffness {item!r}: expected AXIS=K, e.g. x=300")
        out[axis.strip()] = _numbers([value], f"--extra-stiffness {axis.strip()}")[0]
    return out


def run(args) -> int:
    from .common import say
    from ..diagnose.synth import parse_noise, parse_truth, synth
    from ..diagnose.values import changed_text, used_parameters
    from .common import check_values, parse_sets
    from .compare import evaluator_of
    from .poses import warn_workspace

    ev = evaluator_of(args)
    values = check_values(parse_sets(args.set), ev)
    truth = parse_truth(args.truth, ev)
    for name, value in truth.values.items():
        if values.get(name, value) != value:
            raise CliError(f"--truth sets {name} = {value:g} and --set {name}={values[name]:g}: give it once")
    poses = _poses(args.poses, args.pose, ev.pose_names)
    if poses is not None:
        warn_workspace(ev, poses, "synth")
    if args.uff:
        if values:
            raise CliError(f"--set {', '.join(values)} with --uff: give the values in --truth (PRESET:NAME=VALUE)")
        return run_uff(args, ev, _numbers(args.k_a, "--k-a value"), poses)
    if args.sigma is None and parse_noise(args.noise, "--noise") == 0:
        eprint(
            f"eigentwist synth: note: --noise {args.noise} gives noise-free frequencies; sigma_hz is written as "
            "the 2 % default uncertainty (state another with --sigma, e.g. --sigma 0.5%)"
        )
    meas = synth(
        args.truth,
        _numbers(args.k_a, "--k-a value"),
        poses,
        [m for m in args.modes.split(",") if m.strip()],
        args.noise,
        args.seed,
        ev=ev,
        extra_stiffness=_extra(args.extra_stiffness) or None,
        sigma=args.sigma,
        values=values,
        kind=args.kind,
    )
    text = meas.to_csv(args.output)
    if args.output:
        say(f"wrote {len(meas)} rows to {args.output} (truth: {args.truth})")
        say(changed_text(used_parameters(ev, truth.effects, {**values, **truth.values}), ev.robot.name))
    else:
        print(text, end="")
    return 0
