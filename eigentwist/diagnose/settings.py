"""Whole settings that do not belong: a setting (pose x k_a) written wrong.

A lab's commonest error is a setting written with the wrong k_a (or pose): all its modes
then deviate together, so the isolated-row check (:mod:`.misfit`) rightly calls it a
pattern, and the selection would add an effect to absorb it. After the isolated-row
check, each setting with ``MIN_ROWS`` or more rows is checked as a unit against the final model:

* its chi-square, scaled by the Birge ratio of the *other* rows (never below 1), is
  beyond the chi2_{n_s} quantile at alpha/S (Bonferroni over the S settings), and
* the same model at another k_a (a log grid over the measured range widened ``KA_SPAN``
  times each way, plus the measured levels) or at another measured pose (at its written
  k_a) fits its rows within the noise (chi-square test at alpha, one degree of freedom
  spent on the search) and ``FAR`` times better than at its own.

A setting of fewer than ``MIN_ROWS`` rows (one or two modes at one pose and k_a) is checked
by leaving it out: the final model refitted on the other rows predicts its rows; their
chi-square, scaled by the Birge ratio of that refit (never below 1), is beyond the
chi2_{n_s} quantile at alpha/S (S: every setting), and the same refit at another *measured* k_a
or pose (:func:`measured_label`) fits them within the noise (chi2_{n_s} test at alpha) and ``FAR`` times better.

Such a setting is reported (:class:`SettingAnomaly`: its CSV lines, the written and the
best-fitting k_a or pose, the evidence), set aside like an outlier, and the selection
rerun without it; its best k_a (or pose) is then given under the model refitted without it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..runtime.errors import InputError
from .measurements import Measurements
from .predict import Predictor
from .stats import chi2_sf

__all__ = [
    "SettingAnomaly",
    "find_setting_anomalies",
    "settings_of",
    "best_label",
    "measured_label",
    "rescored",
    "deviates",
    "relabelled_fits",
    "FAR",
    "MIN_ROWS",
]

FAR = 10.0  # the best other k_a (or pose) fits this many times better in chi-square
KA_SPAN = 4.0  # k_a searched from min/KA_SPAN to max*KA_SPAN of the measured values
N_KA = 121  # log-spaced k_a values searched
MIN_ROWS = 3  # rows a setting needs: the search spends one degree of freedom, the check of the
# relabelled fit needs two more (the paper's two-row k_a = 125 setting stays a pattern)


@dataclass
class SettingAnomaly:
    """A setting whose rows all fit the model at another k_a (or pose) far better than at its own."""

    lines: list
    pose: list
    k_a: float
    best_k_a: float
    best_pose: list
    chi2_own: float
    chi2_best: float
    n_rows: int
    p_own: float
    scale: float

    @property
    def what(self) -> str:
        """``"k_a"`` or ``"pose"``: which label the best fit changes."""
        return "pose" if self.best_pose != self.pose else "k_a"

    def to_json(self) -> dict:
        return {
            "lines": list(self.lines),
            "pose": list(self.pose),
            "k_a": self.k_a,
            "best_k_a": self.best_k_a,
            "best_pose": list(self.best_pose),
            "mislabelled": self.what,
            "evidence": {
                "chi2_written": self.chi2_own,
                "chi2_best": self.chi2_best,
                "rows": self.n_rows,
                "p_written": self.p_own,
                "birge_ratio_of_other_rows": self.scale**0.5,
            },
        }


def settings_of(meas) -> list[np.ndarray]:
    """Row indices of each setting (same pose to 1e-6, same k_a to 1e-9 relative), in row order.
    A mode label met again under the same pose and k_a starts another setting (the n-th row of
    each label is the n-th setting): a setting written with another's k_a or pose stays apart."""
    key = [tuple(np.round(p, 6)) + (float(f"{k:.9g}"),) for p, k in zip(meas.poses, meas.k_a)]
    groups: dict = {}
    seen: dict = {}
    for i, (k, label) in enumerate(zip(key, meas.mode)):
        n = seen.get((k, label), 0)
        seen[(k, label)] = n + 1
        groups.setdefault(k + (n,), []).append(i)
    return [np.array(g) for g in groups.values()]


def _relabelled(sub: Measurements, k_a: np.ndarray, poses: np.ndarray) -> Measurements:
    """``sub``'s rows repeated once per (k_a, pose) pair given."""
    n, b = len(sub), len(k_a)
    rows = np.tile(np.arange(n), b)
    return Measurements(
        np.repeat(k_a, n),
        tuple(sub.mode[i] for i in rows),
        sub.freq_hz[rows],
        sub.sigma_hz[rows],
        np.repeat(poses, n, axis=0),
        {k: v[rows] for k, v in sub.params.items()},
        sub.lines[rows],
        sub.source,
        sub.robot,
        {},
        sub.k_a_unit,
    )


def _chi2_table(sub: Measurements, ev, final, k_a: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """chi2 of ``sub``'s rows under the final model relabelled with each (k_a, pose) pair."""
    tiled = _relabelled(sub, k_a, poses)
    pred = np.asarray(Predictor(tiled, final.effects, ev, final.fixed).predict(strict=False)[0], dtype=float)
    r = ((pred - tiled.freq_hz) / tiled.sigma_hz).reshape(len(k_a), len(sub))
    chi2 = np.sum(r * r, axis=1)
    return np.where(np.isfinite(chi2), chi2, np.inf)


def best_label(sub: Measurements, ev, final, meas) -> tuple[float, np.ndarray, float]:
    """(k_a, pose, chi2) under which ``final`` fits the setting ``sub`` best: its pose at k_a on a
    log grid over ``meas``' range widened ``KA_SPAN`` times (refined between the grid's
    neighbours), or another measured pose of ``meas`` at its written k_a."""
    levels = np.unique(meas.k_a)
    grid = np.unique(np.concatenate([np.geomspace(levels.min() / KA_SPAN, levels.max() * KA_SPAN, N_KA), levels]))
    poses = np.unique(np.round(meas.poses, 9), axis=0)
    pose0, ka0 = sub.poses[0], float(sub.k_a[0])
    others = np.reshape([p for p in poses if not np.allclose(p, pose0, atol=1e-6)], (-1, poses.shape[1]))
    k_try = np.concatenate([grid, np.full(len(others), ka0)])
    p_try = np.concatenate([np.repeat(pose0[None, :], len(grid), axis=0), others])
    chi2 = _chi2_table(sub, ev, final, k_try, p_try)
    best = int(np.argmin(chi2))
    if best < len(grid):  # refine the k_a between the grid's neighbours
        fine = np.geomspace(grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)], 41)
        chi2_fine = _chi2_table(sub, ev, final, fine, np.repeat(pose0[None, :], len(fine), axis=0))
        j = int(np.argmin(chi2_fine))
        if chi2_fine[j] < chi2[best]:
            return float(fine[j]), pose0, float(chi2_fine[j])
    return float(k_try[best]), p_try[best], float(chi2[best])


def measured_label(sub: Measurements, ev, final, meas) -> tuple[float, np.ndarray, float]:
    """(k_a, pose, chi2) under which ``final`` fits the small setting ``sub`` best among the labels
    ``meas`` already has: another measured k_a at its pose, or another measured pose at its k_a
    (a search over a continuous k_a would spend a degree of freedom that one or two rows cannot
    spare: any model error there would look like a wrong label)."""
    levels = np.unique(meas.k_a)
    poses = np.unique(np.round(meas.poses, 9), axis=0)
    pose0, ka0 = sub.poses[0], float(sub.k_a[0])
    ks = levels[~np.isclose(levels, ka0, rtol=1e-9)]
    others = np.reshape([p for p in poses if not np.allclose(p, pose0, atol=1e-6)], (-1, poses.shape[1]))
    k_try = np.concatenate([ks, np.full(len(others), ka0)])
    p_try = np.concatenate([np.repeat(pose0[None, :], len(ks), axis=0), others])
    if not len(k_try):
        return ka0, pose0, np.inf
    chi2 = _chi2_table(sub, ev, final, k_try, p_try)
    best = int(np.argmin(chi2))
    return float(k_try[best]), p_try[best], float(chi2[best])


def rescored(anomaly: SettingAnomaly, meas, ev, final) -> SettingAnomaly:
    """``anomaly``'s best k_a (or pose) and its chi-square under ``final``, e.g. the model refitted
    without it (the model that flagged it was biased by its rows)."""
    sub = meas.subset(np.isin(meas.lines, anomaly.lines))
    k, pose, chi2 = (best_label if anomaly.n_rows >= MIN_ROWS else measured_label)(sub, ev, final, meas)
    return SettingAnomaly(
        anomaly.lines,
        anomaly.pose,
        anomaly.k_a,
        k,
        np.asarray(pose).tolist(),
        anomaly.chi2_own,
        chi2,
        anomaly.n_rows,
        anomaly.p_own,
        anomaly.scale,
    )


def deviates(own: float, scale: float, n_rows: int, alpha: float, n_settings: int) -> float | None:
    """p-value of a setting's chi-square ``own`` over ``n_rows`` rows (scaled by ``scale``, the
    other rows' squared Birge ratio) when it is below alpha/n_settings (Bonferroni over the
    settings checked), else None."""
    p = chi2_sf(own / scale, n_rows)
    return p if p < alpha / max(n_settings, 1) else None


def relabelled_fits(best: float, own: float, scale: float, dof: int, alpha: float) -> bool:
    """Whether a setting relabelled (chi-square ``best``) fits within the noise (chi2_dof test at
    alpha, dof at least 1) and ``FAR`` times better than as written (``own``)."""
    return bool(chi2_sf(best / scale, max(dof, 1)) > alpha and best * FAR < own)


def _left_out(meas, ev, final, g: np.ndarray, alpha: float, n_settings: int) -> SettingAnomaly | None:
    """The leave-one-setting-out check of a setting of fewer than MIN_ROWS rows (module doc)."""
    from .fit import fit

    keep = np.ones(len(meas), dtype=bool)
    keep[g] = False
    rest = meas.subset(keep)
    dof_rest = len(rest) - final.k
    if dof_rest <= 0:
        return None
    try:
        g_fit = fit(rest, final.effects, ev, final.names, start=final.values, fixed=final.fixed, explore=())
    except InputError:
        return None
    sub = meas.subset(~keep)
    pred = np.asarray(Predictor(sub, g_fit.effects, ev, g_fit.fixed).predict(strict=False)[0], dtype=float)
    res = (pred - sub.freq_hz) / sub.sigma_hz
    own = float(res @ res) if np.all(np.isfinite(res)) else np.inf
    scale = max(1.0, g_fit.chi2 / dof_rest)
    p_own = deviates(own, scale, len(g), alpha, n_settings)
    if p_own is None:
        return None
    k, pose, chi2 = measured_label(sub, ev, g_fit, meas)
    if relabelled_fits(chi2, own, scale, len(g), alpha):
        return SettingAnomaly(
            [int(x) for x in sub.lines],
            sub.poses[0].tolist(),
            float(sub.k_a[0]),
            k,
            np.asarray(pose).tolist(),
            own,
            chi2,
            len(g),
            p_own,
            scale,
        )
    return None


def find_setting_anomalies(meas, ev, final, alpha: float) -> list[SettingAnomaly]:
    """Settings that do not belong (see module doc), worst first."""
    every = settings_of(meas)
    groups = [g for g in every if len(g) >= MIN_ROWS]
    if len(every) < 3:
        return []
    out = [
        a
        for g in every
        if len(g) < MIN_ROWS
        for a in [_left_out(meas, ev, final, g, alpha, len(every))]
        if a is not None
    ]
    if len(groups) < 3:
        return sorted(out, key=lambda a: -a.chi2_own)
    r = final.comparison.error_sigma
    total, n = float(r @ r), len(r)
    for g in groups:
        own = float(r[g] @ r[g])
        dof_other = n - len(g) - final.k
        scale = max(1.0, (total - own) / dof_other) if dof_other > 0 else 1.0
        p_own = deviates(own, scale, len(g), alpha, len(groups))
        if p_own is None:
            continue
        sub = meas.subset(g)
        k, pose, chi2 = best_label(sub, ev, final, meas)
        if relabelled_fits(chi2, own, scale, len(g) - 1, alpha):
            out.append(
                SettingAnomaly(
                    [int(x) for x in sub.lines],
                    sub.poses[0].tolist(),
                    float(sub.k_a[0]),
                    k,
                    np.asarray(pose).tolist(),
                    own,
                    chi2,
                    len(g),
                    p_own,
                    scale,
                )
            )
    return sorted(out, key=lambda a: -a.chi2_own)
