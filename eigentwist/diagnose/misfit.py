"""The cause of a misfit other than a missing effect: too few rows, the stated uncertainty, outliers.

Decided in this order:

1. **Too few rows**: a candidate with k fitted parameters (the current model's and its
   own) needs n > k + 2 rows, otherwise its AICc is infinite and no test has a degree of
   freedom left (:func:`untestable`, decided from the parameter counts, before any
   ranking). Verdict ``"too few rows"``.
2. **The stated uncertainty**, from the final model's Birge ratio B = sqrt(chi2/nu):
   ``"overstated"`` when P(chi2_nu <= chi2) < alpha (the fit is far better than sigma
   allows); ``"understated"`` when P(chi2_nu >= chi2) < alpha *and* the residuals show no
   systematic pattern (:func:`~.patterns.systematic`: a shape over k_a, the pose spread
   scaled by B; :func:`clusters`: neighbouring rows deviating together) *and*
   no catalogue effect is significant any more (implausible ones included) or would
   explain the data without being significant (too few rows for the F test);
   ``"cannot be judged"`` when the fit is far worse than sigma but a pattern or a
   significant effect points at a missing effect (a systematic misfit: the Birge ratio
   then measures the missing effect, not the noise; ``possibly_understated`` set); otherwise
   ``"consistent"`` (never beside a Birge ratio the chi-square test rejects).
3. **Outliers** (:func:`find_outliers`): each row's residual in units of sigma_i times the
   Birge ratio of the other rows (the externally studentized residual) is compared with
   the two-sided Student-t quantile at alpha/n (Bonferroni over the rows), nu - 1 degrees
   of freedom; a row beyond it is an outlier only when it is isolated: none of its
   neighbours (the other modes at the same pose and k_a; the same mode at the same pose
   and the adjacent k_a) deviates the same way by more than ``FAIL_SIGMA``. A pattern
   (the paper's two k_a = 125 N m/rad rows, both modes high) is not an outlier.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .compare import FAIL_SIGMA
from .patterns import systematic
from .stats import chi2_cdf, chi2_sf, t_isf

__all__ = ["Uncertainty", "Outlier", "untestable", "judge_uncertainty", "find_outliers", "VERDICTS"]

VERDICTS = ("consistent", "understated", "overstated", "too few rows", "cannot be judged")
CLUSTER_SIGMA = 2.5  # neighbours both beyond this (studentized, same sign) are a pattern (~0.4 % by chance for 30 rows)


@dataclass
class Uncertainty:
    """The verdict on the stated uncertainty (one of :data:`VERDICTS`) and the numbers behind it."""

    verdict: str
    birge_ratio: float
    chi2: float
    dof: int
    p_low: float = math.nan  # P(chi2_nu <= chi2)
    p_high: float = math.nan  # P(chi2_nu >= chi2)
    possibly_understated: bool = False
    pattern: list = field(default_factory=list)
    effect_significant: bool = False


@dataclass
class Outlier:
    """A row set aside: CSV ``line`` (header = 1), its condition, and its studentized residual."""

    line: int
    k_a: float
    mode: str
    freq_hz: float
    residual_sigma: float


def untestable(n: int, k: int, own: dict) -> dict:
    """Candidates (``own``: effect -> its number of fitted parameters) that n rows cannot test
    on top of a model with k fitted parameters: effect -> rows needed (k + own + 3)."""
    return {e: k + m + 3 for e, m in own.items() if n <= k + m + 2}


def judge_uncertainty(final, untestable_effects: dict, effect_significant: bool, alpha: float) -> Uncertainty:
    """The verdict on the stated sigma from the final model (see module doc)."""
    nu = final.n - final.k
    birge = math.sqrt(final.chi2 / nu) if nu > 0 else math.nan
    if untestable_effects or nu <= 2:
        return Uncertainty("too few rows", birge, final.chi2, nu, effect_significant=effect_significant)
    p_low, p_high = chi2_cdf(final.chi2, nu), chi2_sf(final.chi2, nu)
    out = Uncertainty("consistent", birge, final.chi2, nu, p_low, p_high, effect_significant=effect_significant)
    if p_low < alpha:
        out.verdict = "overstated"
    elif p_high < alpha:
        out.pattern = [
            f"mode {p} over k_a" if p != "pose" else "over poses" for p in systematic(final.comparison, max(birge, 1.0))
        ] + clusters(final.comparison, final.k)
        if out.pattern or effect_significant:
            out.verdict, out.possibly_understated = "cannot be judged", True
        else:
            out.verdict = "understated"
    return out


def _neighbours(meas, i: int) -> np.ndarray:
    """Rows next to row i: other modes at its pose and k_a; its mode at its pose and the adjacent k_a."""
    same_pose = np.all(np.isclose(meas.poses, meas.poses[i], atol=1e-6), axis=1)
    mode = np.asarray(meas.mode)
    same_ka = np.isclose(meas.k_a, meas.k_a[i], rtol=1e-9)
    across = same_pose & same_ka & (mode != mode[i])
    along = same_pose & (mode == mode[i])
    levels = np.unique(meas.k_a[along])
    at = int(np.searchsorted(levels, meas.k_a[i]))
    adjacent = [levels[j] for j in (at - 1, at + 1) if 0 <= j < len(levels)]
    along &= np.isin(meas.k_a, adjacent)
    return np.flatnonzero(across | along)


def studentized(comparison, k: int) -> np.ndarray:
    """Each row's residual / (sigma_i x the Birge ratio of the other rows)."""
    r = comparison.error_sigma
    nu = len(r) - k
    chi2 = float(r @ r)
    scale = np.sqrt(np.maximum((chi2 - r * r) / max(nu - 1, 1), 1e-300))
    return r / scale


def clusters(comparison, k: int) -> list[str]:
    """Neighbouring rows (:func:`_neighbours`) that deviate together the same way by more than
    ``CLUSTER_SIGMA`` (studentized): a pattern, e.g. both modes high at one k_a."""
    z = studentized(comparison, k)
    meas = comparison.meas
    out, seen = [], set()
    for i in np.flatnonzero(np.abs(z) > CLUSTER_SIGMA):
        near = [j for j in _neighbours(meas, i) if np.sign(z[j]) == np.sign(z[i]) and abs(z[j]) > CLUSTER_SIGMA]
        group = tuple(sorted({int(meas.lines[j]) for j in [i, *near]}))
        if near and group not in seen:
            seen.add(group)
            out.append(f"lines {', '.join(map(str, group))} deviate together")
    return out


def find_outliers(comparison, k: int, alpha: float) -> list[Outlier]:
    """Isolated rows beyond the alpha/n threshold, worst first (see module doc)."""
    meas = comparison.meas
    n = len(meas)
    nu = n - k
    if nu < 3:
        return []
    z = studentized(comparison, k)
    threshold = t_isf(alpha / (2 * n), nu - 1)
    out = []
    for i in np.flatnonzero(np.abs(z) > threshold):
        near = _neighbours(meas, i)
        if np.any((np.sign(z[near]) == np.sign(z[i])) & (np.abs(z[near]) > FAIL_SIGMA)):
            continue  # part of a pattern, not an isolated row
        out.append(
            Outlier(int(meas.lines[i]), float(meas.k_a[i]), str(meas.mode[i]), float(meas.freq_hz[i]), float(z[i]))
        )
    return sorted(out, key=lambda o: (-abs(o.residual_sigma), o.line))
