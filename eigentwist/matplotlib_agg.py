"""Matplotlib for files, not screens: the one place eigentwist imports pyplot."""

from __future__ import annotations

from .errors import InputError

__all__ = ["pyplot", "margins"]


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


def margins(fig, left: float, right: float, bottom: float, top: float, wspace: float = 0.0, hspace: float = 0.0):
    """Place ``fig``'s subplot grid with margins and gaps given in inches.

    For figures drawn often (one per setting of a campaign): ``tight_layout`` measures
    every tick label by drawing the figure once more (~40 % of such a figure's time);
    fixed margins sized for the labels the figure holds need no measuring. ``wspace`` and
    ``hspace``: the gaps between columns and rows of panels.
    """
    width, height = fig.get_size_inches()
    grid = fig.axes[0].get_subplotspec().get_gridspec() if fig.axes else None
    n_rows, n_cols = grid.get_geometry() if grid is not None else (1, 1)
    panel_w = (width - left - right - wspace * (n_cols - 1)) / n_cols
    panel_h = (height - bottom - top - hspace * (n_rows - 1)) / n_rows
    if panel_w <= 0 or panel_h <= 0:
        raise InputError(
            f"margins of {left + right} x {bottom + top} in leave no room in a {width} x {height} in figure"
        )
    fig.subplots_adjust(
        left=left / width,
        right=1 - right / width,
        bottom=bottom / height,
        top=1 - top / height,
        wspace=wspace / panel_w,
        hspace=hspace / panel_h,
    )
