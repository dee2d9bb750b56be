"""Shared CLI helpers: options, progress, tables and the one-line error contract."""

from __future__ import annotations

import argparse
import os
import sys

from ..errors import InputError
from ..text import format_table  # re-exported: the CLI's tables

__all__ = [
    "CliError",
    "add_model_options",
    "add_set_option",
    "add_backend_option",
    "add_jacobian_option",
    "BACKEND_ENV",
    "parse_sets",
    "check_values",
    "model_and_values",
    "progress",
    "format_table",
    "eprint",
    "SET_HELP",
    "MODEL_SYNTAX",
    "declare_outputs",
    "input_paths",
    "guard_outputs",
]


class CliError(InputError):
    """A malformed option, reported to the user as one line (exit status 2)."""


def say(*args, **kwargs) -> None:
    """``print`` for a command's default (human) output: lines wrapped at 100 characters
    (:func:`eigentwist.text.wrap`; never for JSON or CSV output)."""
    from ..text import wrap

    print(*(wrap(str(a)) for a in args), **kwargs)


def eprint(*args) -> None:
    print(*args, file=sys.stderr)


SET_HELP = (
    "set a design parameter for this run, SI units: NAME=VALUE, e.g. --set l2=0.60, or one leg's value "
    "NAME@N=VALUE (leg N = 1, 2, ...), e.g. --set eta_a@3=0.5; repeatable. A CSV column of the same "
    "name wins over it; it wins over the robot's default"
)
MODEL_SYNTAX = (
    "PRESET or EFFECT items joined by ',' or '+', each optionally with :PARAM=VALUE,... "
    "(the syntax of synth --truth), e.g. paper:l2=0.60 or rigid,payload_mass:m_p=0.5; none is the bare model"
)


#: environment variable holding the default of every command's ``--backend`` (default: auto)
BACKEND_ENV = "EIGENTWIST_BACKEND"


def _backend(value: str) -> str:
    from ..runtime.loader import BACKENDS

    text = str(value).strip().lower()
    if text not in BACKENDS:
        source = f" (from {BACKEND_ENV})" if os.environ.get(BACKEND_ENV, "").strip() == str(value).strip() else ""
        raise argparse.ArgumentTypeError(
            f"unknown backend {value!r}{source}: expected one of {', '.join(sorted(BACKENDS))}"
        )
    return text


def add_backend_option(p: argparse.ArgumentParser) -> None:
    """The shared ``--backend auto|c|numpy`` option; its default is ``auto`` (as
    ``eigentwist.load``), or the value of the ``EIGENTWIST_BACKEND`` environment variable."""
    default = os.environ.get(BACKEND_ENV, "").strip() or "auto"
    p.add_argument(
        "--backend",
        default=default,
        type=_backend,
        metavar="{auto,c,numpy}",
        help="generated evaluator: auto = the C library where a C compiler exists (compiled on first "
        "use, cached), else the NumPy module; c or numpy to choose (same numbers to 1e-12). "
        f"Default: {BACKEND_ENV} if set, else auto (now: {default})",
    )


def add_jacobian_option(p: argparse.ArgumentParser, help: str) -> None:
    """The shared ``--jacobian differences|exact`` option (default: differences, nothing
    derived at run time); ``help`` says what the derivatives are for."""
    p.add_argument("--jacobian", choices=("differences", "exact"), default="differences", help=help)


def add_set_option(p: argparse.ArgumentParser, help: str = SET_HELP) -> None:
    """The shared ``--set NAME=VALUE`` / ``--set NAME@N=VALUE`` option (repeatable)."""
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", dest="set", help=help)


def add_model_options(p: argparse.ArgumentParser, model_default: str | None = "paper") -> None:
    """``--robot``, ``--pose``, ``--k-a``, ``--set`` and ``--model`` with units in the help."""
    p.add_argument(
        "--robot",
        default="heli4",
        help="robot: a shipped name (heli4, delta, hexapod) or a description file PATH.py defining describe() "
        "(default: heli4)",
    )
    add_backend_option(p)
    p.add_argument(
        "--pose",
        nargs="+",
        type=float,
        metavar="X",
        help="end-effector position in the base frame, m: X Y Z; for a 6-DoF robot (hexapod) "
        "X Y Z ROT_X ROT_Y ROT_Z, the platform origin (m) and its rotation vector (rad) "
        "(default: the robot's x_ref)",
    )
    p.add_argument(
        "--k-a",
        type=float,
        dest="k_a",
        metavar="KA",
        help="commanded actuator stiffness in the robot's unit: N m/rad (revolute actuator) or N/m "
        "(prismatic) (default: the robot's)",
    )
    add_set_option(p)
    if model_default is not None:
        p.add_argument("--model", default=model_default, help=f"{MODEL_SYNTAX} (default: {model_default})")


def _set_name(item: str, name: str) -> str:
    """``"l2"`` -> ``"l2"``, ``"eta_a@03"`` -> ``"eta_a@3"``; malformed names raise :class:`CliError`."""
    base, at, leg = name.partition("@")
    if not base.isidentifier():
        raise CliError(
            f"--set {item!r}: {base!r} is not a parameter name: expected NAME=VALUE or NAME@N=VALUE, "
            "e.g. --set l2=0.60 or --set eta_a@3=0.5"
        )
    if not at:
        return base
    if not leg.isdigit() or int(leg) < 1:
        raise CliError(
            f"--set {item!r}: leg {leg!r} is not a leg number: expected NAME@N=VALUE with N = 1, 2, ..., "
            "e.g. --set eta_a@3=0.5"
        )
    return f"{base}@{int(leg)}"


def parse_sets(items: list[str]) -> dict[str, float]:
    """``["l2=0.55", "eta_a@3=0.5"]`` -> ``{"l2": 0.55, "eta_a@3": 0.5}``.

    The one parser of ``--set`` for every command. Malformed items (no ``=``, a name
    that is not an identifier, a leg that is not a positive integer, a value that is
    not a finite number, one name given twice with different values) raise
    :class:`CliError` naming the item. Whether the name is a parameter of the robot is
    checked by :func:`check_values`, per-leg ranges by the evaluator.
    """
    import math

    out: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise CliError(f"--set {item!r}: expected NAME=VALUE or NAME@N=VALUE, e.g. --set l2=0.60")
        key = _set_name(item, name.strip())
        try:
            number = float(value)
        except ValueError:
            raise CliError(f"--set {item!r}: value {value!r} is not a number (SI units expected)") from None
        if not math.isfinite(number):
            raise CliError(f"--set {item!r}: value {value!r} is not finite: expected a number in SI units")
        if key in out and out[key] != number:
            raise CliError(f"--set {item!r}: {key} is already set to {out[key]:g}: give it once")
        out[key] = number
    return out


def check_values(values: dict, ev, option: str = "--set") -> dict:
    """Check that each name of ``values`` is a parameter of ``ev``'s robot (per-leg names
    by their base name) and within its bounds; return ``values``."""
    from ..description.names import did_you_mean

    for key, value in values.items():
        base = key.partition("@")[0]
        if base not in ev.parameters:
            raise CliError(
                f"{option} {key}={value:g}: unknown parameter {base!r} of {ev.robot.name}"
                f"{did_you_mean(base, ev.parameters)}; expected one of {', '.join(ev.parameters)}"
            )
        try:
            ev.parameters[base].check(value)
        except ValueError as exc:
            raise CliError(f"{option} {key}={value:g}: {exc}") from None
    return values


def model_and_values(spec: str, sets: list[str], ev, option: str = "--model") -> tuple[tuple, dict]:
    """The effects and parameter values of ``--model SPEC`` and ``--set``.

    ``spec`` is a preset or effects, each item optionally carrying ``:PARAM=VALUE,...``
    (the ``synth --truth`` syntax, :func:`eigentwist.diagnose.synth.parse_truth`);
    values given both in ``spec`` and by ``--set`` must agree. Returns
    ``(effects, {name: value})`` in SI units.
    """
    from ..description.effects import resolve_model
    from ..diagnose.synth import parse_truth

    values = check_values(parse_sets(sets), ev)
    if ":" not in spec:
        return resolve_model(spec, ev.robot), values
    truth = parse_truth(spec, ev, what=option)
    for name, value in truth.values.items():
        if name in values and values[name] != value:
            raise CliError(f"{option} {spec!r} sets {name} = {value:g} and --set {name}={values[name]:g}: give it once")
    return truth.effects, {**values, **truth.values}


def progress(iterable=None, **kwargs):
    """tqdm progress bar on stderr, silent when stderr is not a terminal."""
    from tqdm.auto import tqdm

    kwargs.setdefault("disable", not sys.stderr.isatty())
    kwargs.setdefault("file", sys.stderr)
    return tqdm(iterable, **kwargs)


#: options that never name an input file (the command line's own bookkeeping)
_NOT_INPUTS = {"func", "argv", "outputs", "command", "debug"}


def declare_outputs(p: argparse.ArgumentParser, force: bool = True, **kinds: str) -> None:
    """Declare the options of ``p`` that name files it writes, ``dest=kind`` with a kind of
    :data:`eigentwist.outputs.KINDS` (``html``, ``csv``, ``image``, ``directory``) or ``""``
    (checked against the inputs only), and add ``--force`` (unless ``force=False``).
    :func:`guard_outputs` checks them before the command runs."""
    p.set_defaults(outputs=kinds)
    if force:
        p.add_argument(
            "--force",
            action="store_true",
            help="replace an existing output file of another kind (an output is never an input)",
        )


def input_paths(args, outputs=()) -> list[str]:
    """The values of ``args`` (strings, or lists of strings) that name existing files,
    except the options ``outputs``: the command's inputs (data, manifest, description)."""
    found = []
    for dest, value in vars(args).items():
        if dest in _NOT_INPUTS or dest in outputs:
            continue
        for item in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(item, (str, os.PathLike)) and str(item) and os.path.isfile(item):
                found.append(str(item))
    return found


def option_name(args, dest: str) -> str:
    """``-o`` for ``output``, else ``--plot``, ``--uff`` (the option as typed)."""
    return "-o" if dest == "output" else "--" + dest.replace("_", "-")


def guard_outputs(args, extra_inputs=()) -> None:
    """Refuse each declared output (:func:`declare_outputs`) that is one of the command's
    inputs, or that would replace a file of another kind without ``--force``
    (:func:`eigentwist.outputs.check_output`; an :class:`~eigentwist.outputs.OutputError`)."""
    from ..outputs import check_output

    kinds = getattr(args, "outputs", None) or {}
    inputs = input_paths(args, kinds) + [str(p) for p in extra_inputs]
    for dest, kind in kinds.items():
        path = getattr(args, dest, None)
        if not path:
            continue
        if kind:
            check_output(path, kind, inputs, force=bool(getattr(args, "force", False)), option=option_name(args, dest))
        else:
            check_output(path, "directory", inputs, force=True, option=option_name(args, dest))
