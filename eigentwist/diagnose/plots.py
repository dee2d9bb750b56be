"""Figures (matplotlib, Agg backend): the paper's Fig. 6 style and the error falling.

``plot_comparison``: per pose, predicted frequency curves over k_a for each measured
mode, measured points with 1-sigma error bars, and the k_a ranges where the model fails
(|error| > 2 sigma) shaded in the mode's colour. ``plot_diagnosis``: the baseline
(dashed) and final (solid) model over the measurements, and the RMS / max error of each
step of the selection.
"""

from __future__ import annotations

import textwrap

import numpy as np

from ..outputs import atomic_path
from ..matplotlib_agg import pyplot
from .predict import evaluate

__all__ = ["plot_comparison", "plot_diagnosis", "model_curves"]

MAX_POSES = 4
N_CURVE = 120


def _pose_groups(meas):
    poses = np.unique(np.round(meas.poses, 9), axis=0)
    return [(p, np.all(np.isclose(meas.poses, p, atol=1e-9), axis=1)) for p in poses]


def model_curves(ev, meas, effects, values: dict, pose, labels, k_a) -> dict:
    """{label: (K,) predicted Hz} of ``effects`` with ``values`` at one pose over ``k_a``."""
    const = {k: float(v[0]) for k, v in meas.params.items() if np.all(v == v[0])}
    out = {}
    poses = np.repeat(np.asarray(pose, dtype=float)[None, :], len(k_a), axis=0)
    for label in labels:
        f, _ = evaluate(ev, effects, poses, [label] * len(k_a), {**const, **values, "k_a": k_a}, strict=False)
        out[label] = f
    return out


def _k_grid(meas):
    lo, hi = float(meas.k_a.min()), float(meas.k_a.max())
    return np.linspace(0.0, hi * 1.05, N_CURVE)[1:] if lo > 0 else np.linspace(lo, hi, N_CURVE)


def _failing_spans(k_sorted, fail_sorted):
    """Contiguous runs of failing measured k_a, padded half-way to the neighbours."""
    spans, i, n = [], 0, len(k_sorted)
    while i < n:
        if not fail_sorted[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and fail_sorted[j + 1]:
            j += 1
        left = k_sorted[i] - (0.5 * (k_sorted[i] - k_sorted[i - 1]) if i > 0 else 0.03 * k_sorted[-1])
        right = k_sorted[j] + (0.5 * (k_sorted[j + 1] - k_sorted[j]) if j + 1 < n else 0.03 * k_sorted[-1])
        spans.append((left, right))
        i = j + 1
    return spans


def _panel(ax, ev, cmp, rows, pose, k_grid, styles, colors, shade=True, extra=None):
    meas = cmp.meas
    labels = list(dict.fromkeys(np.asarray(meas.mode)[rows]))
    curves = model_curves(ev, meas, cmp.effects, cmp.values, pose, labels, k_grid)
    for label in labels:
        c = colors[label]
        sel = rows & (np.asarray(meas.mode) == label)
        order = np.argsort(meas.k_a[sel])
        k, f, s = meas.k_a[sel][order], meas.freq_hz[sel][order], meas.sigma_hz[sel][order]
        fail = cmp.failing[sel][order]
        ax.errorbar(k, f, yerr=s, fmt="o", color=c, ms=4, capsize=2, label=f"measured, mode {label}")
        if fail.any():
            ax.plot(k[fail], f[fail], "o", mfc="none", mec="red", ms=8)
        ax.plot(k_grid, curves[label], styles[0], color=c, label=f"{styles[1]}, mode {label}")
        if shade:
            for a, b in _failing_spans(k, fail):
                ax.axvspan(a, b, color=c, alpha=0.12, lw=0)
        if extra is not None:
            ex = model_curves(ev, meas, extra.effects, extra.values, pose, [label], k_grid)
            ax.plot(k_grid, ex[label], "--", color=c, alpha=0.7, label=f"baseline, mode {label}")
    ax.set_xlabel(f"actuator stiffness k_a [{ev.parameter('k_a').unit}]")
    ax.set_ylabel("natural frequency [Hz]")
    ax.set_title(f"pose {np.round(pose, 4).tolist()} m", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)


def _colors(meas):
    cycle = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink"]
    return {lb: cycle[k % len(cycle)] for k, lb in enumerate(dict.fromkeys(meas.mode))}


def plot_comparison(cmp, path, ev, title: str | None = None):
    """Fig. 6 style figure of a :class:`~eigentwist.diagnose.compare.Comparison`, saved to ``path``."""
    plt = pyplot()
    groups = _pose_groups(cmp.meas)[:MAX_POSES]
    fig, axes = plt.subplots(1, len(groups), figsize=(max(7.0, 5.2 * len(groups)), 4.6), squeeze=False)
    k_grid = _k_grid(cmp.meas)
    colors = _colors(cmp.meas)
    for ax, (pose, rows) in zip(axes[0], groups):
        _panel(ax, ev, cmp, rows, pose, k_grid, ("-", "model"), colors)
    title = title or (
        f"model: {', '.join(cmp.effects) or '(no effect)'} - RMS {cmp.rms_pct:.1f} %, "
        f"max {cmp.max_pct:.1f} %; shaded: |error| > 2 sigma; circled: failing rows"
    )
    fig.suptitle(textwrap.fill(title, int(fig.get_figwidth() * 12)), fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path


def plot_diagnosis(diag, path, ev):
    """Baseline vs final model over the data, and the error falling step by step."""
    plt = pyplot()
    groups = _pose_groups(diag.meas)[:MAX_POSES]
    fig, axes = plt.subplots(1, len(groups) + 1, figsize=(5.2 * (len(groups) + 1), 4.2), squeeze=False)
    k_grid = _k_grid(diag.meas)
    colors = _colors(diag.meas)
    final = diag.final.comparison
    for ax, (pose, rows) in zip(axes[0], groups):
        _panel(ax, ev, final, rows, pose, k_grid, ("-", "final"), colors, extra=diag.baseline)
    ax = axes[0][-1]
    x = np.arange(len(diag.steps))
    rms = [s.fit.rms_pct for s in diag.steps]
    mx = [s.fit.max_pct for s in diag.steps]
    ax.bar(x - 0.2, rms, 0.4, label="RMS error")
    ax.bar(x + 0.2, mx, 0.4, label="max error")
    noise = 100 * float(np.sqrt(np.mean(diag.meas.relative_sigma**2)))
    ax.axhline(noise, color="k", ls=":", lw=1, label=f"RMS sigma ({noise:.2g} %)")
    ax.set_xticks(x, [s.change for s in diag.steps], rotation=20, fontsize=8)
    ax.set_ylabel("error [%]")
    ax.set_title("error step by step", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(True, axis="y", alpha=0.3)
    verdict = "explained" if diag.explained else "NOT explained (an effect outside the catalogue?)"
    fig.suptitle(
        textwrap.fill(
            f"{diag.robot}: baseline {', '.join(diag.baseline.effects) or '(none)'} -> "
            f"{', '.join(diag.final.effects) or '(none)'}: {verdict}",
            int(fig.get_figwidth() * 12),
        ),
        fontsize=10,
    )
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path
