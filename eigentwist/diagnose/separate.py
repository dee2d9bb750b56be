"""The next measurement that best tells two fitted models apart.

Both models (with their fitted parameters) are evaluated over a coarse grid of poses
in the robot's workspace box (plus the measured poses), a range of k_a (log-spaced over
the measured range, plus the measured values) and every mode direction both models
have. The measurement proposed is the (pose, k_a, mode) where the predictions differ
most relative to the expected uncertainty sigma = (median relative sigma of the data)
x (mean prediction).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..runtime import EigentwistError
from .damping import carries_damping, zeta_sigma
from .matching import DIRECTIONS, match_frequencies

__all__ = [
    "next_measurement",
    "damping_measurement",
    "workspace_poses",
    "equivalent",
    "measured_band",
    "EQUIVALENT_SIGMA",
    "BAND",
    "QUANTITIES",
]

GRID = 3  # poses per axis of the workspace box
N_KA = 9  # log-spaced k_a values over the measured range
EQUIVALENT_SIGMA = 0.05  # two fitted models never further apart than this (in sigma) are one model
N_RANDOM = 40  # random workspace poses of the equivalence check (plus the grid and the measured ones)
KA_SPAN = 4.0  # k_a of the equivalence check: measured range widened by this factor each way


@lru_cache(maxsize=None)
def _reachable_grid(ev, n: int) -> np.ndarray:
    dim = len(ev.robot.workspace)
    if dim > 3:
        n = min(n, 2)  # a 6-D box: the corners (64 poses), not 3^6
    axes = [np.linspace(lo, hi, n) for lo, hi in ev.robot.workspace]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    try:
        ev.jacobians(grid)
        return grid
    except EigentwistError:
        pass
    keep = []
    for p in grid:
        try:
            ev.jacobians(p)
            keep.append(p)
        except EigentwistError:
            continue
    return np.array(keep).reshape(-1, dim)


def workspace_poses(ev, meas, n: int = GRID) -> np.ndarray:
    """Reachable grid poses of the workspace box (n per axis) and the measured poses, m."""
    poses = np.concatenate([_reachable_grid(ev, n), meas.poses])
    return np.unique(np.round(poses, 9), axis=0)


def _constant_columns(meas) -> dict:
    return {k: float(v[0]) for k, v in meas.params.items() if np.all(v == v[0])}


BAND = 1.25  # a proposed mode lies within the measured band widened this factor each way


def measured_band(meas) -> tuple[float, float]:
    """The frequencies (Hz) a next measurement may ask for: the measured band widened ``BAND`` each way."""
    return float(np.min(meas.freq_hz)) / BAND, float(np.max(meas.freq_hz)) * BAND


def _kind(meas) -> str:
    """The frequency the data measured: ``damped_hz`` where a row is a damped frequency, else ``natural_hz``."""
    return "damped_hz" if np.any(np.asarray(getattr(meas, "damped", False))) else "natural_hz"


def _best(modes_of, labels, rel_sigma, band=(0.0, np.inf), quantity: str = "natural_hz"):
    """(separation, label, row, f_a, f_b) of the largest separation over ``labels``, both
    predictions (``quantity``: the natural or the damped frequency) inside ``band`` (Hz)."""
    best = None
    n = len(modes_of[0].freq_hz)
    for label in labels:
        fs, ok = [], np.ones(n, dtype=bool)
        for m in modes_of:
            f, idx = match_frequencies(m, [label] * n, strict=False)
            if m.damping is not None:  # a damped model: the pole's modulus or its damped frequency
                f = np.asarray(getattr(m, quantity), dtype=float)[np.arange(n), idx]
            fs.append(f)
            ok &= m.direction[np.arange(n), idx] == DIRECTIONS.index(label)
            if m.constrained is not None:  # a rigid constraint's mode: not measurable
                ok &= ~m.constrained[np.arange(n), idx]
        ok &= (np.minimum(fs[0], fs[1]) >= band[0]) & (np.maximum(fs[0], fs[1]) <= band[1])
        sep = np.abs(fs[0] - fs[1]) / (rel_sigma * 0.5 * (fs[0] + fs[1]))
        sep = np.where(ok, sep, -np.inf)
        k = int(np.argmax(sep))
        if np.isfinite(sep[k]) and (best is None or sep[k] > best[0]):
            best = (float(sep[k]), label, k, float(fs[0][k]), float(fs[1][k]))
    return best


def next_measurement(ev, meas, fit_a, fit_b, k_a_range=None, grid: int = GRID) -> dict | None:
    """Where ``fit_a`` and ``fit_b`` (:class:`~eigentwist.diagnose.fit.FitResult`) differ most.

    Only a mode direction the data's sensors observed (a label of ``meas``) and predicted
    inside the measured band (:func:`measured_band`) by both models is proposed. The
    frequencies compared are the kind the data measured: damped (omega_d / 2 pi) where a row
    is a damped frequency, else the natural ones. Returns
    None when there is none, else a dict: ``between`` (the two models, named by the
    effects that differ), ``pose`` (m), ``k_a`` (N m/rad), ``mode`` (direction),
    ``predicted_hz`` (per model), ``separation_sigma``, ``sigma_hz``, and
    ``with_measured_modes`` (the same; kept for the JSON's readers).
    """
    lo, hi = k_a_range or (float(meas.k_a.min()), float(meas.k_a.max()))
    k_a = np.unique(np.concatenate([np.geomspace(lo, hi, N_KA), meas.k_a[(meas.k_a >= lo) & (meas.k_a <= hi)]]))
    poses = workspace_poses(ev, meas, grid)
    pose_rows = np.repeat(poses, len(k_a), axis=0)
    ka_rows = np.tile(k_a, len(poses))
    base = _constant_columns(meas)
    modes_of = [ev.modes(pose_rows, f.effects, k_a=ka_rows, **{**base, **f.fixed}) for f in (fit_a, fit_b)]
    labels = [a for a in modes_of[0].axes if a in modes_of[1].axes and a in set(meas.mode)]
    rel_sigma = float(np.median(meas.relative_sigma))
    name_a, name_b = _label(fit_a, fit_b), _label(fit_b, fit_a)

    def describe(best):
        if best is None:
            return None
        sep, label, k, fa, fb = best
        return {
            "k_a_unit": ev.parameter("k_a").unit,
            "between": [name_a, name_b],
            "pose": pose_rows[k].tolist(),
            "k_a": float(ka_rows[k]),
            "mode": label,
            "predicted_hz": {name_a: fa, name_b: fb},
            "separation_sigma": sep,
            "sigma_hz": rel_sigma * 0.5 * (fa + fb),
        }

    out = describe(_best(modes_of, labels, rel_sigma, measured_band(meas), _kind(meas)))
    if out is not None:
        out["with_measured_modes"] = dict(out)
    return out


QUANTITIES = ("damping_ratio", "damped_hz", "natural_hz")  # what a damping measurement may read


def damping_measurement(ev, meas, fit_a, fit_b, names: tuple | None = None, grid: int = GRID) -> dict | None:
    """Where two fitted damping explanations (``fit_a``, ``fit_b``: models that differ in a
    damping effect) differ most: over the grid and measured poses, k_a log-spaced over the
    measured range (plus the measured values) and the mode directions the data's sensors
    observed, the condition where their predicted damping ratio (sigma:
    :func:`~.damping.zeta_sigma` of the two models' mean, a new measurement's default
    uncertainty) or frequency (the data's kind: damped omega_d / 2 pi where a row is damped,
    else omega_n / 2 pi; sigma: the data's median relative sigma of the mean, Hz) are most
    sigma apart. Only conditions where both models are stable (no growing mode: no step
    response would decay there) and both frequencies lie in the measured band
    (:func:`measured_band`) count.

    Returns None when there is no such condition, else a dict: ``between`` (the models,
    named by the effects that differ), ``quantity`` (``damping_ratio``, ``damped_hz`` or
    ``natural_hz``), ``pose`` (m), ``k_a`` (N m/rad), ``mode`` (direction), ``predicted``
    (per model: the quantity, - or Hz), ``separation_sigma``, ``sigma`` (the quantity's
    unit) and ``unit``; ``names`` (two strings) names the models, by default the effects
    that differ."""
    lo, hi = float(meas.k_a.min()), float(meas.k_a.max())
    k_a = np.unique(np.concatenate([np.geomspace(lo, hi, N_KA), meas.k_a]))
    poses = workspace_poses(ev, meas, grid)
    pose_rows, ka_rows, modes_of = _grid_modes(ev, meas, (fit_a, fit_b), poses, k_a)
    if modes_of is None:
        return None
    labels = [a for a in modes_of[0].axes if a in modes_of[1].axes and a in set(meas.mode)]
    rel_sigma = float(np.median(meas.relative_sigma))
    band = measured_band(meas)
    freq = _kind(meas)
    n = len(pose_rows)
    rows = np.arange(n)
    stable = np.ones(n, dtype=bool)
    for m in modes_of:
        zeta = np.asarray(m.damping_ratio, dtype=float)
        stable &= np.all(np.isnan(zeta) | (zeta >= 0.0), axis=1) & np.asarray(m.stable, dtype=bool)
    best = None
    for label in labels:
        values = {q: [] for q in ("damping_ratio", freq)}
        ok = stable.copy()
        for m in modes_of:
            _, idx = match_frequencies(m, [label] * n, strict=False)
            ok &= m.direction[rows, idx] == DIRECTIONS.index(label)
            if m.constrained is not None:
                ok &= ~m.constrained[rows, idx]
            for q in values:
                values[q].append(np.asarray(getattr(m, q), dtype=float)[rows, idx])
        fa, fb = values[freq]
        ok &= (np.minimum(fa, fb) >= band[0]) & (np.maximum(fa, fb) <= band[1])
        for q, (a, b) in values.items():
            sigma = zeta_sigma(0.5 * (a + b)) if q == "damping_ratio" else rel_sigma * 0.5 * (a + b)
            with np.errstate(invalid="ignore", divide="ignore"):
                sep = np.where(ok, np.abs(a - b) / sigma, -np.inf)
            sep = np.where(np.isnan(sep), -np.inf, sep)
            k = int(np.argmax(sep))
            if np.isfinite(sep[k]) and (best is None or sep[k] > best[0]):
                best = (float(sep[k]), q, label, k, float(a[k]), float(b[k]), float(sigma[k]))
    if best is None:
        return None
    sep, q, label, k, va, vb, sigma = best
    name_a, name_b = names or (_label(fit_a, fit_b), _label(fit_b, fit_a))
    return {
        "between": [name_a, name_b],
        "quantity": q,
        "pose": pose_rows[k].tolist(),
        "k_a": float(ka_rows[k]),
        "k_a_unit": ev.parameter("k_a").unit,
        "mode": label,
        "predicted": {name_a: va, name_b: vb},
        "separation_sigma": sep,
        "sigma": sigma,
        "unit": "-" if q == "damping_ratio" else "Hz",
    }


def _random_poses(ev, n: int, seed: int = 0) -> np.ndarray:
    """``n`` random poses of the workspace box (fixed seed: the check is reproducible), the
    valid ones only (reachable, not singular: ``Evaluator.valid``, one batch)."""
    rng = np.random.default_rng(seed)
    box = np.array(ev.robot.workspace, dtype=float)
    poses = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, len(box)))
    return poses[ev.valid(poses)]


def equivalent(ev, meas, fit_a, fit_b, tol: float = EQUIVALENT_SIGMA) -> dict | None:
    """Whether two fitted models are one model under two names: the same frequencies (within
    ``tol`` sigma, sigma as in :func:`next_measurement`) for every mode both have, at the
    grid and ``N_RANDOM`` random poses of the workspace and the measured ones, times k_a
    log-spaced over the measured range widened ``KA_SPAN`` times each way (not only the
    measured rows). Where the data carry damping (damped frequencies or damping ratios:
    :func:`~.damping.carries_damping`) the damped frequencies and the damping ratios must
    agree as well (:func:`~.damping.zeta_sigma` for a damping ratio's sigma). Returns the
    evidence (``max_separation_sigma``, ``poses``, ``k_a``) when they are, else None."""
    lo, hi = float(meas.k_a.min()) / KA_SPAN, float(meas.k_a.max()) * KA_SPAN
    k_a = np.unique(np.round(np.concatenate([np.geomspace(lo, hi, N_KA), meas.k_a]), 9))
    poses = np.unique(np.round(np.concatenate([workspace_poses(ev, meas), _random_poses(ev, N_RANDOM)]), 9), axis=0)
    pose_rows, ka_rows, modes_of = _grid_modes(ev, meas, (fit_a, fit_b), poses, k_a)
    if modes_of is None:
        return None
    fa, fb = (np.asarray(m.freq_hz, dtype=float) for m in modes_of)
    if fa.shape != fb.shape:
        return None
    # a rigid constraint's mode (infinite frequency, a stand-in value): equal where both models
    # have it, a difference no noise can hide where only one has it
    ca, cb = (np.zeros(fa.shape, dtype=bool) if m.constrained is None else m.constrained for m in modes_of)
    if np.any(ca != cb):
        return None
    fa, fb = np.where(ca, np.nan, fa), np.where(cb, np.nan, fb)
    rel_sigma = float(np.median(meas.relative_sigma))
    with np.errstate(invalid="ignore", divide="ignore"):
        sep = np.abs(fa - fb) / (rel_sigma * 0.5 * (fa + fb))
    if np.isnan(fa).any() != np.isnan(fb).any() or not np.any(np.isfinite(sep)):
        return None
    worst = float(np.nanmax(sep))
    if carries_damping(meas):  # damped frequencies and damping ratios measured: compared too
        worst = max(worst, _damping_apart(modes_of, ~(ca | np.isnan(fa) | np.isnan(fb)), rel_sigma))
    if worst >= tol:
        return None
    return {
        "max_separation_sigma": worst,
        "poses": int(len(poses)),
        "k_a": k_a.tolist(),
        "k_a_unit": ev.parameter("k_a").unit,
    }


def _damping_apart(modes_of, keep: np.ndarray, rel_sigma: float) -> float:
    """The largest separation (sigma) of two models' damped frequencies (sigma: ``rel_sigma``
    of their mean) and damping ratios (:func:`~.damping.zeta_sigma` of their mean) over the
    ``keep`` entries; inf where only one of them is finite (one model stable, one not)."""
    out = 0.0
    for quantity, sigma in (
        ("damped_hz", lambda a, b: rel_sigma * 0.5 * (a + b)),
        ("damping_ratio", lambda a, b: zeta_sigma(0.5 * (a + b))),
    ):
        a, b = (np.asarray(getattr(m, quantity), dtype=float)[keep] for m in modes_of)
        if np.any(np.isfinite(a) != np.isfinite(b)):
            return math.inf
        with np.errstate(invalid="ignore", divide="ignore"):
            sep = np.abs(a - b) / sigma(a, b)
        if np.any(np.isfinite(sep)):
            out = max(out, float(np.nanmax(sep)))
    return out


def _label(f, other) -> str:
    extra = [e for e in f.effects if e not in other.effects]
    return ",".join(extra) if extra else ",".join(f.effects)


def _grid_modes(ev, meas, fits, poses: np.ndarray, k_a: np.ndarray):
    """``(pose_rows, ka_rows, modes)``: every pose at every k_a (N m/rad), and each fit's
    :class:`~eigentwist.runtime.Modes` there (the data's constant columns and the fit's
    values set; invalid poses NaN); ``modes`` None where a model cannot be evaluated."""
    pose_rows = np.repeat(poses, len(k_a), axis=0)
    ka_rows = np.tile(k_a, len(poses))
    base = _constant_columns(meas)
    try:
        modes = [ev.modes(pose_rows, f.effects, k_a=ka_rows, invalid="nan", **{**base, **f.fixed}) for f in fits]
    except EigentwistError:
        return pose_rows, ka_rows, None
    return pose_rows, ka_rows, modes
