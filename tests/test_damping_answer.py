"""The answer's damping part, and ties that count measured damping ratios (cheap: no fits run).

Each rule is checked on both sides of its threshold with stand-in candidates, fits and
evaluators whose predictions are chosen here: a damping effect fits as well as the final model
when its AICc on top of it is within DELTA_AICC; two models are tied when their frequencies
and measured damping ratios together are less than SEPARATION apart (chi distance), one search
entry below SAME, one model when no frequency, damped frequency or damping ratio differs by
EQUIVALENT_SIGMA anywhere.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from eigentwist.diagnose import damping_support as ds
from eigentwist.diagnose import search, select, separate
from eigentwist.diagnose.compare import Comparison
from eigentwist.diagnose.damping import whitened_predictions, zeta_sigma
from eigentwist.diagnose.stats import DELTA_AICC, SEPARATION

IN, OUT = 0.99, 1.01  # just inside / just outside a threshold (relative)

EFFECTS = {  # name -> (primitive, parameters)
    "stiff": ("compliance", ("k",)),
    "servo_damping": ("damping", ("c_a",)),
    "servo_delay": ("damping", ("t_d",)),
    "structural_loss": ("damping", ("eta_s",)),
}


class _Ev:
    """A stand-in evaluator: the effects above, units of seconds."""

    robot = NS(effect=lambda n: NS(primitive=EFFECTS[n][0], parameters=EFFECTS[n][1], fit=EFFECTS[n][1]))

    def parameter(self, name):
        return NS(unit="s", plausible_range=(0.0, 1.0))

    def accepts(self, name):
        return True


def _fit(effects, aicc, values=None):
    values = values or {}
    return NS(
        effects=tuple(effects),
        aicc=aicc,
        values=values,
        std={k: 0.1 * v for k, v in values.items()},
        names=tuple(values),
    )


def _cand(effect, fit, p, plausible=True):
    return NS(
        effect=effect,
        fit=fit,
        p_value=p,
        plausible=plausible,
        names=tuple(n for n in fit.values if n in EFFECTS[effect][1]),
    )


def _diagnosis(gap_delay: float, manual=False):
    """Final model stiff + servo_damping (added at p = 1e-5); on top of it servo_delay at AICc
    final + ``gap_delay`` (p = 0.08) and structural_loss far worse (p = 1)."""
    base = _fit(["stiff"], 20.0)
    mid = _fit(["stiff"], 10.0, {"k": 1.0})
    final = _fit(["stiff", "servo_damping"], 5.0, {"k": 1.0, "c_a": 2.4})
    first = [_cand("servo_damping", _fit(["stiff", "servo_damping"], 15.0, {"c_a": 2.8}), 0.2)]
    last = [
        _cand(
            "servo_delay",
            _fit(final.effects + ("servo_delay",), 5.0 + gap_delay, {"t_d": 7e-4, "c_a": 2.7, "k": 1.0}),
            0.08,
        ),
        _cand(
            "structural_loss", _fit(final.effects + ("structural_loss",), 9.0, {"eta_s": 1e-5}), 1.0, plausible=False
        ),
    ]
    steps = [
        NS(fit=base, added=None, p_value=None, ranking=first),
        NS(fit=mid, added="k_effect", p_value=1e-9, ranking=[]),
        NS(fit=final, added="servo_damping", p_value=1e-5, ranking=last),
    ]
    return NS(
        baseline=NS(effects=("stiff",)),
        final=final,
        steps=steps,
        ranking=first,
        removed=[],
        alternatives=[],
        manual=manual,
        meas=NS(),
    )


@pytest.fixture
def calls(monkeypatch):
    made = []

    def fake(ev, meas, fit_a, fit_b, names=None):
        made.append((fit_a, fit_b, names))
        return {
            "between": list(names),
            "quantity": "damping_ratio",
            "pose": [0.0, 0.0, -0.625],
            "k_a": 4000.0,
            "k_a_unit": "N m/rad",
            "mode": "y",
            "predicted": {names[0]: 0.047, names[1]: 1.4e-5},
            "separation_sigma": 9.3,
            "sigma": 0.005,
            "unit": "-",
        }

    monkeypatch.setattr(ds, "damping_measurement", fake)
    return made


def test_a_damping_effect_fits_alike_within_delta_aicc_and_is_then_separated(calls):
    d = _diagnosis(DELTA_AICC * IN)
    s = ds.damping_support(d, _Ev())
    assert s["supported"] == [{"effect": "servo_damping", "p_value": 1e-5}]
    no = {x["effect"]: x for x in s["not_supported"]}
    assert no["servo_delay"]["fits_alike"] and no["servo_delay"]["delta_aicc"] == pytest.approx(DELTA_AICC * IN)
    assert not no["structural_loss"]["fits_alike"]  # implausible and far worse
    # the values of the model that fits as well: its own t_d and the damping it refitted (c_a), not k
    assert [p["name"] for p in no["servo_delay"]["params"]] == ["t_d", "c_a"]
    assert s["alike"]["between"] == ["servo_damping", "servo_damping + servo_delay"]
    ((fit_a, fit_b, names),) = calls
    assert fit_a is d.final and fit_b.effects == d.final.effects + ("servo_delay",)
    text = ds.damping_sentence(s)
    assert text.startswith(
        "Damping supported: servo_damping (p = 1e-05); not supported: servo_delay (p = 0.08, fits as well"
    )
    assert "structural_loss (p = 1)" in text and "To tell them apart, measure the damping ratio of mode y" in text
    assert "0.047 without servo_delay, 1.4e-05 with it (9.3 sigma apart)" in text


def test_a_damping_effect_beyond_delta_aicc_is_not_alike_and_nothing_is_measured(calls):
    s = ds.damping_support(_diagnosis(DELTA_AICC * OUT), _Ev())
    assert not any(x["fits_alike"] for x in s["not_supported"]) and s["alike"] is None and not calls
    assert "To tell" not in ds.damping_sentence(s)


def test_a_candidate_not_fitted_on_the_final_model_never_fits_alike(calls):
    d = _diagnosis(0.0)
    lag = d.steps[-1].ranking[0]
    lag.fit.effects = ("stiff", "servo_delay")  # fitted on another model than the final one
    s = ds.damping_support(d, _Ev())
    x = next(x for x in s["not_supported"] if x["effect"] == "servo_delay")
    assert x["delta_aicc"] is None and not x["fits_alike"] and not calls


def test_no_damping_part_when_no_damping_effect_was_selected_or_tested():
    d = _diagnosis(0.0)
    for s in d.steps:
        s.ranking = [c for c in s.ranking if c.effect == "stiff"]
    d.ranking, d.final = [], _fit(["stiff"], 5.0, {"k": 1.0})
    assert ds.damping_support(d, _Ev()) is None and ds.damping_sentence(None) == ""


def test_none_supported_names_each_damping_effect_with_its_p_value(calls):
    d = _diagnosis(5.0)
    d.final = d.steps[1].fit
    d.steps = d.steps[:2]
    d.steps[-1].ranking = [_cand("servo_damping", _fit(d.final.effects + ("servo_damping",), 11.0, {"c_a": 2.0}), 0.3)]
    s = ds.damping_support(d, _Ev())
    assert s["supported"] == [] and ds.damping_sentence(s).startswith(
        "Damping supported: none; not supported: servo_damping (p = 0.3"
    )


def test_damping_of_the_baseline_is_given_and_names_the_models_apart(calls):
    """A baseline with servo damping (a preset with the stated c_a): nothing more supported, a lag
    on top fits as well; the two models are named with the given damping."""
    d = _diagnosis(0.5)
    d.baseline = NS(effects=("stiff", "servo_damping"))
    s = ds.damping_support(d, _Ev())
    assert s["given"] == ["servo_damping"] and s["supported"] == []
    assert s["alike"]["between"] == ["servo_damping", "servo_damping + servo_delay"]
    assert ds.damping_sentence(s).startswith(
        "Damping given: servo_damping; supported: none; not supported: servo_delay"
    )


def test_damping_added_by_hand_is_said_so(calls):
    s = ds.damping_support(_diagnosis(DELTA_AICC * OUT, manual=True), _Ev())
    assert s["by_hand"] and ds.damping_sentence(s).startswith("Damping added by hand: servo_damping (p = 1e-05)")


# ------------------------------------------------------------------ ties with damping ratios


def _meas(zeta_measured):
    """Two rows, 10 Hz at sigma 1 Hz; damping ratios measured (sigma 0.01) where given."""
    zeta = np.asarray(zeta_measured, dtype=float)
    return NS(
        freq_hz=np.array([10.0, 10.0]),
        sigma_hz=np.array([1.0, 1.0]),
        damping_ratio=zeta,
        sigma_damping_ratio=np.full(2, 0.01),
        relative_sigma=np.array([0.1, 0.1]),
    )


def _comp(meas, zeta):
    return Comparison(meas, ("x",), np.array([10.0, 10.0]), np.zeros(2, dtype=int), zeta=np.asarray(zeta, dtype=float))


def test_whitened_predictions_add_the_measured_damping_ratios_only():
    meas = _meas([0.05, np.nan])
    w = whitened_predictions(_comp(meas, [0.04, 0.3]))
    assert w == pytest.approx([10.0, 10.0, 0.04 / 0.01])  # the second row's zeta was not measured
    assert whitened_predictions(_comp(_meas([np.nan, np.nan]), [0.04, 0.3])) == pytest.approx([10.0, 10.0])


@pytest.mark.parametrize("factor, tied", [(IN, True), (OUT, False)])
def test_candidates_with_equal_frequencies_are_tied_only_while_their_damping_ratios_agree(monkeypatch, factor, tied):
    """Equal frequencies, AICc 10 apart: tied exactly when the measured damping ratios differ by
    less than SEPARATION sigma (chi distance over frequencies and damping ratios)."""
    meas = _meas([0.05, np.nan])
    dz = SEPARATION * factor * 0.01
    fits = {"a": _comp(meas, [0.05, 0.0]), "b": _comp(meas, [0.05 + dz, 0.0])}
    monkeypatch.setattr(
        select,
        "_candidate",
        lambda meas, ev, cur, e: NS(
            effect=e, fit=NS(aicc=0.0 if e == "a" else 10.0, comparison=fits[e]), plausible=True, order=e
        ),
    )
    monkeypatch.setattr(select, "_signature", lambda *a: None)
    ranking = select.rank_candidates(meas, None, None, ["a", "b"])
    assert (ranking[0].indistinguishable_from == ["b"]) is tied


@pytest.mark.parametrize("factor, pooled", [(IN, True), (OUT, False)])
def test_the_search_pools_singles_only_while_their_damping_ratios_agree_within_same(factor, pooled):
    meas = _meas([0.05, np.nan])
    dz = search.SAME * factor * 0.01

    def cand(name, zeta, aicc):
        return NS(effect=name, plausible=True, fit=NS(aicc=aicc, comparison=_comp(meas, zeta)))

    pool, same = search._distinct(meas, [cand("a", [0.05, 0.0], 1.0), cand("b", [0.05 + dz, 0.0], 2.0)])
    assert ([c.effect for c in pool] == ["a"]) is pooled and (same == {"a": ["b"]}) is pooled


@pytest.mark.parametrize("factor, kept", [(IN, True), (OUT, False)])
def test_a_final_alternative_is_kept_only_while_its_damping_ratios_agree(monkeypatch, factor, kept):
    meas = _meas([0.05, 0.05])
    dz = SEPARATION * factor * 0.01 / math.sqrt(2)  # both rows apart by dz: chi distance sqrt(2) dz / sigma
    final = NS(effects=("x", "a"), aicc=0.0, comparison=_comp(meas, [0.05, 0.05]))
    swapped = NS(effects=("x", "b"), aicc=10.0, comparison=_comp(meas, [0.05 + dz, 0.05 + dz]))
    monkeypatch.setattr(select, "_swap", lambda *a: swapped)
    monkeypatch.setattr(select, "_implausible", lambda ev, g: False)
    monkeypatch.setattr(select, "equivalent", lambda *a: None)
    monkeypatch.setattr(select, "_between", lambda *a: None)
    steps = [
        NS(fit=NS(effects=("x",)), ranking=[NS(effect="b")]),
        NS(fit=final, added="a", alternatives=["b"]),
    ]
    alts = select.final_alternatives(meas, None, steps)
    assert (len(alts) == 1) is kept


# ------------------------------------------------------------------ one model: equivalence


class _GridEv:
    """A stand-in evaluator over a one-axis workspace whose two models differ by ``df`` (Hz, in
    every frequency) and ``dz`` (in every damping ratio, around 0.1)."""

    robot = NS(workspace=((0.0, 1.0),))

    def __init__(self, df=0.0, dz=0.0):
        self.df, self.dz = df, dz

    def jacobians(self, poses):
        return None

    def valid(self, poses):
        return np.ones(len(poses), dtype=bool)

    def parameter(self, name):
        return NS(unit="N m/rad")

    def modes(self, poses, effects, k_a, invalid=None, **params):
        b = params.get("which") == "b"
        f = np.tile([10.0, 20.0], (len(poses), 1)) + (self.df if b else 0.0)
        zeta = np.full(f.shape, 0.1 + (self.dz if b else 0.0))
        return NS(freq_hz=f, damped_hz=f * np.sqrt(1 - zeta**2), damping_ratio=zeta, constrained=None)


class _Rows(NS):
    def __len__(self):
        return len(self.k_a)


def _grid_meas(damped: bool):
    return _Rows(
        k_a=np.array([500.0, 1000.0]),
        poses=np.array([[0.5], [0.5]]),
        relative_sigma=np.array([0.02, 0.02]),
        params={},
        damped=np.array([damped, damped]),
        damping_ratio=np.full(2, np.nan),
    )


A, B = NS(effects=("a",), fixed={"which": "a"}), NS(effects=("b",), fixed={"which": "b"})


@pytest.mark.parametrize("factor, same", [(IN, True), (OUT, False)])
def test_equivalent_within_equivalent_sigma_of_every_frequency(factor, same):
    # the lowest mode (10 Hz) is the farthest apart relative to its sigma: 0.02 * mean
    tol, r = separate.EQUIVALENT_SIGMA * factor, 0.02
    df = tol * r * 10.0 / (1 - tol * r / 2)  # |df| / (r (10 + 10 + df) / 2) = tol
    out = separate.equivalent(_GridEv(df=df), _grid_meas(False), A, B)
    assert (out is not None) is same
    if same:
        assert out["max_separation_sigma"] == pytest.approx(tol, rel=1e-9)


@pytest.mark.parametrize("factor, same", [(IN, True), (OUT, False)])
def test_damped_data_make_damping_ratios_count_in_the_equivalence(factor, same):
    """Equal natural frequencies; damping ratios 0.1 and 0.1 + dz: undamped data cannot tell
    them (one model), damped data can once dz reaches EQUIVALENT_SIGMA sigma_zeta."""
    tol = separate.EQUIVALENT_SIGMA * factor
    dz = tol * 0.2 * 0.1 / (1 - tol * 0.2 / 2)  # dz / (0.2 (0.1 + dz / 2)) = tol
    assert float(zeta_sigma(0.1 + dz / 2)) == pytest.approx(0.2 * (0.1 + dz / 2))
    ev = _GridEv(dz=dz)
    assert separate.equivalent(ev, _grid_meas(False), A, B) is not None  # natural frequencies only
    assert (separate.equivalent(ev, _grid_meas(True), A, B) is not None) is same


@pytest.mark.parametrize("zeta", [0.025 * IN, 0.025 * OUT])
def test_a_damping_ratios_default_sigma_is_the_larger_of_its_two_rules(zeta):
    from eigentwist.diagnose.measurements import DEFAULT_SIGMA_ZETA_ABS, DEFAULT_SIGMA_ZETA_REL

    from eigentwist.diagnose.measurements import Measurements

    edge = DEFAULT_SIGMA_ZETA_ABS / DEFAULT_SIGMA_ZETA_REL  # 0.025: both rules agree
    expected = DEFAULT_SIGMA_ZETA_ABS if zeta < edge else DEFAULT_SIGMA_ZETA_REL * zeta
    assert float(zeta_sigma(zeta)) == pytest.approx(expected)
    # the data's own default: the same rule
    meas = Measurements(
        np.ones(1), ("x",), np.ones(1), np.ones(1), np.zeros((1, 3)), modal={"damping_ratio": np.array([zeta])}
    )
    assert meas.sigma_damping_ratio[0] == pytest.approx(expected)


# ------------------------------------------------------------------ like with like: the next measurement


@pytest.fixture(scope="module")
def heli4():
    import eigentwist

    return eigentwist.load("heli4", backend="numpy")


@pytest.mark.parametrize("kind", ["damped", "undamped"])
def test_the_next_measurement_compares_the_frequency_the_data_measured(heli4, kind):
    """On the paper's step responses (damped) the proposal's frequencies are the models' damped
    ones, omega_n sqrt(1 - zeta^2) from the modes at that condition; read as natural frequencies,
    the natural ones."""
    from eigentwist.diagnose import paper_measurements
    from eigentwist.diagnose.matching import DIRECTIONS

    meas = paper_measurements(heli4, kind=kind)
    damping = {"c_a": 2.4}
    fits = [
        NS(effects=("actuator_loss", e, "servo_damping"), fixed={"k_E_rot": 377.0, "k_E_lin": 1.7e5, **damping})
        for e in ("ee_compliance", "ee_coupling")
    ]
    nm = separate.next_measurement(heli4, meas, *fits)
    for f, name in zip(fits, nm["between"]):
        m = heli4.modes(np.array([nm["pose"]]), f.effects, k_a=np.array([nm["k_a"]]), **f.fixed)
        k = int(np.flatnonzero(m.direction[0] == DIRECTIONS.index(nm["mode"]))[0])
        zeta, natural = m.damping_ratio[0, k], m.natural_hz[0, k]
        expected = natural * math.sqrt(1.0 - zeta**2) if kind == "damped" else natural
        assert zeta > 0.01 and nm["predicted_hz"][name] == pytest.approx(expected, rel=1e-9)
