"""The diagnosis statistics pinned against independent computations.

Each test recomputes a criterion of :mod:`eigentwist.diagnose.stats` another way: the
Gaussian likelihood maximised numerically (AICc), SciPy's F and chi-square distributions
(F test, goodness of fit), Monte Carlo (the F test's false-positive rate under the null,
the reversal probability behind the separation threshold). Fits of the real model are in
``test_fit_coverage.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize, stats as sps

from eigentwist.diagnose import stats


# ------------------------------------------------------------------------------------ AICc
def _neg2_log_likelihood(chi2: float, n: int, log_sigma2: np.ndarray) -> float:
    """-2 ln L of n Gaussian residuals whose sigma_i are known up to one factor s, maximised
    over s numerically (not in closed form), with sum(ln sigma_i^2) = ``log_sigma2``."""
    res = optimize.minimize_scalar(
        lambda ln_s2: n * ln_s2 + chi2 / math.exp(ln_s2), bounds=(-40, 40), method="bounded", options={"xatol": 1e-12}
    )
    return n * math.log(2 * math.pi) + log_sigma2 + float(res.fun)


def _aicc_independent(chi2: float, n: int, k: int, log_sigma2: float = 0.0) -> float:
    n_params = k + 1  # k fitted + the common scale of sigma
    aic = _neg2_log_likelihood(chi2, n, log_sigma2) + 2 * n_params
    return aic + 2 * n_params * (n_params + 1) / (n - n_params - 1)


@pytest.mark.parametrize(
    "n, k_a, k_b, chi2_a, chi2_b",
    [(6, 0, 1, 9.0, 4.0), (8, 1, 2, 30.0, 11.0), (5, 0, 2, 3.0, 0.5), (40, 2, 3, 55.0, 50.0)],
)
def test_aicc_differences_match_the_maximised_likelihood(n, k_a, k_b, chi2_a, chi2_b):
    # the constants of the likelihood (n ln 2 pi + sum ln sigma_i^2 + n) cancel in a difference
    got = stats.aicc(chi2_a, n, k_a) - stats.aicc(chi2_b, n, k_b)
    want = _aicc_independent(chi2_a, n, k_a, 3.7) - _aicc_independent(chi2_b, n, k_b, 3.7)
    assert got == pytest.approx(want, abs=1e-6)


def test_aicc_small_sample_term_is_counted():
    # n = 6, chi2 equal: only the parameter penalties differ. AIC alone: 2 per parameter;
    # AICc adds 2K(K+1)/(n-K-1): K = 1 -> 1, K = 2 -> 4, K = 3 -> 12, K = 4 -> 40 (by hand)
    base = 6 * math.log(2.0 / 6)
    assert stats.aicc(2.0, 6, 0) == pytest.approx(base + 2 + 1)
    assert stats.aicc(2.0, 6, 1) == pytest.approx(base + 4 + 4)
    assert stats.aicc(2.0, 6, 2) == pytest.approx(base + 6 + 12)
    assert stats.aicc(2.0, 6, 3) == pytest.approx(base + 8 + 40)
    assert stats.aicc(2.0, 6, 4) == math.inf  # n - K - 1 = 0: undefined, never preferred
    assert stats.aicc(2.0, 5, 3) == math.inf
    assert math.isfinite(stats.aicc(0.0, 6, 0))  # a perfect fit stays comparable


# --------------------------------------------------------------------------------- F test
@pytest.mark.parametrize(
    "chi2_0, k_0, chi2_1, k_1, n",
    [(20.0, 0, 8.0, 1, 10), (14.0, 1, 9.0, 3, 12), (5.0, 2, 4.9, 3, 30), (7.0, 1, 1.0, 2, 4)],
)
def test_f_test_is_the_extra_sum_of_squares_test(chi2_0, k_0, chi2_1, k_1, n):
    f = ((chi2_0 - chi2_1) / (k_1 - k_0)) / (chi2_1 / (n - k_1))
    assert stats.f_test(chi2_0, k_0, chi2_1, k_1, n) == pytest.approx(sps.f.sf(f, k_1 - k_0, n - k_1), rel=1e-12)


def test_f_test_edge_cases():
    assert math.isnan(stats.f_test(5.0, 1, 4.0, 1, 10))  # not nested: nothing added
    assert math.isnan(stats.f_test(5.0, 2, 4.0, 1, 10))
    assert math.isnan(stats.f_test(5.0, 0, 4.0, 3, 3))  # no residual degrees of freedom
    assert stats.f_test(5.0, 0, 0.0, 1, 10) == 0.0  # a perfect fit of data the smaller model misses
    assert stats.f_test(0.0, 0, 0.0, 1, 10) == 1.0
    assert stats.f_test(5.0, 0, 6.0, 1, 10) == 1.0  # a worse fit is no improvement
    assert 0.0 < stats.f_test(5.0, 0, 4.0, 1, 3) < 1.0  # dof = 2 is enough
    assert stats.f_test(5.0, 0, 4.0, 1, 2) == pytest.approx(sps.f.sf(0.25, 1, 1))  # and dof = 1
    assert stats.f_test(0.5, 0, 0.0, 1, 10) == 0.0  # any misfit of model 0 that model 1 removes


def test_f_test_false_positive_rate_under_the_null_is_alpha():
    # nested linear models on n = 4 points: the data have no slope, model 1 fits one. The
    # smallest dof makes a wrong denominator dof (n - k_0) visible: it rejects 12 %, not 5 %.
    rng = np.random.default_rng(20261122)
    n, reps, alpha = 4, 6000, 0.05
    x = np.linspace(-1.0, 1.0, n)
    y = rng.standard_normal((reps, n)) * 0.3
    sigma = 0.3
    chi2_0 = np.sum(((y - y.mean(axis=1, keepdims=True)) / sigma) ** 2, axis=1)
    slope = (y - y.mean(axis=1, keepdims=True)) @ x / (x @ x)
    chi2_1 = chi2_0 - slope**2 * (x @ x) / sigma**2
    p = np.array([stats.f_test(c0, 1, c1, 2, n) for c0, c1 in zip(chi2_0, chi2_1)])
    rate = np.mean(p < alpha)
    assert abs(rate - alpha) < 4 * math.sqrt(alpha * (1 - alpha) / reps), rate
    assert np.mean(p < 0.5) == pytest.approx(0.5, abs=0.03)  # uniform p-values, not only the tail


# ------------------------------------------------------------------ goodness of fit, chi2
def test_chi2_and_goodness_of_fit():
    assert stats.chi2_value([10.0, 20.0], [11.0, 18.0], [0.5, 1.0]) == pytest.approx(4.0 + 4.0)
    assert stats.gof_p_value(12.0, 10, 2) == pytest.approx(sps.chi2.sf(12.0, 8), rel=1e-12)
    assert math.isnan(stats.gof_p_value(1.0, 3, 3))
    assert stats.gof_p_value(1.0, 3, 2) == pytest.approx(sps.chi2.sf(1.0, 1))  # one dof is enough
    dof = 8
    edge = sps.chi2.isf(stats.ALPHA, dof)  # the chi2 at p = alpha
    assert stats.explained(edge * 0.999, dof + 2, 2) and not stats.explained(edge * 1.001, dof + 2, 2)
    assert not stats.explained(0.0, 2, 2)  # nothing left to judge with
    assert stats.explained(edge * 1.001, dof + 2, 2, alpha=stats.ALPHA / 2)
    assert stats.ALPHA == 0.01 and stats.DELTA_AICC == 2.0


def test_goodness_of_fit_p_values_are_uniform_for_a_right_model():
    rng = np.random.default_rng(7)
    n, k, reps = 12, 0, 4000
    chi2 = np.sum(rng.standard_normal((reps, n)) ** 2, axis=1)
    p = np.array([stats.gof_p_value(c, n, k) for c in chi2])
    assert np.mean(p < 0.1) == pytest.approx(0.1, abs=0.02) and np.mean(p < 0.5) == pytest.approx(0.5, abs=0.03)


# ------------------------------------------------------------------------- separation
def test_separation_is_the_whitened_distance():
    a, b, s = np.array([10.0, 20.0, 30.0]), np.array([10.3, 19.6, 30.0]), np.array([0.1, 0.2, 1.0])
    assert stats.separation(a, b, s) == pytest.approx(math.hypot(3.0, 2.0))


def test_noise_reverses_the_order_of_two_models_as_stated():
    # data from model a; how often does model b fit better? The docstring: Phi(-D/2), 6.7 % at D = 3
    rng = np.random.default_rng(11)
    n, reps = 20, 40000
    sigma = np.full(n, 0.5)
    a = np.linspace(10.0, 30.0, n)
    direction = rng.standard_normal(n)
    b = a + direction / np.linalg.norm(direction / sigma) * stats.SEPARATION
    assert stats.separation(a, b, sigma) == pytest.approx(stats.SEPARATION)
    data = a + sigma * rng.standard_normal((reps, n))
    reversed_ = np.mean(np.sum(((data - b) / sigma) ** 2, axis=1) < np.sum(((data - a) / sigma) ** 2, axis=1))
    assert reversed_ == pytest.approx(sps.norm.cdf(-stats.SEPARATION / 2), abs=0.005)
    assert 0.06 < reversed_ < 0.075  # the 3 of the criteria: ~7 %


def _pair(distance: float, n: int = 5):
    sigma = np.full(n, 0.2)
    a = np.linspace(5.0, 9.0, n)
    return a, a + sigma * distance / math.sqrt(n), sigma


@pytest.mark.parametrize(
    "distance, same", [(0.5, True), (1.5, True), (2.5, True), (2.95, True), (3.05, False), (6.0, False)]
)
def test_models_closer_than_three_sigma_are_indistinguishable(distance, same):
    a, b, sigma = _pair(distance)
    assert stats.separation(a, b, sigma) == pytest.approx(distance)
    # AICc far apart: only the separation can make them indistinguishable
    assert stats.indistinguishable(100.0, 120.0, a, b, sigma) is same
    assert stats.indistinguishable(math.inf, 120.0, a, b, sigma) is same


def test_models_with_comparable_support_are_indistinguishable():
    a, b, sigma = _pair(10.0)
    assert stats.indistinguishable(100.0, 101.9, a, b, sigma)
    assert stats.indistinguishable(101.9, 100.0, a, b, sigma)
    assert not stats.indistinguishable(100.0, 102.1, a, b, sigma)
    assert not stats.indistinguishable(102.1, 100.0, a, b, sigma)
    assert not stats.indistinguishable(100.0, math.inf, a, b, sigma)


def test_criteria_state_the_numbers_the_code_uses():
    text = " ".join(stats.CRITERIA.values())
    assert f"D = {stats.SEPARATION:g}" in text and f"< {stats.DELTA_AICC:g}" in text
    assert "2K(K+1)/(n-K-1)" in text and "max(1, chi2/(n-k))" in text


# ------------------------------------------------------------ switched effects (no parameter)
def test_switch_test_is_the_chi2_of_one_dof_scaled_up_only():
    # sigma right (chi2_1/nu <= 1): delta chi2 against chi2 with 1 dof, as written
    assert stats.switch_test(30.0, 18.0, 20, 2) == pytest.approx(sps.chi2.sf(12.0, 1), rel=1e-12)
    # fit worse than sigma: delta chi2 divided by chi2_1/nu = 2
    assert stats.switch_test(76.0, 36.0, 20, 2) == pytest.approx(sps.chi2.sf(20.0, 1), rel=1e-12)
    assert stats.switch_test(10.0, 12.0, 20, 2) == 1.0  # worse with it: no evidence
    assert math.isnan(stats.switch_test(10.0, 5.0, 3, 3))
    assert stats.switch_test(10.0, 5.0, 4, 3) == pytest.approx(sps.chi2.sf(1.0, 1), rel=1e-12)  # dof 1


def test_switch_test_false_positive_rate_under_the_null_is_alpha():
    # an effect that changes nothing real: delta chi2 ~ chi2_1 under the null (projection on one direction)
    rng = np.random.default_rng(5)
    n, reps, alpha = 20, 6000, 0.05
    d = rng.standard_normal(n)
    d /= np.linalg.norm(d)
    e = rng.standard_normal((reps, n))
    chi2_0 = np.sum(e**2, axis=1)
    chi2_1 = chi2_0 - (e @ d) ** 2  # the switched model removes one direction
    p = np.array([stats.switch_test(c0, c1, n, 0) for c0, c1 in zip(chi2_0, chi2_1)])
    assert abs(np.mean(p < alpha) - alpha) < 4 * math.sqrt(alpha * (1 - alpha) / reps)


@pytest.mark.parametrize("x", [-1.0, -1e-300, 0.0, 0.3, 4.2, 61.0])
def test_distribution_functions_equal_scipy_stats(x):
    """The diagnosis' chi2, F and t functions are scipy.stats' (x < 0 on both sides of 0)."""
    from scipy import stats as st

    from eigentwist.diagnose.stats import chi2_cdf, chi2_sf, f_sf, t_isf

    for dof in (1, 3, 52):
        assert chi2_sf(x, dof) == pytest.approx(float(st.chi2.sf(x, dof)), rel=1e-14, abs=1e-300)
        assert chi2_cdf(x, dof) == pytest.approx(float(st.chi2.cdf(x, dof)), rel=1e-14, abs=1e-300)
        assert f_sf(x, 2, dof) == pytest.approx(float(st.f.sf(x, 2, dof)), rel=1e-14, abs=1e-300)
    q = min(max(abs(x) / 100, 1e-4), 0.9)
    assert t_isf(q, 7) == pytest.approx(float(st.t.isf(q, 7)), rel=1e-14)


def test_diagnosis_does_not_import_scipy_stats():
    """The diagnosis' statistics come from scipy.special: importing it leaves scipy.stats out."""
    import subprocess
    import sys

    code = "import sys, eigentwist.diagnose, eigentwist.diagnose.select; print('scipy.stats' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
