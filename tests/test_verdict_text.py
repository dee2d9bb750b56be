"""The diagnosis's text (``eigentwist/diagnose/verdict.py``), sentence by sentence, on stand-in
diagnoses: each branch of the verdict, its thresholds on both sides (p against alpha, the
table's row limit, the lists cut at 4 poses and 12 lines) and the cells of each table. The
tables' cells are read where they are handed to ``format_table``; the p-values are
recomputed with SciPy. No evaluator, no fit.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from scipy import stats

from eigentwist.diagnose import verdict as vd
from eigentwist.diagnose.backward import Removal
from eigentwist.diagnose.compare import Comparison
from eigentwist.diagnose.misfit import Outlier, Uncertainty
from eigentwist.diagnose.select import Alternative, Step

from .standin_diagnosis import Rows, diag, fit_of

UNITS = {"k_E_rot": "N m/rad", "m_p": "kg", "E_l1": "Pa", "k_a": "N m/rad"}
RANGES = {"E_l1": (4e10, 2.5e11)}


class FakeEv:
    """Stands in for an evaluator: units and plausible ranges; no effect has legs or damping."""

    def accepts(self, name):
        return name in UNITS

    def parameter(self, name):
        return NS(unit=UNITS[name], plausible_range=RANGES.get(name, (0, math.inf)), default=1.0)

    robot = NS(effect=lambda name: (_ for _ in ()).throw(KeyError(name)))


EV = FakeEv()


@pytest.fixture
def tables(monkeypatch):
    """The (headers, rows) each table of the text is built from."""
    got = []

    def record(headers, rows, **kw):
        got.append((headers, [list(r) for r in rows], kw))
        return f"<table {len(got) - 1}>"

    monkeypatch.setattr(vd, "format_table", record)
    return got


# -- small formatters ------------------------------------------------------------------------------------


def test_pose_rounds_to_a_tenth_of_a_millimetre_and_names_its_unit():
    assert vd._pose([0.123456, -0.02, -0.6]) == "[0.1235, -0.02, -0.6]"
    assert vd._pose_unit([0, 0, 0]) == "m" and vd._pose_unit([0] * 6) == "m, rad"


def test_format_params_values_errors_and_units():
    text = vd.format_params({"k_E_rot": 374.21, "m_p": 0.3, "free": 2.0}, {"k_E_rot": 38.4, "m_p": math.nan}, EV)
    assert text == "k_E_rot = 374.2 ± 38 N m/rad, m_p = 0.3 ± (undetermined) kg, free = 2 ± (undetermined)"
    assert vd.format_params({}, {}, EV) == "-"


# -- the comparison ------------------------------------------------------------------------------------------


def comparison(n=3, failing=(False, True, False), mac=None, poses=None):
    meas = Rows(
        lines=np.arange(2, n + 2),
        k_a=np.linspace(250.0, 1000.0, n),
        poses=np.tile([0.0, 0.0, -0.625], (n, 1)) if poses is None else poses,
        mode=tuple("xyz"[i % 3] for i in range(n)),
        freq_hz=np.linspace(10.0, 20.0, n),
        sigma_hz=np.full(n, 0.05),
        k_a_unit="N m/rad",
    )
    err_sigma = np.where(np.asarray(failing), 3.0, 0.5)
    out = NS(
        meas=meas,
        mac=mac,
        error_pct=err_sigma * 0.01,
        error_sigma=err_sigma,
        failing=np.asarray(failing),
        mode_index=np.arange(n),
        predicted=meas.freq_hz + 0.1,
        rms_pct=1.234,
        max_pct=5.678,
        chi2=12.34,
    )
    out.where_it_fails = lambda: Comparison.where_it_fails(out)
    return out


def test_comparison_table_cells(tables):
    cmp = comparison(mac=np.array([0.98765, np.nan, 0.5]))
    assert vd.comparison_table(cmp) == "<table 0>"
    ((headers, rows, _),) = tables
    assert headers == [
        "line",
        "k_a [N m/rad]",
        "pose [m]",
        "mode",
        "model mode",
        "measured [Hz]",
        "sigma [Hz]",
        "predicted [Hz]",
        "error [%]",
        "error [sigma]",
        "|err|>2sigma",
        "MAC",
    ]
    assert rows[1] == [3, "625", "[0, 0, -0.625]", "y", 2, "15", "0.05", "15.1", "+0.03", "+3.00", "FAILS", "-"]
    assert rows[0][-2:] == ["", "0.9877"] and rows[2][-1] == "0.5000"


def test_comparison_table_of_a_6_dof_robot_without_shapes(tables):
    cmp = comparison(poses=np.zeros((3, 6)))
    vd.comparison_table(cmp)
    ((headers, rows, _),) = tables
    assert headers[2] == "pose [m, rad]" and "MAC" not in headers and len(rows[0]) == 11


def test_comparison_table_beyond_its_limit_lists_the_failing_rows(tables):
    cmp = comparison(n=5, failing=(True, False, True, True, False))
    assert vd.comparison_table(cmp, limit=5) == "<table 0>"  # just inside: every row, no heading
    text = vd.comparison_table(cmp, limit=4)  # just outside: the failing rows
    assert text == "5 rows, more than 4: listed are the 3 failing rows (--json prints every row)\n<table 1>"
    assert [r[0] for r in tables[1][1]] == [2, 4, 5]
    text = vd.comparison_table(cmp, limit=3)  # as many failing rows as the limit
    assert text.startswith("5 rows, more than 3: listed are the 3 failing rows")
    text = vd.comparison_table(cmp, limit=2)
    assert text.startswith("5 rows, more than 2: listed are the first 2 of the 3 failing rows (")
    assert [r[0] for r in tables[3][1]] == [2, 4]
    none = comparison(n=3, failing=(False, False, False))
    assert (
        vd.comparison_table(none, limit=2)
        == "3 rows, more than 2: listed are the 0 failing rows (--json prints every row)"
    )


def test_comparison_table_of_no_rows_has_a_position_column(tables):
    empty = comparison(n=0, failing=(), poses=np.zeros((0, 3)))
    vd.comparison_table(empty)
    assert tables[0][0][2] == "pose [m]"


def test_comparison_summary():
    assert vd.comparison_summary(comparison()) == (
        "RMS error 1.23 %, max 5.68 % (error = (predicted - measured)/measured); chi2 = 12.3 for 3 rows; "
        "1 of 3 rows fail (|error| > 2 sigma)"
    )


def test_failing_text_cuts_poses_at_four_and_lines_at_twelve():
    five = [[0.1 * i, 0.0, -0.6] for i in range(5)]
    cmp = NS(
        meas=NS(k_a_unit="N m/rad"),
        where_it_fails=lambda: [
            dict(
                mode="x",
                rows=2,
                of=10,
                k_a_range=[1000.0, 1000.0],
                poses=five[:4],
                predicted="too high",
                lines=list(range(2, 14)),
            ),
            dict(
                mode="y",
                rows=13,
                of=13,
                k_a_range=[250.0, 4000.0],
                poses=five,
                predicted="both ways",
                lines=list(range(2, 15)),
            ),
        ],
    )
    x, y = vd.failing_text(cmp)
    assert x == (
        "mode x: 2 of 10 rows, k_a = 1000 N m/rad, pose(s) [0, 0, -0.6]; [0.1, 0, -0.6]; [0.2, 0, -0.6]; "
        "[0.3, 0, -0.6] m, model too high (lines 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13)"
    )
    assert y == (
        "mode y: 13 of 13 rows, k_a 250-4000 N m/rad, pose(s) [0, 0, -0.6]; [0.1, 0, -0.6]; [0.2, 0, -0.6]; "
        "[0.3, 0, -0.6] ... m, model both ways (lines 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13 ...)"
    )
    six = NS(
        meas=NS(k_a_unit="N/m"),
        where_it_fails=lambda: [
            dict(mode="1", rows=1, of=1, k_a_range=[5.0, 5.0], poses=[[0.0] * 6], predicted="too low", lines=[7])
        ],
    )
    assert vd.failing_text(six) == [
        "mode 1: 1 of 1 rows, k_a = 5 N/m, pose(s) [0, 0, 0, 0, 0, 0] m, rad, model too low (lines 7)"
    ]
    assert vd.failing_text(NS(meas=None, where_it_fails=lambda: [])) == ["nowhere: every row is within 2 sigma"]


# -- the verdict's head and why ---------------------------------------------------------------------------------


def chi2_at(p, dof):
    """The chi-square whose goodness-of-fit p-value is ``p``."""
    return float(stats.chi2.isf(p, dof))


def test_head_without_degrees_of_freedom():
    for n in (3, 2):
        d = diag(final=fit_of(n=n, k=3, chi2=0.0), explained=False)
        assert vd._head(d) == (
            f"cannot judge whether the final model explains the data: it has 3 fitted parameters for {n} "
            "measurements (measure more)"
        )
    assert vd._head(diag(final=fit_of(n=4, k=3, chi2=1.0))).startswith("the final model explains")


def test_head_of_a_diagnosis_without_implausible_values():
    d = diag(final=fit_of(chi2=chi2_at(0.5, 29)), explained=False)
    del d.implausible
    assert vd._head(d).startswith("the final model does NOT explain the data within the measurement uncertainty")


def test_head_explained_and_not():
    chi2 = chi2_at(0.5, 29)
    stat = f"chi2 = {chi2:.1f} for 29 degrees of freedom (reduced {chi2 / 29:.2f}, p = 0.5)"
    d = diag(final=fit_of(chi2=chi2))
    assert vd._head(d) == "the final model explains the data within the measurement uncertainty: " + stat
    d.explained = False
    assert vd._head(d) == (
        "the final model does NOT explain the data within the measurement uncertainty: " + stat + " <= alpha = 0.01"
    )


@pytest.mark.parametrize("p, fits", [(0.0101, True), (0.0099, False)])
def test_head_of_an_implausible_fit_at_alpha(p, fits):
    d = diag(final=fit_of(chi2=chi2_at(p, 29)), explained=False, implausible={"E_l1": (1e13, (4e10, 2.5e11))})
    text = vd._head(d)
    assert text.startswith("the final model does NOT explain the data: it fits (chi2 = ") is fits
    assert text.endswith(f"p = {p:.3g})) only with E_l1 outside the plausible range") is fits
    assert text.endswith(" <= alpha = 0.01") is not fits


def test_why_in_its_order():
    u = Uncertainty("understated", 3.04, 100.0, 10, pattern=["mode x too high", "z low"])
    alt = Alternative(("a",), None, "chain_spring", None)
    d = diag(explained=False, manual=True, uncertainty=Uncertainty("too few rows", 1.0, 1.0, 1), alternatives=[alt])
    assert vd._why(d).startswith("The effects added by hand are not enough; run without --add")
    d.manual = False
    assert vd._why(d) == "Too few rows to tell a missing effect from the stated uncertainty: measure more (below)"
    d.uncertainty = u
    assert vd._why(d).startswith("Catalogue effects would explain it, but these rows cannot show it significantly")
    d.alternatives = [Alternative(("a",), "x", "y", None)]
    assert vd._why(d) == (
        "The residuals are 3 times the stated uncertainty, without a systematic pattern, and no catalogue effect is "
        "significant: the stated uncertainties are too small (understated), rather than an effect missing"
    )
    d.uncertainty = Uncertainty("consistent", 1.0, 10.0, 10, pattern=["mode x too high", "z low"])
    assert vd._why(d) == (
        "Every catalogue effect this robot has is already in the model: an effect outside the catalogue is missing"
        " (the residuals are systematic: mode x too high; z low), or the stated uncertainties are too small"
    )
    d.steps = [Step(fit_of(), ranking=[NS(effect="x")])]
    d.uncertainty = None
    assert vd._why(d) == (
        "No catalogue effect improves it significantly any more: an effect outside the catalogue is missing, "
        "or the stated uncertainties are too small"
    )


def test_too_few_rows():
    meas = Rows(freq_hz=np.zeros(6))
    d = diag(meas=meas, final=fit_of(n=6, k=2), untestable={"b_effect": 9, "a_effect": 11})
    assert vd._too_few(d) == (
        "Too few rows: with 6 rows, a_effect, b_effect cannot be tested (up to 11 rows needed; AICc is infinite "
        "when n <= k + 2). Measure more: at least 5 more rows, e.g. more k_a values, another pose or the other "
        "mode directions"
    )
    d = diag(meas=meas, final=fit_of(n=6, k=2), next_measurement={"message": "mode z at [0, 0, -0.6]"})
    assert vd._too_few(d) == (
        "Too few rows: with 6 rows, the final model's goodness of fit cannot be tested (up to 5 rows needed; AICc "
        "is infinite when n <= k + 2). Measure more: at least -1 more rows, e.g. more k_a values, another pose or "
        "the other mode directions; the most informative: mode z at [0, 0, -0.6]"
    )


def test_uncertainty_sentences():
    over = Uncertainty("overstated", 0.25, 3.456, 20, p_low=0.0012)
    assert vd._uncertainty_sentence(diag(uncertainty=over)) == (
        "The stated uncertainties look overstated: the final model fits 4 times better than they allow (Birge "
        "ratio sqrt(chi2/nu) = 0.25, P(chi2 <= 3.46) = 0.0012); with honest uncertainties smaller effects may "
        "become visible"
    )
    zero = Uncertainty("overstated", 0.0, 0.0, 20, p_low=0.0)
    assert "fits 1e+12 times better" in vd._uncertainty_sentence(diag(uncertainty=zero))
    under = Uncertainty("understated", 2.345, 100.0, 20)
    assert vd._uncertainty_sentence(diag(uncertainty=under)) == (
        "The stated uncertainties look understated by a factor of about 2.3 (Birge ratio)"
    )
    for u in (None, Uncertainty("too few rows", 1.0, 1.0, 1), Uncertainty("consistent", 1.0, 1.0, 1)):
        assert vd._uncertainty_sentence(diag(uncertainty=u)) is None


def test_outlier_sentence():
    outliers = [Outlier(17, 1000.0, "x", 23.456789, 5.04), Outlier(9, 250.0, "z", 8.0, -4.96)]
    d = diag(outliers=outliers, all_rows=NS(selected=[], final=fit_of()))
    assert vd._outlier_sentence(d, EV) == (
        "Isolated outlier(s) set aside: line 17 (mode x, k_a = 1000 N m/rad, 23.46 Hz, +5.0 sigma); line 9 (mode z, "
        "k_a = 250 N m/rad, 8 Hz, -5.0 sigma); the selection and fitted values above are without them (with every "
        "row the selection is nothing)"
    )
    d.all_rows = NS(selected=["payload_mass"], final=fit_of(values={"m_p": 0.31}, std={"m_p": 0.012}))
    assert vd._outlier_sentence(d, EV).endswith(
        "(with every row the selection is payload_mass (m_p = 0.31 ± 0.012 kg))"
    )
    d.all_rows = NS(selected=["a", "b"], final=fit_of())
    assert vd._outlier_sentence(d, EV).endswith("(with every row the selection is a, b)")
    d.all_rows = None  # the diagnosis with every row not run: the sentence without it
    assert vd._outlier_sentence(d, EV).endswith("the selection and fitted values above are without them")
    assert vd._outlier_sentence(diag(outliers=[]), EV) is None


def test_alternatives_sentence():
    nm = {"message": "mode y at [0, 0, -0.6]"}
    one = [Alternative(("a",), None, "chain_spring", None, next_measurement=nm)]
    d = diag(alternatives=one, meas=Rows(freq_hz=np.zeros(20)))
    assert vd._alternatives_sentence(d) == (
        "chain_spring would explain the data, but not significantly with 20 rows; measure more (mode y at [0, 0, -0.6])"
    )
    two = [Alternative(("a",), None, "chain_spring", None), Alternative(("b",), None, "hose", None)]
    d.alternatives = two
    assert vd._alternatives_sentence(d) == (
        "chain_spring or hose would explain the data, but not significantly with 20 rows: these data cannot tell "
        "them apart; measure more"
    )
    nm2 = {"mode": "z", "pose": [0.123456, 0.0, -0.6], "k_a": 1234.5678, "separation_sigma": 3.14159}
    swap = Alternative(("b",), "payload_mass", "tool_mass", None, next_measurement=nm2)
    d.alternatives = [swap]
    assert vd._alternatives_sentence(d) == (
        "payload_mass or tool_mass: these data cannot tell them apart; measure mode z at [0.1235, 0, -0.6] m with "
        "k_a = 1235 N m/rad, where they differ by 3.1 sigma"
    )
    same = Alternative(
        ("b",),
        "payload_mass",
        "tool_mass",
        None,
        equivalent={"max": 0.0},
        next_measurement=dict(nm2, k_a_unit="N/m", pose=[0.0] * 6),
    )
    d.alternatives = [Alternative(("a",), None, "hose", None), same]
    assert vd._alternatives_sentence(d) == (
        "hose would explain the data, but not significantly with 20 rows; measure more. payload_mass and tool_mass "
        "are one model under two names (the same frequencies at every pose and k_a); measure mode z at [0, 0, 0, "
        "0, 0, 0] m, rad with k_a = 1235 N/m, where they differ by 3.1 sigma"
    )


def test_alternatives_sentence_names_ties_only_with_too_few_rows():
    top = NS(effect="a", indistinguishable_from=["b", "c", "d"], plausible=True)
    ranking = [top, NS(effect="b", plausible=True), NS(effect="c", plausible=False), NS(effect="d", plausible=True)]
    d = diag(ranking=ranking, uncertainty=Uncertainty("too few rows", 1.0, 1.0, 1))
    assert vd._alternatives_sentence(d) == "a or b or d: these data cannot tell them apart"
    d.uncertainty = Uncertainty("consistent", 1.0, 1.0, 1)
    assert vd._alternatives_sentence(d) is None
    d.uncertainty = None
    assert vd._alternatives_sentence(d) is None
    top.indistinguishable_from = ["c"]
    d.uncertainty = Uncertainty("too few rows", 1.0, 1.0, 1)
    assert vd._alternatives_sentence(d) is None
    assert vd._alternatives_sentence(diag(ranking=[], uncertainty=d.uncertainty)) is None


def candidate(effect, p, aicc=5.0, implausible=None, values=None, std=None, at_bound=(), **kw):
    imp = dict(implausible or {})
    return NS(
        effect=effect,
        p_value=p,
        fit=fit_of(values=values, std=std, at_bound=at_bound, aicc=aicc),
        plausible=not imp,
        implausible=imp,
        plausible_range={n: RANGES.get(n, (0.0, 1.0)) for n in imp},
        params=dict(values or {}),
        param_std=dict(std or {}),
        delta_aicc=kw.get("delta_aicc", 0.0),
        indistinguishable_from=kw.get("ties", []),
    )


def test_implausible_sentence_at_the_bonferroni_level():
    """Two candidates: significant below alpha/2, and only with a lower AICc than the final model."""
    final = fit_of(aicc=10.0)
    bad = candidate("tube_modulus", 0.0049, implausible={"E_l1": 3.3e12}, at_bound=("E_l1",))
    other = candidate("x", 0.5)
    d = diag(final=final, steps=[Step(final, ranking=[bad, other])])
    assert vd._implausible_sentence(d, EV) == (
        "Only implausible fits would explain more: tube_modulus needs E_l1 = 3.3e+12 Pa (at the search bound), "
        "plausible 4e+10 ... 2.5e+11 Pa"
    )
    bad.p_value = 0.0051
    assert vd._implausible_sentence(d, EV) is None
    bad.p_value, bad.fit.aicc = 0.0049, 10.0
    assert vd._implausible_sentence(d, EV) is None


def test_needs_of_an_unknown_parameter():
    c = candidate("free", 0.001, implausible={"free": 5.0})
    c.plausible_range = {}
    assert vd._needs(c, EV) == "needs free = 5 , plausible nan ... nan "


# -- the tables ----------------------------------------------------------------------------------------------


def test_ranking_table_cells(tables):
    a = candidate("payload_mass", 1.234e-5, aicc=1.04, values={"m_p": 0.3}, std={"m_p": 0.01}, ties=["hose", "x@1"])
    b = candidate(
        "hose",
        math.nan,
        aicc=2.0,
        delta_aicc=0.96,
        values={"k_E_rot": 100.0},
        std={"k_E_rot": 5.0},
        at_bound=("k_E_rot",),
    )
    c = candidate("tube_modulus", None, delta_aicc=-0.04, implausible={"E_l1": 3.3e12})
    vd._ranking_table([a, b, c], EV)
    ((headers, rows, kw),) = tables
    assert headers == [
        "rank",
        "effect",
        "fitted (± std)",
        "RMS [%]",
        "max [%]",
        "AICc",
        "dAICc",
        "p-value",
        "notes (~: tied)",
    ]
    assert kw == {"footnote": (8,)}
    assert rows[0] == [1, "payload_mass", "m_p = 0.3 ± 0.01 kg", "1.50", "3.00", "1.0", "0.0", "1.2e-05", "~ hose, x@1"]
    assert rows[1][0] == 2 and rows[1][6:] == ["1.0", "-", "at search bound: k_E_rot"]
    assert rows[2][6:] == ["0.0", "-", "IMPLAUSIBLE: needs E_l1 = 3.3e+12 Pa, plausible 4e+10 ... 2.5e+11 Pa"]
    tables.clear()
    vd._ranking_table([candidate("q", 0.1, delta_aicc=0.05)], EV)
    assert tables[0][1][0][6] == "0.1"  # |dAICc| of 0.05 is shown, below it 0.0
    tables.clear()
    vd._ranking_table([candidate("q", 0.1, delta_aicc=-0.06)], EV)
    assert tables[0][1][0][6] == "-0.1"
    tables.clear()
    vd._ranking_table([], EV)
    assert tables[0][1] == []


def test_ranking_table_groups_mirror_images(tables):
    a = candidate("transmission_compliance@1", 1e-4, values={"m_p": 1.0})
    b = candidate("transmission_compliance@2", 1e-4, values={"m_p": 1.0})
    vd._ranking_table([a, b], EV)
    ((_, rows, _),) = tables
    assert len(rows) == 1 and rows[0][1] == "transmission_compliance@1 or @2"
    assert rows[0][8] == "mirror images (the same fit)"


def test_steps_table_cells(tables):
    steps = [
        Step(fit_of(effects=(), chi2=123.45, rms=4.0, mx=9.0)),
        Step(fit_of(effects=("a", "b"), chi2=22.0), added="b", p_value=2.345e-7, alternatives=["c", "d"]),
        Step(fit_of(effects=("b",)), removed="a", p_value=math.inf),
    ]
    vd._steps_table(steps)
    ((headers, rows, _),) = tables
    assert headers == ["step", "change", "effects", "RMS [%]", "max [%]", "chi2", "p-value", "equally good instead"]
    assert rows == [
        [0, "baseline", "(none)", "4.00", "9.00", "123.5", "-", "-"],
        [1, "+b", "a, b", "1.50", "3.00", "22.0", "2.3e-07", "c, d"],
        [2, "-a", "b", "1.50", "3.00", "20.0", "-", "-"],
    ]


# -- the verdict as a whole ----------------------------------------------------------------------------------


def test_verdict_text_in_its_order():
    final = fit_of(chi2=chi2_at(0.001, 29))
    d = diag(
        final=final,
        explained=False,
        uncertainty=Uncertainty("too few rows", 1.0, 1.0, 1),
        meas=Rows(freq_hz=np.zeros(30), k_a_unit="N m/rad"),
        untestable={"e": 33},
        outliers=[Outlier(17, 1000.0, "x", 23.5, 5.0)],
        alternatives=[Alternative(("a",), None, "hose", None)],
        steps=[Step(final, ranking=[candidate("tube_modulus", 1e-6, implausible={"E_l1": 1e13})])],
        all_rows=NS(selected=[], final=fit_of()),
    )
    text = vd.verdict_text(d, EV)
    order = [
        "the final model does NOT explain the data within",
        ". Too few rows to tell a missing effect from the stated uncertainty: measure more (below). Too few rows: "
        "with 30 rows, e cannot be tested",
        "Measure more: at least 3 more rows",
        ". Isolated outlier(s) set aside: line 17",
        ". hose would explain the data",
        ". Only implausible fits would explain more: tube_modulus",
    ]
    at = [text.find(s) for s in order]
    assert at[0] == 0 and all(a < b for a, b in zip(at[:-1], at[1:]))
    assert text.endswith("plausible 4e+10 ... 2.5e+11 Pa")


def test_verdict_text_of_an_explained_or_unjudgeable_model_gives_no_reason():
    d = diag(final=fit_of(chi2=10.0))
    assert vd.verdict_text(d, EV) == vd._head(d)
    d = diag(final=fit_of(n=2, k=3), explained=False)
    assert vd.verdict_text(d, EV) == vd._head(d)
    d.uncertainty = Uncertainty("overstated", 0.5, 1.0, 10, p_low=0.001)
    assert vd.verdict_text(d, EV) == vd._head(d) + ". " + vd._uncertainty_sentence(d)


def test_component_sentences_of_the_per_leg_items(monkeypatch):
    import eigentwist.diagnose.scope as scope

    seen = []

    def sentence(ev, item, values, model):
        seen.append((item, dict(values), tuple(model)))
        return f"leg 2's actuator ({item})" if "@" in item else None

    monkeypatch.setattr(scope, "sentence", sentence)
    d = diag(final=fit_of(effects=("a", "b@2"), values={"k": 1.0}))
    assert vd.component_sentences(d, EV) == ["leg 2's actuator (b@2)"]
    assert seen == [("a", {"k": 1.0}, ("a", "b@2")), ("b@2", {"k": 1.0}, ("a", "b@2"))]


# -- the full text ------------------------------------------------------------------------------------------------


def full_diagnosis(**kw):
    meas = Rows(freq_hz=np.zeros(30), source="lab.csv", k_a_unit="N m/rad")
    baseline = comparison()
    baseline.effects = ("rigid_a", "rigid_b")
    final = fit_of(
        effects=("rigid_a", "rigid_b", "payload_mass"), values={"m_p": 0.3}, std={"m_p": 0.01}, rms=0.5, mx=1.25
    )
    final.comparison = comparison(failing=(False, False, False))
    top = candidate("payload_mass", 1e-6, values={"m_p": 0.3}, std={"m_p": 0.01}, ties=["tool_mass"])
    d = diag(
        meas=meas,
        baseline=baseline,
        parameters=[],
        hints=[],
        ranking=[top],
        steps=[
            Step(fit_of(effects=("rigid_a", "rigid_b")), ranking=[top]),
            Step(final, added="payload_mass", p_value=1e-6),
        ],
        removed=[],
        final=final,
        setting_anomalies=[],
        final_hints=[],
    )
    d.__dict__.update(kw)
    return d


def lines_of(d, **kw):
    return vd.diagnosis_text(d, EV, **kw).split("\n")


def test_diagnosis_text_sections(tables):
    d = full_diagnosis()
    out = lines_of(d)
    assert out[0] == "heli4: 30 measured frequencies from lab.csv; baseline: rigid_a, rigid_b"
    assert out[1] == "parameters: heli4's defaults (none changed)"
    assert out[2:8] == [
        "",
        "1. Baseline",
        "   " + vd.comparison_summary(d.baseline),
        "   where it fails:",
        "     mode y: 1 of 1 rows, k_a = 625 N m/rad, pose(s) [0, 0, -0.625] m, model too high (lines 3)",
        "   residual pattern:",
    ]
    assert out[8:12] == [
        "     - no clear pattern over k_a",
        "",
        "2. Candidate effects, each fitted on top of the baseline (best first)",
        "<table 0>",
    ]
    assert out[12:15] == [
        "",
        "3. Can the data tell them apart?",
        "   payload_mass and tool_mass explain these data equally well (dAICc < 2, or predictions less than 3 sigma "
        "apart in total on the measured rows): these data cannot tell them apart.",
    ]
    assert out[15:18] == ["", "4. Forward selection (add the best significant effect, repeat)", "<table 1>"]
    assert out[18] == "   final model: rigid_a, rigid_b, payload_mass; RMS 0.50 %, max 1.25 %"
    assert out[19] == "   fitted: m_p = 0.3 ± 0.01 kg"
    assert out[20] == "   " + vd.verdict_text(d, EV)
    assert out[21:23] == ["", "criteria:"]
    assert len(out) == 23 + len(vd.CRITERIA) and out[23].startswith("   ranking: AICc")
    assert [h for h, _, _ in tables][:2] == [tables[0][0], tables[1][0]] and tables[1][0][0] == "step"


def test_diagnosis_text_with_rows_and_without_candidates(tables):
    d = full_diagnosis(
        ranking=[], hints=["mode x: error grows with k_a"], manual=True, explained=False, final_hints=["mode z too low"]
    )
    d.steps = [Step(fit_of(effects=("rigid_a", "rigid_b")), ranking=[])]
    d.final.values = {}
    out = lines_of(d, show_rows=True)
    assert "     - mode x: error grows with k_a" in out and "     - no clear pattern over k_a" not in out
    i = out.index("   residual pattern:")
    assert out[i + 2 : i + 4] == ["", "<table 0>"]  # the baseline's rows
    assert "   none: the baseline already contains every effect of the catalogue" in out
    assert "   nothing to compare: no candidate effect" in out
    assert "4. Effects added by hand" in out and not any(x.startswith("   fitted:") for x in out)
    j = out.index("   where the final model still fails:")
    assert out[j + 1 : j + 3] == ["     nowhere: every row is within 2 sigma", "     - mode z too low"]
    assert out[j + 3 : j + 5] == ["", "<table 2>"]  # the final model's rows
    assert len(tables) == 3


def test_diagnosis_text_the_data_tell_the_top_apart(tables):
    d = full_diagnosis()
    d.ranking[0].indistinguishable_from = []
    out = lines_of(d)
    assert (
        "   yes: every other effect is worse by dAICc >= 2 and predicts these rows at least 3 sigma differently "
        "from payload_mass." in out
    )


def test_diagnosis_text_next_measurement(tables):
    nm = {
        "between": ("payload_mass", "tool_mass"),
        "pose": [0.1, 0.0, -0.6],
        "k_a": 1234.5678,
        "mode": "z",
        "predicted_hz": {"payload_mass": 12.345678, "tool_mass": 12.5},
        "separation_sigma": 4.04,
        "sigma_hz": 0.0123456,
        "with_measured_modes": {
            "pose": [0.0, 0.0, -0.6],
            "k_a": 500.0,
            "mode": "x",
            "predicted_hz": {"payload_mass": 8.0, "tool_mass": 8.1},
            "separation_sigma": 2.96,
        },
    }
    out = lines_of(full_diagnosis(next_measurement=nm))
    i = out.index("3. Can the data tell them apart?")
    assert out[i + 2] == (
        "   measurement that separates payload_mass and tool_mass best: pose [0.1, 0, -0.6] m, k_a = 1235 N m/rad, "
        "mode z: 12.35 vs 12.5 Hz (4.0 sigma apart at sigma = 0.0123 Hz)"
    )
    assert out[i + 3] == (
        "   with a mode you already measure: pose [0, 0, -0.6] m, k_a = 500 N m/rad, mode x: 8 vs 8.1 Hz (3.0 sigma)"
    )
    nm["k_a_unit"] = "N/m"
    nm["with_measured_modes"]["mode"] = "z"  # the same mode: said once
    out = lines_of(full_diagnosis(next_measurement=nm))
    assert out[i + 2].endswith("k_a = 1235 N/m, mode z: 12.35 vs 12.5 Hz (4.0 sigma apart at sigma = 0.0123 Hz)")
    assert out[i + 3] == ""
    nm["with_measured_modes"].update(mode="y")
    out = lines_of(full_diagnosis(next_measurement=nm))
    assert "k_a = 500 N/m, mode y" in out[i + 3]
    nm["with_measured_modes"]["k_a_unit"] = "N m/rad"
    out = lines_of(full_diagnosis(next_measurement=nm))
    assert "k_a = 500 N m/rad, mode y" in out[i + 3]


def test_diagnosis_text_removals_bounds_anomalies_outliers(tables, monkeypatch):
    removal = Removal("hose", 0.2345, 1.0, 2.0, ("payload_mass",), None)
    anomalies = [
        NS(what="k_a", best_k_a=1012.345, best_pose=[0.0, 0.0, -0.6], lines=[5, 6, 7], k_a=1500.0),
        NS(what="pose", best_k_a=1500.0, best_pose=[0.06, -0.04, -0.6], lines=[8, 9], k_a=1500.0),
    ]
    outliers = [Outlier(17, 1000.0, "x", 23.456, 5.04)]
    d = full_diagnosis(
        removed=[removal],
        setting_anomalies=anomalies,
        outliers=outliers,
        all_rows=NS(selected=[], final=fit_of()),
        uncertainty=Uncertainty("consistent", 1.23456, 29.0, 29),
    )
    d.final.at_bound = ("m_p", "k_E_rot")
    monkeypatch.setattr(vd, "damping_support", lambda d, ev: {"x": 1})
    monkeypatch.setattr(vd, "damping_sentence", lambda s: "Damping supported: " + "word " * 40 + "end.")
    out = lines_of(d)
    assert "   hose removed: not needed once payload_mass was added (p = 0.23 against the model without it)" in out
    assert (
        "   warning: m_p, k_E_rot ended at the edge of the search range (default/1000 ... 1000 x default, within "
        "physical bounds): the value is not physically meaningful" in out
    )
    k = next(i for i, x in enumerate(out) if x.startswith("   Damping supported:"))
    assert len(out[k]) <= 100 and out[k + 1].startswith("     word") and out[k + 2].startswith("     word")
    assert all(len(x) <= 100 for x in out[k : k + 3]) and out[k + 2].endswith("end.")
    assert out[k + 3] == "   stated uncertainty: consistent (Birge ratio sqrt(chi2/nu) = 1.23)"
    assert out[k + 4 : k + 6] == [
        "   setting set aside: lines 5, 6, 7 (k_a = 1500) fit k_a = 1012 far better",
        "   setting set aside: lines 8, 9 (k_a = 1500) fit pose [0.06, -0.04, -0.6] far better",
    ]
    assert out[k + 6 : k + 8] == [
        "   outliers set aside (CSV line, header = 1):",
        "     line 17: mode x, k_a = 1000 N m/rad, 23.46 Hz, +5.0 sigma",
    ]
    assert out[k + 8 : k + 10] == ["", "criteria:"]


def test_diagnosis_text_without_a_damping_sentence(tables, monkeypatch):
    monkeypatch.setattr(vd, "damping_support", lambda d, ev: None)
    monkeypatch.setattr(vd, "damping_sentence", lambda s: "")
    out = lines_of(full_diagnosis())
    assert out[21] == ""


# -- the survivors of a first mutation run ----------------------------------------------------------------------


def test_a_comparison_without_shapes_or_with_one_row(tables):
    cmp = comparison(n=1, failing=(True,))
    del cmp.mac  # a comparison that never had mode shapes
    vd.comparison_table(cmp)
    ((headers, rows, _),) = tables
    assert "MAC" not in headers and headers[2] == "pose [m]" and rows[0][0] == 2


def test_lists_are_joined_with_their_separators(tables):
    c = candidate("tube_modulus", 1e-4, implausible={"E_l1": 3.3e12, "free": 2.0}, at_bound=("E_l1", "m_p"))
    c.plausible_range = {"E_l1": RANGES["E_l1"], "free": (0.0, 1.0)}
    assert vd._needs(c, EV) == (
        "needs E_l1 = 3.3e+12 Pa (at the search bound), plausible 4e+10 ... 2.5e+11 Pa; needs free = 2 , "
        "plausible 0 ... 1 "
    )
    b = candidate("hose", 0.1, values={"k_E_rot": 1.0}, at_bound=("k_E_rot", "m_p"), ties=["a", "b"])
    vd._ranking_table([b], EV)
    assert tables[0][1][0][8] == "at search bound: k_E_rot, m_p; ~ a, b"
    d = diag(final=fit_of(chi2=10.0), explained=False, implausible={"E_l1": (1.0, (0, 1)), "m_p": (1.0, (0, 1))})
    assert "only with E_l1, m_p outside the plausible range" in vd._head(d)
    final = fit_of(aicc=10.0)
    bad = [candidate(e, 1e-6, implausible={"E_l1": 1e13}) for e in ("tube_a", "tube_b")]
    d = diag(final=final, steps=[Step(final, ranking=bad)])
    assert vd._implausible_sentence(d, EV) == (
        "Only implausible fits would explain more: tube_a needs E_l1 = 1e+13 Pa, plausible 4e+10 ... 2.5e+11 Pa; "
        "tube_b needs E_l1 = 1e+13 Pa, plausible 4e+10 ... 2.5e+11 Pa"
    )


def test_why_sentences_in_full():
    d = diag(explained=False, manual=True)
    assert vd._why(d) == (
        "The effects added by hand are not enough; run without --add to let the catalogue be searched, or an effect "
        "outside the catalogue is missing (or the stated uncertainties are too small)"
    )
    d = diag(explained=False, alternatives=[Alternative(("a",), None, "hose", None)])
    assert vd._why(d) == (
        "Catalogue effects would explain it, but these rows cannot show it significantly (below), or the stated "
        "uncertainties are too small"
    )


def test_an_unproven_effect_takes_only_its_own_next_measurement():
    swap = Alternative(("b",), "payload_mass", "tool_mass", None, next_measurement={"message": "theirs"} | NM)
    d = diag(alternatives=[swap, Alternative(("a",), None, "hose", None)], meas=Rows(freq_hz=np.zeros(20)))
    assert vd._alternatives_sentence(d).startswith(
        "hose would explain the data, but not significantly with 20 rows; measure more. payload_mass or tool_mass"
    )


NM = {"mode": "z", "pose": [0.0, 0.0, -0.6], "k_a": 1000.0, "separation_sigma": 3.0}


@pytest.fixture
def no_default_evaluator(monkeypatch):
    """The robot's evaluator, where the text loads it itself: EV, and the robots asked for."""
    import eigentwist.diagnose.evaluators as evaluators

    asked = []

    def evaluator(robot):
        asked.append(robot)
        return EV

    monkeypatch.setattr(evaluators, "evaluator", evaluator)
    return asked


def test_verdict_text_loads_the_robots_evaluator_only_without_one(no_default_evaluator, monkeypatch):
    import eigentwist.diagnose.scope as scope

    evs = []
    monkeypatch.setattr(scope, "sentence", lambda ev, item, values, model: evs.append(ev))
    d = diag(robot="delta", final=fit_of(chi2=10.0, effects=("a",)))
    assert vd.verdict_text(d) == vd._head(d) and no_default_evaluator == ["delta"] and evs == [EV]
    other = FakeEv()
    vd.verdict_text(d, other)
    assert no_default_evaluator == ["delta"] and evs == [EV, other]


def test_the_reason_at_one_degree_of_freedom_and_at_none():
    d = diag(final=fit_of(chi2=100.0, n=2, k=1), explained=False)
    assert vd.verdict_text(d, EV).startswith(vd._head(d) + ". Every catalogue effect this robot has is already")
    d = diag(final=fit_of(chi2=100.0, n=1, k=1), explained=False)
    assert vd.verdict_text(d, EV) == vd._head(d)


def test_verdict_text_formats_the_all_rows_values_with_its_evaluator():
    d = diag(
        final=fit_of(chi2=10.0),
        outliers=[Outlier(17, 1000.0, "x", 23.5, 5.0)],
        all_rows=NS(selected=["payload_mass"], final=fit_of(values={"m_p": 0.31}, std={"m_p": 0.012})),
    )
    assert vd.verdict_text(d, EV).endswith("(with every row the selection is payload_mass (m_p = 0.31 ± 0.012 kg))")


def test_diagnosis_text_of_models_without_effects_and_changed_parameters(tables, no_default_evaluator, monkeypatch):
    import eigentwist.diagnose.scope as scope

    evs = []
    monkeypatch.setattr(scope, "sentence", lambda ev, item, values, model: evs.append(ev))
    d = full_diagnosis()
    d.baseline.effects = ()
    d.final.effects = ()
    d.parameters = [
        dict(name="m_p", value=0.3, unit="kg", default=0.0, source="fitted", differs=True, active=True, effect="p"),
        dict(name="l2", value=0.5, unit="m", default=0.4, source="column", differs=True, active=False, effect="q"),
    ]
    out = lines_of(d)
    assert out[0] == "heli4: 30 measured frequencies from lab.csv; baseline: (no effect)"
    assert out[1] == "parameters changed from heli4's defaults: l2 = 0.5 m (default 0.4, column, q is off)"
    assert "   final model: (no effect); RMS 0.50 %, max 1.25 %" in out
    assert no_default_evaluator == [] and evs == []
    d.final.effects = ("a@1",)
    lines_of(d)
    assert no_default_evaluator == [] and evs == [EV, EV]  # the model's sentences and the verdict's


def test_diagnosis_text_ties_joined(tables):
    d = full_diagnosis()
    d.ranking[0].indistinguishable_from = ["tool_mass", "hose"]
    assert "   payload_mass and tool_mass, hose explain these data equally well" in " ".join(lines_of(d))


def test_diagnosis_text_damping_of_this_diagnosis_kept_whole(tables, monkeypatch):
    support = {"x": 1}
    monkeypatch.setattr(vd, "damping_support", lambda d, ev: support if ev is EV else None)
    long = "u" * 120
    monkeypatch.setattr(vd, "damping_sentence", lambda s: f"Damping supported: {long} end." if s is support else "")
    out = lines_of(full_diagnosis())
    k = out.index("   Damping supported:")
    assert out[k + 1 : k + 3] == [f"     {long}", "     end."]  # a word longer than a line is not broken
