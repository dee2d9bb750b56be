"""Plain-text reports of a comparison and of a diagnosis (what the CLI prints).

:func:`verdict_text` is the diagnosis's verdict in sentences, the same in the text, the
JSON (``final.message``) and the HTML report.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from ..text import format_table
from .compare import FAIL_SIGMA
from .damping_support import damping_sentence, damping_support
from .stats import CRITERIA, gof_p_value
from .values import changed_text

__all__ = ["comparison_table", "comparison_summary", "failing_text", "diagnosis_text", "format_params", "verdict_text"]


def _pose(p) -> str:
    return "[" + ", ".join(f"{v:g}" for v in np.round(p, 4)) + "]"


def _pose_unit(p) -> str:
    """``m`` for a position, ``m, rad`` for a 6-DoF pose (position and rotation vector)."""
    return "m" if len(p) == 3 else "m, rad"


def format_params(values: dict, std: dict, ev) -> str:
    """``"k_E_rot = 374 ± 38 N m/rad, ..."``."""
    parts = []
    for name, v in values.items():
        unit = ev.parameter(name).unit if ev.accepts(name) else ""
        s = std.get(name, math.nan)
        err = f" ± {s:.2g}" if math.isfinite(s) else " ± (undetermined)"
        parts.append(f"{name} = {v:.4g}{err} {unit}".rstrip())
    return ", ".join(parts) if parts else "-"


#: rows a comparison table lists in full; a comparison of more rows lists its failing rows
#: (the first TABLE_ROWS of them, in file order) and says so (``--json`` has every row)
TABLE_ROWS = 2000


def comparison_table(cmp, limit: int = TABLE_ROWS) -> str:
    """One line per measurement: measured, predicted, error in % and in sigma (and the
    MAC of the mode shapes when the data have them); beyond ``limit`` rows, the failing
    rows only (at most ``limit``), under a line that says so."""
    m = cmp.meas
    mac = getattr(cmp, "mac", None)
    err_pct, err_sigma, failing = cmp.error_pct, cmp.error_sigma, cmp.failing
    shown = np.arange(len(m)) if len(m) <= limit else np.flatnonzero(failing)[:limit]
    rows = [
        [
            int(m.lines[i]),
            f"{m.k_a[i]:g}",
            _pose(m.poses[i]),
            m.mode[i],
            int(cmp.mode_index[i]) + 1,
            f"{m.freq_hz[i]:.4g}",
            f"{m.sigma_hz[i]:.3g}",
            f"{cmp.predicted[i]:.4g}",
            f"{err_pct[i]:+.2f}",
            f"{err_sigma[i]:+.2f}",
            "FAILS" if failing[i] else "",
        ]
        + ([] if mac is None else ["-" if np.isnan(mac[i]) else f"{mac[i]:.4f}"])
        for i in shown
    ]
    table = format_table(
        [
            "line",
            f"k_a [{m.k_a_unit}]",
            f"pose [{_pose_unit(m.poses[0]) if len(m) else 'm'}]",
            "mode",
            "model mode",
            "measured [Hz]",
            "sigma [Hz]",
            "predicted [Hz]",
            "error [%]",
            "error [sigma]",
            f"|err|>{FAIL_SIGMA:g}sigma",
        ]
        + ([] if mac is None else ["MAC"]),
        rows,
    )
    if len(shown) == len(m):
        return table
    n_fail = int(failing.sum())
    which = f"the {n_fail} failing rows" if n_fail <= limit else f"the first {limit} of the {n_fail} failing rows"
    return f"{len(m)} rows, more than {limit}: listed are {which} (--json prints every row)" + (
        "\n" + table if len(shown) else ""
    )


def comparison_summary(cmp) -> str:
    n_fail = int(np.sum(cmp.failing))
    return (
        f"RMS error {cmp.rms_pct:.2f} %, max {cmp.max_pct:.2f} % (error = (predicted - measured)/measured); "
        f"chi2 = {cmp.chi2:.1f} for {len(cmp.meas)} rows; {n_fail} of {len(cmp.meas)} rows fail "
        f"(|error| > {FAIL_SIGMA:g} sigma)"
    )


def failing_text(cmp) -> list[str]:
    out = []
    for w in cmp.where_it_fails():
        lo, hi = w["k_a_range"]
        unit = cmp.meas.k_a_unit
        ka = f"k_a = {lo:g} {unit}" if lo == hi else f"k_a {lo:g}-{hi:g} {unit}"
        poses = "; ".join(_pose(p) for p in w["poses"][:4]) + (" ..." if len(w["poses"]) > 4 else "")
        out.append(
            f"mode {w['mode']}: {w['rows']} of {w['of']} rows, {ka}, pose(s) {poses} {_pose_unit(w['poses'][0])}, "
            f"model {w['predicted']} (lines {', '.join(map(str, w['lines'][:12]))}"
            f"{' ...' if len(w['lines']) > 12 else ''})"
        )
    return out or ["nowhere: every row is within 2 sigma"]


def _ranking_table(ranking, ev) -> str:
    """One row per candidate, mirror images at the measured poses as one row
    (``transmission_compliance@1 or @2``, :mod:`.mirror`); long notes become footnotes."""
    from .mirror import collapse, group_label, mirror_groups

    groups = mirror_groups(ranking, ranking[0].fit.comparison.meas.sigma_hz) if ranking else []
    rank = {c.effect: k for k, c in enumerate(ranking)}
    rows = []
    for g in sorted(groups, key=lambda g: rank[g[0].effect]):
        c = g[0]
        note = []
        if len(g) > 1:
            note.append("mirror images (the same fit)")
        if not c.plausible:
            note.append("IMPLAUSIBLE: " + _needs(c, ev))
        elif c.fit.at_bound:
            note.append(f"at search bound: {', '.join(c.fit.at_bound)}")
        ties = [e for e in c.indistinguishable_from if e not in {m.effect for m in g}]
        if ties:
            note.append(f"~ {', '.join(collapse(ties, groups))}")
        rows.append(
            [
                rank[c.effect] + 1,
                group_label([m.effect for m in g]),
                format_params(c.params, c.param_std, ev),
                f"{c.fit.rms_pct:.2f}",
                f"{c.fit.max_pct:.2f}",
                f"{c.fit.aicc:.1f}",
                f"{0.0 if abs(c.delta_aicc) < 0.05 else c.delta_aicc:.1f}",
                "-" if c.p_value is None or not math.isfinite(c.p_value) else f"{c.p_value:.2g}",
                "; ".join(note),
            ]
        )
    return format_table(
        ["rank", "effect", "fitted (± std)", "RMS [%]", "max [%]", "AICc", "dAICc", "p-value", "notes (~: tied)"],
        rows,
        footnote=(8,),
    )


def _steps_table(steps) -> str:
    rows = []
    for k, s in enumerate(steps):
        rows.append(
            [
                k,
                s.change,
                ", ".join(s.fit.effects) or "(none)",
                f"{s.fit.rms_pct:.2f}",
                f"{s.fit.max_pct:.2f}",
                f"{s.fit.chi2:.1f}",
                "-" if s.p_value is None or not math.isfinite(s.p_value) else f"{s.p_value:.2g}",
                ", ".join(s.alternatives) or "-",
            ]
        )
    return format_table(
        ["step", "change", "effects", "RMS [%]", "max [%]", "chi2", "p-value", "equally good instead"], rows
    )


def _needs(c, ev) -> str:
    """``"E_l1 = 3.3e+12 Pa (plausible 4e+10 ... 2.5e+11 Pa)"`` for each implausible value of a candidate."""
    parts = []
    for name, value in c.implausible.items():
        unit = ev.parameter(name).unit if ev.accepts(name) else ""
        lo, hi = c.plausible_range.get(name, (math.nan, math.nan))
        bound = " (at the search bound)" if name in c.fit.at_bound else ""
        parts.append(f"needs {name} = {value:.3g} {unit}{bound}, plausible {lo:.3g} ... {hi:.3g} {unit}")
    return "; ".join(parts)


def _head(d) -> str:
    f = d.final
    if f.dof <= 0:
        return (
            f"cannot judge whether the final model explains the data: it has {f.k} fitted parameters for "
            f"{f.n} measurements (measure more)"
        )
    p = gof_p_value(f.chi2, f.n, f.k)
    stat = f"chi2 = {f.chi2:.1f} for {f.dof} degrees of freedom (reduced {f.reduced_chi2:.2f}, p = {p:.3g})"
    if d.explained:
        return f"the final model explains the data within the measurement uncertainty: {stat}"
    if getattr(d, "implausible", None) and p > d.alpha:
        return (
            f"the final model does NOT explain the data: it fits ({stat}) only with "
            f"{', '.join(d.implausible)} outside the plausible range"
        )
    return (
        f"the final model does NOT explain the data within the measurement uncertainty: {stat} <= alpha = {d.alpha:g}"
    )


def _why(d) -> str:
    """Why the final model misfits, in this order: rows, uncertainty, effects."""
    u = d.uncertainty
    last = d.steps[-1].ranking
    if d.manual:
        return (
            "The effects added by hand are not enough; run without --add to let the catalogue be searched, or "
            "an effect outside the catalogue is missing (or the stated uncertainties are too small)"
        )
    if u is not None and u.verdict == "too few rows":
        return "Too few rows to tell a missing effect from the stated uncertainty: measure more (below)"
    if any(a.replaced is None for a in d.alternatives):
        return (
            "Catalogue effects would explain it, but these rows cannot show it significantly (below), or the stated "
            "uncertainties are too small"
        )
    if u is not None and u.verdict == "understated":
        return (
            f"The residuals are {u.birge_ratio:.2g} times the stated uncertainty, without a systematic pattern, and "
            "no catalogue effect is significant: the stated uncertainties are too small (understated), rather than "
            "an effect missing"
        )
    if not last:
        why = (
            "Every catalogue effect this robot has is already in the model: an effect outside the catalogue is missing"
        )
    else:
        why = "No catalogue effect improves it significantly any more: an effect outside the catalogue is missing"
    if u is not None and u.pattern:
        why += f" (the residuals are systematic: {'; '.join(u.pattern)})"
    return why + ", or the stated uncertainties are too small"


def _too_few(d) -> str:
    n = len(d.meas)
    need = max(d.untestable.values()) if d.untestable else d.final.k + 3
    names = ", ".join(sorted(d.untestable)) or "the final model's goodness of fit"
    out = (
        f"Too few rows: with {n} rows, {names} cannot be tested (up to {need} rows needed; AICc is infinite "
        f"when n <= k + 2). Measure more: at least {need - n} more rows, e.g. more k_a values, another pose or "
        "the other mode directions"
    )
    if d.next_measurement:
        out += f"; the most informative: {d.next_measurement['message']}"
    return out


def _uncertainty_sentence(d) -> str | None:
    u = d.uncertainty
    if u is None or u.verdict in ("too few rows",):
        return None
    if u.verdict == "overstated":
        return (
            f"The stated uncertainties look overstated: the final model fits {1 / max(u.birge_ratio, 1e-12):.2g} "
            f"times better than they allow (Birge ratio sqrt(chi2/nu) = {u.birge_ratio:.2g}, P(chi2 <= "
            f"{u.chi2:.3g}) = {u.p_low:.2g}); with honest uncertainties smaller effects may become visible"
        )
    if u.verdict == "understated":
        return f"The stated uncertainties look understated by a factor of about {u.birge_ratio:.2g} (Birge ratio)"
    return None  # possibly understated: said in the reason for the misfit


def _outlier_sentence(d, ev) -> str | None:
    if not d.outliers:
        return None
    rows = "; ".join(
        f"line {o.line} (mode {o.mode}, k_a = {o.k_a:g} {d.meas.k_a_unit}, {o.freq_hz:.4g} Hz, "
        f"{o.residual_sigma:+.1f} sigma)"
        for o in d.outliers
    )
    text = f"Isolated outlier(s) set aside: {rows}; the selection and fitted values above are without them"
    a = getattr(d, "all_rows", None)
    if a is None:  # the diagnosis with every row was not run
        return text
    with_all = f"with every row the selection is {', '.join(a.selected) or 'nothing'}" + (
        f" ({format_params(a.final.values, a.final.std, ev)})" if a.final.values else ""
    )
    return f"{text} ({with_all})"


def _alternatives_sentence(d) -> str | None:
    parts = []
    unproven = [a.by for a in d.alternatives if a.replaced is None]
    if unproven:
        text = (
            f"{' or '.join(unproven)} would explain the data, but not significantly with {len(d.meas)} rows"
            + (": these data cannot tell them apart" if len(unproven) > 1 else "")
            + "; measure more"
        )
        nm = next((a.next_measurement for a in d.alternatives if a.replaced is None and a.next_measurement), None)
        if nm:
            text += f" ({nm['message']})"
        parts.append(text)
    for a in d.alternatives:
        if a.replaced is None:
            continue
        text = f"{a.replaced} or {a.by}: these data cannot tell them apart"
        if a.equivalent:
            text = f"{a.replaced} and {a.by} are one model under two names (the same frequencies at every pose and k_a)"
        nm = a.next_measurement
        if nm:
            pose = ", ".join(f"{v:g}" for v in np.round(nm["pose"], 4))
            text += (
                f"; measure mode {nm['mode']} at [{pose}] {_pose_unit(nm['pose'])} "
                f"with k_a = {nm['k_a']:.4g} {nm.get('k_a_unit', 'N m/rad')}, where they "
                f"differ by {nm['separation_sigma']:.1f} sigma"
            )
        parts.append(text)
    if not parts and d.ranking and (d.uncertainty is not None and d.uncertainty.verdict == "too few rows"):
        top = d.ranking[0]
        ties = [e for e in top.indistinguishable_from if e in {c.effect for c in d.ranking if c.plausible}]
        if ties:
            parts.append(f"{' or '.join([top.effect] + ties)}: these data cannot tell them apart")
    return ". ".join(parts) if parts else None


def _implausible_sentence(d, ev) -> str | None:
    from .significance import significant

    last = d.steps[-1].ranking
    bad = [c for c in last if not c.plausible and significant(c, d.final, len(last), d.alpha, plausible_only=False)]
    if not bad:
        return None
    return "Only implausible fits would explain more: " + "; ".join(f"{c.effect} {_needs(c, ev)}" for c in bad)


def component_sentences(d, ev) -> list[str]:
    """What each per-leg effect of the final model says about its leg's component
    ("leg 3's actuator delivers 0.45 of its commanded stiffness (the other legs 0.82)")."""
    from .scope import sentence

    f = d.final
    return [t for t in (sentence(ev, item, f.values, f.effects) for item in f.effects) if t]


def verdict_text(d, ev=None) -> str:
    """The verdict in sentences: explained or not and why, too few rows, the uncertainty,
    outliers, alternative final models, implausible fits, in this order."""
    if ev is None:
        from .evaluators import evaluator

        ev = evaluator(d.robot)
    head = _head(d)
    if not d.explained and d.final.dof > 0:
        head += ". " + _why(d)
    parts = [head] + component_sentences(d, ev)
    if d.uncertainty is not None and d.uncertainty.verdict == "too few rows":
        parts.append(_too_few(d))
    for sentence in (
        _uncertainty_sentence(d),
        _outlier_sentence(d, ev),
        _alternatives_sentence(d),
        _implausible_sentence(d, ev),
    ):
        if sentence:
            parts.append(sentence)
    return ". ".join(parts)


def diagnosis_text(d, ev, show_rows: bool = False) -> str:
    """The full diagnosis as text (sections 1-4: baseline, candidates, whether the data tell them apart, selection)."""
    m = d.meas
    out = [
        f"{d.robot}: {len(m)} measured frequencies from {m.source}; baseline: "
        f"{', '.join(d.baseline.effects) or '(no effect)'}"
    ]
    out += [changed_text([r for r in d.parameters if r["source"] != "fitted"], d.robot), ""]
    out += ["1. Baseline", "   " + comparison_summary(d.baseline), "   where it fails:"]
    out += ["     " + t for t in failing_text(d.baseline)]
    out += ["   residual pattern:"] + ["     - " + h for h in (d.hints or ["no clear pattern over k_a"])]
    if show_rows:
        out += ["", comparison_table(d.baseline)]
    out += ["", "2. Candidate effects, each fitted on top of the baseline (best first)"]
    if d.ranking:
        out += [_ranking_table(d.ranking, ev)]
    else:
        out += ["   none: the baseline already contains every effect of the catalogue"]
    out += ["", "3. Can the data tell them apart?"]
    top = d.ranking[0] if d.ranking else None
    if top and top.indistinguishable_from:
        out.append(
            f"   {top.effect} and {', '.join(top.indistinguishable_from)} explain these data equally well "
            "(dAICc < 2, or predictions less than 3 sigma apart in total on the measured rows): these data cannot "
            "tell them apart."
        )
    elif top:
        out.append(
            f"   yes: every other effect is worse by dAICc >= 2 and predicts these rows at least 3 sigma "
            f"differently from {top.effect}."
        )
    if not top:
        out.append("   nothing to compare: no candidate effect")
    nm = d.next_measurement
    if nm:
        a, b = nm["between"]
        out.append(
            f"   measurement that separates {a} and {b} best: pose {_pose(nm['pose'])} {_pose_unit(nm['pose'])}, "
            f"k_a = {nm['k_a']:.4g} {nm.get('k_a_unit', 'N m/rad')}, mode {nm['mode']}: "
            f"{nm['predicted_hz'][a]:.4g} vs {nm['predicted_hz'][b]:.4g} Hz "
            f"({nm['separation_sigma']:.1f} sigma apart at sigma = {nm['sigma_hz']:.3g} Hz)"
        )
        alt = nm.get("with_measured_modes")
        if alt and alt["mode"] != nm["mode"]:
            out.append(
                f"   with a mode you already measure: pose {_pose(alt['pose'])} {_pose_unit(alt['pose'])}, "
                f"k_a = {alt['k_a']:.4g} {alt.get('k_a_unit', nm.get('k_a_unit', 'N m/rad'))}, mode {alt['mode']}: "
                f"{alt['predicted_hz'][a]:.4g} vs {alt['predicted_hz'][b]:.4g} Hz "
                f"({alt['separation_sigma']:.1f} sigma)"
            )
    title = "4. Effects added by hand" if d.manual else "4. Forward selection (add the best significant effect, repeat)"
    out += ["", title, _steps_table(d.steps)]
    out += [f"   {r.reason} (p = {r.p_value:.2g} against the model without it)" for r in d.removed]
    f = d.final
    out.append(f"   final model: {', '.join(f.effects) or '(no effect)'}; RMS {f.rms_pct:.2f} %, max {f.max_pct:.2f} %")
    if f.values:
        out.append(f"   fitted: {format_params(f.values, f.std, ev)}")
    out += [f"   {text}" for text in component_sentences(d, ev)]
    if f.at_bound:
        out.append(
            f"   warning: {', '.join(f.at_bound)} ended at the edge of the search range (default/1000 ... "
            "1000 x default, within physical bounds): the value is not physically meaningful"
        )
    out.append(f"   {verdict_text(d, ev)}")
    damping = damping_sentence(damping_support(d, ev))
    if damping:
        out += textwrap.wrap(
            damping, width=100, initial_indent="   ", subsequent_indent="     ", break_long_words=False
        )
    u = d.uncertainty
    if u is not None:
        out.append(f"   stated uncertainty: {u.verdict} (Birge ratio sqrt(chi2/nu) = {u.birge_ratio:.3g})")
    for a in d.setting_anomalies:
        best = f"k_a = {a.best_k_a:.4g}" if a.what == "k_a" else f"pose [{', '.join(f'{v:g}' for v in a.best_pose)}]"
        out.append(
            f"   setting set aside: lines {', '.join(map(str, a.lines))} (k_a = {a.k_a:g}) fit {best} far better"
        )
    if d.outliers:
        out.append("   outliers set aside (CSV line, header = 1):")
        out += [
            f"     line {o.line}: mode {o.mode}, k_a = {o.k_a:g} {d.meas.k_a_unit}, {o.freq_hz:.4g} Hz, "
            f"{o.residual_sigma:+.1f} sigma"
            for o in d.outliers
        ]
    if not d.explained:
        out.append("   where the final model still fails:")
        out += ["     " + t for t in failing_text(f.comparison)]
        out += ["     - " + h for h in d.final_hints]
    if show_rows:
        out += ["", comparison_table(f.comparison)]
    out += ["", "criteria:"] + [f"   {k}: {v}" for k, v in CRITERIA.items()]
    return "\n".join(out)
