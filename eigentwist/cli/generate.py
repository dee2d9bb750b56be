"""``eigentwist generate [--check]``: regenerate the evaluators in eigentwist/generated."""

from __future__ import annotations

import difflib
import time

from .common import CliError, eprint, progress

HELP = "regenerate the evaluators in eigentwist/generated (derivation + CSE + emit)"
EPILOG = """examples:
  eigentwist generate            # rewrite eigentwist/generated/*
  eigentwist generate --check    # exit 1 and name the stale files if regeneration would change them
  eigentwist generate --robot my_heli4.py   # generate a description file's evaluators into the cache
"""


def add_parser(sub):
    p = sub.add_parser(
        "generate",
        help=HELP,
        description=HELP,
        epilog=EPILOG,
        formatter_class=__import__("argparse").RawDescriptionHelpFormatter,
    )
    p.add_argument("--check", action="store_true", help="compare only; exit 1 naming stale files")
    p.add_argument(
        "--robot",
        action="append",
        help="only this robot (repeatable; default: all shipped ones); a description file PATH.py is "
        "generated into the cache instead (as on its first use by any command)",
    )
    p.add_argument("--diff", action="store_true", help="with --check, print a unified diff")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..codegen.generate import GENERATED, PROGRESS_STEPS, render_all, stale, write
    from ..robots import NAMES

    from ..runtime.userfile import is_description_file

    files = [r for r in args.robot or () if is_description_file(r)]
    if files:
        if args.check or len(files) != len(args.robot):
            raise CliError("--robot PATH.py: generate description files alone, without --check or shipped robots")
        return _generate_files(files)
    robots = args.robot or list(NAMES)
    for r in robots:
        if r not in NAMES:
            raise CliError(f"--robot {r!r}: expected one of {', '.join(NAMES)} or a description file PATH.py")
    timings: dict = {}
    t0 = time.perf_counter()
    # derive, CSE and emit per robot; the bar is silent when stderr is not a terminal
    with progress(total=PROGRESS_STEPS * len(robots), desc="generate", unit="step") as bar:

        def step(message):
            bar.set_description(message)
            bar.update(1)

        files = render_all(robots, progress=step, timings=timings)
    total = time.perf_counter() - t0
    for r, t in timings.items():
        eprint(f"[generate] {r}: derive {t['derive_s']:.1f} s, CSE {t['cse_s']:.1f} s, emit {t['emit_s']:.1f} s")
    if args.check:
        bad = stale(files)
        if bad:
            for rel in bad:
                print(f"stale: eigentwist/generated/{rel}")
                if args.diff:
                    path = GENERATED / rel
                    old = path.read_text().splitlines(keepends=True) if path.exists() else []
                    print(
                        "".join(
                            difflib.unified_diff(old, files[rel].splitlines(keepends=True), rel, rel + " (regenerated)")
                        )
                    )
            print("run `eigentwist generate` (or `make generate`) to update them")
            return 1
        print(f"up to date: {len(files)} file(s) in eigentwist/generated ({total:.1f} s)")
        return 0
    for path in write(files):
        print(f"wrote {path.relative_to(GENERATED.parent.parent)}")
    print(f"generated {len(files)} file(s) in {total:.1f} s")
    return 0


def _generate_files(paths) -> int:
    """Generate (or find in the cache) the evaluators of description files."""
    from ..runtime.loader import load

    for path in paths:
        t0 = time.perf_counter()
        ev = load(path, backend="auto", progress=lambda m: eprint(f"[generate] {m}"))
        print(f"{path}: {ev.robot.name} ready ({ev.backend} backend, {time.perf_counter() - t0:.1f} s)")
    return 0
