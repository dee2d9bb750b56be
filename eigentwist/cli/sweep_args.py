"""Command-line text of ``eigentwist sweep`` to numbers: value lists, ranges, ``--vary``."""

from __future__ import annotations

import math

import numpy as np

from .common import CliError

__all__ = ["parse_values", "parse_vary"]


def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise CliError(f"{what}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise CliError(f"{what}: {text.strip()!r} is not a finite number")
    return value


def parse_values(text: str, what: str = "values") -> tuple[float, ...]:
    """``"500,1000,2000"`` (a list), ``"500:4000:8"`` (8 values, linspace, ends
    included) or ``"2000"`` (one value) -> a tuple of floats.

    ``what`` names the option in the error, e.g. ``"--k-a '500:x:8'"``.
    """
    text = str(text).strip()
    if not text:
        raise CliError(f"{what}: empty: expected a value, a list A,B,C or a range LO:HI:N")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise CliError(f"{what}: {text!r} is not a range: expected LO:HI:N, e.g. 0.45:0.60:16")
        lo, hi = (_number(p, what) for p in parts[:2])
        try:
            n = int(parts[2])
        except ValueError:
            raise CliError(
                f"{what}: count {parts[2]!r} in {text!r} is not an integer: expected LO:HI:N with N >= 1"
            ) from None
        if n < 1:
            raise CliError(f"{what}: count {n} in {text!r}: expected N >= 1")
        return tuple(float(v) for v in np.linspace(lo, hi, n))
    return tuple(_number(p, what) for p in text.split(","))


def parse_vary(item: str) -> tuple[str, tuple[float, ...]]:
    """``"l2=0.45:0.60:16"`` -> ``("l2", (0.45, 0.46, ..., 0.60))`` (SI units)."""
    name, sep, values = str(item).partition("=")
    if not sep or not name.strip():
        raise CliError(f"--vary {item!r}: expected NAME=LO:HI:N or NAME=A,B,C, e.g. l2=0.45:0.60:16")
    return name.strip(), parse_values(values, f"--vary {item!r}")
