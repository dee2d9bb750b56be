"""Entry point of the ``eigentwist`` command."""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import re
import sys
import traceback
import warnings

# Subcommands are the modules of this package that define ``add_parser``; this order
# first, any others alphabetically (adding a command needs no edit here).
ORDER = ("reproduce", "matrices", "compare", "diagnose", "synth", "sweep", "report", "generate")


def subcommands() -> list[str]:
    import pkgutil

    from pathlib import Path

    names = [
        m.name
        for m in pkgutil.iter_modules([str(Path(__file__).parent)])
        if m.name not in ("main", "common", "__init__")
    ]
    return sorted(names, key=lambda n: (ORDER.index(n) if n in ORDER else len(ORDER), n))


DESCRIPTION = """eigentwist: closed-form natural-frequency models of parallel manipulators
(Hoevenaars, Krut & Herder 2020, DOI 10.1016/j.mechmachtheory.2019.103775).
Units are SI throughout: m, rad, kg, N, N m/rad, Pa, Hz."""


def build_parser(robot: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser; ``robot`` (a shipped robot) rewrites the subcommands'
    examples in its terms (:mod:`.examples`)."""
    parser = argparse.ArgumentParser(
        prog="eigentwist",
        description=DESCRIPTION,
        epilog="example: eigentwist matrices --pose 0 0 -0.625 --k-a 2000 --json",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"eigentwist {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in subcommands():
        module = importlib.import_module(f".{name}", __package__)
        if hasattr(module, "add_parser"):
            module.add_parser(sub)
    if robot:
        from .examples import adapt_epilog

        for name, p in sub.choices.items():
            p.epilog = adapt_epilog(p.epilog, name, robot)
    return parser


# a negative percentage after an option (``--noise -2%``) is its value, not an option: argparse
# takes only plain negative numbers as values, so the pair is joined (``--noise=-2%``) and the
# option's own check names the value
_NEGATIVE_PERCENT = re.compile(r"^-\d*\.?\d+(e[-+]?\d+)?%$", re.I)
# optional dependencies -> the extra that installs them (pyproject.toml)
EXTRA_OF = {
    "pyuff": "modal",
    "sdypy": "modal",
    "threadpoolctl": "modal",
    "matplotlib": "plot",
    "dask": "dask",
    "distributed": "dask",
    "pyarrow": "parquet",
}


def join_negative_percentages(argv: list[str]) -> list[str]:
    """``["--noise", "-2%"]`` -> ``["--noise=-2%"]`` (only after a ``--option``)."""
    out: list[str] = []
    for tok in argv:
        if out and _NEGATIVE_PERCENT.match(tok) and out[-1].startswith("--") and "=" not in out[-1]:
            out[-1] = f"{out[-1]}={tok}"
        else:
            out.append(tok)
    return out


def missing_extra(exc: ImportError, args) -> str | None:
    """One line naming the extra that installs a missing optional module, or None."""
    root = (getattr(exc, "name", None) or "").split(".")[0]
    extra = EXTRA_OF.get(root)
    if extra is None:
        return None
    if args.command == "identify" or getattr(args, "uff", None):
        extra = "modal"  # modal-test campaigns need the whole modal extra
    return f"the optional module {root!r} is not installed (needed here): pip install 'eigentwist[{extra}]'"


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    text = str(message).strip()
    return (text if text.startswith("eigentwist") else f"eigentwist: {category.__name__}: {text}") + "\n"


def version_only(argv: list[str]) -> bool:
    """True when ``--version`` comes before any command or help option: argparse would
    print the version and exit, so nothing else (SymPy, NumPy, the subcommands) is imported."""
    for tok in argv:
        if tok == "--version":
            return True
        if tok in ("-h", "--help") or not tok.startswith("-"):
            return False
    return False


def one_blas_thread() -> None:
    """OpenBLAS on one thread in a command's process, unless the user set
    ``OPENBLAS_NUM_THREADS``: the commands' linear algebra is on small matrices (a fit's
    Jacobian, 6 x 6 pencils batched in C or by NumPy's own loops), between whose calls
    OpenBLAS's threads would only spin (on two cores, 8 % of ``diagnose paper``'s CPU).
    OpenBLAS reads the variable when NumPy first loads it: a process that has imported NumPy
    already (a test calling :func:`main`) is left as it is."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def main(argv=None) -> int:
    from .examples import requested_robot

    own_process = argv is None  # the console script: the process is the command's own
    if own_process:
        one_blas_thread()
    argv = join_negative_percentages(list(sys.argv[1:] if argv is None else argv))
    if version_only(argv):
        from .. import __version__

        print(f"eigentwist {__version__}")
        raise SystemExit(0)
    parser = build_parser(requested_robot(argv))
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)  # the command line, for provenance
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    # a warning is one line on stderr, like an error: its text, not the source line that
    # raised it (e.g. the C backend unavailable: the NumPy module is used); restored on return
    formatwarning = warnings.formatwarning
    if not args.debug:
        warnings.formatwarning = _one_line_warning
    if own_process:
        # the objects the imports and the parser built live as long as the process: the
        # cyclic garbage collector skips them in every collection of the command's work
        gc.freeze()
    try:
        return _run(args)
    finally:
        warnings.formatwarning = formatwarning


def _run(args) -> int:
    """``args.func(args)`` under the one-line error contract (exit status 2)."""
    import numpy as np

    from .. import __version__
    from ..errors import EigentwistError
    from ..runtime.ccompile import BuildError
    from .common import CliError, guard_outputs

    try:
        # floating-point overflow on absurd inputs is detected and named by the checks
        # (unreachable pose, non-finite frequency); NumPy's own warnings would only add lines
        guard_outputs(args)
        with np.errstate(all="ignore"):
            code = int(args.func(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return code
    except BrokenPipeError:
        # the reader stopped reading (``eigentwist diagnose paper | head -1``): what it took
        # was what it wanted, so this is no error; point stdout at devnull so that the
        # interpreter's final flush does not raise again (Python docs, "Note on SIGPIPE")
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except ImportError as exc:
        msg = missing_extra(exc, args)
        if msg is None or args.debug:
            raise
        print(f"eigentwist {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except (CliError, EigentwistError, OSError, BuildError) as exc:
        if args.debug:
            raise
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f"eigentwist {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except Exception:  # not the user's doing: a bug, shown whole
        if args.debug:
            raise
        traceback.print_exc()
        print(
            f"eigentwist {args.command}: internal error (a bug in eigentwist {__version__}, not in your input): "
            "please report it to eigentwist's maintainers with the command line and the traceback above",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":
    sys.exit(main())
