"""The rules of the answer's damping part (``eigentwist/diagnose/damping_support.py``) beyond
``tests/test_damping_answer.py``: which variant of a damping effect counts (the lowest p-value
among its legs), effects taken back by backward elimination, alternative final models that swap
a damping effect, the pair that fits most alike, the order of the effects not supported, the
memory of one diagnosis, and each sentence in full. Stand-in candidates and fits; no model.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import pytest

from eigentwist.diagnose import damping_support as ds
from eigentwist.diagnose.backward import Removal
from eigentwist.diagnose.select import Alternative
from eigentwist.diagnose.stats import DELTA_AICC

EFFECTS = {  # name -> (primitive, parameters)
    "stiff": ("compliance", ("k",)),
    "servo_damping": ("damping", ("c_a",)),
    "servo_delay": ("damping", ("t_d",)),
    "structural_loss": ("damping", ("eta_s",)),
}
UNITS = {"k": "N/m", "c_a": "N m s/rad", "t_d": "s", "eta_s": "-"}


def _effect(name):
    if name == "bare":  # an effect of the robot without a primitive
        return NS(parameters=())
    kind, params = EFFECTS[name]
    return NS(primitive=kind, parameters=params, fit=params)


class Ev:
    """A stand-in evaluator: the effects above; ``free`` is no parameter of the robot."""

    robot = NS(effect=_effect)

    def parameter(self, name):
        return NS(unit=UNITS[name.partition("@")[0]])

    def accepts(self, name):
        return name.partition("@")[0] in UNITS


EV = Ev()


def fit_of(effects, aicc, values=None, std=None):
    values = dict(values or {})
    return NS(effects=tuple(effects), aicc=aicc, values=values, std=dict(std or {}), names=tuple(values))


def cand(effect, fit, p, plausible=True, names=None):
    return NS(effect=effect, fit=fit, p_value=p, plausible=plausible, names=tuple(names or ()))


def diag(final, rankings, baseline=("stiff",), **kw):
    steps = [NS(added=None, p_value=None, ranking=r) for r in rankings]
    base = dict(
        baseline=NS(effects=tuple(baseline)),
        final=final,
        steps=steps,
        ranking=rankings[0] if rankings else [],
        removed=[],
        alternatives=[],
        manual=False,
        meas=NS(name="meas"),
    )
    base.update(kw)
    return NS(**base)


@pytest.fixture
def measured(monkeypatch):
    """The separating measurement asked for: (ev, meas, fit_a, fit_b, names) of each call."""
    calls = []

    def fake(ev, meas, fit_a, fit_b, names=None):
        calls.append((ev, meas, fit_a, fit_b, names))
        return None

    monkeypatch.setattr(ds, "damping_measurement", fake)
    return calls


# -- which effects are damping ones, which variant counts ---------------------------------------------------


def test_is_damping():
    assert ds.is_damping(EV, "servo_delay") and ds.is_damping(EV, "servo_delay@2")
    assert not ds.is_damping(EV, "stiff") and not ds.is_damping(EV, "bare") and not ds.is_damping(EV, "unknown")


def test_the_variant_with_the_lowest_p_value_counts_and_a_later_ranking_replaces():
    final = fit_of(["stiff"], 10.0)
    f = fit_of(["stiff", "servo_delay"], 12.0)
    first = [
        cand("stiff", f, 1e-9),  # not a damping effect: skipped, the rest still read
        cand("servo_delay@1", f, None),
        cand("servo_delay@2", f, 0.3),
        cand("servo_delay@3", f, math.nan),
        cand("servo_delay@4", f, 0.3),  # as low as @2: the first stays
        cand("structural_loss", f, 0.9),
    ]
    tested = ds._tested(diag(final, [first]), EV)
    assert {k: c.effect for k, c in tested.items()} == {
        "servo_delay": "servo_delay@2",
        "structural_loss": "structural_loss",
    }
    second = [cand("servo_delay@1", f, None)]
    tested = ds._tested(diag(final, [first, second]), EV)
    assert tested["servo_delay"].effect == "servo_delay@1" and tested["structural_loss"].effect == "structural_loss"
    only_none = [cand("servo_delay@1", f, None), cand("servo_delay@2", f, math.inf)]
    assert ds._tested(diag(final, [only_none]), EV)["servo_delay"].effect == "servo_delay@1"


def test_without_step_rankings_the_diagnosis_ranking_counts():
    final = fit_of(["stiff"], 10.0)
    c = cand("servo_delay", fit_of(["stiff", "servo_delay"], 12.0), 0.2)
    d = diag(final, [[]], ranking=[c])
    assert ds._tested(d, EV) == {"servo_delay": c}


# -- the support ---------------------------------------------------------------------------------------------


def test_values_of_a_fit():
    f = fit_of([], 0.0, {"t_d": 7.04e-4, "free": 2.0}, {"t_d": 2.1e-5})
    assert ds._values(EV, f, ["t_d", "free"]) == [
        {"name": "t_d", "value": 7.04e-4, "std": 2.1e-5, "unit": "s", "text": "t_d = (7.04 ± 0.21)·10⁻⁴ s"},
        {"name": "free", "value": 2.0, "std": math.inf, "unit": "", "text": "free = 2 (± undetermined)"},
    ]


def test_a_leg_variant_of_a_selected_effect_is_not_offered_again(measured):
    final = fit_of(["stiff", "servo_damping@2"], 5.0, {"c_a@2": 2.0})
    again = cand("servo_damping", fit_of(["stiff", "servo_damping@2", "servo_damping"], 5.5), 0.3)
    d = diag(final, [[again]])
    s = ds.damping_support(d, EV)
    assert s["supported"] == [{"effect": "servo_damping@2", "p_value": None}] and s["not_supported"] == []


def test_removed_damping_is_not_supported_and_its_test_not_repeated(measured):
    final = fit_of(["stiff"], 5.0)
    tried = cand("servo_delay", fit_of(["stiff", "servo_delay"], 5.5), 0.01)
    other = cand("structural_loss", fit_of(["stiff", "structural_loss"], 9.0), 0.5)
    removal = Removal("servo_delay", 0.2345, 1.0, 2.0, (), None)
    d = diag(final, [[tried, other]], removed=[removal, Removal("stiff", 0.5, 1.0, 2.0, (), None)])
    s = ds.damping_support(d, EV)
    assert s["not_supported"] == [
        {"effect": "servo_delay", "p_value": 0.2345, "params": [], "delta_aicc": None, "fits_alike": False},
        {"effect": "structural_loss", "p_value": 0.5, "params": [], "delta_aicc": 4.0, "fits_alike": False},
    ]
    assert set(s) == {"given", "by_hand", "supported", "not_supported", "alike", "measurement"}
    assert s["alike"] is None and s["measurement"] is None and measured == []
    d = diag(final, [[]], removed=[removal])
    assert ds.damping_support(d, EV)["not_supported"][0]["effect"] == "servo_delay"  # removed alone is enough
    d = diag(final, [[]])
    del d.removed  # a diagnosis without backward elimination
    assert ds.damping_support(d, EV) is None


@pytest.mark.parametrize("gap, alike", [(DELTA_AICC * 0.99, True), (DELTA_AICC, False)])
def test_fits_alike_strictly_within_delta_aicc(measured, gap, alike):
    final = fit_of(["stiff"], 5.0)
    c = cand("servo_delay", fit_of(["stiff", "servo_delay"], 5.0 + gap, {"t_d": 1e-3}), 0.3, names=("t_d",))
    s = ds.damping_support(diag(final, [[c]]), EV)
    assert s["not_supported"][0]["fits_alike"] is alike
    if alike:
        assert s["alike"] == {
            "between": ["no damping", "servo_delay"],
            "delta_aicc": pytest.approx(gap),
            "added": "servo_delay",
        }
        assert measured == [(EV, d_meas(), final, c.fit, ("no damping", "servo_delay"))]


def d_meas():
    return NS(name="meas")


def test_an_alternative_that_swaps_a_damping_effect_fits_alike(measured):
    final = fit_of(["stiff", "servo_damping"], 5.0, {"c_a": 2.0})
    alt_fit = fit_of(["stiff", "servo_delay"], 6.5)
    swap = Alternative(("stiff", "servo_delay"), "servo_damping", "servo_delay", alt_fit)
    unfit = Alternative(("stiff", "structural_loss"), "servo_damping", "structural_loss", None)
    plain = Alternative(("stiff2",), "stiff", "stiff", fit_of(["stiff"], 5.1))
    d = diag(final, [[]], alternatives=[swap, unfit, plain])
    d.steps.append(NS(added="servo_damping", p_value=1e-4, ranking=[]))
    s = ds.damping_support(d, EV)
    assert s["supported"] == [{"effect": "servo_damping", "p_value": 1e-4}]
    assert s["alike"] == {"between": ["servo_damping", "servo_delay"], "delta_aicc": 1.5, "added": None}
    assert measured == [(EV, d.meas, final, alt_fit, ("servo_damping", "servo_delay"))]


def test_a_replaced_damping_effect_counts_and_given_damping_names_the_models(measured):
    final = fit_of(["stiff", "servo_damping", "servo_delay"], 5.0)
    alt_fit = fit_of(["stiff", "servo_damping", "structural_loss"], 4.0)
    swap = Alternative((), "servo_delay", "stiff", alt_fit)  # only the replaced one is damping
    d = diag(final, [[]], baseline=("stiff", "servo_damping"), alternatives=[swap])
    s = ds.damping_support(d, EV)
    assert s["given"] == ["servo_damping"] and s["supported"] == [{"effect": "servo_delay", "p_value": None}]
    assert s["alike"]["between"] == ["servo_damping + servo_delay", "servo_damping + structural_loss"]
    assert s["alike"]["delta_aicc"] == -1.0


def test_the_pair_closest_in_aicc_is_measured(measured):
    final = fit_of(["stiff"], 5.0)
    near = cand("servo_delay", fit_of(["stiff", "servo_delay"], 6.0), 0.3)
    alt_fit = fit_of(["stiff", "structural_loss"], 3.5)
    swap = Alternative((), "stiff", "structural_loss", alt_fit)
    s = ds.damping_support(diag(final, [[near]], alternatives=[swap]), EV)
    assert s["alike"]["delta_aicc"] == 1.0 and measured[0][3] is near.fit  # |1.0| < |-1.5|
    swap.fit = fit_of(["stiff", "structural_loss"], 4.5)
    s = ds.damping_support(diag(final, [[near]], alternatives=[swap]), EV)
    assert s["alike"]["delta_aicc"] == -0.5 and measured[1][3] is swap.fit


def test_not_supported_alike_first_then_by_p_value(measured):
    final = fit_of(["stiff"], 5.0)
    r = [
        cand("servo_delay@1", fit_of(["stiff", "servo_delay@1"], 20.0), None),
        cand("structural_loss", fit_of(["stiff", "structural_loss"], 20.0), 0.5),
        cand("servo_damping", fit_of(["stiff", "servo_damping"], 20.0), 0.1),
    ]
    s = ds.damping_support(diag(final, [r]), EV)
    assert [x["effect"] for x in s["not_supported"]] == ["servo_damping", "structural_loss", "servo_delay@1"]
    r[1].fit.aicc = 5.5  # fits alike: first, whatever its p-value
    s = ds.damping_support(diag(final, [r]), EV)
    assert [x["effect"] for x in s["not_supported"]] == ["structural_loss", "servo_damping", "servo_delay@1"]


def test_computed_once_per_diagnosis(measured, monkeypatch):
    final = fit_of(["stiff"], 5.0)
    d = diag(final, [[cand("servo_delay", fit_of(["stiff", "servo_delay"], 5.5), 0.3)]])
    first = ds.damping_support(d, EV)
    calls = []
    monkeypatch.setattr(ds, "_support", lambda d, ev: calls.append(1))
    assert ds.damping_support(d, EV) is first and first is not None and calls == []
    none = diag(final, [[]])
    assert ds.damping_support(none, EV) is None and ds.damping_support(none, EV) is None and calls == [1]


# -- the sentences ---------------------------------------------------------------------------------------------


def test_p_and_sortable():
    assert ds._p(None) == "p undetermined" and ds._p(math.nan) == "p undetermined" and ds._p(0.01234) == "p = 0.012"
    assert ds._sortable(None) == math.inf and ds._sortable(math.inf) == math.inf and ds._sortable(0.2) == 0.2


def test_pose_to_a_tenth_of_a_millimetre():
    assert ds._pose([0.123456, 0.0, -0.6]) == "[0.1235, 0, -0.6] m"


def measurement(quantity="damping_ratio", unit="-"):
    return {
        "between": ["servo_damping", "servo_damping + servo_delay"],
        "quantity": quantity,
        "pose": [0.06, -0.04, -0.6],
        "k_a": 4000.0,
        "k_a_unit": "N m/rad",
        "mode": "y",
        "predicted": {"servo_damping": 0.047123, "servo_damping + servo_delay": 1.40e-5},
        "separation_sigma": 9.34,
        "unit": unit,
    }


def test_measurement_sentences():
    assert ds._measurement(measurement(), "servo_delay") == (
        "To tell them apart, measure the damping ratio of mode y at [0.06, -0.04, -0.6] m, k_a = 4000 N m/rad: "
        "0.047 without servo_delay, 1.4e-05 with it (9.3 sigma apart)."
    )
    assert ds._measurement(measurement("damped_hz", "Hz"), None) == (
        "To tell servo_damping from servo_damping + servo_delay, measure the damped frequency of mode y at "
        "[0.06, -0.04, -0.6] m, k_a = 4000 N m/rad: servo_damping 0.04712 Hz, servo_damping + servo_delay "
        "1.4e-05 Hz (9.3 sigma apart)."
    )


def test_damping_sentence_in_full():
    s = {
        "given": ["servo_damping", "structural_loss"],
        "by_hand": False,
        "supported": [{"effect": "servo_delay", "p_value": None}, {"effect": "x", "p_value": 1e-5}],
        "not_supported": [
            {"effect": "a", "p_value": 0.3, "params": [{"text": "t_d = 1 s"}, {"text": "c_a = 2"}], "fits_alike": True},
            {"effect": "b", "p_value": None, "params": [], "fits_alike": True},
            {"effect": "c", "p_value": 0.9, "params": [{"text": "q"}], "fits_alike": False},
        ],
        "alike": {"between": ["m1", "m2"], "delta_aicc": 0.5, "added": None},
        "measurement": None,
    }
    assert ds.damping_sentence(s) == (
        "Damping given: servo_damping, structural_loss; supported: servo_delay, x (p = 1e-05); not supported: a "
        "(p = 0.3, fits as well with t_d = 1 s, c_a = 2), b (p undetermined, fits as well), c (p = 0.9). "
        "No measured mode direction and k_a tells m1 from m2."
    )
    s.update(given=[], supported=[], not_supported=[], alike=None, by_hand=True)
    assert ds.damping_sentence(s) == "Damping added by hand: none."
    s.update(alike={"between": ["m1", "m2"], "added": "servo_delay"}, measurement=measurement())
    assert ds.damping_sentence(s) == "Damping added by hand: none. " + ds._measurement(measurement(), "servo_delay")
    s.update(alike=None)
    assert ds.damping_sentence(s) == "Damping added by hand: none. " + ds._measurement(measurement(), None)
