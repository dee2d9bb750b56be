"""The rules of the whole-setting check (``eigentwist/diagnose/settings.py``) on a toy model.

The model's prediction is replaced by a closed form written here,
f = C[mode] sqrt(k_a) (1 + x) (x: the pose's first coordinate), so the k_a and pose under which
a setting fits best, the chi-square quantiles and the Bonferroni level are known without the
robot: each threshold is tested just inside and just outside. No evaluator, no fit.
"""

from __future__ import annotations

import importlib
import types

import numpy as np
import pytest
from scipy import stats

from eigentwist.diagnose import settings as st
from eigentwist.diagnose.measurements import Measurements
from eigentwist.runtime.errors import InputError

C = {"x": 1.0, "y": 1.3, "z": 1.7}
SIGMA = 0.05
LEVELS = (250.0, 500.0, 1000.0, 2000.0, 4000.0)
POSE_A, POSE_B = (0.0, 0.0, -0.6), (0.2, 0.0, -0.6)


EV = object()  # the evaluator handed through to the predictions
K_NONE = 50000.0  # above this k_a the toy model has no modes (NaN)


def toy(k_a, mode, poses):
    """The toy model's frequencies (Hz) of rows at k_a (N m/rad), mode labels and poses (m)."""
    c = np.array([C.get(m, np.nan) for m in mode])
    k = np.asarray(k_a, dtype=float)
    return np.where(k > K_NONE, np.nan, c * np.sqrt(k) * (1.0 + np.asarray(poses, dtype=float)[:, 0]))


class ToyPredictor:
    """Stands in for :class:`eigentwist.diagnose.predict.Predictor`; remembers what it was asked."""

    calls: list = []

    def __init__(self, meas, effects, ev, fixed):
        assert ev is EV and effects == ("toy",)
        self.meas, self.gain = meas, fixed.get("gain", 1.0)
        ToyPredictor.calls.append(meas)

    def predict(self, strict=True):
        assert strict is False
        m = self.meas
        return self.gain * toy(m.k_a, m.mode, m.poses), np.zeros(len(m), dtype=int)


@pytest.fixture(autouse=True)
def toy_model(monkeypatch):
    ToyPredictor.calls = []
    monkeypatch.setattr(st, "Predictor", ToyPredictor)


def meas_of(rows, noise=None):
    """Measurements from (true k_a, written k_a, mode, true pose, written pose) rows, exact
    toy frequencies plus ``noise`` sigmas."""
    k_true = np.array([r[0] for r in rows], dtype=float)
    k_written = np.array([r[1] for r in rows], dtype=float)
    mode = tuple(r[2] for r in rows)
    p_true = np.array([r[3] for r in rows], dtype=float)
    p_written = np.array([r[4] for r in rows], dtype=float)
    f = toy(k_true, mode, p_true) + SIGMA * (np.zeros(len(rows)) if noise is None else np.asarray(noise))
    return Measurements(k_written, mode, f, np.full(len(rows), SIGMA), p_written, lines=np.arange(2, len(rows) + 2))


def setting(k, mode="xyz", pose=POSE_A, k_written=None, pose_written=None):
    return [
        (k, k if k_written is None else k_written, m, pose, pose if pose_written is None else pose_written)
        for m in mode
    ]


def final_of(meas, k=1, fixed=None):
    """A stand-in for the final fit: its residuals in sigma under the toy model."""
    r = (toy(meas.k_a, meas.mode, meas.poses) - meas.freq_hz) / meas.sigma_hz
    return types.SimpleNamespace(
        effects=("toy",),
        fixed=dict(fixed or {}),
        k=k,
        names=("gain",),
        values={"gain": 1.0},
        comparison=types.SimpleNamespace(error_sigma=r),
    )


# -- settings_of ------------------------------------------------------------------------------------


def test_a_setting_is_one_pose_to_1e_6_and_one_k_a_to_1e_9():
    rows = [
        (1000.0, 1000.0, "x", POSE_A, POSE_A),
        (1000.0, 1000.0 * (1 + 1e-11), "y", POSE_A, (4e-7, 0.0, -0.6)),  # same setting
        (1000.0, 1000.0 * (1 + 1e-8), "z", POSE_A, POSE_A),  # another k_a
        (1000.0, 1000.0, "z", POSE_A, (2e-6, 0.0, -0.6)),  # another pose
        (1000.0, 1000.0, "z", POSE_A, POSE_A),  # back in the first setting
    ]
    assert [g.tolist() for g in st.settings_of(meas_of(rows))] == [[0, 1, 4], [2], [3]]


def test_a_label_met_again_starts_the_next_setting():
    """Two settings written alike: the n-th row of each label is the n-th setting."""
    rows = setting(1000.0) + setting(1000.0, mode="yx") + setting(1000.0, mode="x")
    assert [g.tolist() for g in st.settings_of(meas_of(rows))] == [[0, 1, 2], [3, 4], [5]]


# -- deviates, relabelled_fits ---------------------------------------------------------------------


@pytest.mark.parametrize("n_settings, level", [(4, 0.01 / 4), (0, 0.01), (1, 0.01)])
def test_deviates_at_the_bonferroni_level(n_settings, level):
    scale, n = 2.0, 3
    edge = stats.chi2.isf(level, n) * scale  # the chi-square whose p-value is alpha / S
    p = st.deviates(edge * 1.001, scale, n, 0.01, n_settings)
    assert p == pytest.approx(stats.chi2.sf(edge * 1.001 / scale, n), rel=1e-9) and p < level
    assert st.deviates(edge * 0.999, scale, n, 0.01, n_settings) is None


@pytest.mark.parametrize("dof, used", [(2, 2), (0, 1), (1, 1)])
def test_relabelled_fits_within_the_noise_and_far_better(dof, used):
    scale, alpha = 1.5, 0.01
    edge = stats.chi2.isf(alpha, used) * scale  # the relabelled chi-square at p = alpha
    far = 1000.0
    assert st.relabelled_fits(edge * 0.999, far, scale, dof, alpha)
    assert not st.relabelled_fits(edge * 1.001, far, scale, dof, alpha)
    best = 2.0
    assert st.relabelled_fits(best, best * st.FAR * 1.001, scale, dof, alpha)
    assert not st.relabelled_fits(best, best * st.FAR * 0.999, scale, dof, alpha)
    assert st.relabelled_fits(best, best * st.FAR * 1.001, scale, dof, alpha) is True
    assert not st.relabelled_fits(best, best * st.FAR, scale, dof, alpha)  # FAR times better, not more: stays


def test_far_and_min_rows_are_the_documented_values():
    assert st.FAR == 10.0 and st.MIN_ROWS == 3 and st.KA_SPAN == 4.0 and st.N_KA == 121


# -- the chi-square table ---------------------------------------------------------------------------


def test_chi2_table_sums_each_label_and_a_missing_mode_is_infinite():
    sub = meas_of(setting(1000.0, mode="xy"), noise=[0.5, -1.0])
    final = final_of(sub)
    k = np.array([1000.0, 4000.0])
    p = np.array([POSE_A, POSE_B])
    got = st._chi2_table(sub, EV, final, k, p)
    want = [np.sum(((toy([kk] * 2, "xy", [pp] * 2) - sub.freq_hz) / SIGMA) ** 2) for kk, pp in zip(k, p)]
    assert got == pytest.approx(want, rel=1e-12) and got[0] == pytest.approx(1.25)
    tiled = ToyPredictor.calls[0]  # sub's rows once per label tried, with their lines, file and robot
    assert tiled.lines.tolist() == [2, 3, 2, 3] and tiled.mode == ("x", "y", "x", "y")
    assert tiled.k_a.tolist() == [1000.0, 1000.0, 4000.0, 4000.0] and tiled.sigma_hz.tolist() == [SIGMA] * 4
    assert (tiled.source, tiled.robot, tiled.k_a_unit, tiled.modal) == (sub.source, sub.robot, sub.k_a_unit, {})
    sub.source, sub.robot, sub.k_a_unit = "lab.csv", "delta", "N/m"
    st._chi2_table(sub, EV, final, k, p)
    tiled = ToyPredictor.calls[-1]
    assert (tiled.source, tiled.robot, tiled.k_a_unit) == ("lab.csv", "delta", "N/m")
    nan = meas_of(setting(1000.0, mode="x")).subset([0])
    nan.mode = ("w",)  # no such mode in the toy model: a NaN prediction
    assert np.all(st._chi2_table(nan, EV, final, k, p) == np.inf)


# -- best_label, measured_label -----------------------------------------------------------------------


def campaign(extra=()):
    return meas_of(
        [r for k in LEVELS for r in setting(k)] + [r for k in LEVELS for r in setting(k, pose=POSE_B)] + list(extra)
    )


def test_best_label_searches_the_widened_log_grid_and_the_measured_levels():
    meas = campaign()
    sub = meas_of(setting(1234.0, k_written=1500.0))
    st.best_label(sub, EV, final_of(meas), meas)
    first = ToyPredictor.calls[0]
    at_a = np.all(np.isclose(first.poses, POSE_A), axis=1)
    tried = np.unique(first.k_a[at_a])
    grid = np.geomspace(250.0 / 4, 4000.0 * 4, 121)
    assert len(tried) == len(np.unique(np.concatenate([grid, LEVELS])))
    assert np.allclose(tried[[0, -1]], [62.5, 16000.0], rtol=1e-12)
    assert all(np.any(np.isclose(tried, g, rtol=1e-12)) for g in grid)
    assert all(np.any(tried == lvl) for lvl in LEVELS)
    # the other measured pose, at the written k_a
    assert np.all(first.k_a[~at_a] == 1500.0) and np.allclose(first.poses[~at_a], POSE_B)


def test_best_label_refines_between_the_grid_neighbours():
    meas = campaign()
    sub = meas_of(setting(1234.0, k_written=1500.0))
    k, pose, chi2 = st.best_label(sub, EV, final_of(meas), meas)
    grid = np.unique(np.concatenate([np.geomspace(62.5, 16000.0, 121), LEVELS]))
    coarse = np.min(np.abs(np.log(grid / 1234.0)))
    step = np.log(grid[1] / grid[0])  # one step of the coarse grid (log)
    assert abs(np.log(k / 1234.0)) <= step / 20 + 1e-12 and abs(np.log(k / 1234.0)) < coarse
    assert np.allclose(pose, POSE_A)
    want = np.sum(((toy([k] * 3, "xyz", [POSE_A] * 3) - sub.freq_hz) / SIGMA) ** 2)
    assert chi2 == pytest.approx(want, rel=1e-9)


def coarse_and_fine(true):
    """The coarse grid's best index for a true k_a (the toy model's chi2 is a weighted sum of
    (sqrt(k) - sqrt(true))^2) and the refinement between its neighbours."""
    grid = np.unique(np.concatenate([np.geomspace(62.5, 16000.0, 121), LEVELS]))
    b = int(np.argmin(np.abs(np.sqrt(grid) - np.sqrt(true))))
    return grid, b, np.geomspace(grid[max(b - 1, 0)], grid[min(b + 1, len(grid) - 1)], 41)


@pytest.mark.parametrize("true", [1234.0, 62.5 * 1.01, 16000.0 * 0.99, 300.0])
def test_best_label_refines_on_41_points_between_the_neighbours(true):
    meas = campaign()
    sub = meas_of(setting(true, k_written=1500.0))
    k, _, _ = st.best_label(sub, EV, final_of(meas), meas)
    grid, b, fine = coarse_and_fine(true)
    assert np.allclose(np.unique(ToyPredictor.calls[1].k_a), np.unique(fine), rtol=1e-12)
    assert len(ToyPredictor.calls[1].k_a) == 3 * 41
    assert k == fine[np.argmin(np.abs(np.sqrt(fine) - np.sqrt(true)))]
    assert abs(np.log(k / true)) < abs(np.log(grid[b] / true))


def test_best_label_on_a_grid_point_keeps_it():
    """The true k_a a measured level: the coarse grid's point is exact, no refinement beats it."""
    meas = campaign()
    sub = meas_of(setting(2000.0, k_written=1500.0))
    k, pose, chi2 = st.best_label(sub, EV, final_of(meas), meas)
    assert k == 2000.0 and chi2 == pytest.approx(0.0, abs=1e-18)


@pytest.mark.parametrize("true, edge", [(15000.0, None), (17000.0, 16000.0), (66.0, None), (60.0, 62.5)])
def test_best_label_reaches_ka_span_times_the_measured_range(true, edge):
    meas = campaign()
    sub = meas_of(setting(true, k_written=1500.0))
    k, _, _ = st.best_label(sub, EV, final_of(meas), meas)
    if edge is None:
        assert k == pytest.approx(true, rel=3e-3)
    else:
        assert k == pytest.approx(edge, rel=1e-12)


def test_best_label_beyond_the_grids_ends_stops_at_them():
    meas = campaign()
    for true, factor in ((16000.0, 1.01), (62.5, 0.99)):  # beyond the grid's ends: its end
        sub = meas_of(setting(true * factor, k_written=1500.0))
        k, _, _ = st.best_label(sub, EV, final_of(meas), meas)
        assert k == pytest.approx(true, rel=1e-12)


def test_best_label_finds_another_measured_pose():
    meas = campaign()
    sub = meas_of(setting(1000.0, pose=POSE_B, pose_written=POSE_A))
    k, pose, chi2 = st.best_label(sub, EV, final_of(meas), meas)
    assert k == 1000.0 and np.allclose(pose, POSE_B) and chi2 == pytest.approx(0.0, abs=1e-18)


def test_a_pose_within_a_micrometre_is_the_written_pose():
    """A measured pose 0.5 um from the written one is not another pose: the best label keeps the
    written pose (its own rows' k_a refined), the measured labels do not offer it."""
    near = (5e-7, 0.0, -0.6)
    meas = meas_of([r for k in LEVELS for r in setting(k)] + setting(1000.0, pose=near))
    sub = meas_of(setting(1000.0, pose=near, pose_written=POSE_A, k_written=1000.0))
    k, pose, chi2 = st.best_label(sub, EV, final_of(meas), meas)
    assert np.array_equal(pose, POSE_A) and k == pytest.approx(1000.0, rel=1e-5)
    k, pose, chi2 = st.measured_label(sub.subset([0, 1]), EV, final_of(meas), meas)
    assert np.array_equal(pose, POSE_A) and k != 1000.0


def test_measured_label_offers_a_level_1e_5_from_its_own():
    """Only a level equal to the written one to 1e-9 is its own; 5e-6 apart is another level."""
    meas = campaign(setting(1000.005, mode="xy"))
    sub = meas_of(setting(1000.005, mode="xy", k_written=1000.0))
    k, pose, chi2 = st.measured_label(sub, EV, final_of(meas), meas)
    assert k == 1000.005 and chi2 == pytest.approx(0.0, abs=1e-12)
    one = meas_of(setting(1000.005, mode="x", k_written=1000.0))  # a setting of one row
    assert st.measured_label(one, EV, final_of(meas), meas)[0] == 1000.005


def test_measured_label_only_offers_measured_labels():
    meas = campaign()
    sub = meas_of(setting(1234.0, mode="xy", k_written=2000.0))
    k, pose, chi2 = st.measured_label(sub, EV, final_of(meas), meas)
    assert k == 1000.0 and np.allclose(pose, POSE_A)
    tried = ToyPredictor.calls[0]
    # its own level is not offered, the other pose is (at its own k_a)
    at_a = np.all(np.isclose(tried.poses, POSE_A), axis=1)
    assert sorted(set(tried.k_a[at_a])) == [250.0, 500.0, 1000.0, 4000.0]
    assert set(tried.k_a[~at_a]) == {2000.0} and np.allclose(tried.poses[~at_a], POSE_B)
    sub_b = meas_of(setting(1000.0, mode="xy", pose=POSE_B, pose_written=POSE_A, k_written=1000.0))
    k, pose, chi2 = st.measured_label(sub_b, EV, final_of(meas), meas)
    assert k == 1000.0 and np.allclose(pose, POSE_B) and chi2 == pytest.approx(0.0, abs=1e-18)


def test_measured_label_with_nothing_else_measured():
    meas = meas_of(setting(1000.0))
    sub = meas.subset([0, 1])
    k, pose, chi2 = st.measured_label(sub, EV, final_of(meas), meas)
    assert (k, chi2) == (1000.0, np.inf) and np.allclose(pose, POSE_A)
    assert ToyPredictor.calls == []


def test_rescored_searches_a_continuous_k_a_from_min_rows():
    meas = campaign(setting(1234.0, k_written=1500.0))
    lines = meas.lines[-3:].tolist()
    a = st.SettingAnomaly(lines, list(POSE_A), 1500.0, 0.0, list(POSE_A), 50.0, 1.0, 3, 1e-6, 1.0)
    got = st.rescored(a, meas, EV, final_of(meas))
    assert got.best_k_a == pytest.approx(1234.0, rel=3e-3) and got.lines == lines and got.chi2_own == 50.0
    assert (got.pose, got.k_a, got.n_rows, got.p_own, got.scale) == (list(POSE_A), 1500.0, 3, 1e-6, 1.0)
    assert got.best_pose == list(POSE_A) and got.chi2_best == pytest.approx(0.0, abs=1e-3)
    two = st.SettingAnomaly(lines[:2], list(POSE_A), 1500.0, 0.0, list(POSE_A), 50.0, 1.0, 2, 1e-6, 1.0)
    got = st.rescored(two, meas.subset(np.arange(len(meas) - 1)), EV, final_of(meas))
    assert got.best_k_a == 1000.0 and got.n_rows == 2 and got.what == "k_a"  # a measured level only


# -- find_setting_anomalies ------------------------------------------------------------------------------


def test_a_setting_written_with_another_k_a_is_flagged_with_its_evidence():
    rng = np.random.default_rng(3)
    rows = [r for k in LEVELS for r in setting(k)] + setting(1000.0, pose=POSE_B, k_written=1500.0)
    meas = meas_of(rows, noise=rng.normal(size=len(rows)))
    final = final_of(meas)
    (a,) = st.find_setting_anomalies(meas, EV, final, 0.01)
    assert a.lines == meas.lines[-3:].tolist() and a.what == "k_a" and a.n_rows == 3
    assert a.pose == list(POSE_B) and a.k_a == 1500.0 and a.best_k_a == pytest.approx(1000.0, rel=0.03)
    r = final.comparison.error_sigma
    own = float(r[-3:] @ r[-3:])
    scale = max(1.0, float(r[:-3] @ r[:-3]) / (len(r) - 3 - 1))
    assert a.chi2_own == pytest.approx(own) and a.scale == pytest.approx(scale)
    assert a.p_own == pytest.approx(stats.chi2.sf(own / scale, 3), rel=1e-9)
    assert 0 <= a.chi2_best < own / st.FAR
    j = a.to_json()
    assert set(j) == {"lines", "pose", "k_a", "best_k_a", "best_pose", "mislabelled", "evidence"}
    assert j["mislabelled"] == "k_a" and j["lines"] == a.lines and j["best_pose"] == list(POSE_B)
    assert (j["pose"], j["k_a"], j["best_k_a"]) == (list(POSE_B), 1500.0, a.best_k_a)
    assert j["evidence"] == {
        "chi2_written": own,
        "chi2_best": a.chi2_best,
        "rows": 3,
        "p_written": a.p_own,
        "birge_ratio_of_other_rows": pytest.approx(scale**0.5),
    }


def test_the_other_rows_birge_ratio_scales_the_check():
    """The other rows scattered 4x their sigma: the written setting's chi-square is judged
    against 16x the noise (their squared Birge ratio), which no longer rejects it."""
    rng = np.random.default_rng(5)
    rows = [r for k in LEVELS for r in setting(k)] + setting(1000.0, pose=POSE_B, k_written=1008.5)
    noise = np.concatenate([4 * rng.normal(size=15), np.zeros(3)])
    meas = meas_of(rows, noise=noise)
    final = final_of(meas)
    r = final.comparison.error_sigma
    own = float(r[-3:] @ r[-3:])
    scale = float(r[:-3] @ r[:-3]) / (len(r) - 3 - 1)
    assert scale > 4 and stats.chi2.sf(own, 3) < 0.01 / 6 < stats.chi2.sf(own / scale, 3)  # the case's premise
    assert st.find_setting_anomalies(meas, EV, final, 0.01) == []
    assert len(st.find_setting_anomalies(meas_of(rows), EV, final_of(meas_of(rows)), 0.01)) == 1


def test_the_others_dof_counts_the_fitted_parameters():
    """scale = chi2 of the other rows / (n - rows - k); without degrees of freedom left, 1."""
    rng = np.random.default_rng(3)
    rows = [r for k in LEVELS[:3] for r in setting(k)] + setting(1000.0, pose=POSE_B, k_written=1500.0)
    meas = meas_of(rows, noise=np.concatenate([2 * rng.normal(size=9), np.zeros(3)]))
    r = final_of(meas).comparison.error_sigma
    other = float(r[:-3] @ r[:-3])
    for k in (1, 4, 8):  # 8: one degree of freedom left
        (a,) = st.find_setting_anomalies(meas, EV, final_of(meas, k=k), 0.01)
        assert a.scale == pytest.approx(max(1.0, other / (12 - 3 - k)))
    for k in (9, 10):  # dof of the other rows 0 or below: unscaled
        (a,) = st.find_setting_anomalies(meas, EV, final_of(meas, k=k), 0.01)
        assert a.scale == 1.0


def test_a_setting_that_fits_nothing_better_stays():
    """Its rows off by a pattern no label explains (the modes in opposite directions)."""
    rows = [r for k in LEVELS for r in setting(k)] + setting(1000.0, pose=POSE_B)
    meas = meas_of(rows, noise=[0.0] * 15 + [40.0, -40.0, 40.0])
    assert st.find_setting_anomalies(meas, EV, final_of(meas), 0.01) == []


def test_fewer_than_three_settings_are_not_checked():
    rows = setting(1000.0) + setting(2000.0, k_written=4000.0)
    meas = meas_of(rows)
    assert st.find_setting_anomalies(meas, EV, final_of(meas), 0.01) == []
    meas3 = meas_of(rows + setting(4000.0))
    (a,) = st.find_setting_anomalies(meas3, EV, final_of(meas3), 0.01)
    assert a.lines == [5, 6, 7] and a.best_k_a == pytest.approx(2000.0)
    assert a.scale == 1.0  # the other rows fit exactly: never scaled below 1


def test_three_small_settings_are_checked_but_two_large_ones_are_not(monkeypatch):
    """Every setting counts towards the three; only settings of MIN_ROWS rows are checked as units."""
    fitted = []

    def fake_fit(rest, effects, ev, names, start=None, fixed=None, explore=None):
        fitted.append(len(rest))
        return types.SimpleNamespace(effects=effects, fixed=fixed, chi2=float(len(rest) - 1))

    fitmod = importlib.import_module("eigentwist.diagnose.fit")

    monkeypatch.setattr(fitmod, "fit", fake_fit)
    rows = setting(1000.0) + setting(2000.0, k_written=4000.0) + setting(500.0, mode="x")
    meas = meas_of(rows)
    # two settings of three rows and one of one row: three settings, the small one left out and
    # refitted; the two large ones are fewer than three and not checked
    assert st.find_setting_anomalies(meas, EV, final_of(meas), 0.01) == []
    assert fitted == [6]


# -- the leave-one-setting-out check of small settings --------------------------------------------------


@pytest.fixture
def fake_fit(monkeypatch):
    """``fit`` returning the toy model with a chosen chi-square (its refit's Birge ratio)."""
    fitmod = importlib.import_module("eigentwist.diagnose.fit")

    state = types.SimpleNamespace(chi2=None, raise_=False, calls=[])

    def fit(rest, effects, ev, names, start=None, fixed=None, explore=None):
        state.calls.append(dict(n=len(rest), names=names, start=start, fixed=fixed, explore=explore))
        if state.raise_:
            raise InputError("cannot fit")
        return types.SimpleNamespace(effects=effects, fixed=fixed, chi2=state.chi2 if state.chi2 is not None else 0.0)

    monkeypatch.setattr(fitmod, "fit", fit)
    return state


def two_row_rows(k_written=3000.0):
    """Modes x, y at each level at pose A and at 1000 N m/rad at pose B; lines 6, 7 (k_a = 1000
    at pose A) written with ``k_written``."""
    rows = [r for k in LEVELS for r in setting(k, mode="xy")] + setting(1000.0, mode="xy", pose=POSE_B)
    rows[4] = (1000.0, k_written, "x", POSE_A, POSE_A)
    rows[5] = (1000.0, k_written, "y", POSE_A, POSE_A)
    return rows


def two_row_case(k_written=3000.0):
    return meas_of(two_row_rows(k_written))


def test_a_two_row_setting_is_refitted_without_it_and_flagged(fake_fit):
    meas = two_row_case()
    final = final_of(meas)
    (a,) = st.find_setting_anomalies(meas, EV, final, 0.01)
    assert a.lines == [6, 7] and a.best_k_a == 1000.0 and a.n_rows == 2 and a.k_a == 3000.0
    own = np.sum(((toy([3000.0] * 2, "xy", [POSE_A] * 2) - meas.freq_hz[4:6]) / SIGMA) ** 2)
    assert a.chi2_own == pytest.approx(own, rel=1e-12) and a.scale == 1.0 and a.chi2_best == 0.0
    assert a.p_own == pytest.approx(stats.chi2.sf(own, 2), rel=1e-6)
    assert (a.pose, a.best_pose) == (list(POSE_A), list(POSE_A))
    # each of the six two-row settings left out in turn, the final model's start and fixed values
    assert fake_fit.calls == [dict(n=10, names=("gain",), start={"gain": 1.0}, fixed={}, explore=())] * 6


def test_the_refits_birge_ratio_scales_a_small_setting(fake_fit):
    meas = two_row_case(k_written=1020.0)
    own = np.sum(((toy([1020.0] * 2, "xy", [POSE_A] * 2) - meas.freq_hz[4:6]) / SIGMA) ** 2)
    dof_rest = 10 - 1
    edge = stats.chi2.isf(0.01 / 6, 2)  # Bonferroni over the 6 settings
    assert own > edge  # flagged unscaled
    fake_fit.chi2 = dof_rest * own / edge * 0.99  # scaled just above the edge: still flagged
    assert len(st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)) == 1
    fake_fit.chi2 = dof_rest * own / edge * 1.01  # just below: not
    assert st.find_setting_anomalies(meas, EV, final_of(meas), 0.01) == []
    fake_fit.chi2 = 0.5 * dof_rest  # a refit better than the noise never scales below 1
    (a,) = st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    assert a.scale == 1.0


def test_a_small_setting_without_a_refit_is_not_flagged(fake_fit):
    meas = two_row_case()
    fake_fit.raise_ = True
    assert st.find_setting_anomalies(meas, EV, final_of(meas), 0.01) == []
    fake_fit.raise_ = False
    # no degrees of freedom left for the refit: not checked, not fitted
    fake_fit.calls.clear()
    assert st.find_setting_anomalies(meas, EV, final_of(meas, k=10), 0.01) == []
    assert fake_fit.calls == []
    assert len(st.find_setting_anomalies(meas, EV, final_of(meas, k=9), 0.01)) == 1


def test_a_small_setting_the_model_cannot_predict_is_flagged_by_its_label(fake_fit):
    """A row the model has no mode for: its chi-square is infinite, not NaN."""
    meas = two_row_case()
    meas.mode = meas.mode[:5] + ("w",) + meas.mode[6:]
    found = st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    assert found == []  # no label fits a mode the model lacks
    sub = meas.subset([4, 5])
    k, pose, chi2 = st.measured_label(sub, EV, final_of(meas), meas)
    assert chi2 == np.inf


def test_anomalies_worst_first(fake_fit):
    rows = two_row_rows() + setting(4000.0, mode="xy", pose=POSE_B)
    rows[8] = (4000.0, 2000.0, "x", POSE_A, POSE_A)
    rows[9] = (4000.0, 2000.0, "y", POSE_A, POSE_A)
    meas = meas_of(rows)
    found = st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    own = {
        (6, 7): np.sum(((toy([3000.0] * 2, "xy", [POSE_A] * 2) - meas.freq_hz[4:6]) / SIGMA) ** 2),
        (10, 11): np.sum(((toy([2000.0] * 2, "xy", [POSE_A] * 2) - meas.freq_hz[8:10]) / SIGMA) ** 2),
    }
    assert [a.lines for a in found] == [list(k) for k in sorted(own, key=lambda k: -own[k])]
    assert [a.best_k_a for a in found] == [1000.0, 4000.0]


def test_a_one_row_setting_is_checked_too(fake_fit):
    rows = two_row_rows()[:-2] + setting(1000.0, mode="xy", pose=POSE_B)
    rows[5] = (1000.0, 1000.0, "y", POSE_A, POSE_A)  # only line 6 written 3000
    meas = meas_of(rows)
    (a,) = st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    assert a.lines == [6] and (a.k_a, a.best_k_a, a.pose, a.n_rows) == (3000.0, 1000.0, list(POSE_A), 1)


def test_a_small_setting_with_no_mode_where_written_is_flagged(fake_fit):
    """Written at a k_a where the model has no mode: its chi-square is infinite (not NaN), and a
    measured k_a fits it."""
    meas = two_row_case(k_written=60000.0)
    (a,) = st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    assert a.lines == [6, 7] and a.chi2_own == np.inf and a.best_k_a == 1000.0 and a.p_own == 0.0


def test_the_search_spends_one_degree_of_freedom(monkeypatch, fake_fit):
    """A setting of MIN_ROWS rows is judged relabelled on rows - 1 degrees of freedom (its k_a was
    searched), a small one on its rows (only measured labels offered)."""
    seen = []
    real = st.relabelled_fits

    def spy(best, own, scale, dof, alpha):
        seen.append(dof)
        return real(best, own, scale, dof, alpha)

    monkeypatch.setattr(st, "relabelled_fits", spy)
    rows = [r for k in LEVELS for r in setting(k)] + setting(1000.0, pose=POSE_B, k_written=1500.0)
    meas = meas_of(rows)
    st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    assert seen == [2]
    seen.clear()
    meas = two_row_case()
    st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    assert seen == [2]


def test_large_anomalies_worst_first():
    """Two settings written 1500 for 1000 at x = 0.2 and 0.19 m: each flagged (the other's
    chi-square, in the other rows' Birge ratio, is about its own), the larger chi-square first."""
    pose_d = (0.19, 0.0, -0.6)
    rows = (
        [r for k in LEVELS for r in setting(k)]
        + setting(1000.0, pose=pose_d, k_written=1500.0)
        + setting(1000.0, pose=POSE_B, k_written=1500.0)
    )
    meas = meas_of(rows)
    found = st.find_setting_anomalies(meas, EV, final_of(meas), 0.01)
    r = final_of(meas).comparison.error_sigma
    own = {(17, 18, 19): float(r[15:18] @ r[15:18]), (20, 21, 22): float(r[18:21] @ r[18:21])}
    assert own[(20, 21, 22)] > own[(17, 18, 19)]
    assert [tuple(a.lines) for a in found] == [(20, 21, 22), (17, 18, 19)]
