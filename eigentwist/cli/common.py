"""Shared CLI helpers: options, progress, tables and the one-line error contract."""
from __future__ import annotations

import argparse
import sys

from ..text import format_table  # re-exported: the CLI's tables

__all__ = ["CliError", "add_model_options", "parse_sets", "progress", "format_table", "eprint"]


class CliError(Exception):
    """An error reported to the user as one line (exit status 2)."""


def eprint(*args) -> None:
    print(*args, file=sys.stderr)


def add_model_options(p: argparse.ArgumentParser, model_default: str | None = "paper") -> None:
    """``--robot``, ``--pose``, ``--k-a``, ``--set`` and ``--model`` with units in the help."""
    p.add_argument("--robot", default="heli4", help="robot: a shipped name (heli4, delta) or a description file PATH.py defining describe() (default: heli4)")
    p.add_argument("--backend", default="numpy", choices=("numpy", "c", "auto"),
                   help="generated evaluator to use (default: numpy)")
    p.add_argument("--pose", nargs=3, type=float, metavar=("X", "Y", "Z"),
                   help="end-effector position in the base frame, m (default: the robot's x_ref)")
    p.add_argument("--k-a", type=float, dest="k_a", metavar="KA",
                   help="commanded actuator stiffness in the robot's unit: N m/rad (revolute actuator) or N/m "
                        "(prismatic) (default: the robot's)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a design parameter in SI units, e.g. --set l2=0.55 (repeatable)")
    if model_default is not None:
        p.add_argument("--model", default=model_default,
                       help="preset (rigid, paper) or comma-separated effects, e.g. rigid,payload_mass "
                            f"(default: {model_default})")


def parse_sets(items: list[str]) -> dict[str, float]:
    """``["l2=0.55"]`` -> ``{"l2": 0.55}``; malformed items raise :class:`CliError`."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise CliError(f"--set {item!r}: expected NAME=VALUE, e.g. --set l2=0.55")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise CliError(f"--set {item!r}: value {value!r} is not a number") from None
    return out


def progress(iterable=None, **kwargs):
    """tqdm progress bar on stderr, silent when stderr is not a terminal."""
    from tqdm.auto import tqdm

    kwargs.setdefault("disable", not sys.stderr.isatty())
    kwargs.setdefault("file", sys.stderr)
    return tqdm(iterable, **kwargs)
