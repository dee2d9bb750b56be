"""Every threshold of the diagnosis' decisions, just inside and just outside (cheap: no selection runs).

Expectations are the documented rules themselves, evaluated here independently (SciPy's chi2
and F distributions): the Bonferroni divisors, the "far better" factor, the minimum rows of a
setting, the AICc conditions, the mirror tolerance, the plausible range, the unit factors, the
measured band, the equivalence threshold of the subset search, the shares of rows set aside as
outliers and as whole settings, a failing row, the pose spread, the rows a shape over k_a and a
judged uncertainty need, the AICc rounding of the ranking and an identifiable extra parameter.
The damping part's rules and the equivalence threshold (EQUIVALENT_SIGMA) are in
tests/test_damping_answer.py.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from scipy import stats

from eigentwist.diagnose import backward, mirror, search, separate, settings, units
from eigentwist.diagnose.plausible import PLAUSIBLE_SIGMA, is_plausible
from eigentwist.diagnose.significance import significant
from eigentwist.diagnose.stats import DELTA_AICC, SEPARATION, indistinguishable

ALPHA = 0.01
IN, OUT = 0.99, 1.01  # just inside / just outside a threshold (relative)


def _fit(chi2=10.0, k=1, n=30, aicc=0.0, pred=(1.0,)):
    return NS(chi2=chi2, k=k, n=n, aicc=aicc, comparison=NS(predicted=np.asarray(pred, float)))


# ------------------------------------------------------------------ forward and backward rules


@pytest.mark.parametrize("m", [1, 5, 28])
def test_forward_significance_is_bonferroni_over_the_step_candidates(m):
    current = _fit(aicc=0.0)
    for p, expected in ((ALPHA / m * IN, True), (ALPHA / m * OUT, False)):
        c = NS(plausible=True, p_value=p, fit=_fit(aicc=-1.0))
        assert significant(c, current, m, ALPHA) is expected
    # the AICc condition: significant but not lowering AICc is not added
    c = NS(plausible=True, p_value=1e-12, fit=_fit(aicc=0.0))
    assert not significant(c, current, m, ALPHA)
    c = NS(plausible=False, p_value=1e-12, fit=_fit(aicc=-5.0))
    assert not significant(c, current, m, ALPHA) and significant(c, current, m, ALPHA, plausible_only=False)


@pytest.mark.parametrize("m", [1, 4])
def test_backward_keeps_an_effect_only_below_alpha_over_m_and_with_a_lower_aicc(m):
    final, smaller = _fit(aicc=-1.0), _fit(aicc=0.0)
    assert backward._needed(ALPHA / m * IN, final, smaller, m, ALPHA)
    assert not backward._needed(ALPHA / m * OUT, final, smaller, m, ALPHA)
    assert not backward._needed(1e-12, _fit(aicc=0.0), smaller, m, ALPHA)  # AICc not lower
    assert not backward._needed(math.nan, final, smaller, m, ALPHA)


def test_backward_removes_the_least_needed_effect_first(monkeypatch):
    """Two unneeded effects: the one with the larger p-value goes first (then the other)."""
    final = _fit(aicc=-10.0)
    p = {"a": 0.3, "b": 0.6, "c": 1e-9}
    monkeypatch.setattr(
        backward, "without", lambda meas, ev, f, e: NS(aicc=f.aicc + (5.0 if e == "c" else -1.0), effects=(), removed=e)
    )
    monkeypatch.setattr(backward, "removal_test", lambda f, smaller: p[smaller.removed])
    final.effects = ("a", "b", "c")
    out = backward.eliminate(None, None, final, [("a", 3), ("b", 3), ("c", 3)], ALPHA)
    assert [r.effect for r in out] == ["b", "a"]
    assert out[0].after == ("c",) and out[1].after == ("c",)


# ------------------------------------------------------------------ settings


@pytest.mark.parametrize("n_rows, n_settings", [(2, 8), (1, 20), (3, 10)])
def test_a_setting_deviates_below_alpha_over_the_number_of_settings(n_rows, n_settings):
    edge = stats.chi2.isf(ALPHA / n_settings, n_rows)  # chi2 with p = alpha/S exactly
    assert settings.deviates(edge * OUT, 1.0, n_rows, ALPHA, n_settings) is not None
    assert settings.deviates(edge * IN, 1.0, n_rows, ALPHA, n_settings) is None
    # the Birge scale of the other rows divides the chi-square
    assert settings.deviates(edge * OUT * 2.0, 2.0, n_rows, ALPHA, n_settings) is not None
    assert settings.deviates(edge * IN * 2.0, 2.0, n_rows, ALPHA, n_settings) is None


def test_a_relabelled_setting_must_fit_far_better_and_within_the_noise():
    best = 1.0
    assert settings.relabelled_fits(best, settings.FAR * best * OUT, 1.0, 2, ALPHA)
    assert not settings.relabelled_fits(best, settings.FAR * best * IN, 1.0, 2, ALPHA)
    edge = stats.chi2.isf(ALPHA, 2)  # the relabelled fit's own test at alpha
    assert settings.relabelled_fits(edge * IN, 1e9, 1.0, 2, ALPHA)
    assert not settings.relabelled_fits(edge * OUT, 1e9, 1.0, 2, ALPHA)
    assert settings.relabelled_fits(stats.chi2.isf(ALPHA, 1) * IN, 1e9, 1.0, 0, ALPHA)  # dof at least 1


def _meas(labels, k_a, poses):
    return NS(mode=tuple(labels), k_a=np.asarray(k_a, float), poses=np.asarray(poses, float))


def test_settings_are_split_where_a_mode_label_repeats():
    p = [0, 0, -0.6]
    m = _meas("xyxyz", [2000] * 5, [p] * 5)  # a setting written with another's k_a
    assert [g.tolist() for g in settings.settings_of(m)] == [[0, 1, 4], [2, 3]]


def test_settings_below_min_rows_take_the_leave_one_out_check(monkeypatch):
    """MIN_ROWS - 1 rows: the leave-one-setting-out check; MIN_ROWS rows: the whole-setting check."""
    calls = []
    monkeypatch.setattr(settings, "_left_out", lambda meas, ev, final, g, alpha, s: calls.append(len(g)))
    n = settings.MIN_ROWS
    labels = ["x", "y", "z"][:n] * 2 + ["x", "y", "z"][: n - 1] * 2
    k_a = [100] * n + [200] * n + [300] * (n - 1) + [400] * (n - 1)
    m = _meas(labels, k_a, [[0, 0, -0.6]] * len(labels))
    final = NS(comparison=NS(error_sigma=np.zeros(len(labels))), k=1)
    assert settings.find_setting_anomalies(m, None, final, ALPHA) == []
    assert calls == [n - 1, n - 1]


# ------------------------------------------------------------------ ties, mirrors, plausibility


def test_indistinguishable_at_delta_aicc_and_separation():
    sigma = np.ones(1)
    far = (np.zeros(1), np.full(1, 10.0))
    assert indistinguishable(0.0, DELTA_AICC * IN, *far, sigma)
    assert not indistinguishable(0.0, DELTA_AICC * OUT, *far, sigma)
    assert indistinguishable(0.0, 100.0, np.zeros(1), np.full(1, SEPARATION * IN), sigma)
    assert not indistinguishable(0.0, 100.0, np.zeros(1), np.full(1, SEPARATION * OUT), sigma)


def test_mirror_images_agree_within_mirror_sigma_on_every_row():
    sigma = np.ones(3)
    a = _fit(pred=(1.0, 2.0, 3.0))
    assert mirror.same_fit(a, _fit(pred=(1.0, 2.0, 3.0 + mirror.MIRROR_SIGMA * IN)), sigma)
    assert not mirror.same_fit(a, _fit(pred=(1.0, 2.0, 3.0 + mirror.MIRROR_SIGMA * OUT)), sigma)


def test_plausible_within_plausible_sigma_standard_errors_of_the_range():
    lo, hi, std = 1.0, 2.0, 0.1  # linear range edge 2.0, std 0.1
    assert is_plausible(2.0 + PLAUSIBLE_SIGMA * std * IN, std, (-1.0, hi))
    assert not is_plausible(2.0 + PLAUSIBLE_SIGMA * std * OUT, std, (-1.0, hi))
    # positive range: relative, on the log
    v_in, v_out = hi * math.exp(PLAUSIBLE_SIGMA * 0.01 * IN), hi * math.exp(PLAUSIBLE_SIGMA * 0.01 * OUT)
    assert is_plausible(v_in, 0.01 * v_in, (lo, hi)) and not is_plausible(v_out, 0.01 * v_out, (lo, hi))
    assert not is_plausible(1.5, 0.1, (lo, hi), at_bound=True)  # never at a bound


def test_a_value_outside_its_plausible_range_is_never_explained():
    from eigentwist.diagnose.plausible import outside_plausible

    p = NS(plausible_range=(0.3, 1.0))
    ev = NS(parameter=lambda name: p)
    assert outside_plausible(ev, NS(values={"eta_a": 1.0})) == {}
    assert outside_plausible(ev, NS(values={"eta_a": 1.0 + 1e-9})) == {"eta_a": (1.0 + 1e-9, (0.3, 1.0))}
    assert outside_plausible(ev, NS(values={"eta_a": 0.3 - 1e-9})) != {}
    assert outside_plausible(ev, NS(values={"eta_a": 1.0 - 1e-9}, at_bound=("eta_a",))) != {}  # at a hard bound


# ------------------------------------------------------------------ units, band, search


@pytest.mark.parametrize("unit, factor", units.UNITS)
def test_units_line_within_unit_tol_of_the_unit_factor(unit, factor):
    pred = np.array([10.0, 20.0, 30.0])
    assert unit in units.unit_note(pred * factor * units.UNIT_TOL * IN, pred)
    assert unit in units.unit_note(pred * factor / units.UNIT_TOL * OUT, pred)
    outside = units.unit_note(pred * factor * units.UNIT_TOL * OUT, pred)
    assert outside is None or unit not in outside


def test_no_units_line_within_unit_tol_of_the_model():
    pred = np.array([10.0, 20.0])
    assert units.unit_note(pred * units.UNIT_TOL * IN, pred) is None
    assert units.unit_note(pred / units.UNIT_TOL * OUT, pred) is None
    assert units.unit_note(pred * 2 * math.pi, pred).startswith("Units:")


def test_the_measured_band_is_widened_by_band_each_way():
    lo, hi = separate.measured_band(NS(freq_hz=np.array([20.0, 50.0, 100.0])))
    assert lo == pytest.approx(20.0 / separate.BAND) and hi == pytest.approx(100.0 * separate.BAND)


def test_search_pools_singles_whose_predictions_stay_within_same():
    sigma = np.ones(2)
    meas = NS(sigma_hz=sigma)

    def cand(name, pred, aicc):
        return NS(effect=name, plausible=True, fit=_fit(aicc=aicc, pred=pred))

    ranking = [
        cand("a", (0.0, 0.0), 1.0),
        cand("b", (0.0, search.SAME * IN), 1.0),
        cand("c", (0.0, search.SAME * OUT), 2.0),
        NS(effect="d", plausible=False, fit=_fit(aicc=0.0)),
    ]
    pool, same = search._distinct(meas, ranking)
    assert [c.effect for c in pool] == ["a", "c"] and same == {"a": ["b"]}


def test_search_member_needed_below_alpha_over_m_and_lowering_aicc():
    n, m = 40, 20
    smaller = _fit(chi2=100.0, k=1, n=n, aicc=0.0)
    f_edge = stats.f.isf(ALPHA / m, 1, n - 2)  # F with p = alpha/m exactly
    chi2_edge = 100.0 / (1 + f_edge / (n - 2))  # (100 - c)/(c/(n-2)) = F
    ok, p = search._needed(_fit(chi2=chi2_edge * IN, k=2, n=n, aicc=-1.0), smaller, m, ALPHA)
    assert ok and p < ALPHA / m
    ok, p = search._needed(_fit(chi2=chi2_edge * 1.0001, k=2, n=n, aicc=-1.0), smaller, m, ALPHA)
    assert not ok and p > ALPHA / m
    assert not search._needed(_fit(chi2=1.0, k=2, n=n, aicc=0.0), smaller, m, ALPHA)[0]  # AICc not lower


def test_an_axis_no_mode_points_along_takes_the_mode_repeating_a_lower_direction():
    from eigentwist.diagnose.matching import _by_order

    direction = np.array([[3, 3, 5, 0, 2, 1], [4, 3, 5, 0, 2, 1]])  # "x, x, z, ..." and "y, x, z, ..."
    share = np.array([[0.4, 0.3, 0.0, 0.1, 0.1, 0.1], [0.5, 0.3, 0.0, 0.1, 0.1, 0.1]])
    assert _by_order(direction, share).tolist() == [1, 0]  # the second x; no repeat: the largest share


def test_ambiguous_labels_at_a_delta_pose_are_matched_by_order_and_said_once():
    """At this pose the Delta's two lowest modes both point along x: rows written 1, 2, 3 by rank
    and relabelled x, y, z are matched to the same modes as the ranks (noise-free: exactly)."""
    import dataclasses

    import eigentwist
    from eigentwist.diagnose import synth
    from eigentwist.diagnose.select import _baseline

    ev = eigentwist.load("delta", backend="numpy")
    pose = [[-0.0057, 0.1558, -0.6231]]
    meas = synth("paper", (1000, 4000), pose, ("1", "2", "3"), 0.0, seed=0, ev=ev)
    named = dataclasses.replace(meas, mode=tuple({"1": "x", "2": "y", "3": "z"}[m] for m in meas.mode))
    cmp, notes = _baseline(named, ev, ("actuator_loss", "rod_compliance"), None)
    assert np.allclose(cmp.predicted, meas.freq_hz, rtol=1e-9)
    assert len(notes) == 1 and notes[0].startswith("Mode labels:")
    scaled = dataclasses.replace(meas, freq_hz=meas.freq_hz * 2 * np.pi, sigma_hz=meas.sigma_hz * 2 * np.pi)
    cmp, notes = _baseline(scaled, ev, ("actuator_loss", "rod_compliance"), None)
    assert len(notes) == 1 and "rad/s" in notes[0]


def test_the_search_replaces_the_stepwise_result_only_when_better_by_more_than_better():
    def sub(effects, aicc):
        return search.Subset(tuple(effects), _fit(aicc=aicc), True, True)

    assert search.replaces(sub(("a", "b"), -search.BETTER * OUT), ("c", "d"), 0.0)
    assert not search.replaces(sub(("a", "b"), -search.BETTER * IN), ("c", "d"), 0.0)
    assert not search.replaces(sub(("d", "c"), -100.0), ("c", "d"), 0.0)  # the same effects
    assert not search.replaces(None, ("c",), 0.0)


def test_rows_and_settings_are_checked_from_min_dof_rows_degrees_of_freedom():
    from eigentwist.diagnose.select import MIN_DOF_ROWS, rows_checked

    assert rows_checked(NS(untestable={}, final=NS(dof=MIN_DOF_ROWS)))
    assert not rows_checked(NS(untestable={}, final=NS(dof=MIN_DOF_ROWS - 1)))
    assert not rows_checked(NS(untestable={"payload_mass": 5}, final=NS(dof=30)))


@pytest.mark.parametrize(
    "factor, signs, expected",
    [
        (1.01, (1, 1), ["lines 2, 3 deviate together"]),  # both just beyond, the same way: a pattern
        (0.99, (1, 1), []),  # both just inside: nothing
        (1.01, (1, -1), []),  # beyond, but opposite ways: no pattern
    ],
)
def test_cluster_sigma_on_both_sides(factor, signs, expected):
    """Two neighbouring rows (modes x and y at one pose and k_a) whose studentized residuals
    (each residual over the Birge ratio of the other rows, computed here from its definition)
    sit just beyond or just inside the documented 2.5 (``misfit.CLUSTER_SIGMA``)."""
    from types import SimpleNamespace

    from eigentwist.diagnose.misfit import clusters

    n, k = 30, 1
    background = np.where(np.arange(n - 2) % 2, 1.0, -1.0)  # |z| ~ 1 each, alternating: no pattern
    B, nu = float(background @ background), n - k
    z = 2.5 * factor
    a = np.sqrt(z**2 * B / (nu - 1 - z**2))  # z = a / sqrt((a^2 + B) / (nu - 1))
    r = np.concatenate([[signs[0] * a, signs[1] * a], background])
    meas = SimpleNamespace(
        poses=np.zeros((n, 3)),
        mode=np.array(["x", "y"] * (n // 2)),
        k_a=np.repeat(np.arange(1.0, n // 2 + 1), 2),
        lines=np.arange(n) + 2,
    )
    assert clusters(SimpleNamespace(error_sigma=r, meas=meas), k) == expected


# ------------------------------------------------------------------ how much is set aside


class _Rows:
    """Rows with CSV line numbers; a subset keeps the same stand-in (the rules count lines)."""

    def __init__(self, n):
        self.lines = np.arange(n) + 2

    def __len__(self):
        return len(self.lines)

    def subset(self, keep):
        return self


@pytest.mark.parametrize("n", [9, 10, 19, 20, 29, 30])
def test_outliers_are_set_aside_up_to_max_outlier_share_of_the_rows_and_at_least_one(monkeypatch, n):
    """An outlier is found every time it is looked for: floor(share n) rows, at least one, are set
    aside (29 rows: 2, 2.9 would exceed the share; 30 rows: 3, exactly the share)."""
    from eigentwist.diagnose import select

    meas, found = _Rows(n), []

    def outliers(comparison, k, alpha):
        found.append(NS(line=int(meas.lines[len(found)])))
        return [found[-1]]

    d = NS(final=NS(comparison=None, k=1), outliers=[], all_rows=None)
    monkeypatch.setattr(select, "find_outliers", outliers)
    monkeypatch.setattr(select, "_select", lambda *a, **k: NS(final=NS(comparison=None, k=1)))
    monkeypatch.setattr(select, "_judge", lambda d: d)
    out = select._without_outliers(meas, None, d, (), ALPHA, None)
    assert len(out.outliers) == max(1, math.floor(select.MAX_OUTLIER_SHARE * n))


@pytest.mark.parametrize("n", [39, 40])
def test_whole_settings_are_set_aside_up_to_max_setting_share_of_the_rows(monkeypatch, n):
    """Settings of 5 rows keep deviating: they are set aside while the rows set aside stay within
    the share (40 rows: 10 = 0.25 n, two settings; 39 rows: 9.75, one)."""
    from eigentwist.diagnose import select

    meas, taken = _Rows(n), []

    def anomalies(rows, ev, final, alpha):
        start = 5 * len(taken)
        a = NS(n_rows=5, lines=list(rows.lines[start : start + 5]))
        taken.append(a)
        return [a]

    d = NS(meas=meas, final=None, outliers=[], all_rows=None, uncertainty="judged")
    monkeypatch.setattr(select, "find_setting_anomalies", anomalies)
    monkeypatch.setattr(
        select,
        "_select",
        lambda rows, *a, **k: NS(meas=rows, final=None, outliers=[], all_rows=None, uncertainty="judged"),
    )
    monkeypatch.setattr(select, "rescored", lambda a, meas, ev, final: a)
    out = select._without_settings(meas, None, d, (), ALPHA, None)
    assert len(out.setting_anomalies) == math.floor(select.MAX_SETTING_SHARE * n / 5)


# ------------------------------------------------------------------ residual patterns and rows


def test_a_row_fails_beyond_fail_sigma():
    from eigentwist.diagnose.compare import FAIL_SIGMA, Comparison

    meas = NS(freq_hz=np.full(4, 10.0), sigma_hz=np.full(4, 0.5))
    err = FAIL_SIGMA * np.array([IN, OUT, -IN, -OUT]) * 0.5
    c = Comparison(meas, ("x",), meas.freq_hz + err, np.zeros(4, dtype=int))
    assert c.failing.tolist() == [False, True, False, True]


@pytest.mark.parametrize("factor, flagged", [(IN, False), (OUT, True)])
def test_the_error_depends_on_the_pose_beyond_pose_spread_standard_errors(factor, flagged):
    """Two poses, two rows each, weights (f/sigma)^2 = s^2: each pose's mean error has the standard
    error 1/(s sqrt 2), so means a and b are (a - b) s apart in their combined standard errors."""
    from eigentwist.diagnose.patterns import POSE_SPREAD, systematic

    s = 100.0
    a, b = POSE_SPREAD * factor / s / 2, -POSE_SPREAD * factor / s / 2
    f_meas = 10.0 * np.exp(np.array([a, a, b, b]))
    meas = NS(
        freq_hz=f_meas,
        sigma_hz=f_meas / s,
        poses=np.array([[0, 0, -0.6], [0, 0, -0.6], [0.1, 0, -0.6], [0.1, 0, -0.6]]),
        mode=np.array(["x", "y", "x", "y"]),
        k_a=np.full(4, 1000.0),  # one k_a: no shape over k_a
    )
    out = systematic(NS(meas=meas, predicted=np.full(4, 10.0)))
    assert ("pose" in out) is flagged


def test_a_shape_over_k_a_needs_three_rows_at_two_k_a():
    from eigentwist.diagnose.patterns import classify

    rho = np.array([0.2, 0.1, 0.05])  # a clear trend, weights 1e6
    assert classify([100.0, 200.0, 400.0], rho, np.full(3, 1e6))["shape"] is not None
    assert classify([100.0, 200.0], rho[:2], np.full(2, 1e6))["shape"] is None  # two rows
    assert classify([100.0, 100.0, 100.0], rho, np.full(3, 1e6))["shape"] is None  # one k_a


@pytest.mark.parametrize("nu, few", [(2, True), (3, False)])
def test_the_stated_uncertainty_needs_three_degrees_of_freedom(nu, few):
    from eigentwist.diagnose.misfit import judge_uncertainty

    final = NS(n=nu + 2, k=2, chi2=float(nu), comparison=None)  # chi2 = nu: consistent when judged
    assert (judge_uncertainty(final, {}, False, ALPHA).verdict == "too few rows") is few


@pytest.mark.parametrize("n, k, m, testable", [(6, 1, 2, True), (5, 1, 2, False)])
def test_a_candidate_needs_more_than_k_plus_its_own_plus_two_rows(n, k, m, testable):
    from eigentwist.diagnose.misfit import untestable

    out = untestable(n, k, {"e": m})
    assert (out == {}) is testable and (testable or out == {"e": k + m + 3})


def test_candidates_rank_by_aicc_to_aicc_digits_then_by_the_catalogue():
    from eigentwist.diagnose.select import AICC_DIGITS, _rank_key

    half = 0.5 * 10.0**-AICC_DIGITS  # AICc values closer than this round alike
    first, second = (NS(plausible=True, fit=NS(aicc=1.0 + d), order=o) for d, o in ((0.0, 2), (0.0, 1)))
    second.fit.aicc = 1.0 + half * IN  # rounds to 1.00: the catalogue order (1 before 2) decides
    assert sorted([first, second], key=_rank_key)[0] is second
    second.fit.aicc = 1.0 + 2 * half * OUT  # rounds to 1.01: AICc decides
    assert sorted([first, second], key=_rank_key)[0] is first


@pytest.mark.parametrize(
    "norm, sine, kept",
    [(1.01, None, True), (0.99, None, False), (None, 1.01, True), (None, 0.99, False)],
)
def test_an_extra_parameter_is_identified_beyond_min_sigma_and_below_max_correlation(monkeypatch, norm, sine, kept):
    """Its whitened column, beyond the fitted ones (orthogonal part), must move the predictions
    by MIN_SIGMA and keep sin(angle) >= sqrt(1 - MAX_CORRELATION^2) to the fitted columns."""
    from eigentwist.diagnose import identifiable as ident

    min_sine = math.sqrt(1.0 - ident.MAX_CORRELATION**2)
    e1, e2 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    if norm is not None:  # orthogonal to the fitted column: only its length counts
        col = ident.MIN_SIGMA * norm * e2
    else:  # long, but nearly along the fitted column: the angle counts
        s = min_sine * sine
        col = 1e3 * (math.sqrt(1 - s * s) * e1 + s * e2)
    jac = np.stack([10.0 * e1, col], axis=1)
    monkeypatch.setattr(ident, "fit_names", lambda ev, e: ("a",))
    monkeypatch.setattr(ident, "parameter_names", lambda ev, e: ("a", "b"))
    monkeypatch.setattr(ident, "trial_value", lambda p: 1.0)
    monkeypatch.setattr(ident, "_sensitivity", lambda *a: jac)
    ev = NS(parameter=lambda n: NS())
    out = ident.extra_parameters(NS(params={}), ev, ("e",), "e", {"a": 1.0}, {})
    assert (out == ("b",)) is kept
