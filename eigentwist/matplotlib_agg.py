"""Matplotlib for files, not screens: the one place eigentwist imports pyplot."""

from __future__ import annotations

__all__ = ["pyplot"]


def pyplot(extra: str = "plot"):
    """``matplotlib.pyplot`` on the non-interactive Agg backend.

    Raises ``OSError`` naming the extra that installs matplotlib (``extra``: ``"plot"`` or
    ``"modal"``) when it is missing.
    """
    try:
        import matplotlib
    except ImportError:  # pragma: no cover - matplotlib is an optional dependency
        raise OSError(f"plotting needs matplotlib: pip install 'eigentwist[{extra}]'") from None
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt
