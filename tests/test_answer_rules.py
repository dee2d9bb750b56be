"""The answer block's rules (``eigentwist/diagnose/answer.py``) on stand-in diagnoses: each
sentence's branches, the inputs to check for an implausible value, the effects added with
their legs and mirror images, what cannot be told apart, the next measurement's choice, and
the line budget (:data:`MAX_LINES`, :data:`DAMPING_LINES`) just inside and just outside.
p-values are recomputed with SciPy. No evaluator, no fit (the diagnoses behind
``tests/test_answer.py`` take 7-11 s each).
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from scipy import stats

from eigentwist.diagnose import answer as an
from eigentwist.diagnose.backward import Removal
from eigentwist.diagnose.misfit import Outlier, Uncertainty
from eigentwist.diagnose.select import Alternative, Step

from .standin_diagnosis import Rows, diag, fit_of

PARAMS = {
    "m_p": ("kg", (0.0, 5.0), 0.0),
    "eta_a": ("-", (0.3, 1.0), 0.82),
    "E_l1": ("Pa", (4e10, 2.5e11), 7e10),
    "r_o": ("m", (0.0, 1.0), 0.01),
    "r_i": ("m", (0.0, 1.0), 0.008),
    "k_h": ("N/m", (0.0, 1e4), 0.0),
    "c_h": ("", (0.0, 1.0), 0.5),
    "k_a": ("N m/rad", (0.0, 1e5), 1000.0),
}
EFFECTS = {
    "payload_mass": NS(parameters=("m_p",), fit=("m_p",), component="payload", leg_level=False, primitive=None),
    "actuator_loss": NS(parameters=("eta_a",), fit=("eta_a",), component="actuator", leg_level=True, primitive=None),
    "tube_modulus": NS(
        parameters=("E_l1", "r_o", "r_i"), fit=("E_l1",), component="tube", leg_level=False, primitive=None
    ),
    "hose": NS(parameters=("k_h", "c_h"), fit=("k_h",), component="", leg_level=False, primitive=None),
    "switch": NS(parameters=(), fit=(), component="", leg_level=True, primitive=None),
    "valve": NS(parameters=("k_h", "v_free"), fit=("k_h",)),  # no component, no leg level; v_free unknown
}


class FakeEv:
    """Units, defaults, plausible ranges and effects of a made-up robot (``NAME@N``: leg N's)."""

    def accepts(self, name):
        return name.partition("@")[0] in PARAMS

    def parameter(self, name):
        unit, rng, default = PARAMS[name.partition("@")[0]]
        return NS(unit=unit, plausible_range=rng, default=default)

    robot = NS(effect=lambda name: EFFECTS[name])


EV = FakeEv()


def candidate(effect, p=1e-4, aicc=5.0, implausible=None, values=None, plausible=None, names=None, fit=None):
    imp = dict(implausible or {})
    return NS(
        effect=effect,
        p_value=p,
        fit=fit or fit_of(values=values, aicc=aicc),
        plausible=(not imp) if plausible is None else plausible,
        implausible=imp,
        names=tuple(names if names is not None else (values or {})),
    )


def chi2_at(p, dof):
    return float(stats.chi2.isf(p, dof))


# -- the verdict -------------------------------------------------------------------------------------------


def test_verdict_sentences():
    d = diag(final=fit_of(n=3, k=3, rms=0.5))
    assert an._verdict(d) == "Cannot judge: the final model has 3 fitted parameters for 3 rows; RMS 4.56 % -> 0.5 %."
    chi2 = chi2_at(0.5, 29)
    d = diag(final=fit_of(chi2=chi2, rms=0.5))
    stat = f"chi2/nu = {chi2:.3g}/29 = {chi2 / 29:.3g}"
    assert an._verdict(d) == f"Explained within the stated sigma ({stat}, p = 0.5); RMS 4.56 % -> 0.5 %."
    d.explained = False
    assert an._verdict(d) == f"NOT explained within the stated sigma ({stat}, p = 0.5); RMS 4.56 % -> 0.5 %."
    d.implausible = {"E_l1": (1e13, (4e10, 2.5e11)), "r_o": (2.0, (0.0, 1.0))}
    assert an._verdict(d) == (
        f"NOT explained: it fits ({stat}, p = 0.5) only with E_l1, r_o outside the plausible range; "
        "RMS 4.56 % -> 0.5 %."
    )


@pytest.mark.parametrize("p, fits", [(0.0101, True), (0.0099, False)])
def test_verdict_of_an_implausible_model_at_alpha(p, fits):
    d = diag(final=fit_of(chi2=chi2_at(p, 29)), explained=False, implausible={"E_l1": (1e13, (4e10, 2.5e11))})
    assert an._verdict(d).startswith("NOT explained: it fits") is fits


def test_value_drops_a_missing_unit():
    assert an._value(3.14159, "kg") == "3.14 kg"
    assert an._value(3.14159, "-") == "3.14" and an._value(3.14159, "") == "3.14"


# -- the inputs to check ---------------------------------------------------------------------------------------


def test_check_inputs_of_an_implausible_final_value():
    final = fit_of(effects=("payload_mass", "tube_modulus"), values={"E_l1": 3.3e12}, fixed={"r_o": 0.012})
    d = diag(final=final, explained=False, implausible={"E_l1": (3.3e12, (4e10, 2.5e11))})
    assert an.check_inputs(d, EV) == (
        "Check the inputs: tube_modulus needs E_l1 = 3.3e+12 Pa (plausible 4e+10 ... 2.5e+11 Pa) with "
        "r_o = 0.012 m, r_i = 0.008 m: check the tube's dimensions."
    )


def test_check_inputs_takes_a_legs_value_then_the_shared_one():
    final = fit_of(effects=("hose@2",), values={"k_h@2": 5e4}, fixed={"c_h": 0.7})
    d = diag(final=final, explained=False, implausible={"k_h@2": (5e4, (0.0, 1e4))})
    assert an.check_inputs(d, EV) == (
        "Check the inputs: hose@2 needs k_h@2 = 5e+04 N/m (plausible 0 ... 1e+04 N/m) with c_h@2 = 0.7: "
        "check the hose's values."
    )
    final.fixed = {"c_h@2": 0.9, "c_h": 0.7}
    assert "with c_h@2 = 0.9:" in an.check_inputs(d, EV)


def test_check_inputs_without_an_owner_or_given_values():
    d = diag(final=fit_of(effects=("payload_mass",)), explained=False, implausible={"E_l1": (1e13, (0, 1))})
    assert an.check_inputs(d, EV) is None
    d = diag(
        final=fit_of(effects=("payload_mass",), values={"m_p": 9.0}),
        explained=False,
        implausible={"m_p": (9.0, (0.0, 5.0))},
    )
    assert an.check_inputs(d, EV) == (
        "Check the inputs: payload_mass needs m_p = 9 kg (plausible 0 ... 5 kg): check the payload's values."
    )


def test_check_inputs_of_a_candidate_significant_but_for_its_value():
    """The last ranking's first implausible candidate with p < alpha / m and a lower AICc."""
    final = fit_of(aicc=10.0)
    weak = candidate("payload_mass", p=0.0051, aicc=1.0, implausible={"m_p": 9.0}, values={"m_p": 9.0})
    bad = candidate(
        "tube_modulus",
        p=0.0033,
        aicc=1.0,
        implausible={"r_o": 3.0, "E_l1": 3.3e12},
        values={"E_l1": 3.3e12, "r_o": 3.0},
        names=("E_l1",),
    )
    ok = candidate("hose", p=1e-9, aicc=0.0)
    d = diag(final=final, explained=False, steps=[Step(final, ranking=[ok, weak, bad])])
    assert an.check_inputs(d, EV) == (  # r_o is fitted by the candidate: not a given value
        "Check the inputs: tube_modulus needs E_l1 = 3.3e+12 Pa (plausible 4e+10 ... 2.5e+11 Pa) with "
        "r_i = 0.008 m: check the tube's dimensions."
    )
    bad.names = ()  # none of its own: its first implausible value
    assert an.check_inputs(d, EV).startswith("Check the inputs: tube_modulus needs r_o = 3 m (plausible 0 ... 1 m)")
    bad.p_value = 0.0034  # alpha / 3 < p: not significant
    assert an.check_inputs(d, EV) is None
    bad.p_value, bad.fit.aicc = 0.0033, 10.0  # no lower AICc
    assert an.check_inputs(d, EV) is None
    bad.fit.aicc = 1.0
    for change in ({"explained": True}, {"manual": True}):
        assert an.check_inputs(diag(final=final, steps=d.steps, **{"explained": False, **change}), EV) is None


def test_check_inputs_of_a_switch_names_values():
    final = fit_of(effects=("tube_modulus",), values={"E_l1": 1e9}, names=("E_l1", "r_o", "r_i"))
    d = diag(final=final, explained=False, implausible={"E_l1": (1e9, (4e10, 2.5e11))})
    assert an.check_inputs(d, EV).endswith("(plausible 4e+10 ... 2.5e+11 Pa): check the tube's values.")


# -- why ---------------------------------------------------------------------------------------------------------


def test_why_in_its_order():
    d = diag(
        explained=False,
        manual=True,
        uncertainty=Uncertainty("too few rows", 1, 1, 1),
        alternatives=[Alternative(("a",), None, "hose", None)],
    )
    assert an._why(d) == "Why: the effects added by hand are not enough (run without --add to search the catalogue)."
    d.manual = False
    assert an._why(d) == "Why: too few rows to tell a missing effect from the stated uncertainty."
    d.uncertainty = Uncertainty("understated", 3.0, 1, 1, pattern=["x high"])
    assert an._why(d) == "Why: catalogue effects would explain it, but not significantly with these rows."
    d.alternatives = [Alternative(("a",), "b", "hose", None)]
    assert an._why(d) == "Why: the residuals look like noise: the stated uncertainty is too small."
    d.uncertainty = Uncertainty("consistent", 3.0, 1, 1, pattern=["x high", "z low"])
    assert an._why(d) == (
        "Why: an effect outside the catalogue is missing (none in it helps further; systematic: x high; z low)."
    )
    assert an._why(d, short=True) == "Why: an effect outside the catalogue is missing (none in it helps further)."
    d.uncertainty = None
    assert an._why(d) == "Why: an effect outside the catalogue is missing (none in it helps further)."


# -- what was added ------------------------------------------------------------------------------------------------


def test_added_effects_values_legs_and_plausibility():
    final = fit_of(
        effects=("payload_mass", "actuator_loss@3", "tube_modulus"),
        values={"m_p": 0.3512, "eta_a@3": 0.2, "E_l1": 3e12, "k_x": 1.0},
        std={"m_p": 0.0123, "eta_a@3": 0.01},
        at_bound=("E_l1",),
    )
    d = diag(baseline=fit_of(effects=("payload_mass",)), final=final)
    loss, tube = an.added_effects(d, EV)
    assert loss["effect"] == "actuator_loss@3" and loss["legs"] == [3] and loss["leg_level"] is True
    (eta,) = loss["params"]
    assert eta == {
        "name": "eta_a@3",
        "value": 0.2,
        "std": 0.01,
        "unit": "-",
        "plausible": False,
        "plausible_range": [0.3, 1.0],
        "text": "eta_a@3 = 0.200 ± 0.010 (IMPLAUSIBLE: plausible 0.3 ... 1)",
    }
    (e,) = tube["params"]
    assert tube["legs"] == [] and tube["leg_level"] is False
    assert (
        e["plausible"] is False
        and e["std"] == math.inf
        and e["text"].endswith("(IMPLAUSIBLE: plausible 4e+10 ... 2.5e+11 Pa)")
    )
    assert (
        an.added_effects(diag(baseline=fit_of(), final=fit_of(effects=("hose",), values={"c_h": 2.0})), EV)[0][
            "params"
        ][0]["text"]
        == "c_h = 2 (± undetermined) (IMPLAUSIBLE: plausible 0 ... 1)"
    )
    d.final.at_bound = ()
    d.final.values["E_l1"] = 1e11
    (_, tube) = an.added_effects(d, EV)
    assert tube["params"][0]["plausible"] is True and "IMPLAUSIBLE" not in tube["params"][0]["text"]


def test_added_sentence():
    d = diag(baseline=fit_of(effects=()))
    assert an._added(d, [], []) == "Added: nothing (no catalogue effect improves the baseline significantly)."
    d.manual = True
    assert an._added(d, [], []) == "Added: nothing by hand."
    items = [
        {"effect": "payload_mass", "legs": [], "leg_level": False, "params": [{"text": "m_p = 0.35 ± 0.01 kg"}]},
        {"effect": "actuator_loss", "legs": [], "leg_level": True, "params": [{"text": "eta_a = 0.5"}, {"text": "b"}]},
        {"effect": "switch@2", "legs": [2], "leg_level": True, "params": []},
    ]
    d.manual = False
    d.removed = [Removal("hose", 0.3, 1.0, 2.0, ("payload_mass",), None), Removal("x", 0.3, 1.0, 2.0, (), None)]
    assert an._added(d, items, []) == (
        "Added: payload_mass: m_p = 0.35 ± 0.01 kg; actuator_loss (all legs): eta_a = 0.5, b; switch@2 (leg 2): "
        "switched on, nothing fitted. hose removed: not needed once payload_mass was added; x removed: not needed "
        "in the final model."
    )
    d.manual, d.removed = True, []
    assert an._added(d, items[:1], []) == "Added by hand: payload_mass: m_p = 0.35 ± 0.01 kg."


def test_added_names_mirror_images_as_one():
    g = [NS(effect="switch@2"), NS(effect="switch@4")]
    item = {"effect": "switch@2", "legs": [2], "leg_level": True, "params": []}
    assert an._added(diag(), [item], [[NS(effect="other")], g]).startswith("Added: switch@2 or @4 (leg 2 or 4): ")
    alone = [[NS(effect="switch@2")]]
    assert an._added(diag(), [item], alone).startswith("Added: switch@2 (leg 2): ")
    shared = {"effect": "switch", "legs": [], "leg_level": True, "params": []}
    assert an._added(diag(), [shared], [[NS(effect="switch"), NS(effect="x")]]).startswith("Added: switch (all legs): ")


def test_where():
    assert an._where([]) == "all legs" and an._where([3]) == "leg 3" and an._where([1, 2]) == "leg 1 or 2"


# -- the stated uncertainty, the rows ------------------------------------------------------------------------------


def test_uncertainty_sentence():
    assert an.uncertainty_sentence(None, True) == "The stated uncertainty was not judged."
    u = {"verdict": "too few rows", "birge_ratio": 1.0}
    assert an.uncertainty_sentence(u, True) == "Too few rows to judge the stated uncertainty."
    u = {"verdict": "overstated", "birge_ratio": 0.2345}
    assert an.uncertainty_sentence(u, True) == (
        "The stated uncertainty looks overstated: the fit is better than it allows (Birge ratio 0.234)."
    )
    u = {"verdict": "understated", "birge_ratio": math.nan}
    assert an.uncertainty_sentence(u, True) == "The stated uncertainty looks understated; no effect is missing."
    u = {"verdict": "understated"}
    assert an.uncertainty_sentence(u, True) == "The stated uncertainty looks understated; no effect is missing."
    systematic = "The stated uncertainty cannot be judged: the misfit is systematic (Birge ratio 1.5)."
    assert an.uncertainty_sentence({"verdict": "cannot be judged", "birge_ratio": 1.5}, True) == systematic
    u = {"verdict": "consistent", "birge_ratio": 1.5, "possibly_understated": True}
    assert an.uncertainty_sentence(u, True) == systematic
    u["possibly_understated"] = False
    assert an.uncertainty_sentence(u, False) == systematic
    assert an.uncertainty_sentence(u, True) == "The stated uncertainty is consistent with the fit (Birge ratio 1.5)."
    assert an.uncertainty_sentence({"verdict": "odd", "birge_ratio": 1.5}, True) == (
        "Stated uncertainty: odd (Birge ratio 1.5)."
    )


def test_rows_sentence():
    assert an._rows_sentence(diag()) == "No outliers."
    d = diag(
        outliers=[Outlier(17, 1.0, "x", 1.0, 5.0), Outlier(4, 1.0, "y", 1.0, 5.0)],
        setting_anomalies=[
            NS(what="k_a", lines=[5, 6], k_a=1500.0, best_k_a=1012.345, pose=[0, 0, -0.6], best_pose=[0, 0, -0.6]),
            NS(
                what="pose",
                lines=[8],
                k_a=1.0,
                best_k_a=1.0,
                pose=[0.0, 0.0, -0.6],
                best_pose=[0.06, -0.04, -0.6, 0.0, 0.0, 0.123456],
            ),
        ],
    )
    assert an._rows_sentence(d) == (
        "Outlier(s) set aside: CSV line 17, 4. Setting set aside: lines 5, 6 (k_a written 1500, its modes fit "
        "k_a = 1012). Setting set aside: lines 8 (pose written [0, 0, -0.6] m, its modes fit [0.06, -0.04, -0.6, "
        "0, 0, 0.1235] m, rad)."
    )


# -- what cannot be told apart ------------------------------------------------------------------------------------


def test_apart_of_step_ties_and_alternatives():
    steps = [Step(fit_of(), ranking=[]), Step(fit_of(), added="a", alternatives=["b", "c"])]
    d = diag(steps=steps, alternatives=[Alternative(("x",), "a", "b", None), Alternative(("y",), "p", "q", None)])
    assert an._apart(d) == (["a or b or c", "p or q"], False)
    same = {"max": 0.0}
    d = diag(steps=[Step(fit_of(), ranking=[])], alternatives=[Alternative(("x",), "p", "q", None, equivalent=same)])
    assert an._apart(d) == (["p or q"], True)
    d.alternatives.append(Alternative(("y",), "r", "s", None))
    assert an._apart(d) == (["p or q", "r or s"], False)
    assert an._apart(diag()) == ([], False)


def test_apart_of_unproven_effects():
    one = [Alternative(("x",), None, "hose", None)]
    assert an._apart(diag(alternatives=one)) == ([], False)
    two = one + [Alternative(("y",), None, "payload_mass", None)]
    assert an._apart(diag(alternatives=two)) == (["hose or payload_mass"], False)


def test_apart_of_mirror_images_only():
    same = NS(predicted=np.zeros(3))
    r = [NS(effect="actuator_loss@3", fit=NS(comparison=same)), NS(effect="actuator_loss@4", fit=NS(comparison=same))]
    steps = [Step(fit_of(), ranking=r), Step(fit_of(), added="actuator_loss@3", alternatives=["actuator_loss@4"])]
    d = diag(steps=steps)
    assert an._apart(d) == (["actuator_loss@3 or @4 (mirror images at the measured poses)"], False)


# -- the next measurement ------------------------------------------------------------------------------------------


def nm_between(a, b, **kw):
    return dict(
        between=(a, b),
        mode="z",
        pose=[0.1, 0.0, -0.6],
        k_a=1234.5678,
        predicted_hz={a: 12.345678, b: 12.5},
        separation_sigma=4.04,
        **kw,
    )


def test_next_choice_only_between_allowed_effects():
    own = nm_between("payload_mass", "hose,tool")
    alt = nm_between("payload_mass", "tool_mass")
    d = diag(
        selected=["payload_mass"],
        baseline=fit_of(effects=("base",)),
        steps=[Step(fit_of()), Step(fit_of(), added="payload_mass", alternatives=["hose"])],
        alternatives=[Alternative(("tool_mass",), "payload_mass", "tool_mass", None, next_measurement=alt)],
        next_measurement=own,
    )
    assert an._allowed(d) == {"payload_mass", "hose", "tool_mass"}
    assert an.next_choice(d) is alt  # "tool" is no allowed effect
    own["between"] = ("payload_mass", "hose,base")
    assert an.next_choice(d) is own
    d.removed = [Removal("hose", 0.3, 1.0, 2.0, (), None)]
    assert an.next_choice(d) is alt
    d.alternatives[0].next_measurement = None
    assert an.next_choice(d) is None


def test_next_sentence_of_a_measurement():
    nm = nm_between("payload_mass", "tool_mass")
    d = diag(selected=["payload_mass", "tool_mass"], next_measurement=nm)
    assert an._next(d, EV, [], False) == (
        "Next: measure mode z at [0.1, 0, -0.6] m, k_a = 1235 N m/rad: payload_mass 12.35 Hz, tool_mass 12.5 Hz "
        "(4.0 sigma apart)."
    )
    nm["k_a_unit"] = "N/m"
    assert "k_a = 1235 N/m: payload_mass" in an._next(d, EV, [], False)


def test_next_sentence_with_too_few_rows():
    u = Uncertainty("too few rows", 1, 1, 1)
    d = diag(uncertainty=u, untestable={"a": 35, "b": 33}, meas=Rows(n=30))
    assert an._next(d, EV, [], False) == (
        "Next: measure more rows (at least 5): more k_a values, another pose or other mode directions."
    )
    d = diag(uncertainty=u, final=fit_of(k=2), meas=Rows(n=4))
    assert an._next(d, EV, [], False).startswith("Next: measure more rows (at least 1):")
    d = diag(uncertainty=u, final=fit_of(k=2), meas=Rows(n=6))
    assert an._next(d, EV, [], False).startswith("Next: measure more rows (at least 1):")  # never below one
    d = diag(uncertainty=u, final=fit_of(k=2), meas=Rows(n=3))
    assert an._next(d, EV, [], False).startswith("Next: measure more rows (at least 2):")


def test_next_sentence_when_nothing_tells_them_apart():
    assert an._next(diag(), EV, ["a or b"], True) == (
        "Next: no measurement tells them apart: they are one model (equal frequencies everywhere)."
    )
    assert an._next(diag(), EV, ["a or b"], False) == (
        "Next: no mode in the measured band and directions tells them apart: measure another direction or a wider band."
    )


def test_next_sentence_where_the_model_still_fails():
    fails = [dict(mode="x", k_a_range=[250.0, 4000.0], poses=[[0.0, 0.0, -0.625]]), dict(mode="y")]
    final = fit_of()
    final.comparison = NS(where_it_fails=lambda: fails)
    d = diag(explained=False, final=final)
    assert an._next(d, EV, [], False) == (
        "Next: measure more where the final model still fails (mode x, k_a 250-4000 N m/rad, [0, 0, -0.625] m): "
        "other poses at the same k_a."
    )
    fails[0]["k_a_range"] = [1000.0, 1000.0]
    assert "(mode x, k_a = 1000 N m/rad, [0, 0, -0.625] m)" in an._next(d, EV, [], False)
    fails.clear()
    assert an._next(d, EV, [], False) == "Next: no measurement needed to choose between the candidates."


def test_next_sentence_names_the_runner_up():
    a = candidate("payload_mass", aicc=3.0)
    b = candidate("tool_mass", aicc=7.25, plausible=False)
    c = candidate("hose", aicc=5.5)
    steps = [Step(fit_of(), ranking=[a, b, c]), Step(fit_of(), added="payload_mass", ranking=[])]
    d = diag(selected=["payload_mass"], steps=steps)
    assert an._runner_up(d) == ("payload_mass", c)
    assert an._next(d, EV, [], False) == (
        "Next: none needed: the data already tell payload_mass from the runner-up hose (dAICc = 2.5)."
    )
    assert an._gap(d, "payload_mass", b) == pytest.approx(4.25)
    assert math.isnan(an._gap(d, "other", b))
    steps[0].ranking = [a, b]
    assert an._runner_up(d) is None
    d.selected = []
    assert an._runner_up(d) is None


def test_runner_up_of_the_last_selected_step():
    a, b, c = candidate("a", aicc=1.0), candidate("b", aicc=2.0), candidate("c", aicc=3.0)
    steps = [
        Step(fit_of(), ranking=[a, b, c]),
        Step(fit_of(), added="a", ranking=[c, b]),
        Step(fit_of(), added="c", ranking=[]),
        Step(fit_of(), removed="x"),
    ]
    d = diag(selected=["a", "c"], steps=steps)
    assert an._runner_up(d) == ("c", b)
    d.selected = ["a"]
    assert an._runner_up(d) == ("a", b)


# -- the block ------------------------------------------------------------------------------------------------


def test_lines_in_their_order_wrapped():
    parts = {k: "" for k in ("verdict", "notes", "why", "added", "damping", "search", "apart", "rows", "next")}
    parts.update(verdict="V.", rows="R.", next="N.", notes="O.", added="A " * 30 + "end.")
    assert an._lines(parts, 40) == [
        "V.",
        "O.",
        "A A A A A A A A A A A A A A A A A A A A",
        "  A A A A A A A A A A end.",
        "R.",
        "N.",
    ]
    assert an._wrap("", 10) == [""] and an._wrap("a-b-c-d-e-f", 4) == ["a-b-c-d-e-f"]


def block(n_why=1, damping="", why_check=None, manual=False):
    """A diagnosis whose why is ``n_why`` lines long at width 100 (the pattern's length)."""
    u = Uncertainty("consistent", 2.0, 100.0, 29, pattern=["p" * 20] * (4 * n_why))
    d = diag(
        explained=False,
        final=fit_of(chi2=100.0),
        uncertainty=u,
        manual=manual,
        next_measurement=None,
        setting_anomalies=[],
        outliers=[],
    )
    return d


@pytest.fixture
def quiet(monkeypatch):
    monkeypatch.setattr(an, "damping_support", lambda d, ev: None)
    monkeypatch.setattr(an, "damping_sentence", lambda s: "")


def test_answer_parts(quiet):
    d = diag()
    out = an.answer(d, EV)
    assert out["lines"] == [out["verdict"], out["added"], out["rows"], out["next"]]
    assert out["why"] == "" and out["apart"] == "" and out["search"] == "" and out["notes"] == ""
    assert out["rows"] == "No outliers. The stated uncertainty was not judged."
    assert out["effects"] == [] and out["cannot_tell_apart"] == [] and out["mirror_images"] == []
    assert out["damping"] == "" and out["damping_support"] is None
    d = diag(uncertainty=Uncertainty("understated", 2.5, 1, 1, possibly_understated=True), notes=["one", "two"])
    out = an.answer(d, EV)
    assert (
        out["rows"] == "No outliers. The stated uncertainty looks understated (Birge ratio 2.5); no effect is missing."
    )
    assert out["notes"] == "one two"
    assert an.answer_text(d, EV) == "\n".join(out["lines"])


def test_answer_why_is_the_check_or_the_reason(quiet):
    final = fit_of(effects=("payload_mass",), values={"m_p": 9.0})
    d = diag(final=final, explained=False, implausible={"m_p": (9.0, (0.0, 5.0))})
    assert an.answer(d, EV)["why"].startswith("Check the inputs: payload_mass needs m_p = 9 kg")
    d.implausible = {}
    assert an.answer(d, EV)["why"] == "Why: an effect outside the catalogue is missing (none in it helps further)."
    d.final = fit_of(n=2, k=2)
    assert an.answer(d, EV)["why"] == ""


def test_answer_apart_and_search_ties(quiet):
    same = {"max": 0.0}
    d = diag(alternatives=[Alternative(("x",), "p", "q", None, equivalent=same)])
    out = an.answer(d, EV)
    assert out["apart"] == "One model under two names (equal frequencies everywhere): p or q."
    assert out["next"].startswith("Next: no measurement tells them apart: they are one model")
    ties = [NS(effects=("a", "b")), NS(effects=("c",)), NS(effects=("d",))]
    d.search = NS(ties=ties, sentence="Searched 12 subsets.")
    d.final = fit_of(effects=("base", "payload_mass", "hose"))
    d.baseline = fit_of(effects=("base",))
    out = an.answer(d, EV)
    assert out["apart"] == "Cannot tell apart: p or q; payload_mass + hose or a + b or c."
    assert (
        out["cannot_tell_apart"] == ["p or q", "payload_mass + hose or a + b or c"]
        and out["search"] == "Searched 12 subsets."
    )
    assert out["next"].startswith("Next: no mode in the measured band")
    d.final = fit_of(effects=("base",))
    assert an.answer(d, EV)["cannot_tell_apart"][-1] == "nothing or a + b or c"
    d.manual = True
    assert an.answer(d, EV)["cannot_tell_apart"] == ["p or q"]
    d.manual, d.search = False, NS(ties=[], sentence="")
    assert an.answer(d, EV)["cannot_tell_apart"] == ["p or q"] and an.answer(d, EV)["search"] == ""


def test_answer_mirror_images_once(quiet):
    same = NS(predicted=np.zeros(3))
    r = [NS(effect=e, fit=NS(comparison=same)) for e in ("actuator_loss@3", "actuator_loss@4", "payload_mass")]
    d = diag(steps=[Step(fit_of(), ranking=r)])
    assert an.answer(d, EV)["mirror_images"] == [["actuator_loss@3", "actuator_loss@4"]]
    d = diag(steps=[Step(fit_of(), ranking=[])], ranking=r)  # the first step without a ranking: the diagnosis's
    assert an.answer(d, EV)["mirror_images"] == [["actuator_loss@3", "actuator_loss@4"]]


def long_diagnosis(n_pattern):
    """Not explained; its why holds ``n_pattern`` systematic patterns (about 2.6 a line at width 100)."""
    u = Uncertainty("consistent", 2.0, 100.0, 29, pattern=[f"pattern {i:02d} " + "q" * 25 for i in range(n_pattern)])
    return diag(explained=False, final=fit_of(chi2=100.0), uncertainty=u)


def test_answer_shortens_its_why_then_cuts_at_max_lines(quiet):
    """verdict, why, added, rows (2 lines), next: 5 lines and the why's; at MAX_LINES all of it,
    beyond it the why without its patterns, and beyond that the last line says where the rest is."""
    base = len(an.answer(long_diagnosis(0), EV)["lines"])
    for n in range(0, 40):
        out = an.answer(long_diagnosis(n), EV)
        full = an._lines({**out, "why": an._why(long_diagnosis(n))}, an.WIDTH)
        if len(full) <= an.MAX_LINES:
            assert out["lines"] == full and "systematic" in out["why"] or n == 0
        else:
            assert out["why"] == an._why(long_diagnosis(n), short=True) and len(out["lines"]) == base
    assert any(
        len(an._lines({**an.answer(long_diagnosis(n), EV), "why": an._why(long_diagnosis(n))}, 100)) == an.MAX_LINES
        for n in range(40)
    )


def test_answer_cuts_at_max_lines_with_a_pointer(quiet):
    d = diag(notes=["n" * 95] * (an.MAX_LINES - 4))  # verdict, notes (a line each), added, rows, next
    out = an.answer(d, EV)
    assert len(out["lines"]) == an.MAX_LINES and out["lines"][-1] == out["next"]  # just inside
    d.notes.append("n" * 95)
    out = an.answer(d, EV)
    assert len(out["lines"]) == an.MAX_LINES and out["lines"][-1] == "  ... (the rest: --details)"  # just outside
    assert out["lines"][:-1] == an._lines(out, an.WIDTH)[: an.MAX_LINES - 1]


def test_answer_with_a_damping_part_has_damping_lines_more(monkeypatch):
    monkeypatch.setattr(an, "damping_support", lambda d, ev: {"given": []})
    monkeypatch.setattr(an, "damping_sentence", lambda s: "Damping supported: " + "d" * 80 + " " + "e" * 80)
    most = an.MAX_LINES + an.DAMPING_LINES
    d = diag(notes=["n" * 95] * (most - 6))  # verdict, notes, added, damping (2), rows, next
    out = an.answer(d, EV)
    assert len(out["lines"]) == most and out["lines"][-1] == out["next"]
    assert out["damping_support"] == {"given": []} and out["damping"].startswith("Damping supported:")
    d.notes.append("n" * 95)
    out = an.answer(d, EV)
    assert len(out["lines"]) == most and out["lines"][-1] == "  ... (the rest: --details)"


def test_answer_keeps_the_check_however_long(quiet):
    final = fit_of(effects=("payload_mass",), values={"m_p": 9.0})
    d = diag(final=final, explained=False, implausible={"m_p": (9.0, (0.0, 5.0))}, notes=["n" * 95] * 6)
    out = an.answer(d, EV)
    assert out["why"].startswith("Check the inputs") and out["lines"][-1] == "  ... (the rest: --details)"


# -- the survivors of a first mutation run ------------------------------------------------------------------


def test_one_degree_of_freedom_is_judged(quiet):
    d = diag(final=fit_of(n=2, k=1, chi2=100.0), explained=False)
    assert an._verdict(d).startswith("NOT explained within the stated sigma (chi2/nu = 100/1 = 100")
    assert an.answer(d, EV)["why"].startswith("Why: ")


def test_a_diagnosis_without_the_optional_parts(quiet):
    """A diagnosis object without implausible values, removals, setting anomalies, a search or notes."""
    d = diag(explained=False, final=fit_of(effects=("payload_mass",), chi2=100.0, values={"m_p": 0.3}))
    for name in ("implausible", "removed", "setting_anomalies", "search", "notes"):
        delattr(d, name)
    out = an.answer(d, EV)
    assert out["search"] == "" and out["notes"] == "" and out["rows"].startswith("No outliers.")
    assert out["why"].startswith("Why: an effect outside") and an._allowed(d) == set()
    assert out["added"] == "Added: payload_mass: m_p = 0.3 (± undetermined) kg."


def test_an_effect_without_component_leg_level_or_a_known_parameter():
    final = fit_of(effects=("valve",), values={"k_h": 5e4, "v_free": 3.0}, std={"k_h": 1e3})
    alone = fit_of(effects=("valve",), values={"k_h": 5e4})  # v_free given, unknown to the evaluator
    d = diag(final=alone, explained=False, implausible={"k_h": (5e4, (0.0, 1e4))})
    assert an.check_inputs(d, EV) == (
        "Check the inputs: valve needs k_h = 5e+04 N/m (plausible 0 ... 1e+04 N/m): check the valve's values."
    )
    (item,) = an.added_effects(diag(final=final), EV)
    assert item["leg_level"] is False
    k_h, free = item["params"]
    assert k_h["text"] == "k_h = (5.00 ± 0.10)·10⁴ N/m (IMPLAUSIBLE: plausible 0 ... 1e+04 N/m)"
    assert free == {
        "name": "v_free",
        "value": 3.0,
        "std": math.inf,
        "unit": "",
        "plausible": True,
        "plausible_range": None,
        "text": "v_free = 3 (± undetermined)",
    }


def test_a_value_at_its_search_bound_is_implausible_inside_its_range():
    final = fit_of(effects=("payload_mass",), values={"m_p": 0.35}, std={"m_p": 0.01}, at_bound=("m_p",))
    (item,) = an.added_effects(diag(final=final), EV)
    assert item["params"][0]["plausible"] is False
    assert item["params"][0]["text"] == "m_p = 0.350 ± 0.010 kg (IMPLAUSIBLE: plausible 0 ... 5 kg)"


def mirror_ranking(*effects):
    same = NS(predicted=np.zeros(3))
    return [NS(effect=e, fit=NS(comparison=same)) for e in effects]


def test_added_groups_from_the_ranking_each_effect_was_chosen_in():
    steps = [
        Step(fit_of(), ranking=mirror_ranking("actuator_loss@3", "actuator_loss@4", "payload_mass")),
        Step(fit_of(), added="actuator_loss@3", ranking=mirror_ranking("switch@1", "switch@2")),
        Step(fit_of(), added="switch@2", ranking=[]),
    ]
    groups = an._added_groups(diag(steps=steps))
    assert [[c.effect for c in g] for g in groups] == [["actuator_loss@3", "actuator_loss@4"], ["switch@1", "switch@2"]]


def test_apart_of_alternatives_mirror_images_and_order():
    ranking = mirror_ranking("actuator_loss@3", "actuator_loss@4")
    steps = [Step(fit_of(), ranking=ranking), Step(fit_of(), added="payload_mass", ranking=[])]
    mirror = Alternative(("x",), "actuator_loss@3", "actuator_loss@4", None)
    unproven = Alternative(("y",), None, "hose", None)
    d = diag(steps=steps, alternatives=[unproven, mirror])
    assert an._apart(d) == (["actuator_loss@3 or @4 (mirror images at the measured poses)"], False)
    # the same pair as a step's tie is said once
    steps = [Step(fit_of(), ranking=[]), Step(fit_of(), added="a", alternatives=["b"])]
    d = diag(steps=steps, alternatives=[Alternative(("x",), "a", "b", None)])
    assert an._apart(d) == (["a or b"], False)
    # one model only when every set is
    same = {"max": 0.0}
    d = diag(alternatives=[Alternative(("x",), "p", "q", None), Alternative(("y",), "r", "s", None, equivalent=same)])
    assert an._apart(d) == (["p or q", "r or s"], False)


def test_apart_of_unproven_mirror_images_in_the_last_ranking():
    ranking = mirror_ranking("actuator_loss@3", "actuator_loss@4")
    steps = [Step(fit_of(), ranking=[]), Step(fit_of(), added="payload_mass", ranking=ranking)]
    alts = [Alternative(("x",), None, "actuator_loss@3", None), Alternative(("y",), None, "actuator_loss@4", None)]
    d = diag(steps=steps, alternatives=alts)
    assert an._apart(d) == (["actuator_loss@3 or @4 (mirror images at the measured poses)"], False)
    # a later step without a ranking has no groups (the diagnosis's ranking is the first step's)
    steps = [Step(fit_of(), ranking=[]), Step(fit_of(), added="payload_mass", ranking=[])]
    d = diag(steps=steps, alternatives=alts, ranking=ranking)
    assert an._apart(d) == (["actuator_loss@3 or actuator_loss@4"], False)


def test_allowed_holds_an_alternatives_effects_and_its_replacement():
    d = diag(alternatives=[Alternative(("x", "y"), "w", "z", None)])
    assert an._allowed(d) == {"x", "y", "z"}


def test_gap_without_the_added_effect_in_its_ranking():
    steps = [Step(fit_of(), ranking=[candidate("other", aicc=1.0)]), Step(fit_of(), added="a")]
    assert math.isnan(an._gap(diag(steps=steps), "a", candidate("b", aicc=2.0)))


def test_answer_with_an_added_effect_and_its_evaluator(monkeypatch):
    support = {"given": []}
    seen = []

    def damping_support(d, ev):
        seen.append((d, ev))
        return support

    monkeypatch.setattr(an, "damping_support", damping_support)
    monkeypatch.setattr(an, "damping_sentence", lambda s: "Damping: x." if s is support else "")
    nm = nm_between("payload_mass", "tool_mass")  # no k_a unit: the evaluator's
    final = fit_of(effects=("payload_mass",), values={"m_p": 0.35}, std={"m_p": 0.01})
    d = diag(
        final=final,
        selected=["payload_mass", "tool_mass"],
        next_measurement=nm,
        uncertainty=Uncertainty("consistent", 1.1, 29.0, 29),
    )
    out = an.answer(d, EV)
    assert out["added"] == "Added: payload_mass: m_p = 0.350 ± 0.010 kg."
    assert out["next"].startswith("Next: measure mode z at [0.1, 0, -0.6] m, k_a = 1235 N m/rad: payload_mass")
    assert out["rows"] == "No outliers. The stated uncertainty is consistent with the fit (Birge ratio 1.1)."
    assert out["damping"] == "Damping: x." and seen == [(d, EV)]
    assert an.answer_text(d, EV, 40) == "\n".join(an.answer(d, EV, 40)["lines"])
    assert max(map(len, an.answer(d, EV, 40)["lines"])) <= 40 < max(map(len, out["lines"]))


def test_answer_one_model_under_two_names_joined(quiet):
    same = {"max": 0.0}
    alts = [Alternative(("x",), "p", "q", None, equivalent=same), Alternative(("y",), "r", "s", None, equivalent=same)]
    out = an.answer(diag(alternatives=alts), EV)
    assert out["apart"] == "One model under two names (equal frequencies everywhere): p or q; r or s."
