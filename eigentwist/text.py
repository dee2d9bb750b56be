"""Results as text and as JSON values: plain-text tables, JSON-safe conversion.

Core modules (diagnosis, report, paper reproduction) and the command line share these;
they live here so that the core never imports :mod:`eigentwist.cli`.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["format_table", "json_safe", "format_estimate"]


def format_table(headers: list[str], rows: list[list], floatfmt: str = ".4g") -> str:
    """Plain-text table with right-aligned cells; floats formatted with ``floatfmt``."""
    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return format(float(v), floatfmt)
        return str(v)
    cells = [[fmt(v) for v in r] for r in rows]
    widths = [max(len(h), *(len(r[k]) for r in cells)) if cells else len(h) for k, h in enumerate(headers)]
    line = lambda r: "  ".join(c.rjust(w) for c, w in zip(r, widths))  # noqa: E731
    return "\n".join([line(headers), line(["-" * w for w in widths])] + [line(r) for r in cells])


def json_safe(obj):
    """A copy of ``obj`` that ``json.dumps(..., allow_nan=False)`` accepts.

    NumPy scalars and arrays become Python numbers and lists, NaN and inf become None,
    dict keys become strings.
    """
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def format_estimate(value, std=None, unit: str = "") -> str:
    """A fitted value with its standard error and unit, as people write it.

    The error keeps two significant digits and the value as many decimals;
    values of 10^4 and more (or below 10^-3) share a power of ten:
    ``format_estimate(373.6, 37.72, "N m/rad")`` is ``"374 ± 38 N m/rad"``,
    ``format_estimate(164072.4, 30643.8, "N/m")`` is ``"(1.64 ± 0.31)·10⁵ N/m"``.
    A missing or infinite error gives ``"... (± undetermined)"``; unit ``"-"`` is dropped.
    """
    unit = "" if unit in (None, "-") else unit
    if value is None or not math.isfinite(float(value)):
        return f"(undetermined) {unit}".strip()
    v = float(value)
    exp = math.floor(math.log10(abs(v))) if v != 0 else 0
    scale_exp = exp if (exp >= 4 or exp <= -4) else 0
    scale = 10.0 ** scale_exp
    finite = std is not None and math.isfinite(float(std)) and float(std) > 0
    if finite:
        s = float(std) / scale
        decimals = max(0, 1 - math.floor(math.log10(s)))
        text = f"{v / scale:.{decimals}f} ± {s:.{decimals}f}"
    else:
        text = f"{v / scale:.6g}"
    if scale_exp:
        text = f"({text})·10{str(scale_exp).translate(_SUPERSCRIPT)}" if finite else \
            f"{text}·10{str(scale_exp).translate(_SUPERSCRIPT)}"
    if not finite and std is not None:
        text += " (± undetermined)"
    return f"{text} {unit}".strip()
