"""Results as text and as JSON values: plain-text tables, JSON-safe conversion.

Core modules (diagnosis, report, paper reproduction) and the command line share these;
they live here so that the core never imports :mod:`eigentwist.cli`.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

__all__ = ["format_table", "json_safe", "format_estimate", "wrap", "WIDTH"]


WIDTH = 100  # characters per line of a command's default output


def format_table(
    headers: list[str],
    rows: list[list],
    floatfmt: str = ".4g",
    width: int | None = WIDTH,
    footnote: tuple | None = None,
) -> str:
    """Plain-text table with right-aligned cells; floats formatted with ``floatfmt``.

    A table wider than ``width`` characters first puts its headers on two lines (split at
    the space nearest the middle: ``measured`` over ``[Hz]``), then moves the longest text
    cells of its widest column into numbered footnotes under the table (``[1]``; equal
    texts share one number), until it fits or no text cell is left to move.
    ``width=None``: one line per row, however wide.
    """

    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return format(float(v), floatfmt)
        return str(v)

    cells = [[fmt(v) for v in r] for r in rows]
    heads = [[h] for h in headers]

    def widths():
        return [
            max(max(len(x) for x in heads[k]), *(len(r[k]) for r in cells)) if cells else max(len(x) for x in heads[k])
            for k in range(len(headers))
        ]

    def total():
        return sum(widths()) + 2 * max(len(headers) - 1, 0)

    notes: dict[str, int] = {}
    if width is not None and total() > width:
        heads = [_split_header(h) for h in headers]
        moved = set()
        while total() > width:
            w = widths()
            text_cols = [
                k
                for k in (range(len(headers)) if footnote is None else footnote)
                if k not in moved and any(_is_text(r[k]) for r in cells)
            ]
            if not text_cols:
                break
            k = max(text_cols, key=lambda j: w[j]) if footnote is None else text_cols[0]
            moved.add(k)
            cap = max(len(max(heads[k], key=len)), 5, w[k] - (total() - width))
            for r in cells:
                if len(r[k]) > cap:
                    r[k] = f"[{notes.setdefault(r[k], len(notes) + 1)}]"
    w = widths()
    line = lambda r: "  ".join(c.rjust(n) for c, n in zip(r, w)).rstrip()  # noqa: E731
    depth = max(len(h) for h in heads) if heads else 1
    head_lines = [line([(h[len(h) - depth + i] if i >= depth - len(h) else "") for h in heads]) for i in range(depth)]
    out = head_lines + [line(["-" * n for n in w])] + [line(r) for r in cells]
    for text, n in notes.items():
        out += textwrap.wrap(
            f"[{n}] {text}", width=width, subsequent_indent="    ", break_long_words=False, break_on_hyphens=False
        )
    return "\n".join(out)


def wrap(text: str, width: int = WIDTH) -> str:
    """Every line of ``text`` longer than ``width`` wrapped at spaces, continued under its own
    indentation plus two spaces (tables of :func:`format_table` already fit and stay as they are)."""
    out = []
    for line in str(text).split("\n"):
        if len(line) <= width:
            out.append(line)
            continue
        indent = " " * (len(line) - len(line.lstrip()))
        out += textwrap.wrap(
            line,
            width=width,
            initial_indent=indent,
            subsequent_indent=indent + "  ",
            break_long_words=False,
            break_on_hyphens=False,
        ) or [line]
    return "\n".join(out)


def _split_header(h: str) -> list[str]:
    """``"measured [Hz]"`` -> ``["measured", "[Hz]"]``: at the space nearest the middle."""
    spaces = [i for i, ch in enumerate(h) if ch == " "]
    if not spaces or len(h) <= 6:
        return [h]
    cut = min(spaces, key=lambda i: abs(i - len(h) / 2))
    if "[" in h and h.index("[") - 1 in spaces:
        cut = h.index("[") - 1
    return [h[:cut], h[cut + 1 :]]


def _is_text(cell: str) -> bool:
    """A cell that is prose (a footnote may hold it), not a number."""
    try:
        float(cell.replace("%", "").replace("+", ""))
        return False
    except ValueError:
        return len(cell) > 5


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
    scale = 10.0**scale_exp
    finite = std is not None and math.isfinite(float(std)) and float(std) > 0
    if finite:
        s = float(std) / scale
        decimals = max(0, 1 - math.floor(math.log10(s)))
        text = f"{v / scale:.{decimals}f} ± {s:.{decimals}f}"
    else:
        text = f"{v / scale:.6g}"
    if scale_exp:
        text = (
            f"({text})·10{str(scale_exp).translate(_SUPERSCRIPT)}"
            if finite
            else f"{text}·10{str(scale_exp).translate(_SUPERSCRIPT)}"
        )
    if not finite and std is not None:
        text += " (± undetermined)"
    return f"{text} {unit}".strip()
