"""``fit()``'s values and standard errors against independent computations.

The seam: one catalogue parameter (the payload mass m_p of ``rigid + payload_mass``) fitted
to synthetic Heli4 frequencies. Its standard error is compared with SciPy's
``curve_fit`` (absolute sigma, and sigma scaled by chi2/nu), with the profile of chi2
(delta chi2 = 1), and with the Monte Carlo coverage of the reported +-1 std interval,
including data whose scatter exceeds the stated sigma (where the Birge scaling matters).
The same draws give the F test's false-positive rate under the null.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.optimize import curve_fit

import eigentwist
from eigentwist.diagnose import fit, synth
from eigentwist.diagnose.fit import SPAN, FitResult, Transform, _covariance, _starts
from eigentwist.diagnose.measurements import Measurements
from eigentwist.diagnose.predict import Predictor
from eigentwist.diagnose.stats import aicc, f_test

MODEL = ("actuator_loss", "payload_mass")
TRUTH_MP = 0.4
POSES = [[0.0, 0.0, -0.625], [0.05, -0.03, -0.6]]
KA = [250.0, 1000.0, 4000.0]


@pytest.fixture(scope="module")
def ev_fast():
    """The Heli4 evaluator on the C backend where a compiler exists (NumPy otherwise)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eigentwist.load("heli4", backend="auto")


@pytest.fixture(scope="module")
def truth(ev_fast):
    return synth(f"rigid+payload_mass:m_p={TRUTH_MP}", KA, POSES, ("x", "y", "z"), 0, ev=ev_fast)


def _draw(truth: Measurements, noise: float, stated: float, rng) -> Measurements:
    """The truth with relative normal scatter ``noise`` and stated sigma ``stated`` (as synth makes)."""
    f = truth.freq_hz * (1 + noise * rng.standard_normal(len(truth)))
    return Measurements(truth.k_a, truth.mode, f, stated * f, truth.poses, robot=truth.robot, source="draw")


def _scipy_fit(meas, ev, start, absolute: bool):
    predictor = Predictor(meas, MODEL, ev)

    def model(_x, m_p):
        return predictor.predict_sets(["m_p"], [[m_p]])[0]

    p, cov = curve_fit(
        model,
        np.arange(len(meas)),
        meas.freq_hz,
        p0=[start],
        sigma=meas.sigma_hz,
        absolute_sigma=absolute,
        epsfcn=1e-10,
    )
    return float(p[0]), float(math.sqrt(cov[0, 0]))


@pytest.mark.parametrize("noise, stated", [(0.005, 0.02), (0.03, 0.01)])
def test_standard_error_matches_scipy_curve_fit(ev_fast, truth, noise, stated):
    meas = _draw(truth, noise, stated, np.random.default_rng(4))
    r = fit(meas, MODEL, ev_fast, ["m_p"])
    value, std_abs = _scipy_fit(meas, ev_fast, r.values["m_p"], absolute=True)
    _, std_rel = _scipy_fit(meas, ev_fast, r.values["m_p"], absolute=False)
    assert r.values["m_p"] == pytest.approx(value, rel=1e-4)
    if noise < stated:  # fit better than sigma: sigma at face value, never shrunk by chi2/nu
        assert r.reduced_chi2 < 0.2 and std_rel < 0.5 * std_abs
        assert r.std["m_p"] == pytest.approx(std_abs, rel=0.02)
    else:  # fit worse than sigma: scaled by the Birge ratio sqrt(chi2/nu)
        assert r.reduced_chi2 > 4 and std_rel > 2 * std_abs
        assert r.std["m_p"] == pytest.approx(std_rel, rel=0.02)
        assert r.std["m_p"] == pytest.approx(std_abs * math.sqrt(r.chi2 / r.dof), rel=0.02)


def test_standard_error_matches_the_chi2_profile(ev_fast, truth):
    meas = _draw(truth, 0.01, 0.01, np.random.default_rng(5))
    r = fit(meas, MODEL, ev_fast, ["m_p"])
    grid = r.values["m_p"] + np.linspace(-4, 4, 401) * r.std["m_p"]
    f = Predictor(meas, MODEL, ev_fast).predict_sets(["m_p"], grid[:, None])
    chi2 = np.sum(((f - meas.freq_hz) / meas.sigma_hz) ** 2, axis=1)
    assert chi2.min() == pytest.approx(r.chi2, abs=1e-3)
    inside = grid[chi2 <= r.chi2 + 1.0]  # the delta chi2 = 1 interval
    half_width = (inside.max() - inside.min()) / 2
    assert half_width == pytest.approx(
        r.std["m_p"] * max(1.0, math.sqrt(r.reduced_chi2)) if r.reduced_chi2 > 1 else r.std["m_p"], rel=0.05
    )


@pytest.mark.slow
def test_intervals_cover_the_truth_and_the_f_test_holds_its_level(ev_fast, truth):
    """200 draws per case (100 where sigma is overstated); +-1 std covers the truth in ~68 %
    (binomial sd 3.3 %). Without the Birge scaling the understated case covers ~26 %."""
    rng = np.random.default_rng(20261122)
    reps, n = 200, len(truth)
    coverage, p_values = {}, []
    for noise, stated, draws in [(0.01, 0.01, reps), (0.03, 0.01, reps), (0.005, 0.02, reps // 2)]:
        hits = 0
        for _ in range(draws):
            meas = _draw(truth, noise, stated, rng)
            r = fit(meas, MODEL, ev_fast, ["m_p"], explore=())
            hits += abs(r.values["m_p"] - TRUTH_MP) <= r.std["m_p"]
            chi2_truth = float(np.sum(((truth.freq_hz - meas.freq_hz) / meas.sigma_hz) ** 2))
            if noise >= stated:  # m_p fitted vs m_p held at the truth: the null is true
                p_values.append(f_test(chi2_truth, 0, r.chi2, 1, n))
        coverage[(noise, stated)] = hits / draws
    assert coverage[(0.01, 0.01)] == pytest.approx(0.68, abs=0.1), coverage
    assert coverage[(0.03, 0.01)] == pytest.approx(0.68, abs=0.1), coverage  # Birge-scaled
    assert coverage[(0.005, 0.02)] > 0.97, coverage  # sigma overstated: conservative
    p_values = np.array(p_values)
    assert np.mean(p_values < 0.1) == pytest.approx(0.1, abs=0.045)  # 400 draws: sd 1.5 %
    assert np.mean(p_values < 0.5) == pytest.approx(0.5, abs=0.08)


# ------------------------------------------------------------------------- fit internals
def test_log_transform_round_trips_and_keeps_to_the_search_range(ev_fast):
    t = Transform.of(ev_fast.parameters["m_p"])
    assert t.log and t.lo == pytest.approx(0.2 / SPAN) and t.hi == pytest.approx(0.2 * SPAN)
    assert t.theta(0.5) == pytest.approx(math.log(0.5)) and t.value(math.log(0.5)) == pytest.approx(0.5)
    assert t.theta(1e6) == pytest.approx(math.log(t.hi)) and t.theta(0.0) == pytest.approx(math.log(t.lo))
    assert t.bounds == pytest.approx((math.log(t.lo), math.log(t.hi)))
    assert t.std(0.5, 0.1) == pytest.approx(0.05)  # delta method: std_p = p std_theta
    assert t.ref == 0.2 and t.scale == 1.0
    eta = Transform.of(ev_fast.parameters["eta_a"])  # hard bound (0, 1]: no actuator delivers more
    # inside it by a relative margin (not one ulp), so that exp(log(p)) cannot round outside
    assert eta.log and eta.hi == pytest.approx(1 - 1e-9, rel=1e-13) and eta.hi < 1.0
    assert eta.lo == pytest.approx(0.82 / SPAN, rel=1e-13)


def test_linear_transform_for_a_parameter_that_can_be_negative(ev_fast):
    t = Transform.of(ev_fast.parameters["p_x"])  # default 0, bounds (-1, 1)
    assert not t.log and t.ref == 0.0 and t.scale == pytest.approx(0.1)
    assert (t.lo, t.hi) == (-1.0, 1.0)
    assert t.theta(0.05) == pytest.approx(0.5) and t.value(0.5) == pytest.approx(0.05)
    assert t.theta(5.0) == pytest.approx(10.0) and t.bounds == pytest.approx((-10.0, 10.0))
    assert t.std(0.05, 0.2) == pytest.approx(0.02)


def test_covariance_is_the_inverse_normal_matrix_scaled_only_upwards():
    jac = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0], [0.5, -1.0]])
    normal_inv = np.linalg.inv(jac.T @ jac)
    assert _covariance(jac, 2.0, 2) == pytest.approx(normal_inv)  # chi2/nu = 1
    assert _covariance(jac, 1.0, 2) == pytest.approx(normal_inv)  # better than sigma: not shrunk
    assert _covariance(jac, 8.0, 2) == pytest.approx(4 * normal_inv)  # worse: Birge ratio^2
    assert _covariance(jac, 8.0, 0) == pytest.approx(normal_inv)  # no dof: no scale
    assert _covariance(0.01 * jac, 2.0, 2) == pytest.approx(1e4 * normal_inv)  # small but determined


def test_covariance_of_an_undetermined_parameter_is_infinite():
    jac = np.array([[1.0, 0.0, 2.0], [2.0, 0.0, 1.0], [0.0, 0.0, 1.0]])  # column 2 has no influence
    cov = _covariance(jac, 3.0, 1)
    assert np.isinf(cov[1, 1]) and np.isinf(cov[0, 1]) and np.isinf(cov[1, 2])
    sub = np.linalg.inv(jac[:, [0, 2]].T @ jac[:, [0, 2]]) * 3.0
    assert cov[np.ix_([0, 2], [0, 2])] == pytest.approx(sub)
    assert np.isinf(_covariance(np.zeros((3, 1)), 1.0, 2)[0, 0])


def test_start_grid_explores_only_the_named_log_parameters(ev_fast):
    tr = [Transform.of(ev_fast.parameters[n]) for n in ("m_p", "p_x", "k_t")]
    table = _starts(tr, {"m_p": 0.3, "p_x": 0.01, "k_t": 1e4}, {"m_p", "p_x"})
    assert table.shape == (5, 3)  # p_x is linear, k_t not explored
    assert sorted(table[:, 0]) == pytest.approx([0.03, 0.09, 0.3, 0.9, 3.0])
    assert np.all(table[:, 1] == 0.01) and np.all(table[:, 2] == 1e4)
    clipped = _starts(tr[:1], {"m_p": 150.0}, {"m_p"})
    assert clipped[:, 0].max() == pytest.approx(tr[0].hi)


def test_fit_result_and_edge_cases(ev_fast, truth):
    meas = _draw(truth, 0.01, 0.01, np.random.default_rng(9))
    none = fit(meas, MODEL, ev_fast, [], fixed={"m_p": TRUTH_MP})
    chi2 = float(np.sum(((truth.freq_hz - meas.freq_hz) / meas.sigma_hz) ** 2))
    assert isinstance(none, FitResult) and none.k == 0 and none.names == ()
    assert none.chi2 == pytest.approx(chi2, rel=1e-9) and none.aicc == pytest.approx(aicc(chi2, len(meas), 0))
    r = fit(meas, MODEL, ev_fast, ["m_p"], start={"m_p": 1.0})
    assert r.success and r.k == 1 and r.n == len(meas) == 18 and r.dof == 17
    assert r.aicc == pytest.approx(aicc(r.chi2, 18, 1)) and r.reduced_chi2 == pytest.approx(r.chi2 / 17)
    assert r.gof_p_value == pytest.approx(__import__("scipy").stats.chi2.sf(r.chi2, 17))
    assert r.chi2 < none.chi2 and r.fixed == {"m_p": r.values["m_p"]} and r.at_bound == ()
    assert r.rms_pct == r.comparison.rms_pct and r.max_pct == r.comparison.max_pct and r.nfev > 0
    assert r.chi2 == pytest.approx(float(np.sum(((r.comparison.predicted - meas.freq_hz) / meas.sigma_hz) ** 2)))
    other = fit(meas, MODEL, ev_fast, ["m_p"], fixed={"m_p": 5.0, "eta_a": 0.8})  # m_p starts at 5 kg
    assert other.fixed["eta_a"] == 0.8 and "eta_a" not in other.values and other.names == ("m_p",)
    assert other.values["m_p"] == pytest.approx(TRUTH_MP, rel=0.1)


def test_a_parameter_given_as_data_is_not_fitted(ev_fast, truth):
    meas = _draw(truth, 0.01, 0.01, np.random.default_rng(3))
    with_column = Measurements(
        meas.k_a,
        meas.mode,
        meas.freq_hz,
        meas.sigma_hz,
        meas.poses,
        {"m_p": np.full(len(meas), TRUTH_MP)},
        robot=meas.robot,
    )
    r = fit(with_column, MODEL, ev_fast, ["m_p", "eta_a"])
    assert r.names == ("eta_a",) and r.k == 1


def test_a_fit_that_ends_on_its_search_bound_says_so(ev_fast):
    empty = synth("rigid", KA, POSES, ("x", "y", "z"), 0, ev=ev_fast)  # no payload at all: m_p -> 0
    r = fit(empty, MODEL, ev_fast, ["m_p"])
    assert r.at_bound == ("m_p",) and r.values["m_p"] == pytest.approx(0.2 / SPAN, rel=1e-3)


# --------------------------------------------------------- two parameters, the objective
TWO = ("actuator_loss", "payload_mass", "transmission_compliance")


def test_two_parameter_covariance_matches_scipy_curve_fit(ev_fast):
    truth2 = synth(
        "rigid+payload_mass:m_p=0.4+transmission_compliance:k_t=8000",
        [125.0, 500.0, 2000.0, 8000.0],
        POSES,
        ("x", "y", "z"),
        0,
        ev=ev_fast,
    )
    meas = _draw(truth2, 0.01, 0.01, np.random.default_rng(8))
    r = fit(meas, TWO, ev_fast, ["m_p", "k_t"])
    predictor = Predictor(meas, TWO, ev_fast)

    def model(_x, m_p, k_t):
        return predictor.predict_sets(["m_p", "k_t"], [[m_p, k_t]])[0]

    p0 = [r.values["m_p"], r.values["k_t"]]
    p, cov = curve_fit(
        model,
        np.arange(len(meas)),
        meas.freq_hz,
        p0=p0,
        sigma=meas.sigma_hz,
        absolute_sigma=True,
        method="trf",
        x_scale=p0,
        diff_step=1e-6,
    )
    assert [r.values["m_p"], r.values["k_t"]] == pytest.approx(p, rel=1e-3)
    cov = cov * max(1.0, r.chi2 / r.dof)  # the Birge scaling, when chi2/nu > 1
    cov_p = r.cov_theta * np.outer(p0, p0)  # delta method for log-parameters
    assert np.sqrt(np.diag(cov_p)) == pytest.approx(np.sqrt(np.diag(cov)), rel=0.03)
    corr = cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1])
    assert cov_p[0, 1] / np.sqrt(cov_p[0, 0] * cov_p[1, 1]) == pytest.approx(corr, abs=0.02)
    assert [r.std["m_p"], r.std["k_t"]] == pytest.approx(np.sqrt(np.diag(cov_p)), rel=1e-9)


def _objective(transforms, meas=None):
    from types import SimpleNamespace

    from eigentwist.diagnose.fit import STEP, _Objective

    return _Objective(SimpleNamespace(meas=meas), transforms), STEP


def test_difference_points_stay_inside_the_search_range(ev_fast):
    m_p = Transform.of(ev_fast.parameters["m_p"])
    narrow = Transform("narrow", False, -0.0075, 0.0075, 0.0, 1.0)  # narrower than two steps
    room = Transform("room", False, -0.0125, 0.0125, 0.0, 1.0)  # 2.5 steps: the points move inside
    obj, step = _objective([m_p, narrow, room])
    assert step == 0.01
    lo, hi = m_p.bounds
    sets = obj._sets(np.array([lo, 0.005, 0.005]))
    assert sets.shape == (7, 3)
    assert sets[:, 0] == pytest.approx([lo, lo, lo + 2 * step, lo, lo, lo, lo])  # one-sided at the lower bound
    assert sets[:, 1] == pytest.approx([0.005] * 3 + [0.005 - step, 0.005 + step] + [0.005] * 2)
    assert sets[:, 2] == pytest.approx([0.005] * 5 + [-0.0075, 0.0125])
    sets = obj._sets(np.array([hi, 0.0, 0.0]))
    assert sets[:, 0] == pytest.approx([hi, hi - 2 * step, hi, hi, hi, hi, hi])
    middle = obj._sets(np.array([0.0, 0.0, 0.0]))[:, 0]
    assert middle == pytest.approx([0.0, -step, step, 0.0, 0.0, 0.0, 0.0])


def test_objective_residuals_jacobian_and_start_screening(ev_fast, truth, monkeypatch):
    meas = _draw(truth, 0.01, 0.01, np.random.default_rng(12))
    import importlib

    from eigentwist.diagnose.fit import STEP, _Objective

    # the central-difference fallback (the package re-exports fit(), hence import_module)
    monkeypatch.setattr(importlib.import_module("eigentwist.diagnose.fit"), "EXACT_JACOBIAN", False)

    predictor = Predictor(meas, TWO, ev_fast)
    tr = [Transform.of(ev_fast.parameters[n]) for n in ("m_p", "k_t")]
    obj = _Objective(predictor, tr)
    assert obj.nfev == 0 and obj.names == ["m_p", "k_t"]
    theta = np.array([math.log(0.3), math.log(5000.0)])
    r = obj.residuals(list(theta))
    jac = obj.jacobian(theta)
    assert obj.nfev == 1  # one batched call for both
    f = predictor.predict_sets(["m_p", "k_t"], [[0.3, 5000.0]])[0]
    assert r == pytest.approx((f - meas.freq_hz) / meas.sigma_hz, rel=1e-12)
    for j, name in enumerate(("m_p", "k_t")):
        lo_hi = [np.exp(theta) for _ in range(2)]
        lo_hi[0][j] *= math.exp(-STEP)
        lo_hi[1][j] *= math.exp(STEP)
        f_lo, f_hi = predictor.predict_sets(["m_p", "k_t"], lo_hi)
        assert jac[:, j] == pytest.approx((f_hi - f_lo) / meas.sigma_hz / (2 * STEP), rel=1e-9), name
    table = np.array([[0.3, 5000.0], [0.4, 1e6], [2.0, 100.0]])
    chi2 = obj.chi2_of(table)
    assert obj.nfev == 2 and chi2.shape == (3,)
    want = np.sum(((predictor.predict_sets(["m_p", "k_t"], table) - meas.freq_hz) / meas.sigma_hz) ** 2, axis=1)
    assert chi2 == pytest.approx(want, rel=1e-12) and chi2[0] == pytest.approx(r @ r, rel=1e-12)
    chi2 = {}
    for point in (theta + 0.1, theta - 0.1, theta + 0.05):
        rp = obj.residuals(point)
        chi2[point.tobytes()] = float(rp @ rp)
    chi2[theta.tobytes()] = float(r @ r)
    assert obj.nfev == 5  # one call a new point
    # the last point and the best point are kept, the rest forgotten
    best = min(chi2, key=chi2.get)
    last = (theta + 0.05).tobytes()
    for point in (theta, theta + 0.1, theta - 0.1, theta + 0.05):
        calls = obj.nfev
        obj.jacobian(point)
        kept = point.tobytes() in (best, last)
        assert obj.nfev == calls + (0 if kept else 1), point
        if not kept:  # asked for anew: now the last point, the best one still kept
            last = point.tobytes()


def test_fit_result_carries_its_model_covariance_and_message(ev_fast, truth):
    meas = _draw(truth, 0.01, 0.01, np.random.default_rng(13))
    r = fit(meas, MODEL, ev_fast, ["m_p"])
    assert r.effects == MODEL and r.comparison.effects == MODEL and r.comparison.values == r.fixed
    assert isinstance(r.message, str) and r.message not in ("", "None") and r.cov_theta.shape == (1, 1)
    assert r.std["m_p"] == pytest.approx(r.values["m_p"] * math.sqrt(r.cov_theta[0, 0]))
    none = fit(meas, MODEL, ev_fast, [], fixed={"m_p": TRUTH_MP})
    assert none.effects == MODEL and none.comparison.effects == MODEL and none.comparison.values == {"m_p": TRUTH_MP}
    assert none.values == {} and none.std == {} and none.fixed == {"m_p": TRUTH_MP} and none.n == len(meas)
    assert none.comparison.predicted == pytest.approx(truth.freq_hz, rel=1e-12)


def test_a_fit_that_ends_on_its_upper_search_bound_says_so(ev_fast, truth):
    r = fit(truth, TWO, ev_fast, ["k_t"], fixed={"m_p": TRUTH_MP})  # no transmission compliance: k_t -> inf
    assert r.at_bound == ("k_t",) and r.values["k_t"] == pytest.approx(20000.0 * SPAN, rel=1e-3)


def test_linear_transform_of_a_parameter_with_an_offset_default():
    from types import SimpleNamespace

    p = SimpleNamespace(name="offset", default=0.2, bounds=(-1.0, 1.0))
    t = Transform.of(p)
    assert not t.log and t.ref == 0.2 and t.scale == pytest.approx(0.2)
    assert t.theta(0.3) == pytest.approx(0.5) and t.value(0.5) == pytest.approx(0.3)


def test_start_grid_is_clipped_at_the_lower_bound(ev_fast):
    t = Transform.of(ev_fast.parameters["m_p"])
    table = _starts([t], {"m_p": 5e-4}, {"m_p"})
    assert table[:, 0].min() == pytest.approx(t.lo) and table[:, 0].max() == pytest.approx(5e-3)


def test_a_parameter_without_influence_stays_at_its_start(ev_fast, truth):
    paper = ("actuator_loss", "rod_compliance", "ee_compliance")  # G_rod has no influence (README)
    r = fit(truth, paper, ev_fast, ["G_rod"], start={"G_rod": 3e10}, explore=())
    assert r.values["G_rod"] == pytest.approx(3e10, rel=1e-3) and r.std["G_rod"] > 100 * r.values["G_rod"]


def test_a_fit_near_but_inside_its_bound_is_not_at_the_bound(ev_fast):
    small = synth("rigid+payload_mass:m_p=0.0005", KA, POSES, ("x", "y", "z"), 0, ev=ev_fast)  # bound: 0.0002 kg
    r = fit(small, MODEL, ev_fast, ["m_p"])
    assert r.values["m_p"] == pytest.approx(0.0005, rel=1e-3) and r.at_bound == ()


@pytest.mark.parametrize(
    "default, bounds, scale, lo, hi",
    [
        (0.0, (0.0, 1.0), 0.05, 0.0, 1.0),  # zero default: linear even if p >= 0
        (5.0, (-math.inf, math.inf), 5.0, 5.0 - 5000.0, 5.0 + 5000.0),
        (0.5, (-math.inf, math.inf), 1.0, 0.5 - 1000.0, 0.5 + 1000.0),
    ],
)
def test_linear_transform_scale_and_range(default, bounds, scale, lo, hi):
    from types import SimpleNamespace

    t = Transform.of(SimpleNamespace(name="q", default=default, bounds=bounds))
    assert t.log is False and t.scale == pytest.approx(scale)
    assert (t.lo, t.hi) == pytest.approx((lo, hi))


def test_given_start_values_replace_the_grid_for_their_parameter(ev_fast):
    tr = [Transform.of(ev_fast.parameters[n]) for n in ("p_z", "m_p")]
    table = _starts(tr, {"m_p": 0.3, "p_z": 0.0}, {"m_p", "p_z"}, {"p_z": [-5.0, -0.05, 0.05, 5.0]})
    assert table.shape == (20, 2)
    assert sorted(set(table[:, 0])) == pytest.approx([-1.0, -0.05, 0.05, 1.0])  # clipped to the search range
    assert sorted(set(table[:, 1])) == pytest.approx([0.03, 0.09, 0.3, 0.9, 3.0])  # the others keep their grid
    assert _starts(tr, {"m_p": 0.3, "p_z": 0.0}, set(), None).shape == (1, 2)


def _bare_objective():
    from eigentwist.diagnose.fit import _Objective

    obj = object.__new__(_Objective)
    obj.best, obj.since, obj.stall = (math.inf, None), 0, True
    return obj


def test_a_fit_stalls_after_its_points_stop_lowering_chi2_by_the_stated_amount():
    from eigentwist.diagnose.fit import STALL_CHI2, STALL_EVALS, _Stalled

    theta = np.zeros(1)
    obj = _bare_objective()
    obj._progress(theta, 10.0)
    chi2 = 10.0
    for _ in range(STALL_EVALS - 1):  # each new point lowers chi2 by just under STALL_CHI2: no progress
        chi2 -= 0.9 * STALL_CHI2
        obj._progress(theta + chi2, chi2)
    assert obj.since == STALL_EVALS - 1
    assert obj.best[0] == chi2 and obj.best[1][0] == chi2  # the best point is kept, though it is no progress
    obj._progress(theta, chi2 - 1.1 * STALL_CHI2)  # just more than STALL_CHI2: progress, the count restarts
    assert obj.since == 0
    for _ in range(STALL_EVALS - 1):
        obj._progress(theta, 99.0)  # rejected trial points count as no progress
    with pytest.raises(_Stalled):
        obj._progress(theta, 99.0)
    quiet = _bare_objective()
    quiet.stall = False  # outside the solver's run (the covariance's evaluation) nothing is raised
    for _ in range(2 * STALL_EVALS):
        quiet._progress(theta, 1.0)


def test_a_stalled_fit_returns_its_best_point_and_says_so(ev_fast, truth, monkeypatch):
    import importlib

    fit_module = importlib.import_module("eigentwist.diagnose.fit")
    full = fit(truth, MODEL, ev_fast, ["m_p"], start={"m_p": 0.05}, explore=())
    monkeypatch.setattr(fit_module, "STALL_EVALS", 1)
    monkeypatch.setattr(fit_module, "STALL_CHI2", 1e300)  # the first point after the start stalls
    short = fit(truth, MODEL, ev_fast, ["m_p"], start={"m_p": 0.05}, explore=())
    assert short.message.startswith("stalled") and short.success
    assert short.nfev < full.nfev
    assert short.chi2 >= full.chi2  # the best of fewer points, no better than the converged fit
    assert full.values["m_p"] == pytest.approx(TRUTH_MP, rel=1e-6)


def test_predictor_rows_repeated_per_count_read_only_within_the_bound():
    """The measured rows for B parameter sets are np.tile of the rows, read-only, whatever the
    number of counts asked (beyond the predictor's bound of 8 they are built again)."""
    from eigentwist.diagnose import paper_measurements

    meas = paper_measurements()
    pred = Predictor(meas, MODEL, None)
    for b in [*range(1, 11), 3]:
        rows = pred._repeated_rows(b)
        assert len(pred._repeated) <= 8
        assert np.array_equal(rows["poses"], np.tile(meas.poses, (b, 1))) and not rows["poses"].flags.writeable
        assert np.array_equal(rows["params"]["k_a"], np.tile(meas.k_a, b)) and rows["labels"] == meas.mode * b
        first, inverse = rows["unique"]
        assert np.array_equal(rows["poses"][first][inverse], rows["poses"])
        with pytest.raises(ValueError):
            rows["lines"][0] = 0


@pytest.mark.parametrize(
    "model, names",
    [(MODEL, ("m_p",)), (("actuator_loss", "ee_compliance", "servo_damping"), ("c_a", "eta_a"))],
    ids=["payload", "damped paper data"],
)
def test_the_kept_comparison_is_the_evaluated_one_bit_for_bit(ev_fast, truth, model, names):
    """The fit's comparison at its optimum comes from its own evaluation there (the first of
    the batched parameter sets); evaluated anew at the fitted values it is the same, bit for
    bit: predictions, matched modes, damping ratios and chi2 (the paper's damped rows)."""
    from eigentwist.diagnose import paper_measurements
    from eigentwist.diagnose.fit import _comparison

    meas = truth if model == MODEL else paper_measurements(ev_fast)
    out = fit(meas, model, ev_fast, names)
    assert out.nfev > 0
    anew = _comparison(meas, model, ev_fast, out.fixed)
    assert np.array_equal(out.comparison.predicted, anew.predicted)
    assert np.array_equal(out.comparison.mode_index, anew.mode_index) and out.comparison.chi2 == anew.chi2
    if model != MODEL:
        assert np.array_equal(out.comparison.zeta, anew.zeta)
        assert np.array_equal(out.comparison.zeta_residuals, anew.zeta_residuals, equal_nan=True)


def test_a_lag_the_data_do_not_have_fits_no_worse_than_the_model_it_nests(ev_fast):
    """servo_delay tried on damped data without a lag: a lag makes the stiff settings unstable
    over its whole start grid (t_d = 0.1-10 ms; chi2 above 1e3 there), so the candidate's fit
    also starts at the ends of its search range, one of which (t_d = 1 us) is all but the model
    without it. It ends no worse than that model, to within one unit of chi2 (1 us is not
    quite no lag), t_d near that end: no lag, not a precise wrong one (2.5e-4 s at chi2 1.7e3
    from the grid alone)."""
    import importlib

    from eigentwist.diagnose import scope

    select = importlib.import_module("eigentwist.diagnose.select")
    poses = [[0.0, 0.0, -0.625], [0.06, -0.04, -0.6]]
    truth = "paper+servo_damping:c_a=0.12+structural_loss:eta_s=0.08"
    meas = synth(
        truth,
        [250, 500, 1000, 4000],
        poses,
        ("x", "y", "z"),
        "0.5%",
        seed=1,
        ev=ev_fast,
        kind="damped",
        zeta_noise="5%",
    )
    model = scope.order(
        ev_fast, ["actuator_loss", "rod_compliance", "ee_compliance", "servo_damping", "structural_loss"]
    )
    parent = fit(meas, model, ev_fast, ("c_a", "eta_s"))
    f, own = select._fit_effect(meas, ev_fast, parent, "servo_delay")
    assert own == ("t_d",) and parent.chi2 < 2 * parent.n  # the parent explains the data
    assert f.chi2 <= parent.chi2 + 1.0
    assert f.values["t_d"] < 1e-5  # a tenth of the start grid's least: no lag to speak of
