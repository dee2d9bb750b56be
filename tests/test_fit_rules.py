"""The fit's rules (``eigentwist/diagnose/fit.py``) on stand-ins: no evaluator.

The Jacobian kind, the search ranges of a parameter and their cut by a constraint, the
objective's exact and difference Jacobians of a linear stand-in model (checked against
derivatives written here), the round-off rule, the stall bookkeeping, the damping-ratio
residuals, the constraint range's inputs, the comparison at the optimum and the covariance of
an undetermined direction. The fits on real models are tested by tests/test_fit_coverage.py.
"""

from __future__ import annotations

import importlib
import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from eigentwist.runtime import InputError

fm = importlib.import_module("eigentwist.diagnose.fit")  # the module (the package exports its function)

# ------------------------------------------------------------------ the Jacobian kind


def test_the_jacobian_kind_is_the_given_one_else_the_blocks_else_differences():
    assert fm._exact_wanted(None) is False and fm.EXACT_JACOBIAN is False
    assert fm._exact_wanted("exact") is True and fm._exact_wanted("differences") is False
    with fm.using_jacobian("exact"):
        assert fm._exact_wanted(None) is True and fm._exact_wanted("differences") is False
    with pytest.raises(InputError) as err:
        fm._exact_wanted("Exact")
    assert str(err.value) == "jacobian 'Exact': expected one of differences, exact"


# ------------------------------------------------------------------ search ranges


def _param(default, bounds, name="p"):
    return NS(name=name, default=default, bounds=bounds)


def test_a_positive_parameter_searches_on_the_log_above_its_lower_bound():
    t = fm.Transform.of(_param(1.0, (0.5, 1e9)))
    assert t.log and t.lo == 0.5 * (1 + 1e-9) and t.hi == fm.SPAN
    t = fm.Transform.of(_param(1.0, (0.0, 2.0)))
    assert t.lo == 1.0 / fm.SPAN and t.hi == 2.0 * (1 - 1e-9)
    t = fm.Transform.of(_param(5e-324, (0.0, math.inf)))  # the smallest default: the range still excludes 0
    assert t.lo > 0.0 and math.isfinite(t.bounds[0])


def test_a_parameter_with_a_zero_default_and_range_has_a_nonzero_scale():
    assert fm.Transform.of(_param(0.0, (0.0, 0.0))).scale == 1e-12


def test_a_constraint_cuts_a_log_range_inside_its_open_interval():
    t = fm.Transform("r", True, 1e-3, 10.0, 1.0, 1.0)
    cut = t.within(0.5, 2.0)
    assert (cut.lo, cut.hi) == (0.5 * (1 + 1e-9), 2.0 * (1 - 1e-9)) and (cut.name, cut.log, cut.ref) == ("r", True, 1.0)
    assert t.within(-math.inf, math.inf) == t
    wide = t.within(1e-5, 100.0)
    assert (wide.lo, wide.hi) == (1e-3, 10.0)


def test_a_constraint_cuts_a_linear_range_by_a_margin_of_its_scale():
    t = fm.Transform("x", False, -10.0, 10.0, 0.0, 2.0)
    cut = t.within(-1.0, 1.0)
    assert (cut.lo, cut.hi) == (-1.0 + 2e-9, 1.0 - 2e-9)
    assert t.within(-math.inf, 3.0).lo == -10.0 and t.within(-3.0, math.inf).hi == 10.0


def test_a_constraint_that_leaves_no_range_is_an_input_error():
    t = fm.Transform("x", False, -10.0, 10.0, 0.0, 1.0)
    assert t.within(0.0, 4e-9).lo == 1e-9  # a range 2e-9 wide is kept
    with pytest.raises(InputError) as err:
        t.within(0.0, 2e-9)  # the margins meet: an empty open range
    assert str(err.value) == (
        "parameter 'x': the constraints between parameters leave it no range (from 0 to 2e-09): "
        "expected the other parameters' values to admit one"
    )


# ------------------------------------------------------------------ the objective


class Rows:
    """Measured rows: frequencies, their sigma and optional damping ratios."""

    def __init__(self, freq, sigma, zeta=None, sigma_zeta=None):
        self.freq_hz, self.sigma_hz = np.asarray(freq, float), np.asarray(sigma, float)
        if zeta is not None:
            self.damping_ratio = np.asarray(zeta, float)
            self.sigma_damping_ratio = np.asarray(sigma_zeta, float)

    def __len__(self):
        return len(self.freq_hz)


class Linear:
    """A stand-in predictor: f = f0 + A p (Hz) for parameter values p, zeta = z0 + Z p."""

    def __init__(self, meas, f0, A, z0=None, Z=None, names=("a", "b"), ev=None, effects=("e",)):
        self.meas, self.f0, self.A, self.z0, self.Z = meas, np.asarray(f0, float), np.asarray(A, float), z0, Z
        self.names, self.effects, self.calls = names, effects, []
        if ev is not None:
            self.ev = ev

    def predict_sets(self, names, values, strict=True, zeta=False, first=False):
        assert tuple(names) == self.names and strict is False
        self.calls.append(np.array(values))
        f = self.f0 + np.asarray(values) @ self.A.T
        out = (
            f
            if not zeta
            else (f, self.z0 + np.asarray(values) @ self.Z.T, self.z0 + np.asarray(values) @ self.Z.T - 0.01)
        )
        # the first set kept: a stand-in carrying its values
        return (out, NS(values=np.array(values)[0].tolist())) if first else out

    def predict_with_jacobian(self, names, values, strict=True):
        assert tuple(names) == self.names and strict is False
        return self.f0 + self.A @ np.asarray(values), self.A.copy()


def _objective(pred, transforms=None, jacobian=None):
    transforms = transforms or [
        fm.Transform("a", True, 0.01, 100.0, 1.0, 1.0),
        fm.Transform("b", False, -5, 5, 0.0, 2.0),
    ]
    return fm._Objective(pred, transforms, jacobian)


MEAS = Rows([10.0, 20.0, 30.0], [0.5, 1.0, 2.0])
A = np.array([[1.0, 0.5], [2.0, -1.0], [0.0, 3.0]])


def _expected(theta):
    """Residuals and their Jacobian in theta written out: p_a = exp(theta_a), p_b = 2 theta_b."""
    p = np.array([math.exp(theta[0]), 2.0 * theta[1]])
    r = (np.array([9.0, 19.0, 29.0]) + A @ p - MEAS.freq_hz) / MEAS.sigma_hz
    dp = np.array([p[0], 2.0])
    return r, A * dp / MEAS.sigma_hz[:, None]


def test_a_new_objective_starts_with_no_point_and_the_asked_kind():
    obj = _objective(Linear(MEAS, [9, 19, 29], A), jacobian="exact")
    assert (obj.nfev, obj.since, obj.stall, obj.fallback, obj.zeta) == (0, 0, False, "", None)
    assert obj.best == (math.inf, None) and obj.exact is True and obj.names == ["a", "b"]
    assert _objective(Linear(MEAS, [9, 19, 29], A)).exact is False


@pytest.mark.parametrize("jacobian", ["exact", "differences"])
def test_the_objective_residuals_and_jacobian_in_theta(jacobian):
    obj = _objective(Linear(MEAS, [9, 19, 29], A), jacobian=jacobian)
    theta = np.array([0.3, 0.2])
    r, J = _expected(theta)
    assert obj.residuals(theta) == pytest.approx(r, rel=1e-12)
    assert obj.best[0] == pytest.approx(float(r @ r))  # a new point is recorded when first evaluated
    tol = 1e-12 if jacobian == "exact" else 1e-4  # a 1 % central difference of exp: relative error STEP^2 / 6
    assert obj.jacobian(theta) == pytest.approx(J, rel=tol, abs=1e-12)
    assert obj.nfev == 1  # one evaluation gives both
    assert obj.best[0] == pytest.approx(float(r @ r)) and obj.best[1].tolist() == [0.3, 0.2]
    assert obj.jacobian([1, 0]) == pytest.approx(_expected([1.0, 0.0])[1], rel=tol)  # integer points read as float


def test_without_generated_sensitivities_the_objective_falls_back_to_differences():
    pred = Linear(MEAS, [9, 19, 29], A)
    obj = _objective(pred, jacobian="exact")
    pred.predict_with_jacobian = lambda names, values, strict=True: (_ for _ in ()).throw(InputError("no kernel"))
    theta = np.array([0.3, 0.2])
    assert obj.jacobian(theta) == pytest.approx(_expected(theta)[1], rel=1e-4)
    assert obj.exact is False and obj.fallback == "no kernel" and len(pred.calls) == 1


def test_the_exact_jacobian_counts_one_evaluation_a_point():
    obj = _objective(Linear(MEAS, [9, 19, 29], A), jacobian="exact")
    obj.residuals(np.array([0.1, 0.1]))
    obj.residuals(np.array([0.2, 0.1]))
    assert obj.nfev == 2


def test_a_change_within_roundoff_is_no_influence():
    """Parameter b moves the frequencies by just above / below ROUNDOFF of f over its two
    difference points (2 STEP in theta): a derivative, or none. Parameter a lowers f strongly, so a
    threshold read at another point than the centre would differ."""
    f0 = 1000.0
    for factor, flat in ((1.3, False), (0.7, True)):
        slope = factor * fm.ROUNDOFF * f0 / (2 * fm.STEP * 2.0)  # dp_b / dtheta_b = scale 2
        A2 = np.array([[-1e5, slope]] * 3)  # a's lower difference point doubles f: f[1] = 2 f[0]
        linear = [fm.Transform("a", False, -5, 5, 0.0, 1.0), fm.Transform("b", False, -5, 5, 0.0, 2.0)]
        obj = _objective(Linear(Rows([f0] * 3, [1.0] * 3), [f0] * 3, A2), linear)
        J = obj.jacobian(np.array([0.0, 0.0]))
        assert bool((J[:, 1] == 0).all()) is flat
        if not flat:
            assert J[:, 1] == pytest.approx(slope * 2.0, rel=1e-6)


def test_difference_points_of_a_range_two_steps_wide_are_centred_on_the_point():
    t = fm.Transform("b", False, 0.0, 2 * fm.STEP, 0.0, 1.0)
    obj = fm._Objective(Linear(MEAS, [9, 19, 29], A[:, 1:], names=("b",)), [t])
    sets = obj._sets(np.array([0.005]))
    assert sets[:, 0].tolist() == pytest.approx([0.005, 0.005 - fm.STEP, 0.005 + fm.STEP])


def test_the_stall_count_restarts_only_below_best_minus_stall_chi2():
    obj = _objective(Linear(MEAS, [9, 19, 29], A))
    first = np.array([1.0, 1.0])
    obj.best, obj.since = (1.0, first), 3
    obj._progress(np.array([2.0, 2.0]), 1.0 - fm.STALL_CHI2)  # not lower by more than STALL_CHI2
    assert obj.since == 4 and obj.best[0] == 1.0 - fm.STALL_CHI2
    obj._progress(np.array([3.0, 3.0]), 1.0 - fm.STALL_CHI2)  # equal: not a better point
    assert obj.best[1].tolist() == [2.0, 2.0] and obj.since == 5


def test_measured_damping_ratios_are_whitened_residuals_beside_the_frequencies():
    from eigentwist.diagnose.damping import DECAY_SIGMA

    meas = Rows([10.0, 20.0], [0.5, 1.0], zeta=[0.02, np.nan], sigma_zeta=[0.005, 1.0])
    meas.damped = np.array([False, True])  # row 2: a decay seen, no ratio measured
    A1 = np.array([[1.0], [2.0]])
    Z = np.array([[0.01], [0.0]])
    ev = NS(damped_model=lambda effects: True)
    pred = Linear(meas, [9.5, 18.0], A1, z0=np.array([0.03, 0.005]), Z=Z, names=("a",), ev=ev)
    obj = fm._Objective(pred, [fm.Transform("a", False, -5, 5, 0.0, 1.0)], "exact")
    assert obj.exact is False and obj.zeta[0].tolist() == [0, 1]  # damping ratios: differences only
    f, r, _ = obj._residuals(np.array([[1.0]]))
    zeta = 0.03 + 0.01 * 1.0  # row 1's predicted damping ratio
    least = 0.005 - 0.01  # row 2: the least damped of its modes (the stand-in's zeta - 0.01) grows
    assert r[0].tolist() == pytest.approx([(10.5 - 10.0) / 0.5, 0.0, (zeta - 0.02) / 0.005, least / DECAY_SIGMA])
    assert f[0].tolist() == pytest.approx([10.5, 20.0, zeta - 0.02, least])  # the residuals times their sigma


def test_a_damped_model_adds_the_decay_rows_of_its_predictor(monkeypatch):
    seen = []
    monkeypatch.setattr(fm, "_zeta_rows", lambda meas, damped: seen.append((meas, damped)))
    ev = NS(damped_model=lambda effects: effects == ("e",))
    fm._Objective(Linear(MEAS, [9, 19, 29], A, ev=ev), [])
    fm._Objective(Linear(MEAS, [9, 19, 29], A), [])
    assert seen == [(MEAS, True), (MEAS, False)]


# ------------------------------------------------------------------ constraints, comparison, covariance


def _constrained_ev():
    defaults = {"r_i": 1.0, "r_o": 2.0, "a": 3.0, "b": 4.0}
    return NS(
        constraints=[NS(names=("r_i", "r_o")), NS(names=("a", "b"))],
        parameter=lambda n: NS(default=defaults[n]),
    )


def test_the_constraint_range_reads_a_legs_own_values_first(monkeypatch):
    from eigentwist.runtime import constraints

    calls = []
    monkeypatch.setattr(constraints, "interval", lambda *a: calls.append(a) or (1.5, 9.0))
    ev = _constrained_ev()
    values = {"r_i@2": 1.5, "r_i": 1.2, "r_o": 9.0}
    assert fm.constraint_range(ev, "r_o@2", values, ("tube@2", "x")) == (1.5, 9.0)
    assert calls[-1] == (ev.constraints, "r_o", {"r_i": 1.5, "r_o": 9.0}, {"tube", "x"})
    fm.constraint_range(ev, "r_o", {"r_i@2": 1.5}, ())
    assert calls[-1] == (ev.constraints, "r_o", {"r_i": 1.0, "r_o": 2.0}, set())
    assert fm.constraint_range(ev, "c", {}, ()) == (-math.inf, math.inf) and len(calls) == 2
    assert fm.constraint_range(NS(), "r_o", {}, ()) == (-math.inf, math.inf) and len(calls) == 2


def test_the_comparison_at_the_optimum_carries_the_damping_where_measured(monkeypatch):
    log = []

    class Predictor:
        def __init__(self, *a):
            log.append(("predictor",) + a)

        def predict(self, strict=True, return_modes=False):
            log.append(("predict", strict, return_modes))
            return "pred", "idx", "modes"

    monkeypatch.setattr(fm, "Predictor", Predictor)
    monkeypatch.setattr(fm, "Comparison", lambda *a: ("comparison",) + a)
    monkeypatch.setattr(fm, "_zeta_rows", lambda meas, damped: "spec" if damped else None)
    monkeypatch.setattr(fm, "attach_damping", lambda *a: ("damped",) + a)
    ev = NS(damped_model=lambda effects: effects == ("d",))
    out = fm._comparison("m", ["e"], ev, {"v": 1})
    assert out == ("comparison", "m", ("e",), "pred", "idx", {"v": 1})
    assert log == [("predictor", "m", ["e"], ev, {"v": 1}), ("predict", False, True)]
    comp = ("comparison", "m", ("d",), "pred", "idx", {})
    assert fm._comparison("m", ["d"], ev, {}) == ("damped", comp, "m", "modes", "idx", "spec")


def test_the_comparison_at_the_optimum_is_the_kept_first_set_where_there_is_one(monkeypatch):
    """A kept prediction (the fit's evaluation at the optimum) stands for the comparison's
    evaluation: no predictor is made; without one the comparison evaluates."""
    made = []
    monkeypatch.setattr(fm, "Predictor", lambda *a: made.append(a))
    monkeypatch.setattr(fm, "Comparison", lambda *a: ("comparison",) + a)
    monkeypatch.setattr(fm, "_zeta_rows", lambda meas, damped: None)
    kept = NS(predict=lambda: ("kept pred", "kept idx", "kept modes"))
    ev = NS(damped_model=lambda effects: False)
    assert fm._comparison("m", ["e"], ev, {"v": 1}, kept) == (
        "comparison",
        "m",
        ("e",),
        "kept pred",
        "kept idx",
        {"v": 1},
    )
    assert made == []


def test_the_objective_keeps_its_last_and_its_best_point_by_differences():
    """The point asked for last and the lowest chi2 seen keep their evaluation (residuals,
    Jacobian, the first set's prediction); a worse point asked for before the last is evicted."""
    pred = Linear(MEAS, [9, 19, 29], A)
    obj = _objective(pred)
    chi2 = {}
    thetas = [np.array([0.9, 0.6]), np.array([0.1, 0.1]), np.array([0.5, 0.2]), np.array([0.8, 0.6])]
    for theta in thetas:
        r = obj.residuals(theta)
        chi2[theta.tobytes()] = float(r @ r)
    best = min(thetas, key=lambda t: chi2[t.tobytes()])
    assert best is thetas[1] and obj.best[1].tolist() == best.tolist()  # the setting of this test
    assert obj.first_set(thetas[0]) is None and obj.first_set(thetas[2]) is None  # worse, not last: evicted
    for theta in (best, thetas[3]):  # the best point and the last
        assert obj.first_set(theta).values == pytest.approx([math.exp(theta[0]), 2 * theta[1]], rel=1e-15)
    calls = len(pred.calls)
    obj.jacobian(best)
    obj.jacobian(thetas[3])
    assert len(pred.calls) == calls  # no evaluation again
    assert obj.first_set(np.array([9.0, 9.0])) is None  # never evaluated
    exact = _objective(Linear(MEAS, [9, 19, 29], A), jacobian="exact")
    exact.residuals(thetas[0])
    assert exact.first_set(thetas[0]) is None  # the sensitivities' route keeps no modes


@pytest.mark.parametrize("jacobian", ["differences", "exact"])
def test_the_fit_compares_at_its_optimum_with_the_kept_first_set(monkeypatch, jacobian):
    meas, ev, _ = _fit_world(monkeypatch)
    out = fm.fit(meas, ("e",), ev, ("a", "b"), jacobian=jacobian)
    first = out.comparison.first
    if jacobian == "exact":
        assert first is None
    else:
        assert first.values == [out.values["a"], out.values["b"]]  # the very values of the optimum


def test_the_covariance_of_fewer_rows_than_parameters_is_infinite_along_the_free_direction():
    """One row, two parameters: only their sum is determined, neither parameter is."""
    assert np.isinf(fm._covariance(np.array([[1.0, 1.0]]), 1.0, -1)).all()
    assert fm._covariance(np.zeros((3, 0)), 1.0, 3).shape == (0, 0)


def test_a_singular_value_at_the_relative_threshold_is_no_information():
    cov = fm._covariance(np.diag([1.0, 1e-9]), 0.0, 5)  # 1e-9 = 1e-9 x the largest: undetermined
    assert cov[0, 0] == 1.0 and np.isinf(cov[1, 1]) and np.isinf(cov[0, 1])


def test_an_undetermined_direction_adds_nothing_to_the_determined_parameters():
    """J's null direction (1e-4, 1) normalised is undetermined in b; a's variance is that of the
    determined direction alone: 1 / s^2 times its squared component."""
    c = np.array([1.0, -1e-4]) / math.hypot(1.0, 1e-4)
    J = np.outer([2.0, 0.0, 0.0], c)
    cov = fm._covariance(J, 0.0, 1)
    assert cov[0, 0] == pytest.approx(c[0] ** 2 / 4.0, rel=1e-13) and np.isinf(cov[1, 1])


# ------------------------------------------------------------------ a whole fit of a linear stand-in

F0 = np.array([9.0, 19.0, 29.0, 4.0])
A4 = np.array([[1.0, 0.5], [2.0, -1.0], [0.0, 3.0], [1.5, 1.5]])
SIGMA = np.array([0.5, 1.0, 2.0, 0.4])
TRUTH = np.array([2.0, 0.5])
NOISE = np.array([0.3, -0.4, 0.5, 0.2])  # in sigma: a fit worse than sigma, chi2 / dof > 1


class FitRows(Rows):
    params: tuple = ()


def _fit_world(monkeypatch, jacobian_error=None, zeta=False):
    meas = FitRows(F0 + A4 @ TRUTH + NOISE * SIGMA * 3, SIGMA)
    if zeta:
        meas.damping_ratio, meas.sigma_damping_ratio = np.array([0.02, np.nan, np.nan, np.nan]), np.full(4, 0.01)
    made = []

    def predictor(m, effects, ev, fixed):
        z0, Z = (np.full(4, 0.02), np.zeros((4, 2))) if zeta else (None, None)
        p = Linear(m, F0, A4, z0=z0, Z=Z)
        if jacobian_error is not None:
            p.predict_with_jacobian = lambda names, values, strict=True: (_ for _ in ()).throw(jacobian_error)
        made.append((m, effects, ev, fixed))
        return p

    def comparison(m, effects, ev, values, first=None):
        r = (F0 + A4 @ np.array([values["a"], values["b"]]) - m.freq_hz) / m.sigma_hz
        return NS(chi2=float(r @ r), values=dict(values), effects=tuple(effects), first=first)

    monkeypatch.setattr(fm, "Predictor", predictor)
    monkeypatch.setattr(fm, "_comparison", comparison)
    params = {"a": _param(1.0, (0.0, math.inf), "a"), "b": _param(0.0, (-math.inf, math.inf), "b")}
    ev = NS(parameter=lambda n: params[n], damped_model=lambda effects: False)
    return meas, ev, made


def _least_squares(meas):
    """The weighted linear least-squares solution and its covariance, Birge-scaled (n - k = 2)."""
    Aw, yw = A4 / SIGMA[:, None], (meas.freq_hz - F0) / SIGMA
    p, *_ = np.linalg.lstsq(Aw, yw, rcond=None)
    r = Aw @ p - yw
    return p, np.linalg.inv(Aw.T @ Aw) * max(1.0, float(r @ r) / 2)


@pytest.mark.parametrize("jacobian", ["differences", "exact"])
def test_a_fit_of_a_linear_model_is_its_least_squares_solution(monkeypatch, jacobian):
    meas, ev, made = _fit_world(monkeypatch)
    out = fm.fit(meas, ("e",), ev, ("a", "b"), fixed={"c": 7.0}, jacobian=jacobian)
    p, cov = _least_squares(meas)
    assert [out.values["a"], out.values["b"]] == pytest.approx(p, rel=1e-6)
    assert [out.std["a"], out.std["b"]] == pytest.approx(np.sqrt(np.diag(cov)), rel=1e-4)
    assert (out.n, out.k, out.at_bound, out.jacobian) == (
        4,
        2,
        (),
        "exact" if jacobian == "exact" else "central differences",
    )
    assert out.fixed == {"c": 7.0, "a": out.values["a"], "b": out.values["b"]} and made[0][3] == {"c": 7.0}


def test_a_fit_without_sensitivities_says_why_it_used_differences(monkeypatch):
    meas, ev, _ = _fit_world(monkeypatch, jacobian_error=InputError("no kernel for gravity"))
    out = fm.fit(meas, ("e",), ev, ("a", "b"), jacobian="exact")
    assert out.jacobian == "central differences: no kernel for gravity"


def test_measured_damping_ratios_count_as_rows(monkeypatch):
    meas, ev, _ = _fit_world(monkeypatch, zeta=True)
    assert fm.fit(meas, ("e",), ev, ("a", "b")).n == 5


def test_given_start_values_are_screened_for_their_parameter(monkeypatch):
    meas, ev, made = _fit_world(monkeypatch)
    calls = []
    monkeypatch.setattr(
        fm._Objective, "chi2_of", lambda self, table: calls.append(table.copy()) or np.zeros(len(table))
    )
    fm.fit(meas, ("e",), ev, ("a", "b"), starts={"a": (0.5, 3.0)}, explore=("b",))
    assert sorted(set(calls[0][:, 0])) == [0.5, 3.0] and sorted(set(calls[0][:, 1])) == [0.0]
    calls.clear()
    fm.fit(meas, ("e",), ev, ("a", "b"), starts={"a": (0.5, 3.0)}, explore=("a",))  # given: no corners of a
    assert calls[0].tolist() == [[0.5, 0.0], [3.0, 0.0]]
    calls.clear()
    fm.fit(meas, ("e",), ev, ("a", "b"), fixed={"b": 0.7}, explore=())  # a fitted name's fixed value: its start
    assert calls[0].tolist() == [[1.0, 0.7]]


@pytest.mark.parametrize("hi", [1.5, 2.5], ids=["the optimum beyond: at the bound", "inside: not at it"])
def test_a_constraint_cuts_the_fits_search_range(monkeypatch, hi):
    from eigentwist.runtime import constraints

    meas, ev, _ = _fit_world(monkeypatch)
    ev.constraints = [NS(names=("a", "c"))]
    ev.parameter("a").default = 1.0
    seen = []
    monkeypatch.setattr(
        constraints,
        "interval",
        lambda compiled, name, values, effects: seen.append((name, values, effects)) or (0.5, hi),
    )
    defaults = {"a": ev.parameter("a"), "b": ev.parameter("b"), "c": NS(default=4.0)}
    ev.parameter = lambda n: defaults[n]
    out = fm.fit(meas, ("e@2",), ev, ("a", "b"), start={"a": 1.2}, fixed={"c": 3.0})
    assert seen == [("a", {"a": 1.2, "c": 3.0}, {"e"})]
    if hi < 1.6:  # the optimum (a ~ 1.7) beyond the range's end: the fit ends on it, named at its bound
        assert out.values["a"] == pytest.approx(1.5, rel=1e-6) and out.at_bound == ("a",)
    else:  # inside: not at a bound
        assert 0.5 + 0.1 < out.values["a"] < hi - 0.1 and out.at_bound == ()


# ------------------------------------------------------------------ starts: the grid, the corners, the refit


def test_the_corners_of_the_explored_box_pair_each_explored_ends_with_the_others_starts():
    tr = [
        fm.Transform("a", True, 0.01, 100.0, 1.0, 1.0),  # explored, positive: its two ends
        fm.Transform("b", False, -5.0, 5.0, 0.0, 2.0),  # linear: never explored
        fm.Transform("c", True, 1e-3, 1e3, 1.0, 1.0),  # positive, not in explore: at its start
        fm.Transform("d", True, 0.1, 10.0, 1.0, 1.0),  # explored, positive
    ]
    start = {"a": 2.0, "b": 0.5, "c": 7.0, "d": 1.0}
    ends = fm._ends(tr, start, {"a", "b", "d"})
    assert ends.tolist() == [
        [0.01, 0.5, 7.0, 0.1],
        [0.01, 0.5, 7.0, 10.0],
        [100.0, 0.5, 7.0, 0.1],
        [100.0, 0.5, 7.0, 10.0],
    ]
    # a parameter given its own start values is screened over them, not over its ends; a start
    # outside the search range is clipped into it
    given = fm._ends(tr, {**start, "c": 5e3}, {"a", "d"}, {"d": (-1.0, 3.0)})
    assert given.tolist() == [[0.01, 0.5, 1e3, 0.1], [100.0, 0.5, 1e3, 0.1]]
    assert fm._ends(tr, start, {"b"}).shape == (0, 4) and fm._ends(tr, start, set()).shape == (0, 4)
    assert fm._ends(tr, start, {"a"}, {"a": (1.0, 2.0)}).shape == (0, 4)  # the one explored has its starts


def test_a_start_the_model_cannot_evaluate_is_never_taken():
    table = np.array([[1.0], [2.0], [3.0]])
    assert fm._best_start(table, np.array([np.nan, 5.0, 4.0])).tolist() == [3.0]  # argmin would take the NaN
    assert fm._best_start(table, np.array([2.0, np.inf, np.nan])).tolist() == [1.0]
    assert fm._best_start(table, np.array([np.nan, np.nan, np.nan])).tolist() == [1.0]  # none: the first


class Valley(Linear):
    """One row measured at 0 Hz (sigma 1): f(a) = (1 + x^2 / 2) (x - x_lo) / -x_lo with x = ln a.
    Over the start grid (a = 0.1 ... 10) a valley whose floor, near a = 1, is 0.96; at the lower
    end of the search range (a = 1e-3) the model vanishes, f = 0: the nested model."""

    X_LO = math.log(1e-3)

    def predict_sets(self, names, values, strict=True, zeta=False, first=False):
        self.calls.append(np.array(values))
        x = np.log(np.asarray(values, dtype=float)[:, :1])
        f = (1 + x * x / 2) * (x - self.X_LO) / -self.X_LO
        return (f, NS(values=np.array(values)[0].tolist())) if first else f


def _valley_world(monkeypatch, valley=True):
    meas = FitRows([0.0], [1.0])
    made = []

    def predictor(m, effects, ev, fixed):
        p = (Valley if valley else Linear)(m, [0.5], [[1.0]], names=("a",))
        made.append(p)
        return p

    def comparison(m, effects, ev, values, first=None):
        f = made[-1].predict_sets(("a",), np.array([[values["a"]]]), strict=False)
        return NS(chi2=float(np.sum(f * f)), values=dict(values), effects=tuple(effects), first=first)

    monkeypatch.setattr(fm, "Predictor", predictor)
    monkeypatch.setattr(fm, "_comparison", comparison)
    params = {"a": _param(1.0, (0.0, math.inf), "a")}
    return meas, NS(parameter=lambda n: params[n], damped_model=lambda effects: False), made


def test_a_fit_that_ends_above_a_corner_is_fitted_again_from_it(monkeypatch):
    meas, ev, made = _valley_world(monkeypatch)
    solved = []
    solve = fm._solve
    monkeypatch.setattr(fm, "_solve", lambda *a: solved.append(a[3]) or solve(*a))
    out = fm.fit(meas, ("e",), ev, ("a",), explore=("a",))
    # the start grid's best (a = 1) descends to the valley's floor (chi2 0.96), above the lower
    # corner (chi2 0): fitted again from there, it ends at the corner, where the model vanishes
    assert [float(s[0]) for s in solved] == [1.0, pytest.approx(1e-3)]
    assert out.values["a"] == pytest.approx(1e-3, rel=1e-6) and out.chi2 < 1e-12 and out.at_bound == ("a",)
    assert out.nfev > 2  # both runs counted
    screened = made[0].calls[0][:, 0]  # one batched evaluation: the grid, then the two corners
    assert screened.tolist() == pytest.approx([0.1, 0.3, 1.0, 3.0, 10.0, 1e-3, 1e3])


def test_a_fit_that_ends_below_every_corner_runs_once(monkeypatch):
    meas, ev, _ = _valley_world(monkeypatch, valley=False)  # f = 0.5 + a: the optimum a -> 0 is the lower corner
    solved = []
    solve = fm._solve
    monkeypatch.setattr(fm, "_solve", lambda *a: solved.append(a[3]) or solve(*a))
    out = fm.fit(meas, ("e",), ev, ("a",), explore=("a",))
    assert len(solved) == 1 and out.values["a"] == pytest.approx(1e-3, rel=1e-6)


@pytest.mark.parametrize("below, refits", [(0.9 * fm.STALL_CHI2, False), (1.1 * fm.STALL_CHI2, True)])
def test_a_corner_counts_only_below_the_fits_end_by_more_than_stall_chi2(monkeypatch, below, refits):
    meas, ev, _ = _fit_world(monkeypatch)
    ended = 10.0  # the chi2 where the first run ends
    monkeypatch.setattr(fm, "_ends", lambda *a: np.array([[5.0, 1.0]]))
    monkeypatch.setattr(
        fm._Objective, "chi2_of", lambda self, table: np.r_[np.full(len(table) - 1, 20.0), ended - below]
    )
    solved, runs = [], []

    def solve(least_squares, obj, transforms, start, lo, hi, max_nfev):
        solved.append(list(start))
        runs.append(obj)
        obj.nfev += 3
        return np.array([math.log(start[0]), start[1] / 2.0]), True, "stub"

    monkeypatch.setattr(fm, "_solve", solve)
    monkeypatch.setattr(fm, "_chi2", lambda obj, theta: ended if obj is runs[0] else ended - 2 * below)
    out = fm.fit(meas, ("e",), ev, ("a", "b"), explore=("a",))
    assert len(solved) == (2 if refits else 1)
    assert solved[0] == [0.1, 0.0]  # the grid's first row (every row at chi2 20)
    assert out.values["a"] == pytest.approx(5.0 if refits else 0.1)  # the refit's end kept where it is lower
    assert out.nfev == 1 + 3 + (3 if refits else 0)  # the screen and every run, the refit's too


def test_a_refit_that_ends_higher_is_dropped(monkeypatch):
    meas, ev, _ = _fit_world(monkeypatch)
    monkeypatch.setattr(fm, "_ends", lambda *a: np.array([[5.0, 1.0]]))
    monkeypatch.setattr(fm._Objective, "chi2_of", lambda self, table: np.r_[np.full(len(table) - 1, 20.0), 1.0])
    solved = []

    def solve(least_squares, obj, transforms, start, lo, hi, max_nfev):
        solved.append(obj)
        obj.nfev += 3
        return np.array([math.log(start[0]), start[1] / 2.0]), True, f"run {len(solved)}"

    monkeypatch.setattr(fm, "_solve", solve)
    monkeypatch.setattr(fm, "_chi2", lambda obj, theta: 10.0 if obj is solved[0] else 12.0)
    out = fm.fit(meas, ("e",), ev, ("a", "b"), explore=("a",))
    assert len(solved) == 2 and out.message == "run 1" and out.values["a"] == pytest.approx(0.1)
    assert out.nfev == 1 + 3  # the screen and the kept run
