"""The selection's rules (``eigentwist/diagnose/select.py``) on stand-ins: no evaluator, no fit.

Each test replaces the selection's collaborators (the fit, the effects' scope, the statistics'
verdicts) by stand-ins that record what they are handed and return made-up fits, and checks
the documented rule: which model each candidate is fitted on and from which start, when the
identifiable extra parameters are kept, the significance test of a candidate with and without
parameters, the ranking's order and ties, the signature's mode and threshold, the rivals of
the next measurement, the forward-backward path, the swapped and unproven alternatives, the
manual effects' checks and the fields of the diagnosis. The whole selection on real data is
tested by tests/test_diagnose.py and tests/test_backward.py.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from scipy import stats

from eigentwist.diagnose import select as sel
from eigentwist.diagnose.matching import ModeMatchError
from eigentwist.diagnose.plausible import PLAUSIBLE_SIGMA
from eigentwist.diagnose.stats import DELTA_AICC
from eigentwist.runtime import InputError

ALPHA = 0.01


def fr(effects=(), names=(), values=None, std=None, fixed=None, chi2=10.0, n=30, k=None, aicc=0.0, at_bound=()):
    """A stand-in fit: ``k`` defaults to the number of fitted names."""
    values = dict(values or {})
    k = len(names) if k is None else k
    return NS(
        effects=tuple(effects),
        names=tuple(names),
        values=values,
        std=dict(std or {n: 0.0 for n in values}),
        fixed=dict(fixed or {}),
        chi2=chi2,
        n=n,
        k=k,
        dof=n - k,
        aicc=aicc,
        at_bound=tuple(at_bound),
        comparison=NS(predicted=np.ones(3), tag=tuple(effects)),
    )


class Fits:
    """A stand-in ``fit``: records each call and returns the next prepared result."""

    def __init__(self, *results):
        self.results, self.calls = list(results), []

    def __call__(self, meas, effects, ev, names, **kw):
        self.calls.append(NS(meas=meas, effects=tuple(effects), ev=ev, names=tuple(names), kw=kw))
        out = self.results.pop(0)
        if isinstance(out, Exception):
            raise out
        return out


class Scope:
    """A stand-in of :mod:`eigentwist.diagnose.scope`: effect -> its parameters (and fitted ones);
    every call must be handed an evaluator."""

    def __init__(self, params, fits=None):
        self.params, self.fits = params, fits or params

    def order(self, ev, effects):
        assert ev is not None
        return tuple(sorted(effects))

    def fit_names(self, ev, e):
        assert ev is not None
        return tuple(self.fits[e])

    def parameter_names(self, ev, e):
        assert ev is not None
        return tuple(self.params[e])

    def taken(self, ev, effects):
        assert ev is not None
        return {p for e in effects for p in self.params[e]}

    def sentence(self, ev, e, values, model):
        assert ev is not None
        return f"{e} with {sorted(values)} in {tuple(model)}"

    where = staticmethod(sel.scope.where)
    rank = staticmethod(sel.scope.rank)


def _ev(ranges=None):
    """An evaluator whose parameters have plausible ranges (default (0, 10)) and trial values."""
    ranges = ranges or {}
    return NS(parameter=lambda n: NS(name=n, plausible_range=list(ranges.get(n, (0.0, 10.0)))))


def cand(effect, aicc=0.0, plausible=True, p=1e-6, order=None, ties=(), fit=None, names=()):
    f = fit or fr((effect,), aicc=aicc)
    return NS(
        effect=effect,
        fit=f,
        p_value=p,
        plausible=plausible,
        order=(order if order is not None else 0,),
        indistinguishable_from=list(ties),
        names=tuple(names),
        params={n: f.values[n] for n in names if n in f.values},
    )


# ------------------------------------------------------------------ the candidate and its plausibility


def test_a_candidates_params_and_their_standard_errors_are_its_own_names_only():
    f = fr(("a",), ("x", "y"), {"x": 1.0, "y": 2.0, "z": 3.0}, {"x": 0.1, "y": 0.2, "z": 0.3})
    c = sel.Candidate("payload_mass@3", f, 0.01, names=("x", "z", "gone"))
    assert c.params == {"x": 1.0, "z": 3.0}
    assert c.param_std == {"x": 0.1, "z": 0.3}
    assert c.where == [3] and sel.Candidate("payload_mass", f, 0.01).where == []
    assert c.order == sel.scope.rank("payload_mass@3")


def test_a_candidate_is_implausible_beyond_plausible_sigma_or_at_a_bound():
    """Range (-1, 1) (not positive: absolute distances), std 0.1: 3 std = 0.3 beyond the edge."""
    edge = 1.0 + PLAUSIBLE_SIGMA * 0.1

    def c(value, std=0.1, at_bound=(), ranges=True):
        f = fr(("a",), ("x",), {"x": value}, {"x": std} if std is not None else {}, at_bound=at_bound)
        f.std = {"x": std} if std is not None else {}
        return sel.Candidate("a", f, 0.01, ("x",), {"x": (-1.0, 1.0)} if ranges else {})

    assert c(edge * 0.99).plausible and c(edge * 0.99).implausible == {}
    assert not c(edge * 1.01).plausible and c(edge * 1.01).implausible == {"x": edge * 1.01}
    assert not c(0.5, at_bound=("x",)).plausible  # inside the range, but at a search bound
    assert not c(1.01, std=None).plausible  # no standard error: infinite, nothing allowed beyond the edge
    assert c(1e6, ranges=False).plausible  # no range: any value


def test_step_change_names_the_added_or_removed_effect():
    assert sel.Step(fr(), added="a").change == "+a"
    assert sel.Step(fr(), removed="b").change == "-b"
    assert sel.Step(fr()).change == "baseline"


def test_the_diagnosis_renders_through_its_text_and_json_modules(monkeypatch):
    from eigentwist.diagnose import evaluators, render_json, verdict

    d = sel.Diagnosis("heli4", None, None, [], [], [], fr(), True, None, [])
    monkeypatch.setattr(render_json, "diagnosis_json", lambda x: {"of": x})
    monkeypatch.setattr(render_json, "dumps", lambda obj, **kw: (obj, kw))
    monkeypatch.setattr(evaluators, "evaluator", lambda robot: f"ev of {robot}")
    monkeypatch.setattr(verdict, "diagnosis_text", lambda x, ev, rows: (x, ev, rows))
    monkeypatch.setattr(verdict, "verdict_text", lambda x: ("verdict", x))
    assert d.to_json() == {"of": d}
    assert d.json(indent=3) == ({"of": d}, {"indent": 3})
    assert d.text() == (d, "ev of heli4", False) and d.text(True) == (d, "ev of heli4", True)
    assert d.message == ("verdict", d)
    assert d.final_comparison is d.final.comparison


def test_the_final_hints_are_empty_when_the_final_model_explains_the_data(monkeypatch):
    monkeypatch.setattr(sel, "hints", lambda cmp: ["hint of", cmp])
    f = fr()
    assert sel.Diagnosis("r", None, None, [], [], [], f, True, None, []).final_hints == []
    assert sel.Diagnosis("r", None, None, [], [], [], f, False, None, []).final_hints == ["hint of", f.comparison]


@pytest.mark.parametrize("meas, carries, damping", [(None, None, True), ("m", True, True), ("m", False, False)])
def test_candidates_are_per_leg_and_damping_only_where_the_data_carry_damping(monkeypatch, meas, carries, damping):
    calls = []
    monkeypatch.setattr(sel.scope, "candidates", lambda ev, effects, **kw: calls.append((ev, effects, kw)) or ["c"])
    monkeypatch.setattr(sel, "carries_damping", lambda m: carries if m == "m" else pytest.fail("no meas"))
    assert sel.candidates_for("ev", ("a",), meas) == ["c"]
    assert calls == [("ev", ("a",), {"per_leg": True, "damping": damping})]


def test_start_values_of_extra_parameters_try_both_signs_of_a_sign_free_one(monkeypatch):
    monkeypatch.setattr(sel, "trial_value", lambda p: p.trial)
    monkeypatch.setattr(sel, "sign_free", lambda p: p.free)
    table = {"off": NS(trial=0.02, free=True), "m": NS(trial=3.0, free=False)}
    ev = NS(parameter=lambda n: table[n])
    assert sel._starts(ev, ("off", "m")) == ({"off": 0.02, "m": 3.0}, {"off": (-0.02, 0.02)})
    assert sel._starts(ev, ()) == ({}, {})


# ------------------------------------------------------------------ one candidate's fit


def _fit_world(monkeypatch, results, extra=(), determined=True, implausible=None):
    """``_fit_effect``'s collaborators: effect "b" (own fitted "kb", "p" also measured) on top of
    a model "a" fitting "ka"; ``extra`` the identifiable extra parameters."""
    fits = Fits(*results)
    monkeypatch.setattr(sel, "fit", fits)
    monkeypatch.setattr(sel, "scope", Scope({"a": ("ka",), "b": ("kb", "ka", "p")}))
    seen = []

    def extra_parameters(meas, ev, effects, effect, values, fixed):
        seen.append((meas, ev, effects, effect, values, fixed))
        if isinstance(extra, Exception):
            raise extra
        return extra

    monkeypatch.setattr(sel, "extra_parameters", extra_parameters)
    monkeypatch.setattr(sel, "trial_value", lambda p: 0.5)
    monkeypatch.setattr(sel, "sign_free", lambda p: p.name == "off")
    judged = []
    monkeypatch.setattr(sel, "_determined", lambda ev, g, f, names: judged.append((ev, g, f, names)) or determined)
    implausible = implausible or {}
    monkeypatch.setattr(sel, "_implausible", lambda ev, f: ev is not None and implausible.get(id(f), False))
    fits.judged = judged
    current = fr(("a",), ("ka",), {"ka": 2.0}, fixed={"ka": 2.0, "q": 1.0})
    meas = NS(params=("p",))
    return fits, seen, current, meas


def test_a_candidate_is_fitted_on_top_of_the_current_model_from_its_values(monkeypatch):
    f = fr(("a", "b"), ("ka", "kb"), {"ka": 2.1, "kb": 4.0}, fixed={"ka": 2.1, "kb": 4.0, "q": 1.0})
    fits, seen, current, meas = _fit_world(monkeypatch, [f])
    assert sel._fit_effect(meas, "ev", current, "b") == (f, ("kb",))  # "ka" fitted already, "p" measured
    (call,) = fits.calls
    assert (call.meas, call.effects, call.ev, call.names) == (meas, ("a", "b"), "ev", ("ka", "kb"))
    assert call.kw == dict(start={"ka": 2.0}, fixed={"ka": 2.0, "q": 1.0}, explore=("kb",), max_nfev=sel.CANDIDATE_NFEV)
    assert seen == [(meas, "ev", ("a", "b"), "b", f.values, f.fixed)]


def _with_extra(monkeypatch, chi2_f=10.0, chi2_g=9.0, **kw):
    f = fr(("a", "b"), ("ka", "kb"), {"ka": 2.1, "kb": 4.0}, fixed={"kb": 4.0}, chi2=chi2_f)
    g = fr(("a", "b"), ("ka", "kb", "off", "m"), {"ka": 2.1, "kb": 4.0, "off": 0.1, "m": 1.0}, chi2=chi2_g)
    fits, _, current, meas = _fit_world(monkeypatch, [f, g], extra=("off", "m"), **kw)
    return sel._fit_effect(meas, EV, current, "b"), f, g, fits


EV = _ev()


def test_identifiable_extra_parameters_are_fitted_from_both_signs_and_kept(monkeypatch):
    (out, own), f, g, fits = _with_extra(monkeypatch)
    assert out is g and own == ("kb", "off", "m")
    assert fits.judged == [(EV, g, f, ("off", "m"))]
    call = fits.calls[1]
    assert (call.meas.params, call.ev) == (("p",), EV)
    assert call.names == ("ka", "kb", "off", "m") and call.effects == ("a", "b")
    assert call.kw == dict(
        start={"ka": 2.1, "kb": 4.0, "off": 0.5, "m": 0.5},
        fixed={"kb": 4.0},
        explore=(),
        starts={"off": (-0.5, 0.5)},
        max_nfev=sel.CANDIDATE_NFEV,
    )


@pytest.mark.parametrize("chi2_g, kept", [(10.0, True), (10.0 * 1.0001, False)])
def test_extra_parameters_are_dropped_when_the_larger_fit_ends_worse(monkeypatch, chi2_g, kept):
    (out, own), f, g, _ = _with_extra(monkeypatch, chi2_g=chi2_g)
    assert (out is g) is kept and (out is f) is not kept
    assert own == (("kb", "off", "m") if kept else ("kb",))


def test_extra_parameters_that_ran_away_are_dropped(monkeypatch):
    (out, own), f, _, _ = _with_extra(monkeypatch, determined=False)
    assert out is f and own == ("kb",)


@pytest.mark.parametrize("g_bad, f_bad, kept", [(True, False, False), (True, True, True), (False, True, True)])
def test_extra_parameters_making_the_fit_implausible_are_dropped_unless_it_was_already(monkeypatch, g_bad, f_bad, kept):
    f = fr(("a", "b"), ("ka", "kb"), {"ka": 2.1, "kb": 4.0})
    g = fr(("a", "b"), ("ka", "kb", "off"), {"ka": 2.1, "kb": 4.0, "off": 0.1}, chi2=9.0)
    fits, _, current, meas = _fit_world(monkeypatch, [f, g], extra=("off",), implausible={id(g): g_bad, id(f): f_bad})
    out, own = sel._fit_effect(meas, _ev(), current, "b")
    assert (out is g) is kept and own == (("kb", "off") if kept else ("kb",))


@pytest.mark.parametrize("where", ["extra", "fit"])
def test_extra_parameters_leaving_their_constraints_are_not_identifiable(monkeypatch, where):
    f = fr(("a", "b"), ("ka", "kb"), {"ka": 2.1, "kb": 4.0})
    if where == "extra":
        _, _, current, meas = _fit_world(monkeypatch, [f], extra=InputError("r_i < r_o"))
    else:
        _, _, current, meas = _fit_world(monkeypatch, [f, InputError("r_i < r_o")], extra=("off",))
    assert sel._fit_effect(meas, _ev(), current, "b") == (f, ("kb",))


def test_extra_parameters_are_determined_within_a_quarter_of_their_range_and_tenfold_errors():
    """An extra's standard error up to 0.25 (hi - lo); the others' up to 10 times those without it."""
    ev = _ev({"off": (-0.1, 0.3)})
    quarter = 0.25 * 0.4
    f = fr(names=("ka", "kb"), values={"ka": 1, "kb": 1}, std={"ka": 0.01, "kb": math.inf})

    def g(std_off, std_ka=0.01, std_kb=1e9):
        return fr(names=("ka", "kb", "off"), std={"off": std_off, "ka": std_ka, "kb": std_kb})

    assert sel._determined(ev, g(quarter), f, ("off",))
    assert not sel._determined(ev, g(quarter * 1.01), f, ("off",))
    assert not sel._determined(ev, g(math.nan), f, ("off",))
    assert sel._determined(ev, g(0.0, std_ka=0.1), f, ("off",))  # ten times: still determined
    assert not sel._determined(ev, g(0.0, std_ka=0.1 * 1.01), f, ("off",))
    assert not sel._determined(ev, g(0.0, std_ka=math.nan), f, ("off",))  # kb's inf std is not judged


def test_plausible_ranges_are_tuples_of_every_fitted_name():
    assert sel._ranges(_ev({"x": (1.0, 2.0)}), ("x", "y")) == {"x": (1.0, 2.0), "y": (0.0, 10.0)}


def test_a_fit_is_implausible_when_any_value_is():
    ev = _ev({"x": (-1.0, 1.0)})
    edge = 1.0 + PLAUSIBLE_SIGMA * 0.1
    assert not sel._implausible(ev, fr(values={"x": edge * 0.99, "y": 5.0}, std={"x": 0.1}))
    assert sel._implausible(ev, fr(values={"x": edge * 1.01, "y": 5.0}, std={"x": 0.1, "y": 0.0}))
    assert sel._implausible(ev, fr(values={"y": 5.0, "x": 1.01}, std={"y": 0.0}))  # x has no std: infinite
    assert sel._implausible(ev, fr(values={"x": 0.0}, std={"x": 0.1}, at_bound=("x",)))
    assert not sel._implausible(ev, fr(values={"x": 0.0}, std={"x": 0.1}, at_bound=("y",)))


@pytest.mark.parametrize("k_current, k", [(1, 2), (1, 3), (2, 2)])
def test_a_candidate_with_parameters_is_f_tested_and_one_without_is_switch_tested(monkeypatch, k_current, k):
    """p: the extra-sum-of-squares F test (scipy) when the candidate adds parameters; the chi2_1
    test of the chi2 drop, scaled by a Birge ratio above 1, when it only switches the effect on."""
    current = fr(("a",), chi2=40.0, k=k_current, n=20)
    f = fr(("a", "b"), ("ka", "kb"), {"ka": 1.0, "kb": 2.0, "c": 3.0}, chi2=30.0, k=k, n=20)
    ev = _ev({"ka": (1.0, 2.0)})
    monkeypatch.setattr(
        sel,
        "_fit_effect",
        lambda meas, e_, cur, e: (f, ("kb",)) if (meas, e_, cur, e) == ("meas", ev, current, "b") else None,
    )
    monkeypatch.setattr(sel, "scope", Scope({}))
    c = sel._candidate("meas", ev, current, "b")
    if k > k_current:
        dk, dof = k - k_current, 20 - k
        expected = stats.f.sf((40.0 - 30.0) / dk / (30.0 / dof), dk, dof)
    else:
        expected = stats.chi2.sf((40.0 - 30.0) / (30.0 / 18), 1)  # chi2/dof = 30/18 > 1
    assert c.p_value == pytest.approx(expected, rel=1e-9)
    assert (c.effect, c.fit, c.names) == ("b", f, ("kb",))
    assert c.plausible_range == {"ka": (1.0, 2.0), "kb": (0.0, 10.0)}
    assert c.sentence == "b with ['c', 'ka', 'kb'] in ('a', 'b')"


def test_the_rank_key_puts_implausible_and_non_finite_aicc_last():
    def c(aicc, plausible=True, order=0):
        return NS(plausible=plausible, fit=NS(aicc=aicc), order=(order,))

    a, b, inf, nan, bad = c(1.0, order=2), c(1.004, order=1), c(math.inf), c(math.nan), c(-100.0, False)
    assert sorted([bad, nan, a, inf, b], key=sel._rank_key)[:2] == [b, a]
    assert sel._rank_key(nan) == (False, math.inf, (0,)) and sel._rank_key(bad)[0] is True
    assert sel._rank_key(c(1.006)) == (False, 1.01, (0,))


# ------------------------------------------------------------------ the ranking


def test_the_ranking_sorts_measures_delta_aicc_and_names_every_tie(monkeypatch):
    """Whitened predictions: "a" and "b" 0.1 apart (within SEPARATION: indistinguishable), "c" far
    from both, with an AICc within DELTA_AICC of "b" only; "d" implausible."""
    fits = {
        "a": fr(("a",), aicc=5.0),
        "b": fr(("b",), aicc=6.0),
        "c": fr(("c",), aicc=6.0 + DELTA_AICC * 0.99),
        "d": fr(("d",), aicc=-50.0),
    }
    where = {"a": [0.0, 0.0], "b": [0.1, 0.0], "c": [100.0, 0.0], "d": [-100.0, 0.0]}
    for e, f in fits.items():
        f.comparison = NS(white=np.array(where[e]))
    monkeypatch.setattr(
        sel,
        "_candidate",
        lambda meas, ev, cur, e: (
            cand(e, fit=fits[e], plausible=e != "d") if (meas, ev, cur) == ("m", "ev", "cur") else None
        ),
    )
    monkeypatch.setattr(sel, "whitened_predictions", lambda cmp: cmp.white)
    monkeypatch.setattr(sel, "_signature", lambda meas, ev, cur, e: f"sig {e} {meas} {ev} {cur}")
    seen = []

    def progress(items, desc, leave):
        seen.append((tuple(items), desc, leave))
        return items

    out = sel.rank_candidates("m", "ev", "cur", ["d", "c", "b", "a"], progress)
    assert [c.effect for c in out] == ["a", "b", "c", "d"]
    assert seen == [(("d", "c", "b", "a"), "fitting effects", False)]
    assert [c.delta_aicc for c in out] == pytest.approx([0.0, 1.0, 1.0 + DELTA_AICC * 0.99, -55.0])
    assert [c.indistinguishable_from for c in out] == [["b"], ["a", "c"], ["b"], []]
    assert out[2].signature == "sig c m ev cur"
    assert sel.rank_candidates("m", "ev", "cur", []) == []
    assert [c.effect for c in sel.rank_candidates("m", "ev", "cur", ["b", "a"])] == ["a", "b"]


def test_ties_are_judged_on_whitened_predictions_at_unit_sigma(monkeypatch):
    """Two candidates 1.5 SEPARATION apart in whitened units and far apart in AICc: distinguishable."""
    from eigentwist.diagnose.stats import SEPARATION

    fits = {"a": fr(("a",), aicc=0.0), "b": fr(("b",), aicc=10 * DELTA_AICC)}
    fits["a"].comparison, fits["b"].comparison = NS(white=np.zeros(1)), NS(white=np.array([1.5 * SEPARATION]))
    monkeypatch.setattr(sel, "_candidate", lambda meas, ev, cur, e: cand(e, fit=fits[e]))
    monkeypatch.setattr(sel, "whitened_predictions", lambda cmp: cmp.white)
    monkeypatch.setattr(sel, "_signature", lambda *a: None)
    assert [c.indistinguishable_from for c in sel.rank_candidates("m", "ev", "cur", ["a", "b"])] == [[], []]


class _Predictor:
    """A stand-in predictor: the frequencies with the effect at its defaults."""

    made: list = []

    def __init__(self, meas, effects, ev, fixed):
        _Predictor.made.append((meas, effects, ev, fixed))

    def predict(self, strict=True):
        assert strict is False
        return _Predictor.freq, None


def _signature(monkeypatch, rho, mode, k_a=None):
    base = np.full(len(rho), 10.0)
    _Predictor.made, _Predictor.freq = [], base * np.exp(np.asarray(rho, float))
    monkeypatch.setattr(sel, "Predictor", _Predictor)
    monkeypatch.setattr(sel, "scope", Scope({}))
    seen = []
    monkeypatch.setattr(sel, "classify", lambda k, r, w: seen.append((k, r, w)) or {"shape": "rises"})
    meas = NS(mode=tuple(mode), k_a=np.asarray(k_a if k_a is not None else np.arange(1.0, len(rho) + 1)))
    current = fr(("b",), fixed={"x": 1.0})
    current.comparison = NS(predicted=base)
    return sel._signature(meas, "ev", current, "a"), seen, meas


def test_the_signature_is_the_shape_of_the_mode_the_effect_changes_most(monkeypatch):
    rho = [0.01, -0.02, 0.03, -0.001, 0.002, 0.0]  # x: |rho| sums 0.06; y: 0.003
    out, seen, meas = _signature(monkeypatch, rho, ["x", "x", "x", "y", "y", "y"], [1, 2, 3, 4, 5, 6])
    assert out == "rises"
    assert _Predictor.made == [(meas, ("a", "b"), "ev", {"x": 1.0})]
    ((k, r, w),) = seen
    assert k.tolist() == [1, 2, 3] and r == pytest.approx([0.01, -0.02, 0.03]) and w.tolist() == [1e12] * 3


def test_the_signature_takes_the_first_mode_of_equal_change_and_a_later_mode_that_changes_more(monkeypatch):
    _, seen, _ = _signature(monkeypatch, [0.01, 0.01, 0.02, 0.0], ["y", "x", "z", "z"])
    assert seen[0][1] == pytest.approx([0.02, 0.0])  # z: 0.02 beats x and y (0.01 each)
    _, seen, _ = _signature(monkeypatch, [0.01, 0.01], ["y", "x"], [1.0, 2.0])
    assert seen[0][0].tolist() == [1.0]  # a tie: the first mode in the rows' order


@pytest.mark.parametrize("factor, shaped", [(1.01, True), (0.99, False)])
def test_an_effect_changing_its_mode_by_no_more_than_1e_7_has_no_signature(monkeypatch, factor, shaped):
    out, seen, _ = _signature(monkeypatch, [1e-7 * factor, -1e-7 * factor * 0.5], ["x", "x"])
    assert (out == "rises") is shaped and (out is None) is not shaped


@pytest.mark.filterwarnings("error")
def test_an_effect_whose_frequencies_vanish_has_no_signature(monkeypatch):
    """No mode (0 Hz) or an unstable one (a negative stand-in) gives no signature and no warning."""
    _signature(monkeypatch, [0.1, 0.2], ["x", "y"])  # the stand-ins in place
    _Predictor.freq = np.array([10.0, 0.0])
    assert sel._signature(NS(mode=("x", "y"), k_a=np.ones(2)), "ev", _current_of(10.0), "a") is None
    _Predictor.freq = np.array([10.0, -10.0])
    assert sel._signature(NS(mode=("x", "y"), k_a=np.ones(2)), "ev", _current_of(10.0), "a") is None


def _current_of(f):
    c = fr(("b",))
    c.comparison = NS(predicted=np.full(2, f))
    return c


# ------------------------------------------------------------------ the next measurement


def test_the_next_measurement_tries_ties_first_and_at_most_max_rivals(monkeypatch):
    calls = []
    monkeypatch.setattr(sel, "_between", lambda ev, meas, a, b, tied: calls.append((ev, meas, a, b, tied)))
    top = cand("t", ties=("r5", "r6"))
    rivals = [cand(f"r{k}") for k in range(1, 7)]
    assert sel._separation("ev", "m", [top] + rivals) is None
    expected = [rivals[4], rivals[5], rivals[0], rivals[1]][: sel.MAX_RIVALS]
    assert [(c[0], c[1], c[2], c[4]) for c in calls] == [
        ("ev", "m", top.fit, c.effect in top.indistinguishable_from) for c in expected
    ]
    assert [c[3] for c in calls] == [c.fit for c in expected] and sel.MAX_RIVALS == 4
    assert sel._separation("ev", "m", [top]) is None and sel._separation("ev", "m", []) is None
    calls.clear()
    sel._separation("ev", "m", [top, rivals[0]])  # two candidates: one rival
    assert len(calls) == 1


def test_the_next_measurement_is_the_first_rival_that_gives_one(monkeypatch):
    answers = {"r1": None, "r2": {"n": 2}, "r3": {"n": 3}}
    monkeypatch.setattr(sel, "_between", lambda ev, meas, a, b, tied: answers[b.effects[0]])
    assert sel._separation("ev", "m", [cand("t")] + [cand(e) for e in answers]) == {"n": 2}


def test_between_writes_the_next_measurement_unless_the_models_are_one(monkeypatch):
    found = {
        "between": ("payload_mass", "rod_compliance"),
        "pose": np.array([0.123456, -0.2, -0.6]),
        "mode": "2",
        "k_a": 1234.5678,
        "k_a_unit": "N m/rad",
        "predicted_hz": {"payload_mass": 12.3456, "rod_compliance": 13.25},
        "separation_sigma": 3.14159,
    }
    same = {}
    monkeypatch.setattr(sel, "equivalent", lambda ev, meas, a, b: same.get((ev, meas, a, b)))
    monkeypatch.setattr(
        sel,
        "next_measurement",
        lambda ev, meas, a, b: dict(found) if (ev, meas, a, b) == ("ev", "m", "A", "B") else None,
    )
    out = sel._between("ev", "m", "A", "B", True)
    assert out["indistinguishable"] is True and sel._between("ev", "m", "A", "B", False)["indistinguishable"] is False
    assert out["message"] == (
        "to tell payload_mass from rod_compliance, measure mode 2 at pose [0.1235, -0.2, -0.6] m with "
        "k_a = 1235 N m/rad: payload_mass predicts 12.35 Hz, rod_compliance 13.25 Hz (3.1 sigma apart)"
    )
    assert sel._between("ev", "m", "A", "C", True) is None  # no mode between them
    same[("ev", "m", "A", "B")] = {"why": "one model"}
    assert sel._between("ev", "m", "A", "B", True) is None


# ------------------------------------------------------------------ effects added by hand


def test_effects_added_by_hand_are_read_in_order_and_checked_against_the_robot(monkeypatch):
    resolved = []
    monkeypatch.setattr(sel, "resolve_model", lambda name, robot: resolved.append((name, robot)))
    ev = NS(effects=("payload_mass", "own_effect"), robot="R")
    assert sel._effect_list(" payload_mass , ,own_effect@2,own_effect", ev) == [
        "payload_mass",
        "own_effect@2",
        "own_effect",
    ]
    assert resolved == [("payload_mass", "R"), ("own_effect@2", "R"), ("own_effect", "R")]
    with pytest.raises(InputError) as err:
        sel._effect_list(["rod_compliance", "own_efect@3"], ev)
    assert str(err.value) == (
        "add 'own_efect@3': not an effect (did you mean own_effect?); expected one of payload_mass, own_effect"
    )


def test_an_unknown_list_item_is_refused_after_the_known_ones(monkeypatch):
    monkeypatch.setattr(sel, "resolve_model", lambda name, robot: None)
    ev = NS(effects=("own_effect",), robot="R")
    assert sel._effect_list(["rod_compliance@1", " "], ev) == ["rod_compliance@1"]
    with pytest.raises(InputError, match="^add '7': not an effect; expected one of own_effect$"):
        sel._effect_list(["rod_compliance", 7], ev)
    with pytest.raises(InputError, match=r"^add 'own_efect': not an effect \(did you mean own_effect\?\)"):
        sel._effect_list("own_efect", ev)
    long = "own_efect@12345678901234567890"  # the suggestion is read from the name before "@"
    with pytest.raises(InputError, match=r"not an effect \(did you mean own_effect\?\)"):
        sel._effect_list(long, ev)


def test_effects_added_by_hand_must_be_new_and_describe_another_part(monkeypatch):
    monkeypatch.setattr(sel, "scope", Scope({"a": ("x",), "b": ("y", "z"), "c": ("z", "y", "w"), "d": ("v",)}))
    sel._check_manual("ev", ["b", "d"], ("a",))  # new parts: accepted
    with pytest.raises(InputError) as err:
        sel._check_manual("ev", ["d", "a"], ("a", "b"))
    assert str(err.value) == "add 'a': the effect is already in the model (a, b, d)"
    with pytest.raises(InputError) as err:
        sel._check_manual("ev", ["d", "c"], ("a", "b"))
    assert str(err.value) == (
        "add 'c': it describes the same part as an effect already in the model (shares y, z); "
        "remove that one from the baseline instead"
    )
    with pytest.raises(InputError, match="'d': the effect is already in the model"):
        sel._check_manual("ev", ["d", "d"], ())  # each added effect joins the model


def test_effects_added_by_hand_are_fitted_in_order_each_on_the_last(monkeypatch):
    fits = {}

    def candidate(meas, ev, current, e):
        f = fr(current.effects + (e,))
        fits[e] = (meas, ev, current)
        return cand(e, fit=f, p=len(current.effects) / 10)

    monkeypatch.setattr(sel, "_candidate", candidate)
    base = fr(("a",))
    steps = sel._manual_steps("m", "ev", base, ["b", "c"])
    assert [(s.added, s.p_value, s.fit.effects) for s in steps] == [
        (None, None, ("a",)),
        ("b", 0.1, ("a", "b")),
        ("c", 0.2, ("a", "b", "c")),
    ]
    assert steps[0].fit is base and fits["b"] == ("m", "ev", base) and fits["c"][2] is steps[1].fit


# ------------------------------------------------------------------ forward and backward


def _forward_world(monkeypatch, rankings, significant=lambda c, cur, m, alpha: c.p_value < alpha / m):
    """Each call of rank_candidates returns the next ranking; the candidates offered are the
    ranking's effects."""
    seen = []
    queue = list(rankings)

    def candidates_for(ev, effects, meas=None):
        assert ev == "ev"
        seen.append(("cands", effects, meas))
        return [c.effect for c in queue[0]] if queue else []

    def rank(meas, ev, current, cands, progress=None):
        seen.append(("rank", meas, ev, current.effects, tuple(cands), progress))
        return queue.pop(0)

    monkeypatch.setattr(sel, "candidates_for", candidates_for)
    monkeypatch.setattr(sel, "rank_candidates", rank)
    monkeypatch.setattr(sel, "significant", significant)
    return seen


def test_forward_adds_the_best_candidate_while_it_is_significant_bonferroni_over_the_step(monkeypatch):
    f1, f2 = fr(("a",)), fr(("a", "b"))
    # three candidates (alpha / 3); "c" a plausible tie, "d" an implausible one, "x" not ranked here
    r1 = [cand("a", p=ALPHA / 3 * 0.99, fit=f1, ties=("c", "d", "x")), cand("c"), cand("d", plausible=False)]
    r2 = [cand("b", p=ALPHA / 2 * 1.01, fit=f2), cand("c")]
    seen = _forward_world(monkeypatch, [r1, r2])
    base = sel.Step(fr())
    steps = sel._forward("m", "ev", [base], ALPHA, "bar")
    assert [s.added for s in steps] == [None, "a"]
    assert steps[1].fit is f1 and steps[1].p_value == r1[0].p_value and steps[1].alternatives == ["c"]
    assert steps[0].ranking is r1 and steps[1].ranking is r2  # every step keeps its ranking
    assert seen[:2] == [("cands", (), "m"), ("rank", "m", "ev", (), ("a", "c", "d"), "bar")]
    assert seen[2:] == [("cands", ("a",), "m"), ("rank", "m", "ev", ("a",), ("b", "c"), "bar")]


def test_forward_stops_without_candidates_and_never_adds_a_removed_effect_again(monkeypatch):
    seen = _forward_world(monkeypatch, [])
    steps = [sel.Step(fr())]
    assert sel._forward("m", "ev", steps, ALPHA, None) == steps and len(steps) == 1
    r = [cand("a", p=1e-9)]
    _forward_world(monkeypatch, [r])
    assert len(sel._forward("m", "ev", [sel.Step(fr())], ALPHA, None, {"a"})) == 1
    _forward_world(monkeypatch, [[cand("a", p=1e-9)], []])
    assert [s.added for s in sel._forward("m", "ev", [sel.Step(fr())], ALPHA, None, {"b"})] == [None, "a"]
    assert seen == [("cands", (), "m")]  # nothing to rank


def test_forward_hands_the_step_candidates_count_and_alpha_to_the_significance_rule(monkeypatch):
    calls = []

    def significant(c, cur, m, alpha):
        calls.append((c.effect, cur.effects, m, alpha))
        return False

    r = [cand("a"), cand("b")]
    _forward_world(monkeypatch, [r], significant)
    sel._forward("m", "ev", [sel.Step(fr(("z",)))], 0.05, None)
    assert calls == [("a", ("z",), 2, 0.05)]


def _removal(effect, fit, p):
    return NS(effect=effect, fit=fit, p_value=p)


def test_stepwise_removes_what_backward_elimination_finds_and_selects_forward_again(monkeypatch):
    f0, f1, f2, f3 = fr(), fr(("a",)), fr(("a", "b")), fr(("b",))
    forward_calls, eliminate_calls = [], []

    def forward(meas, ev, steps, alpha, progress, removed=()):
        forward_calls.append((meas, ev, [s.change for s in steps], alpha, progress, set(removed)))
        if len(forward_calls) == 1:
            steps[0].ranking = [1, 2, 3]
            return steps + [sel.Step(f1, "a", 0.001, ranking=[1, 2]), sel.Step(f2, "b", 0.002)]
        return steps

    def eliminate(meas, ev, final, added, alpha):
        eliminate_calls.append((meas, ev, final, added, alpha))
        return [_removal("a", f3, 0.5)] if len(eliminate_calls) == 1 else []

    monkeypatch.setattr(sel, "_forward", forward)
    monkeypatch.setattr(sel, "eliminate", eliminate)
    steps, removals = sel._stepwise("m", "ev", f0, ALPHA, "bar")
    assert [s.change for s in steps] == ["baseline", "+a", "+b", "-a"] and steps[0].fit is f0
    assert (steps[3].fit, steps[3].p_value, steps[3].added) == (f3, 0.5, None)
    assert [r.effect for r in removals] == ["a"]
    assert eliminate_calls[0] == ("m", "ev", f2, [("a", 3), ("b", 2)], ALPHA)
    assert eliminate_calls[1][2] is f3 and len(eliminate_calls) == 2
    assert forward_calls == [
        ("m", "ev", ["baseline"], ALPHA, "bar", set()),
        ("m", "ev", ["baseline", "+a", "+b", "-a"], ALPHA, "bar", {"a"}),
    ]


def test_stepwise_stops_after_max_rounds(monkeypatch):
    rounds = []
    monkeypatch.setattr(sel, "_forward", lambda meas, ev, steps, alpha, progress, removed=(): steps)
    monkeypatch.setattr(
        sel,
        "eliminate",
        lambda meas, ev, final, added, alpha: rounds.append(1) or [_removal(f"e{len(rounds)}", fr(), 0.9)],
    )
    steps, removals = sel._stepwise("m", "ev", fr(), ALPHA, None)
    assert len(rounds) == sel.MAX_ROUNDS == 5 and len(removals) == 5 and len(steps) == 6


# ------------------------------------------------------------------ the subset search and its path


@pytest.mark.parametrize(
    "chi2, chosen, runs",
    [
        (10.0, ("a",), False),  # explains with one effect: no search
        (10.0, ("a", "b"), True),  # two effects: searched
        (80.0, ("a",), True),  # misfits: searched
        (80.0, (), True),
    ],
)
def test_the_subset_search_runs_when_the_result_misfits_or_holds_two_effects(monkeypatch, chi2, chosen, runs):
    calls = []
    monkeypatch.setattr(sel, "search_subsets", lambda *a: calls.append(a) or "found")
    base = fr(("z",))
    final = fr(("z",) + chosen, k=1, n=30, chi2=chi2)  # chi2 10 on 29 dof explains; 80 does not
    first = sel.Step(base, ranking=["r"])
    steps = [first, sel.Step(fr(("z", "q"), chi2=80.0, k=1), "q"), sel.Step(final, "a")]  # the last step decides
    out = sel._search("m", "ev", base, steps, 7, ALPHA, "bar")
    assert (out == "found") is runs and (out is None) is not runs
    if runs:
        assert calls == [("m", "ev", base, ["r"], final, chosen, 7, ALPHA, "bar")]


def test_the_search_uses_alpha_to_judge_the_fit(monkeypatch):
    monkeypatch.setattr(sel, "search_subsets", lambda *a: "found")
    chi2 = stats.chi2.isf(0.05, 29)  # p = 0.05: explained at alpha 0.01, not at 0.1
    steps = [sel.Step(fr()), sel.Step(fr(("a",), k=1, chi2=chi2), "a")]
    assert sel._search("m", "ev", fr(), steps, 3, 0.01) is None
    assert sel._search("m", "ev", fr(), steps, 3, 0.1) == "found"


def test_the_path_to_the_searched_subset_adds_its_members_in_the_order_of_their_single_fits(monkeypatch):
    """Members "b" (single AICc 1) and "a" (2); "a" ranked again on top of "b" with its equivalent
    "c" ("d" is offered no more); "c" a plausible tie of "a", "e" a tie that is not equivalent."""
    singles = [cand("a", aicc=2.0, order=1), cand("b", aicc=1.0, order=2), cand("c", aicc=1.0, order=0)]
    singles[1].indistinguishable_from = ["c", "x"]
    first = sel.Step(fr(), ranking=singles)
    found = NS(best=NS(effects=("a", "b")), same={"a": ["c", "d", "e"], "b": ["c"]})
    second = [
        cand("a", fit=fr(("a", "b")), ties=("c", "e", "d", "g")),
        cand("c"),
        cand("e"),
        cand("d", plausible=False),
    ]
    second.append(cand("g"))  # a tie that is not equivalent to "a" alone
    calls = []
    monkeypatch.setattr(
        sel, "candidates_for", lambda ev, effects: ["a", "c", "e", "q"] if (ev, effects) == ("ev", ("b",)) else []
    )
    monkeypatch.setattr(sel, "rank_candidates", lambda m, ev, cur, names: calls.append((m, ev, cur, names)) or second)
    steps = sel._path("m", "ev", first, found)
    assert [s.change for s in steps] == ["baseline", "+b", "+a"]
    assert steps[1].fit is singles[1].fit and steps[2].fit is second[0].fit
    assert steps[1].p_value == singles[1].p_value
    assert steps[1].alternatives == ["c"]  # plausible, equivalent, tied
    assert steps[2].alternatives == ["c", "e"]
    assert calls == [("m", "ev", singles[1].fit, ["a", "c", "e"])]
    assert steps[0].ranking is singles and steps[1].ranking is second and steps[0].fit is first.fit


def test_the_path_ranks_each_later_member_on_top_of_the_one_before(monkeypatch):
    singles = [cand("a", aicc=1.0), cand("b", aicc=2.0), cand("c", aicc=3.0)]
    rankings = {"b": [cand("b", fit=fr(("a", "b")))], "c": [cand("c", fit=fr(("a", "b", "c")))]}
    seen = []
    monkeypatch.setattr(sel, "candidates_for", lambda ev, effects: ["b", "c"])
    monkeypatch.setattr(
        sel, "rank_candidates", lambda m, ev, cur, names: seen.append(cur.effects) or rankings[names[0]]
    )
    found = NS(best=NS(effects=("c", "a", "b")), same={})
    steps = sel._path("m", "ev", sel.Step(fr(), ranking=singles), found)
    assert [s.change for s in steps] == ["baseline", "+a", "+b", "+c"] and seen == [("a",), ("a", "b")]
    assert steps[1].ranking is rankings["b"] and steps[2].ranking is rankings["c"] and steps[3].ranking == []


def test_the_path_orders_members_of_equal_aicc_by_the_catalogue(monkeypatch):
    singles = [cand("a", aicc=1.0, order=2), cand("b", aicc=1.0, order=1)]
    monkeypatch.setattr(sel, "candidates_for", lambda ev, effects: ["a"])
    monkeypatch.setattr(sel, "rank_candidates", lambda m, ev, cur, names: [cand("a")])
    steps = sel._path("m", "ev", sel.Step(fr(), ranking=singles), NS(best=NS(effects=("a", "b")), same={}))
    assert [s.added for s in steps[1:]] == ["b", "a"] and steps[1].alternatives == []


def _swap_world(monkeypatch, result=None):
    fits = Fits(result or fr(("x",)))
    monkeypatch.setattr(sel, "fit", fits)
    monkeypatch.setattr(sel, "scope", Scope({"a": ("ka", "ma"), "b": ("kb",), "c": ("kc", "kb"), "d": ("kd",)}))
    return fits


def test_a_tie_is_swapped_into_the_final_model_and_refitted_as_a_whole(monkeypatch):
    refit = fr(("b", "d"))
    fits = _swap_world(monkeypatch, refit)
    final = fr(("a", "b"), ("ka", "kb", "z"), fixed={"ka": 1.0, "ma": 2.0, "kb": 3.0, "q": 4.0})
    rival = cand("d", fit=fr(("d",), values={"kd": 5.0, "z": 9.0, "y": 8.0}), names=("kd", "z"))
    out = sel._swap("m", "ev", final, sel.Step(final, "a"), rival)
    assert out is refit
    (call,) = fits.calls
    assert (call.meas, call.effects, call.ev) == ("m", ("b", "d"), "ev")
    assert call.names == ("kb", "z", "kd")  # "a"'s parameters dropped, the rival's added once
    assert call.kw == dict(start={"kb": 3.0, "q": 4.0, "kd": 5.0, "z": 9.0}, fixed={"kb": 3.0, "q": 4.0}, explore=())


def test_a_tie_sharing_a_part_with_the_rest_of_the_model_is_no_swap(monkeypatch):
    fits = _swap_world(monkeypatch)
    final = fr(("a", "b"), ("ka", "kb"))
    assert sel._swap("m", "ev", final, sel.Step(final, "a"), cand("c", names=("kc",))) is None
    assert fits.calls == []
    assert sel._swap("m", "ev", final, sel.Step(final, "b"), cand("c", names=("kc",))) is not None


def test_final_alternatives_are_the_path_ties_that_fit_as_well(monkeypatch):
    """Step "+a" has ties "c" (as good, a different model: next measurement), "d" (one model
    with the final: no measurement), "e" (worse by far), "f" (implausible), "g" (no model);
    "+b" was taken back, its tie "h" is not offered."""
    final = fr(("a",), aicc=10.0)
    final.comparison = NS(white=np.zeros(2))
    swapped = {
        "c": fr(("c",), aicc=10.5),
        "d": fr(("d",), aicc=10.0),
        "e": fr(("e",), aicc=10.0 + DELTA_AICC * 1.01),
        "f": fr(("f",), aicc=10.0),
        "h": fr(("h",), aicc=10.0),
    }
    # whitened predictions (unit sigma): "e" 1.5 SEPARATION from the final model
    where = {"c": [10.0, 0.0], "d": [0.0, 0.0], "e": [0.0, 4.5], "f": [0.0, 0.0], "h": [0.0, 0.0]}
    for e, g in swapped.items():
        g.comparison = NS(white=np.array(where[e]))
    ranking = [cand(e) for e in "acdefgh"]
    steps = [
        sel.Step(fr(), ranking=ranking),
        sel.Step(fr(("b",)), "b", alternatives=["h"], ranking=ranking),
        sel.Step(fr(("a",)), "a", alternatives=["c", "d", "e", "f", "g"]),
        sel.Step(final, None, removed="b"),
    ]
    swaps = []

    def swap(meas, ev, fin, step, rival):
        swaps.append((meas, ev, fin, step.added, rival.effect))
        return swapped.get(rival.effect)

    monkeypatch.setattr(sel, "_swap", swap)
    monkeypatch.setattr(sel, "_implausible", lambda ev, g: ev == "ev" and g is swapped["f"])
    monkeypatch.setattr(sel, "whitened_predictions", lambda cmp: cmp.white)

    def equivalent(ev, meas, a, b):
        assert (ev, meas, a) == ("ev", "m", final)
        return {"one": b.effects} if b is swapped["d"] else None

    monkeypatch.setattr(sel, "equivalent", equivalent)
    monkeypatch.setattr(sel, "_between", lambda ev, meas, a, b, tied: {"between": (a, b, tied, ev, meas)})
    out = sel.final_alternatives("m", "ev", steps)
    assert [s[4] for s in swaps] == ["c", "d", "e", "f", "g"] and swaps[0][:4] == ("m", "ev", final, "a")
    assert [(a.by, a.replaced, a.effects) for a in out] == [("c", "a", ("c",)), ("d", "a", ("d",))]
    assert out[0].fit is swapped["c"] and out[0].next_measurement == {"between": (final, swapped["c"], True, "ev", "m")}
    assert out[0].equivalent is None
    assert out[1].next_measurement is None and out[1].equivalent == {"one": ("d",)}


def test_final_alternatives_take_each_rival_from_the_ranking_of_its_step(monkeypatch):
    first, second = [cand("a"), cand("c", fit=fr(("c1",)))], [cand("b"), cand("c", fit=fr(("c2",)))]
    steps = [
        sel.Step(fr(), ranking=first),
        sel.Step(fr(("a",)), "a", alternatives=["c"], ranking=second),
        sel.Step(fr(("a", "b")), "b", alternatives=["c"]),
    ]
    rivals = []
    monkeypatch.setattr(sel, "_swap", lambda meas, ev, fin, step, rival: rivals.append((step.added, rival.fit.effects)))
    assert sel.final_alternatives("m", "ev", steps) == []
    assert rivals == [("a", ("c1",)), ("b", ("c2",))]


def _unproven_world(monkeypatch, same=()):
    def equivalent(ev, meas, a, b):
        assert (ev, meas) == ("ev", "m")
        return {"one": (a.effects, b.effects)} if {a.effects[0], b.effects[0]} == set(same) else None

    monkeypatch.setattr(sel, "equivalent", equivalent)
    monkeypatch.setattr(sel, "_between", lambda ev, meas, a, b, tied: (a.effects, b.effects, tied, ev, meas))


def test_unproven_alternatives_would_explain_a_misfit_and_are_compared_with_the_first(monkeypatch):
    """The final model misfits (chi2 80 on 29 dof); "b" and "d" explain the rows (chi2 20) but
    were not significant, "c" is a tie of "b", "x" explains but is implausible, "e" explains nothing."""
    _unproven_world(monkeypatch, same=("b", "c"))
    last = [
        cand("x", plausible=False, fit=fr(("x",), chi2=20.0)),
        cand("b", fit=fr(("b",), chi2=20.0, k=1), ties=("c", "x")),
        cand("e", fit=fr(("e",), chi2=80.0, k=1)),
        cand("c", fit=fr(("c",), chi2=60.0, k=1)),
        cand("d", fit=fr(("d",), chi2=20.0, k=1)),
    ]
    steps = [sel.Step(fr()), sel.Step(fr(("a",), chi2=80.0, k=1), "a", ranking=last)]
    out = sel.unproven("m", "ev", steps, ALPHA)
    assert [(a.by, a.replaced, a.effects) for a in out] == [
        ("b", None, ("b",)),
        ("c", None, ("c",)),
        ("d", None, ("d",)),
    ]
    assert [a.fit for a in out] == [last[1].fit, last[3].fit, last[4].fit]
    assert out[0].equivalent == {"one": (("b",), ("c",))} and out[0].next_measurement is None
    assert out[1].equivalent == {"one": (("c",), ("b",))} and out[1].next_measurement is None
    assert out[2].equivalent is None and out[2].next_measurement == (("d",), ("b",), True, "ev", "m")


def test_one_unproven_alternative_is_compared_with_nothing(monkeypatch):
    _unproven_world(monkeypatch, same=("b",))  # "b" would be one model with itself: never asked
    last = [cand("b", fit=fr(("b",), chi2=20.0, k=1))]
    (alt,) = sel.unproven("m", "ev", [sel.Step(fr(("a",), chi2=80.0, k=1), ranking=last)], ALPHA)
    assert alt.by == "b" and alt.next_measurement is None and alt.equivalent is None


def test_the_second_unproven_alternative_is_compared_with_the_first_and_the_first_with_the_second(monkeypatch):
    _unproven_world(monkeypatch)
    last = [cand(e, fit=fr((e,), chi2=20.0, k=1)) for e in "bcd"]
    out = sel.unproven("m", "ev", [sel.Step(fr(("a",), chi2=80.0, k=1), ranking=last)], ALPHA)
    assert [a.next_measurement[:2] for a in out] == [(("b",), ("c",)), (("c",), ("b",)), (("d",), ("b",))]


def test_two_unproven_alternatives_are_compared_with_each_other(monkeypatch):
    _unproven_world(monkeypatch)
    last = [cand(e, fit=fr((e,), chi2=20.0, k=1)) for e in "bc"]
    out = sel.unproven("m", "ev", [sel.Step(fr(("a",), chi2=80.0, k=1), ranking=last)], ALPHA)
    assert [a.next_measurement[:2] for a in out] == [(("b",), ("c",)), (("c",), ("b",))]


def test_no_unproven_alternative_when_the_final_model_explains_the_rows(monkeypatch):
    _unproven_world(monkeypatch)
    chi2 = stats.chi2.isf(0.05, 29)  # p = 0.05: explained at alpha 0.01, not at 0.1
    last = [cand("b", fit=fr(("b",), chi2=chi2, k=1))]
    steps = [sel.Step(fr(("a",), chi2=chi2, k=1), ranking=last)]
    assert sel.unproven("m", "ev", steps, 0.01) == []
    steps[-1].ranking = [cand("b", fit=fr(("b",), chi2=20.0, k=1))]
    assert [a.by for a in sel.unproven("m", "ev", steps, 0.1)] == ["b"]
    steps[-1].ranking = [cand("b", fit=fr(("b",), chi2=chi2, k=1))]
    assert sel.unproven("m", "ev", steps, 0.1) == []  # the candidate must pass the same alpha


# ------------------------------------------------------------------ one selection and its diagnosis


def _recorder(log, name, value):
    """A stand-in that logs its name and every argument it is handed, and returns ``value``."""
    return lambda *a, **kw: log.append((name,) + a + tuple(sorted(kw.items()))) or value


def _select_world(monkeypatch):
    log = []
    base = fr(("z",))
    first = sel.Step(base, ranking=["first"])
    for name, value in [
        ("_baseline", ("cmp", ["note"])),
        ("fit", base),
        ("candidates_for", ["a", "b"]),
        ("_check_manual", None),
        ("_manual_steps", ["manual steps"]),
        ("rank_candidates", ["ranked"]),
        ("_stepwise", ([first], ["removed"])),
    ]:
        monkeypatch.setattr(sel, name, _recorder(log, name, value))
    monkeypatch.setattr(sel, "_diagnosis", lambda *a: ("diagnosis",) + a)
    monkeypatch.setattr(sel, "_searched", lambda d, ev, progress, values: ("searched", d, ev, progress, values))
    return log, base, first


def test_a_selection_by_hand_fits_the_given_effects_and_ranks_the_candidates_beside(monkeypatch):
    log, base, _ = _select_world(monkeypatch)
    out = sel._select("m", "ev", ("z",), ["a"], 0.05, "bar", {"v": 1.0}, search=True)
    assert out == ("diagnosis", "m", "ev", "cmp", ["ranked"], ["manual steps"], [], True, 0.05, {"v": 1.0}, ["note"])
    assert log == [
        ("_baseline", "m", "ev", ("z",), {"v": 1.0}),
        ("fit", "m", ("z",), "ev", (), ("fixed", {"v": 1.0})),
        ("candidates_for", "ev", ("z",), "m"),
        ("_check_manual", "ev", ["a"], ("z",)),
        ("_manual_steps", "m", "ev", base, ["a"]),
        ("rank_candidates", "m", "ev", base, ["a", "b"], "bar"),
    ]


@pytest.mark.parametrize("search", [False, True])
def test_an_automatic_selection_is_stepwise_and_searched_when_asked(monkeypatch, search):
    log, base, first = _select_world(monkeypatch)
    out = sel._select("m", "ev", ("z",), None, 0.05, "bar", {"v": 2}, search)
    d = ("diagnosis", "m", "ev", "cmp", ["first"], [first], ["removed"], False, 0.05, {"v": 2}, ["note"])
    assert out == (("searched", d, "ev", "bar", {"v": 2}) if search else d)
    assert log[-1] == ("_stepwise", "m", "ev", base, 0.05, "bar") and len(log) == 4
    assert sel._select("m", "ev", ("z",), None, 0.05, "bar", {"v": 2}) == d  # no search by default


def test_the_diagnosis_holds_the_final_model_and_what_the_path_found(monkeypatch):
    ev = NS(spec="heli4-spec")
    final = fr(("z", "a", "b"), chi2=10.0, k=2)
    steps = [
        sel.Step(fr(("z",))),
        sel.Step(fr(("z", "a")), "a"),
        sel.Step(fr(("z", "a", "c")), "c"),
        sel.Step(fr(("z", "a")), None, removed="c"),
        sel.Step(final, "b"),
    ]
    first = [NS(effect="a", signature="up"), NS(effect="b", signature=None)]
    calls = {}

    def rec(name, value):
        return lambda *a: calls.setdefault(name, a) and value

    monkeypatch.setattr(sel, "outside_plausible", lambda e, f: {} if (e, f) == (ev, final) else pytest.fail())
    monkeypatch.setattr(sel, "_separation", rec("separation", {"next": 1}))
    monkeypatch.setattr(sel, "hints", rec("hints", ["h"]))
    monkeypatch.setattr(sel, "final_alternatives", rec("final", ["alt"]))
    monkeypatch.setattr(sel, "unproven", rec("unproven", ["unproven"]))
    monkeypatch.setattr(sel, "_untestable", rec("untestable", {"u": 5}))
    monkeypatch.setattr(sel, "used_parameters", rec("used", ["p"]))
    d = sel._diagnosis("m", ev, "cmp", first, steps, ["rm"], False, 0.05, {"v": 1}, ["note"], "search")
    assert (d.robot, d.meas, d.baseline, d.ranking, d.steps, d.final) == ("heli4-spec", "m", "cmp", first, steps, final)
    assert d.selected == ["a", "b"] and d.removed == ["rm"] and d.explained is True and d.implausible == {}
    assert d.next_measurement == {"next": 1} and d.hints == ["h"] and d.alpha == 0.05 and d.manual is False
    assert d.alternatives == ["alt", "unproven"] and d.untestable == {"u": 5} and d.parameters == ["p"]
    assert d.search == "search" and d.notes == ["note"]
    assert calls["separation"] == (ev, "m", first) and calls["hints"] == ("cmp", {"a": "up", "b": None})
    assert calls["final"] == ("m", ev, steps) and calls["unproven"] == ("m", ev, steps, 0.05)
    assert calls["untestable"] == ("m", ev, steps)
    assert calls["used"] == (ev, final.effects, {"v": 1}, "m", final.values)


def test_a_diagnosis_by_hand_has_no_alternatives_and_judges_only_the_baseline_candidates(monkeypatch):
    steps = [sel.Step(fr(("z",))), sel.Step(fr(("z", "a"), chi2=100.0, k=1), "a")]
    seen = {}
    monkeypatch.setattr(sel, "outside_plausible", lambda ev, f: {})
    monkeypatch.setattr(sel, "_separation", lambda *a: None)
    monkeypatch.setattr(sel, "hints", lambda *a: [])
    monkeypatch.setattr(sel, "_untestable", lambda meas, ev, s: seen.setdefault("steps", s) and {})
    monkeypatch.setattr(sel, "used_parameters", lambda *a: [])
    monkeypatch.setattr(sel, "final_alternatives", lambda *a: ["alt"])
    monkeypatch.setattr(sel, "unproven", lambda *a: ["unproven"])
    d = sel._diagnosis("m", NS(spec="r"), "cmp", [], steps, [], True, ALPHA, None, [])
    assert d.alternatives == [] and d.manual is True and seen["steps"] == steps[:1]
    assert d.explained is False and d.search is None  # chi2 100 on 29 dof misfits


@pytest.mark.parametrize("chi2, outside, explained", [(10.0, {}, True), (100.0, {}, False), (10.0, {"x": 1}, False)])
def test_a_diagnosis_explains_the_rows_only_with_a_fit_inside_the_plausible_ranges(
    monkeypatch, chi2, outside, explained
):
    for name in ("_separation", "hints", "final_alternatives", "unproven", "_untestable", "used_parameters"):
        monkeypatch.setattr(sel, name, lambda *a: [])
    monkeypatch.setattr(sel, "outside_plausible", lambda ev, f: outside)
    steps = [sel.Step(fr(("z",), chi2=chi2, k=1))]
    d = sel._diagnosis("m", NS(spec="r"), "cmp", [], steps, [], False, ALPHA, None, [])
    assert d.explained is explained and d.implausible == outside


def test_a_diagnosis_judges_the_final_fit_on_its_degrees_of_freedom_at_alpha(monkeypatch):
    """chi2 with p = 0.03 on 10 - 7 = 3 degrees of freedom: explained at alpha 0.01, not at 0.05."""
    for name in ("_separation", "hints", "final_alternatives", "unproven", "_untestable", "used_parameters"):
        monkeypatch.setattr(sel, name, lambda *a: [])
    monkeypatch.setattr(sel, "outside_plausible", lambda ev, f: {})
    steps = [sel.Step(fr(("z",), chi2=stats.chi2.isf(0.03, 3), n=10, k=7))]
    assert sel._diagnosis("m", NS(spec="r"), "cmp", [], steps, [], False, 0.01, None, []).explained is True
    assert sel._diagnosis("m", NS(spec="r"), "cmp", [], steps, [], False, 0.05, None, []).explained is False


def _searched_world(monkeypatch, found):
    log = []
    monkeypatch.setattr(sel, "candidates_for", lambda ev, effects: ["a", "b", "c"])
    monkeypatch.setattr(sel, "_search", lambda *a: log.append(("search",) + a) or found)
    monkeypatch.setattr(sel, "_path", lambda meas, ev, first, f: log.append(("path", meas, ev, first, f)) or ["path"])
    monkeypatch.setattr(
        sel,
        "_forward",
        lambda meas, ev, steps, alpha, progress: (
            log.append(("forward", meas, ev, steps, alpha, progress)) or ["forward"]
        ),
    )
    monkeypatch.setattr(sel, "_diagnosis", lambda *a: NS(args=a, outliers=None, all_rows=None, setting_anomalies=None))
    base = fr(("z",))
    d = NS(
        steps=[sel.Step(base), sel.Step(fr(("z", "a")), "a")],
        meas="m",
        alpha=0.05,
        baseline="cmp",
        ranking=["first"],
        notes=["note"],
        outliers=["o"],
        all_rows="all",
        setting_anomalies=["s"],
        search="before",
    )
    return log, d, base


@pytest.mark.parametrize("found", [None, NS(changed=False)])
def test_a_search_that_changes_nothing_is_attached_to_the_diagnosis(monkeypatch, found):
    log, d, base = _searched_world(monkeypatch, found)
    assert sel._searched(d, "ev", "bar", {"v": 1}) is d and d.search is found
    assert log == [("search", "m", "ev", base, d.steps, 3, 0.05, "bar")]


def test_a_search_that_wins_replaces_the_path_and_keeps_the_rows_set_aside(monkeypatch):
    found = NS(changed=True)
    log, d, base = _searched_world(monkeypatch, found)
    out = sel._searched(d, "ev", "bar", {"v": 1})
    assert log[1:] == [("path", "m", "ev", d.steps[0], found), ("forward", "m", "ev", ["path"], 0.05, "bar")]
    assert out.args == ("m", "ev", "cmp", ["first"], ["forward"], [], False, 0.05, {"v": 1}, ["note"], found)
    assert (out.outliers, out.all_rows, out.setting_anomalies) == (["o"], "all", ["s"])


def test_the_baseline_matches_ambiguous_labels_by_order_with_a_note_and_the_unit_note_first(monkeypatch):
    calls = []

    def compare(meas, effects, ev, values, check, strict=True):
        calls.append((meas, effects, ev, values, check, strict))
        if strict:
            raise ModeMatchError("pose 3: row 7: no model mode points along x")
        return NS(predicted="pred")

    monkeypatch.setattr(sel, "compare", compare)
    monkeypatch.setattr(sel, "unit_note", lambda f, p: f"unit of {f} {p}")
    cmp, notes = sel._baseline(NS(freq_hz="f"), "ev", ("z",), {"v": 1})
    assert cmp.predicted == "pred" and [c[5] for c in calls] == [True, False]
    assert calls[0][1:5] == calls[1][1:5] == (("z",), "ev", {"v": 1}, False) and calls[0][0] is calls[1][0]
    assert notes == [
        "unit of f pred",
        "Mode labels: at some poses no model mode points along a measured direction (pose 3 first); "
        "those rows are matched by frequency order and shape.",
    ]


def test_the_baseline_raises_other_label_errors_and_says_nothing_without_cause(monkeypatch):
    def compare(meas, effects, ev, values, check, strict=True):
        raise ModeMatchError("mode 9: rank too high")

    monkeypatch.setattr(sel, "compare", compare)
    with pytest.raises(ModeMatchError, match="rank too high"):
        sel._baseline(NS(freq_hz="f"), "ev", ("z",), None)
    monkeypatch.setattr(sel, "compare", lambda meas, effects, ev, values, check: NS(predicted="p", check=check))
    monkeypatch.setattr(sel, "unit_note", lambda f, p: None)
    cmp, notes = sel._baseline(NS(freq_hz="f"), "ev", ("z",), None)
    assert notes == [] and cmp.check is False


def test_untestable_candidates_keep_the_rows_the_first_step_needs(monkeypatch):
    """Candidates "a" (one own parameter) and "b" (two): untestable on n <= k + own + 2 rows, which
    need k + own + 3; an effect untestable at two steps keeps the first step's need."""
    monkeypatch.setattr(sel, "scope", Scope({"a": ("x",), "b": ("y", "w")}))

    def candidates_for(ev, effects, meas):
        assert ev == "ev" and len(meas) in (7, 8)
        return ["a", "b"] if not effects else ["b"]

    monkeypatch.setattr(sel, "candidates_for", candidates_for)
    steps = [sel.Step(fr((), k=3)), sel.Step(fr(("a",), k=4), "a")]
    assert sel._untestable(list(range(8)), "ev", steps) == {"b": 9}  # at the second step: 4 + 2 + 3
    assert sel._untestable(list(range(7)), "ev", steps) == {"b": 8}  # from the first step: 3 + 2 + 3
    steps = [sel.Step(fr((), k=4)), sel.Step(fr(("a",), k=3), "a")]
    assert sel._untestable(list(range(7)), "ev", steps) == {"a": 8, "b": 9}


@pytest.mark.parametrize(
    "p, unproven, effect", [(ALPHA / 2 * 0.99, False, True), (ALPHA / 2 * 1.01, False, False), (1.0, True, True)]
)
def test_the_uncertainty_is_judged_knowing_whether_an_effect_is_left(monkeypatch, p, unproven, effect):
    """An effect is left when a last-step candidate is significant (Bonferroni over the step,
    not only plausible ones) or an unproven alternative would explain the rows."""
    seen = []
    monkeypatch.setattr(
        sel,
        "judge_uncertainty",
        lambda final, untestable, eff, alpha: seen.append((final, untestable, eff, alpha)) or "judged",
    )
    final = fr(("a",), aicc=0.0)
    last = [cand("b", p=p, aicc=-1.0, plausible=False), cand("c", p=1.0, aicc=-1.0)]
    d = NS(
        steps=[sel.Step(final, ranking=last)],
        final=final,
        alpha=ALPHA,
        untestable={"u": 3},
        alternatives=[NS(replaced=None if unproven else "a")],
    )
    assert sel._judge(d) is d and d.uncertainty == "judged"
    assert seen == [(final, {"u": 3}, effect, ALPHA)]


# ------------------------------------------------------------------ rows and settings set aside


class _Rows:
    """Rows with CSV line numbers; ``subset`` keeps the rows of a mask."""

    def __init__(self, lines):
        self.lines = np.asarray(lines)

    def __len__(self):
        return len(self.lines)

    def subset(self, keep):
        return _Rows(self.lines[keep])


def test_outliers_are_set_aside_worst_first_one_at_a_time_and_the_selection_rerun(monkeypatch):
    meas = _Rows(np.arange(2, 32))  # 30 rows: up to 3 outliers
    finals = [NS(comparison=f"cmp{k}", k=k) for k in range(4)]
    looked, selected = [], []

    def find_outliers(cmp, k, alpha):
        looked.append((cmp, k, alpha))
        return [NS(line=[7, 3][len(looked) - 1]), NS(line=99)] if len(looked) < 3 else []

    def select(rows, ev, base, add, alpha, progress, values, search):
        selected.append((rows.lines.tolist(), ev, base, add, alpha, progress, values, search))
        return NS(final=finals[len(selected) % 4], outliers=[], all_rows=None)

    monkeypatch.setattr(sel, "find_outliers", find_outliers)
    monkeypatch.setattr(sel, "_select", select)
    monkeypatch.setattr(sel, "_judge", lambda d: ("judged", d))
    d_all = NS(final=finals[0], outliers=[], all_rows=None)
    out = sel._without_outliers(meas, "ev", d_all, ("z",), ALPHA, "bar", {"v": 1}, search=True)
    assert [o.line for o in out.outliers] == [7, 3] and out.all_rows == ("judged", d_all)
    assert looked == [("cmp0", 0, ALPHA), ("cmp1", 1, ALPHA), ("cmp2", 2, ALPHA)]
    rows = [x for x in range(2, 32)]
    assert selected[0] == ([x for x in rows if x != 7], "ev", ("z",), None, ALPHA, "bar", {"v": 1}, True)
    assert selected[1][0] == [x for x in rows if x not in (3, 7)] and out.final is finals[2]
    looked.clear()
    sel._without_outliers(meas, "ev", d_all, ("z",), ALPHA, "bar")
    assert selected[-1][-2:] == (None, False)  # no values, no search by default


def test_nothing_set_aside_leaves_the_diagnosis_as_it_was(monkeypatch):
    monkeypatch.setattr(sel, "find_outliers", lambda cmp, k, alpha: [])
    d = NS(final=NS(comparison=None, k=1), outliers=["kept"], all_rows="kept")
    assert sel._without_outliers(_Rows([2, 3]), "ev", d, (), ALPHA, None) is d and d.all_rows == "kept"


def _settings_world(monkeypatch, found_per_round, rows=40):
    meas = _Rows(np.arange(2, 2 + rows))
    looked, selected = [], []

    def anomalies(m, ev, final, alpha):
        looked.append((m.lines.tolist(), ev, final, alpha))
        return found_per_round[len(looked) - 1] if len(looked) <= len(found_per_round) else []

    def select(m, ev, base, add, alpha, progress, values, search):
        selected.append((m.lines.tolist(), ev, base, add, alpha, progress, values, search))
        return NS(meas=m, final=f"final{len(selected)}", outliers=["new"], all_rows=None, uncertainty=None)

    monkeypatch.setattr(sel, "find_setting_anomalies", anomalies)
    monkeypatch.setattr(sel, "_select", select)
    monkeypatch.setattr(sel, "rescored", lambda a, m, ev, final: (a.name, len(m), ev, final))
    monkeypatch.setattr(sel, "_judge", lambda d: setattr(d, "uncertainty", "judged") or d)
    return meas, looked, selected


def test_whole_settings_are_set_aside_worst_first_and_rescored_under_the_final_model(monkeypatch):
    s1 = NS(name="s1", n_rows=5, lines=[2, 3, 4, 5, 6])
    s2 = NS(name="s2", n_rows=4, lines=[10, 11, 12, 13])
    meas, looked, selected = _settings_world(monkeypatch, [[s1, NS(name="later")], [s2]])
    d_all = NS(meas=meas, final="final0", outliers=["o1"], all_rows=None, uncertainty=None)
    out = sel._without_settings(meas, "ev", d_all, ("z",), ALPHA, "bar", {"v": 1}, search=True)
    assert out.setting_anomalies == [("s1", 40, "ev", "final2"), ("s2", 40, "ev", "final2")]
    assert out.outliers == ["o1"] and out.all_rows is d_all and d_all.uncertainty == "judged"
    assert looked[0] == (list(range(2, 42)), "ev", "final0", ALPHA) and len(looked) == 3
    assert selected[0] == (list(range(7, 42)), "ev", ("z",), None, ALPHA, "bar", {"v": 1}, True)
    assert selected[1][0] == [x for x in range(7, 42) if x not in (10, 11, 12, 13)]
    looked.clear()
    sel._without_settings(
        meas, "ev", NS(meas=meas, final="f", outliers=[], all_rows=None, uncertainty=None), (), ALPHA, None
    )
    assert selected[-1][-2:] == (None, False)  # no values, no search by default


def test_settings_keep_the_all_rows_diagnosis_of_the_outliers(monkeypatch):
    s1 = NS(name="s1", n_rows=5, lines=[2, 3, 4, 5, 6])
    meas, _, _ = _settings_world(monkeypatch, [[s1]])
    first = NS(all_rows=None, uncertainty="first judged")
    d = NS(meas=meas, final="f", outliers=["o"], all_rows=first, uncertainty=None)
    out = sel._without_settings(meas, "ev", d, (), ALPHA, None)
    assert out.all_rows is first and first.uncertainty == "first judged"
    nested = NS(all_rows="older", uncertainty=None)
    d = NS(meas=meas, final="f", outliers=[], all_rows=nested, uncertainty=None)
    meas, _, _ = _settings_world(monkeypatch, [[s1]])
    out = sel._without_settings(meas, "ev", d, (), ALPHA, None)
    assert out.all_rows is nested and nested.uncertainty == "judged"  # judged once, when not yet


@pytest.mark.parametrize("n_rows, taken", [(10, 1), (11, 0)])
def test_a_setting_is_set_aside_up_to_a_quarter_of_the_rows(monkeypatch, n_rows, taken):
    s = NS(name="s", n_rows=n_rows, lines=list(range(2, 2 + n_rows)))
    meas, _, _ = _settings_world(monkeypatch, [[s]], rows=40)
    d = NS(meas=meas, final="f", outliers=[], all_rows=None, uncertainty=None)
    out = sel._without_settings(meas, "ev", d, (), ALPHA, None)
    assert len(getattr(out, "setting_anomalies", [])) == taken and (out is d) is (taken == 0)


# ------------------------------------------------------------------ the whole diagnosis


def _diagnose_world(monkeypatch):
    from eigentwist.diagnose import measurements

    log = []
    read = NS(freq_hz=1, robot="delta")
    monkeypatch.setattr(measurements, "load_measurements", _recorder(log, "load", read))
    monkeypatch.setattr(measurements, "check_columns", _recorder(log, "columns", None))
    ev = NS(robot="R")
    monkeypatch.setattr(sel, "resolve", _recorder(log, "resolve", ev))
    monkeypatch.setattr(sel, "resolve_model", _recorder(log, "model", ("z",)))
    monkeypatch.setattr(sel, "_effect_list", _recorder(log, "effects", ["a", "b"]))
    monkeypatch.setattr(sel, "_select", _recorder(log, "select", "selected"))
    monkeypatch.setattr(sel, "_rows_and_search", _recorder(log, "rows", "searched"))
    monkeypatch.setattr(sel, "_judge", lambda d: ("judged", d))
    return log, ev, read


def test_diagnose_reads_a_file_selects_and_sets_rows_aside(monkeypatch):
    log, ev, read = _diagnose_world(monkeypatch)
    values = {"v": 1}
    out = sel.diagnose("rows.csv", "paper", alpha=0.05, progress="bar", backend="c", values=values)
    assert out == ("judged", "searched")
    assert log == [
        ("load", "rows.csv", "heli4", None, {"v": 1}),
        ("resolve", None, "delta", "c"),
        ("model", "paper", "R"),
        ("columns", read, ("z",), ev, "the baseline"),
        ("select", read, ev, ("z",), None, 0.05, "bar", {"v": 1}),
        ("rows", read, ev, "selected", ("z",), 0.05, "bar", {"v": 1}),
    ]
    assert log[0][4] is not values  # the caller's dict is not changed


def test_diagnose_by_hand_checks_the_added_columns_and_sets_nothing_aside(monkeypatch):
    log, ev, _ = _diagnose_world(monkeypatch)
    meas = NS(freq_hz=[1.0], robot="heli4")
    assert sel.diagnose(meas, robot="delta", ev="given", add="a,b") == ("judged", "selected")
    assert log == [
        ("resolve", "given", "delta", "numpy"),
        ("model", "rigid", "R"),
        ("effects", "a,b", ev),
        ("columns", meas, ("z", "a", "b"), ev, "the baseline with the added effects"),
        ("select", meas, ev, ("z",), ["a", "b"], sel.ALPHA, None, {}),
    ]
    log.clear()
    sel.diagnose("x.csv", robot="delta", ev="given")
    assert log[0] == ("load", "x.csv", "delta", "given", {}) and log[1] == ("resolve", "given", "delta", "numpy")


def _rows_world(monkeypatch, checked, found_changes, d0_rows=True):
    log = []
    monkeypatch.setattr(sel, "rows_checked", lambda d: d is not None and checked)

    def outliers(meas, ev, d, base, alpha, progress, values, search=False):
        log.append(("outliers", d.name, search, meas, ev, base, alpha, progress, values))
        return NS(name=d.name + "+o", outliers=["o"] if d0_rows else [], setting_anomalies=[], search=d.search)

    def settings(meas, ev, d, base, alpha, progress, values, search=False):
        log.append(("settings", d.name, search, meas, ev, base, alpha, progress, values))
        return NS(name=d.name + "+s", outliers=d.outliers, setting_anomalies=[], search=d.search)

    def searched(d, ev, progress, values):
        log.append(("searched", d.name, ev, progress, values))
        return NS(name=d.name + "+search", outliers=d.outliers, setting_anomalies=[], search=NS(changed=found_changes))

    monkeypatch.setattr(sel, "_without_outliers", outliers)
    monkeypatch.setattr(sel, "_without_settings", settings)
    monkeypatch.setattr(sel, "_searched", searched)
    return log


ARGS = ("m", "ev", ("z",), ALPHA, "bar", {"v": 1})  # meas, ev, base, alpha, progress, values


def test_rows_are_set_aside_before_a_search_that_keeps_the_stepwise_result(monkeypatch):
    log = _rows_world(monkeypatch, True, False)
    d = NS(name="d", search=None, outliers=[], setting_anomalies=[])
    out = sel._rows_and_search("m", "ev", d, ("z",), ALPHA, "bar", {"v": 1})
    assert out.name == "d+o+s+search"
    assert log == [
        ("outliers", "d", False) + ARGS,
        ("settings", "d+o", False) + ARGS,
        ("searched", "d+o+s", "ev", "bar", {"v": 1}),
    ]


def test_a_search_that_changes_the_result_redoes_the_rows_under_its_model(monkeypatch):
    log = _rows_world(monkeypatch, True, True)
    d = NS(name="d", search=None, outliers=[], setting_anomalies=[])
    out = sel._rows_and_search("m", "ev", d, ("z",), ALPHA, "bar", {"v": 1})
    assert out.name == "d+search+o+s"
    assert log[3:] == [
        ("searched", "d", "ev", "bar", {"v": 1}),
        ("outliers", "d+search", True) + ARGS,
        ("settings", "d+search+o", True) + ARGS,
    ]


def test_a_search_that_changes_the_result_with_no_rows_set_aside_is_kept(monkeypatch):
    log = _rows_world(monkeypatch, True, True, d0_rows=False)
    d = NS(name="d", search=None, outliers=[], setting_anomalies=[])
    assert sel._rows_and_search("m", "ev", d, ("z",), ALPHA, None, None).name == "d+o+s+search"
    assert len(log) == 3


def test_without_enough_rows_nothing_is_set_aside_around_the_search(monkeypatch):
    log = _rows_world(monkeypatch, False, True)
    d = NS(name="d", search=None, outliers=[], setting_anomalies=["s"])
    assert sel._rows_and_search("m", "ev", d, ("z",), ALPHA, None, None).name == "d+search"
    assert log == [("searched", "d", "ev", None, None)] * 2
