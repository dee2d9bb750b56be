"""Plain-text formatting shared by the core and the command line (no CLI imports here)."""
from __future__ import annotations

import numpy as np

__all__ = ["format_table"]


def format_table(headers: list[str], rows: list[list], floatfmt: str = ".4g") -> str:
    """Plain-text table with right-aligned numbers."""
    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return format(float(v), floatfmt)
        return str(v)
    cells = [[fmt(v) for v in r] for r in rows]
    widths = [max(len(h), *(len(r[k]) for r in cells)) if cells else len(h) for k, h in enumerate(headers)]
    line = lambda r: "  ".join(c.rjust(w) for c, w in zip(r, widths))  # noqa: E731
    return "\n".join([line(headers), line(["-" * w for w in widths])] + [line(r) for r in cells])
