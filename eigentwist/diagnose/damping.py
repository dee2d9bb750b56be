"""Damping ratios as residuals: measured values, and the decay a damped row shows."""

from __future__ import annotations

import numpy as np

from .measurements import DEFAULT_SIGMA_ZETA_ABS, DEFAULT_SIGMA_ZETA_REL

__all__ = [
    "DECAY_SIGMA",
    "zeta_rows",
    "zeta_residuals",
    "zeta_count",
    "carries_damping",
    "least_damping",
    "attach_damping",
    "whitened_predictions",
    "zeta_sigma",
]

#: a damped row (``kind`` = damped: a decaying oscillation was seen and counted) bounds the
#: damping ratio of every mode of that condition from below: zeta < 0 costs (zeta / DECAY_SIGMA)^2,
#: a stiff penalty (a mode growing by zeta = -0.001 costs 100 in chi2): the model must be stable there
DECAY_SIGMA = 1e-4


def zeta_rows(meas, damped_model: bool = True):
    """``(rows, sigma, measured)`` of the damping-ratio residuals: every row with a measured
    damping ratio and, for a model with damping (``damped_model``), every damped row (the
    decay bound; a model without damping has zeta = 0 there); None without any."""
    measured = ~np.isnan(np.asarray(getattr(meas, "damping_ratio", np.full(len(meas), np.nan)), dtype=float))
    decay = np.asarray(getattr(meas, "damped", np.zeros(len(meas), dtype=bool)), dtype=bool) & damped_model
    rows = np.flatnonzero(measured | decay)
    if not len(rows):
        return None
    sigma = np.where(measured, np.asarray(getattr(meas, "sigma_damping_ratio", np.ones(len(meas)))), DECAY_SIGMA)
    return rows, sigma[rows], measured[rows]


def zeta_residuals(meas, zeta: np.ndarray, spec, least: np.ndarray | None = None) -> np.ndarray:
    """Whitened damping-ratio residuals (..., Z) of predicted ``zeta`` (..., N, the rows'
    modes): measured rows ``(zeta - zeta_meas) / sigma``; damped rows without a measured
    value ``min(zeta_least, 0) / DECAY_SIGMA`` with ``least`` (..., N) the least damping
    ratio of the row's modes (default ``zeta``): a decay was seen, so no mode of that
    condition grows (a growing one would have left no oscillation to count)."""
    rows, sigma, measured = spec
    z = np.asarray(zeta)[..., rows]
    low = z if least is None else np.minimum(z, np.asarray(least)[..., rows])
    target = np.where(measured, np.asarray(meas.damping_ratio)[rows], 0.0)
    r = (z - np.nan_to_num(target)) / sigma
    return np.where(measured, r, np.minimum(low / sigma, 0.0))


def least_damping(modes) -> np.ndarray:
    """(N,) the least damping ratio among each row's modes (NaN modes left out)."""
    zeta = np.asarray(modes.damping_ratio, dtype=float)
    return np.min(np.where(np.isnan(zeta), np.inf, zeta), axis=1)


def zeta_count(meas) -> int:
    """How many damping-ratio values ``meas`` carries (rows with ``damping_ratio``)."""
    return int(np.sum(~np.isnan(np.asarray(getattr(meas, "damping_ratio", np.full(len(meas), np.nan)), dtype=float))))


def carries_damping(meas) -> bool:
    """Whether ``meas`` can tell a damping effect: a damped frequency (``kind`` = damped) or
    a measured damping ratio. Undamped natural frequencies alone hardly can: omega_n = |s|
    moves with a damping only through the series compliance (the Heli4 with c_a = 3 N m
    s/rad: +0.2 to +0.7 %, below the default 2 % uncertainty and alike for both modes), so
    the diagnosis does not offer damping effects for such data."""
    damped = np.asarray(getattr(meas, "damped", np.zeros(len(meas), dtype=bool)), dtype=bool)
    return bool(damped.any() or zeta_count(meas) > 0)


def attach_damping(comp, meas, modes, idx: np.ndarray, spec):
    """``comp`` given the model's damping ratio of each row's matched mode (``modes`` at the
    rows, ``idx`` their mode indices) and, where the data measured damping (``spec`` from
    :func:`zeta_rows`, else None), the whitened damping-ratio residuals its chi2 includes."""
    comp.zeta = modes.damping_ratio[np.arange(len(idx)), idx]
    comp.zeta_residuals = None if spec is None else zeta_residuals(meas, comp.zeta, spec, least_damping(modes))
    return comp


def zeta_sigma(zeta) -> np.ndarray:
    """The uncertainty of a damping ratio ``zeta`` (-) the data would state by default: the
    larger of ``DEFAULT_SIGMA_ZETA_REL`` |zeta| and ``DEFAULT_SIGMA_ZETA_ABS``
    (:attr:`~.measurements.Measurements.sigma_damping_ratio`)."""
    return np.maximum(DEFAULT_SIGMA_ZETA_REL * np.abs(np.asarray(zeta, dtype=float)), DEFAULT_SIGMA_ZETA_ABS)


def whitened_predictions(comp, meas=None) -> np.ndarray:
    """A comparison's predictions in units of their measurements' uncertainties: each row's
    frequency f / sigma_hz and, on the rows with a measured damping ratio, the model's
    zeta / sigma_damping_ratio (a model without damping: zeta = 0). The distance between two
    models' vectors (:func:`~.stats.separation` with sigma 1) is their chi distance over
    everything the data measured; without measured damping ratios it is the frequencies' alone.
    ``meas``: the measurements compared (default: the comparison's own)."""
    meas = comp.meas if meas is None else meas
    f = np.asarray(comp.predicted, dtype=float) / np.asarray(meas.sigma_hz, dtype=float)
    measured = ~np.isnan(np.asarray(getattr(meas, "damping_ratio", np.full(len(f), np.nan)), dtype=float))
    if not measured.any():
        return f
    zeta = np.zeros(len(f)) if comp.zeta is None else np.asarray(comp.zeta, dtype=float)
    sigma = np.asarray(meas.sigma_damping_ratio, dtype=float)
    return np.concatenate([f, zeta[measured] / sigma[measured]])
