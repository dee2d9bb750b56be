"""Figures of an identification (matplotlib, Agg backend), one PNG per setting.

``plot_stabilisation``: the stabilisation diagram (model order over frequency: every
physical pole as a small dot, stable ones as a filled marker), the identified modes as
vertical lines, over the sum of the FRF magnitudes (right axis, log). ``plot_frfs``: the
measured FRF magnitudes (one panel per measured response / reference pair, up to
``MAX_PANELS``) with the LSFD re-synthesis on the band (dashed). ``plot_campaign``
writes both for every setting of a campaign.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..outputs import atomic_path
from ..matplotlib_agg import margins, pyplot

__all__ = ["plot_stabilisation", "plot_frfs", "plot_campaign", "figure_bytes", "MAX_PANELS"]

MAX_PANELS = 12


def plot_stabilisation(res, path) -> None:
    """Stabilisation diagram of one setting's :class:`~eigentwist.modal.identify.SettingModes`."""
    plt = pyplot("modal")
    from matplotlib.ticker import LogFormatter, LogLocator, NullLocator

    fig, ax = plt.subplots(figsize=(8, 4.5))
    stab = res.stabilisation
    # every order's poles in two artists (not yet stable, stable): one line object per order
    # and kind cost most of the figure's drawing
    f = np.concatenate([np.asarray(v, dtype=float) for v in stab.freq_hz] or [np.empty(0)])
    st = np.concatenate([np.asarray(v, dtype=bool) for v in stab.stable] or [np.empty(0, bool)])
    at = np.repeat(np.asarray(stab.orders, dtype=float), [len(v) for v in stab.freq_hz])
    ax.plot(f[~st], at[~st], ".", color="0.7", ms=3)
    ax.plot(f[st], at[st], "o", color="tab:blue", ms=3.5)
    for m in res.modes:
        ax.axvline(m.freq_hz, color="tab:red", lw=0.8)
        ax.text(
            m.freq_hz,
            stab.orders[-1] * 1.04,
            f" {m.label} {m.freq_hz:.3f} Hz",
            rotation=90,
            fontsize=7,
            va="bottom",
            ha="right",
        )
    ax.set_ylim(0, stab.orders[-1] * 1.3)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("LSCF model order")
    ax.set_xlim(*res.band)
    if res.frfs is not None:
        band = res.band_index
        ax2 = ax.twinx()
        ax2.semilogy(res.frfs.freq_hz[band], np.sum(np.abs(res.frfs.H[band]), axis=1), color="0.3", lw=0.8)
        ax2.set_ylabel(f"sum |{res.frfs.form}|")
        ax2.yaxis.set_minor_locator(NullLocator())
        ax2.yaxis.set_major_formatter(LogFormatter())  # 1e-02, plain text: no mathtext to parse
        ax2.yaxis.set_major_locator(LogLocator(numticks=5))
    ax.set_title(
        f"{Path(res.source).name}: stabilisation (grey: pole not yet stable, blue: stable pole, red: identified mode)",
        fontsize=9,
    )
    margins(fig, left=0.75, right=0.85, bottom=0.55, top=0.35)  # right: the FRF sum's axis
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def plot_frfs(res, path) -> None:
    """Measured FRF magnitudes and their LSFD re-synthesis on the band, one panel per pair."""
    plt = pyplot("modal")
    from matplotlib.ticker import LogFormatter, LogLocator, MaxNLocator, NullLocator

    frfs = res.frfs
    n_p = min(frfs.H.shape[1], MAX_PANELS)
    n_c = min(n_p, 3)
    n_r = -(-n_p // n_c)
    fig, axes = plt.subplots(n_r, n_c, figsize=(3.2 * n_c, 2.2 * n_r + 0.6), sharex=True, squeeze=False)
    band = res.band_index
    f = frfs.freq_hz
    for p, ax in enumerate(axes.flat):
        if p >= n_p:
            ax.axis("off")
            continue
        ax.semilogy(f[band], np.abs(frfs.H[band, p]), color="tab:blue", lw=0.9, label="measured")
        ax.semilogy(f[band], np.abs(res.resynthesised[:, p]), "--", color="tab:red", lw=0.9, label="re-synthesised")
        ax.set_title(frfs.pair_label(p), fontsize=8, y=1.0)  # a fixed y: no search over the tick labels
        ax.tick_params(labelsize=7)
        ax.yaxis.set_minor_locator(NullLocator())  # decades are enough: minor ticks cost most of the drawing
        ax.yaxis.set_major_formatter(LogFormatter())  # 1e-02, plain text: no mathtext to parse
        # few major ticks: each is a text laid out per panel (a figure ~30 % faster than the defaults)
        ax.xaxis.set_major_locator(MaxNLocator(nbins=4))
        ax.yaxis.set_major_locator(LogLocator(numticks=4))
    axes[0, 0].legend(fontsize=7)
    fig.supxlabel("frequency [Hz]", fontsize=9)  # one label: no alignment across the panels
    more = f" (first {n_p} of {frfs.H.shape[1]} FRFs)" if frfs.H.shape[1] > n_p else ""
    fig.suptitle(
        f"{Path(res.source).name}: {frfs.form} (LSFD with residuals on {res.band[0]:.3g}..{res.band[1]:.3g} Hz)" + more,
        fontsize=9,
    )
    margins(fig, left=0.55, right=0.15, bottom=0.5, top=0.5, wspace=0.45, hspace=0.4)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def plot_campaign(result, out_dir) -> list[Path]:
    """Both figures for every setting identified from FRFs; returns the written paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for s, res in zip(result.campaign.settings, result.results):
        if res.frfs is None:
            continue
        for kind, plot in (("stabilisation", plot_stabilisation), ("frf", plot_frfs)):
            path = out / f"{s.name()}_{kind}.png"
            plot(res, path)
            written.append(path)
    return written


def figure_bytes(plot, res) -> bytes:
    """PNG bytes of ``plot(res, file)`` (for the HTML report)."""
    import io

    buf = io.BytesIO()
    plot(res, buf)
    return buf.getvalue()
