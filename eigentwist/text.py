"""Results as text and as JSON values: plain-text tables, JSON-safe conversion.

Core modules (diagnosis, report, paper reproduction) and the command line share these;
they live here so that the core never imports :mod:`eigentwist.cli`.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["format_table", "json_safe"]


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
