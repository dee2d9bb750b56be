"""The statistics of the diagnosis, in one place, with the choices stated.

Residuals are weighted by the measurements' standard uncertainties sigma_i:
chi2 = sum(((f_pred,i - f_meas,i) / sigma_i)^2).

* **Goodness of fit / "explained"**: the sigma_i are taken at face value; the model
  explains the data when P(chi2_{n-k} >= chi2) > ``ALPHA`` (k fitted parameters).
* **Model comparison and significance** depend only on the *relative* weights
  1/sigma_i^2, not on their absolute scale, so a too-small or too-large default sigma
  (2 %) cannot create or hide an effect:

  - AICc with the Gaussian likelihood whose sigma_i are known up to one common scale
    factor (estimated, so it counts as a parameter): ``n ln(chi2/n) + 2K +
    2K(K+1)/(n-K-1)``, K = k + 1 (Burnham & Anderson 2002, Eq. 2.14 with RSS -> chi2).
  - the extra-sum-of-squares F test of nested models:
    ``F = ((chi2_0 - chi2_1)/(k_1 - k_0)) / (chi2_1/(n - k_1))``, p from F(k_1 - k_0,
    n - k_1). An effect switched off is the limit of its parameter (stiffness -> inf,
    mass -> 0), i.e. the null lies on the boundary; the F/chi2 reference distribution is
    then conservative (the p-value is at most twice too large, Self & Liang 1987).
  - an effect without fitted parameters (``gravity_preload``: g is known) costs no
    parameter but is a choice: its p-value is P(chi2_1 >= delta chi2 / s^2) with
    s^2 = max(1, chi2_1/(n - k)) (the sigma_i at face value, scaled up when the fit is
    worse than them), never an F test with zero degrees of freedom;
  - forward selection adds the best candidate only if its p-value is below
    ``ALPHA / m`` for m candidates tested at that step (Bonferroni: the best of m is
    picked after looking at all of them).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

__all__ = [
    "ALPHA",
    "chi2_sf",
    "chi2_cdf",
    "f_sf",
    "t_isf",
    "chi2_value",
    "aicc",
    "f_test",
    "switch_test",
    "gof_p_value",
    "explained",
    "indistinguishable",
    "separation",
    "DELTA_AICC",
    "SEPARATION",
    "CRITERIA",
]

ALPHA = 0.01  # significance level of the F test and of the goodness-of-fit test
DELTA_AICC = 2.0  # below this, two models have comparable support (Burnham & Anderson)
SEPARATION = 3.0  # below this chi2 distance between two models' predictions, noise reverses their order > 7 %

CRITERIA = {
    "ranking": "AICc with sigma known up to a common scale factor (n ln(chi2/n) + 2K + 2K(K+1)/(n-K-1), K = k+1)",
    "p_value": "extra-sum-of-squares F test against the model of the previous step",
    "switched": "an effect without fitted parameters: p = P(chi2_1 >= (chi2_0 - chi2_1)/max(1, chi2_1/(n-k)))",
    "plausible": (
        "a candidate whose fitted value lies outside its parameter's documented plausible range by more than 3 "
        "standard errors, or at a search bound, is reported implausible (with the value it would need) and never "
        "selected"
    ),
    "selection": (
        "add the best-ranked effect while its p-value < alpha/m (Bonferroni over m candidates) and it lowers AICc"
    ),
    "explained": "chi-square goodness of fit with the given sigma: P(chi2_{n-k} >= chi2) > alpha",
    "indistinguishable": (
        "|delta AICc| < 2 (comparable support), or the two fitted models' predictions on the measured rows "
        "are less than D = 3 apart, D^2 = sum(((f_a - f_b)/sigma)^2) + sum(((zeta_a - zeta_b)/sigma_zeta)^2) "
        "over the frequencies and the measured damping ratios (noise alone reverses their order with "
        "probability > 7 %)"
    ),
    "damping": (
        "a damping effect not selected fits as well when, fitted on top of the final model, it is plausible and "
        "its AICc is less than 2 above the final model's; the measurement that separates two damping "
        "explanations is the pose, k_a (measured range) and measured mode where their damping ratios (sigma = "
        "max(0.2 zeta, 0.005)) or frequencies (the data's median relative sigma) are most sigma apart, both "
        "models stable there"
    ),
    "param_std": (
        "from the Jacobian at the optimum: cov = (J^T J)^-1 * max(1, chi2/(n-k)) (scaled up by the Birge ratio when "
        "the fit is worse than sigma), propagated from log-parameters by the delta method"
    ),
}


# The distribution functions the diagnosis needs, from scipy.special (the functions that
# scipy.stats' chi2, f and t call for these), so that a diagnosis does not import scipy.stats.
def chi2_sf(x: float, dof: float) -> float:
    """P(chi2_dof >= x), the chi-square survival function (1 for x < 0; NaN for dof <= 0)."""
    if x < 0:
        return 1.0 if dof > 0 else math.nan
    return float(special.chdtrc(dof, x))


def chi2_cdf(x: float, dof: float) -> float:
    """P(chi2_dof <= x), the chi-square distribution function (0 for x < 0; NaN for dof <= 0)."""
    if x < 0:
        return 0.0 if dof > 0 else math.nan
    return float(special.chdtr(dof, x))


def f_sf(x: float, dfn: float, dfd: float) -> float:
    """P(F_{dfn, dfd} >= x), the F distribution's survival function (1 for x < 0)."""
    if x < 0:
        return 1.0 if dfn > 0 and dfd > 0 else math.nan
    return float(special.fdtrc(dfn, dfd, x))


def t_isf(q: float, dof: float) -> float:
    """The t value exceeded with probability q by Student's t with ``dof`` degrees of freedom."""
    return float(-special.stdtrit(dof, q))


def chi2_value(predicted, measured, sigma) -> float:
    """sum(((predicted - measured)/sigma)^2)."""
    r = (np.asarray(predicted) - np.asarray(measured)) / np.asarray(sigma)
    return float(r @ r)


def aicc(chi2: float, n: int, k: int) -> float:
    """AICc of a weighted least-squares fit with k fitted parameters (see module doc)."""
    big_k = k + 1
    if n - big_k - 1 <= 0:
        return math.inf
    return n * math.log(max(chi2, 1e-300) / n) + 2 * big_k + 2 * big_k * (big_k + 1) / (n - big_k - 1)


def f_test(chi2_0: float, k_0: int, chi2_1: float, k_1: int, n: int) -> float:
    """p-value of the improvement of model 1 (k_1 params) over nested model 0 (k_0 < k_1)."""
    dk, dof = k_1 - k_0, n - k_1
    if dk <= 0 or dof <= 0:
        return math.nan
    if chi2_1 <= 0:
        return 0.0 if chi2_0 > 0 else 1.0
    f = max(chi2_0 - chi2_1, 0.0) / dk / (chi2_1 / dof)
    return f_sf(f, dk, dof)


def gof_p_value(chi2: float, n: int, k: int) -> float:
    """P(chi2_{n-k} >= chi2): probability of a fit this bad or worse if the model and sigma are right."""
    dof = n - k
    if dof <= 0:
        return math.nan
    return chi2_sf(chi2, dof)


def explained(chi2: float, n: int, k: int, alpha: float = ALPHA) -> bool:
    """True when the fit is consistent with the measurement uncertainty (p > alpha)."""
    p = gof_p_value(chi2, n, k)
    return bool(p > alpha) if not math.isnan(p) else False


def separation(pred_a, pred_b, sigma) -> float:
    """D = sqrt(sum(((f_a - f_b)/sigma)^2)): how far apart two models are on the measured rows.

    If the data came from one of them, the chi2 advantage it should have over the other is
    about D^2, and the noise on that advantage has a standard deviation of about 2 D; the
    order is reversed by noise alone with probability ~ Phi(-D/2) (16 % at D = 2, 7 % at 3).
    """
    d = (np.asarray(pred_a) - np.asarray(pred_b)) / np.asarray(sigma)
    return float(np.sqrt(d @ d))


def indistinguishable(aicc_a: float, aicc_b: float, pred_a, pred_b, sigma) -> bool:
    """Whether these data cannot tell two fitted models apart (see CRITERIA)."""
    if separation(pred_a, pred_b, sigma) < SEPARATION:
        return True
    if not (math.isfinite(aicc_a) and math.isfinite(aicc_b)):
        return False
    return bool(abs(aicc_a - aicc_b) < DELTA_AICC)


def switch_test(chi2_0: float, chi2_1: float, n: int, k: int) -> float:
    """p-value of switching on an effect that fits no parameter (see module doc).

    ``chi2_0``/``chi2_1``: without/with the effect; ``k``: parameters fitted in both.
    """
    dof = n - k
    if dof <= 0:
        return math.nan
    scale = max(1.0, chi2_1 / dof)
    return chi2_sf(max(chi2_0 - chi2_1, 0.0) / scale, 1)
