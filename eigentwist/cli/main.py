"""Entry point of the ``eigentwist`` command."""
from __future__ import annotations

import argparse
import importlib
import os
import sys

import numpy as np

from ..runtime.ccompile import BuildError
from .common import CliError

# Subcommands are the modules of this package that define ``add_parser``; this order
# first, any others alphabetically (adding a command needs no edit here).
ORDER = ("reproduce", "matrices", "compare", "diagnose", "synth", "sweep", "report", "generate")


def subcommands() -> list[str]:
    import pkgutil

    from pathlib import Path

    names = [m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])
             if m.name not in ("main", "common", "__init__")]
    return sorted(names, key=lambda n: (ORDER.index(n) if n in ORDER else len(ORDER), n))

DESCRIPTION = """eigentwist: closed-form natural-frequency models of parallel manipulators
(Hoevenaars, Krut & Herder 2020, DOI 10.1016/j.mechmachtheory.2019.103775).
Units are SI throughout: m, rad, kg, N, N m/rad, Pa, Hz."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="eigentwist", description=DESCRIPTION,
                                     epilog="example: eigentwist matrices --pose 0 0 -0.625 --k-a 2000 --json",
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in subcommands():
        module = importlib.import_module(f".{name}", __package__)
        if hasattr(module, "add_parser"):
            module.add_parser(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)     # the command line, for provenance
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        # floating-point overflow on absurd inputs is detected and named by the checks
        # (unreachable pose, non-finite frequency); NumPy's own warnings would only add lines
        with np.errstate(all="ignore"):
            code = int(args.func(args) or 0)
        sys.stdout.flush()                   # a closed pipe shows here, not at interpreter exit
        return code
    except BrokenPipeError:
        # the reader stopped reading (``eigentwist diagnose paper | head -1``): what it took
        # was what it wanted, so this is no error; point stdout at devnull so that the
        # interpreter's final flush does not raise again (Python docs, "Note on SIGPIPE")
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except (CliError, ValueError, OSError, KeyError, BuildError) as exc:
        if args.debug:
            raise
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f"eigentwist {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
