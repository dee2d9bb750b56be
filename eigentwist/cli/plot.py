"""``eigentwist plot modes``: the robot at a pose and its lowest mode shapes, as a picture
(PNG), an animation for slides (``--gif``) or for a web page (``--svg``)."""

from __future__ import annotations

import argparse

from .common import add_model_options, declare_outputs

HELP = "draw the robot and its lowest mode shapes: PNG, animated GIF (--gif) or animated SVG (--svg)"
EPILOG = """The robot is drawn from its description (legs, inverse kinematics); each mode shape moves the
platform along its eigentwist, a_i + s (v + omega x a_i), scaled so that the largest attachment
displacement is --amplitude times the link length l2 (a mode shape has no absolute size).

examples:
  eigentwist plot modes -o modes.png                       # the Heli4 at x_ref, paper model, k_a = 2000 N m/rad
  eigentwist plot modes --gif -o modes.gif --k-a 500       # animated, for slides (Matplotlib + Pillow)
  eigentwist plot modes --svg -o modes.svg --model rigid   # animated SVG (SMIL), opens in any browser
  eigentwist plot modes --robot hexapod --pose 0 0 0.8 0 0 0 --k-a 2e7 --gif -o hexapod.gif
"""


def add_parser(sub):
    p = sub.add_parser(
        "plot", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("what", choices=("modes",), help="what to draw: modes (the lowest mode shapes)")
    add_model_options(p)
    p.add_argument(
        "-o", "--output", help="file to write (default: modes.png, modes.gif with --gif, modes.svg with --svg)"
    )
    kind = p.add_mutually_exclusive_group()
    kind.add_argument("--gif", action="store_true", help="write an animated GIF (for slides)")
    kind.add_argument("--svg", action="store_true", help="write an animated SVG (self-contained, no script)")
    p.add_argument("--modes", type=int, default=3, metavar="N", help="number of lowest modes drawn (default: 3)")
    p.add_argument(
        "--amplitude",
        type=float,
        default=0.2,
        help="largest displacement drawn, as a fraction of the link length l2 (default: 0.2)",
    )
    declare_outputs(p, output="image")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..runtime import load
    from ..outputs import check_output, write_atomic
    from .common import CliError, input_paths, model_and_values, say
    from .poses import check_pose, pose_argument
    from ..plots.robot import stiffness_argument, stiffness_text

    if args.modes < 1:
        raise CliError(f"--modes {args.modes}: expected a number of modes >= 1")
    if not args.amplitude > 0:
        raise CliError(f"--amplitude {args.amplitude:g}: expected a positive fraction of l2, e.g. 0.2")
    ev = load(args.robot, backend=args.backend)
    pose = pose_argument(ev, args.pose)
    effects, params = model_and_values(args.model, args.set, ev)
    k_a = args.k_a if args.k_a is not None else params.pop("k_a", ev.defaults.get("k_a"))
    params.pop("k_a", None)
    check_pose(ev, pose, effects, {**params, **stiffness_argument(ev, k_a)}, "plot")
    model = ",".join(effects)
    out = args.output or ("modes.gif" if args.gif else "modes.svg" if args.svg else "modes.png")
    check_output(out, "image", input_paths(args, ("output",)), force=args.force)
    if args.gif:
        from ..plots.animate import modes_gif

        modes_gif(ev, pose, out, model, k_a=k_a, n_modes=args.modes, amplitude=args.amplitude, **params)
    elif args.svg:
        from ..plots.animate import modes_svg

        write_atomic(out, modes_svg(ev, pose, model, k_a=k_a, n_modes=args.modes, amplitude=args.amplitude, **params))
    else:
        from ..plots import plot_modes

        plot_modes(ev, pose, out, model=model, k_a=k_a, n_modes=args.modes, amplitude=args.amplitude, **params)
    say(
        f"wrote {out}: {ev.robot.title} at {[round(float(v), 6) for v in pose]}, "
        f"model {' + '.join(effects) or '(none)'}, "
        f"{stiffness_text(ev, k_a)}{args.modes} lowest modes"
    )
    return 0
