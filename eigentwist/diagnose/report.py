"""Plain-text reports of a comparison and of a diagnosis (what the CLI prints)."""
from __future__ import annotations

import math

import numpy as np

from ..text import format_table
from .compare import FAIL_SIGMA
from .stats import CRITERIA

__all__ = ["comparison_table", "comparison_summary", "failing_text", "diagnosis_text", "format_params"]


def _pose(p) -> str:
    return "[" + ", ".join(f"{v:g}" for v in np.round(p, 4)) + "]"


def format_params(values: dict, std: dict, ev) -> str:
    """``"k_E_rot = 374 ± 38 N m/rad, ..."``."""
    parts = []
    for name, v in values.items():
        unit = ev.parameter(name).unit if ev.accepts(name) else ""
        s = std.get(name, math.nan)
        err = f" ± {s:.2g}" if math.isfinite(s) else " ± (undetermined)"
        parts.append(f"{name} = {v:.4g}{err} {unit}".rstrip())
    return ", ".join(parts) if parts else "-"


def comparison_table(cmp) -> str:
    """One line per measurement: measured, predicted, error in % and in sigma (and the
    MAC of the mode shapes when the data have them)."""
    m = cmp.meas
    mac = getattr(cmp, "mac", None)
    rows = []
    for i in range(len(m)):
        rows.append([int(m.lines[i]), f"{m.k_a[i]:g}", _pose(m.poses[i]), m.mode[i], int(cmp.mode_index[i]) + 1,
                     f"{m.freq_hz[i]:.4g}", f"{m.sigma_hz[i]:.3g}", f"{cmp.predicted[i]:.4g}",
                     f"{cmp.error_pct[i]:+.2f}", f"{cmp.error_sigma[i]:+.2f}", "FAILS" if cmp.failing[i] else ""]
                    + ([] if mac is None else ["-" if np.isnan(mac[i]) else f"{mac[i]:.4f}"]))
    return format_table(["line", f"k_a [{m.k_a_unit}]", "pose [m]", "mode", "model mode", "measured [Hz]", "sigma [Hz]",
                         "predicted [Hz]", "error [%]", "error [sigma]", f"|err|>{FAIL_SIGMA:g}sigma"]
                        + ([] if mac is None else ["MAC"]), rows)


def comparison_summary(cmp) -> str:
    n_fail = int(np.sum(cmp.failing))
    return (f"RMS error {cmp.rms_pct:.2f} %, max {cmp.max_pct:.2f} % (error = (predicted - measured)/measured); "
            f"chi2 = {cmp.chi2:.1f} for {len(cmp.meas)} rows; {n_fail} of {len(cmp.meas)} rows fail "
            f"(|error| > {FAIL_SIGMA:g} sigma)")


def failing_text(cmp) -> list[str]:
    out = []
    for w in cmp.where_it_fails():
        lo, hi = w["k_a_range"]
        unit = cmp.meas.k_a_unit
        ka = f"k_a = {lo:g} {unit}" if lo == hi else f"k_a {lo:g}-{hi:g} {unit}"
        poses = "; ".join(_pose(p) for p in w["poses"][:4]) + (" ..." if len(w["poses"]) > 4 else "")
        out.append(f"mode {w['mode']}: {w['rows']} of {w['of']} rows, {ka}, pose(s) {poses} m, "
                   f"model {w['predicted']} (lines {', '.join(map(str, w['lines'][:12]))}"
                   f"{' ...' if len(w['lines']) > 12 else ''})")
    return out or ["nowhere: every row is within 2 sigma"]


def _ranking_table(ranking, ev) -> str:
    rows = []
    for k, c in enumerate(ranking):
        note = []
        if c.fit.at_bound:
            note.append(f"at search bound: {', '.join(c.fit.at_bound)}")
        if c.indistinguishable_from:
            note.append(f"~ {', '.join(c.indistinguishable_from)}")
        rows.append([k + 1, c.effect, format_params(c.params, c.param_std, ev), f"{c.fit.rms_pct:.2f}",
                     f"{c.fit.max_pct:.2f}", f"{c.fit.aicc:.1f}", f"{0.0 if abs(c.delta_aicc) < 0.05 else c.delta_aicc:.1f}",
                     "-" if c.p_value is None or not math.isfinite(c.p_value) else f"{c.p_value:.2g}",
                     "; ".join(note)])
    return format_table(["rank", "effect", "fitted (± std)", "RMS [%]", "max [%]", "AICc", "dAICc", "p-value",
                         "notes (~ indistinguishable from)"], rows)


def _steps_table(steps, ev) -> str:
    rows = []
    for k, s in enumerate(steps):
        rows.append([k, "+" + s.added if s.added else "baseline", ", ".join(s.fit.effects) or "(none)",
                     f"{s.fit.rms_pct:.2f}", f"{s.fit.max_pct:.2f}", f"{s.fit.chi2:.1f}",
                     "-" if s.p_value is None or not math.isfinite(s.p_value) else f"{s.p_value:.2g}"])
    return format_table(["step", "change", "effects", "RMS [%]", "max [%]", "chi2", "p-value"], rows)


def diagnosis_text(d, ev, show_rows: bool = False) -> str:
    """The full diagnosis as text (sections 1-4 of the issue)."""
    m = d.meas
    out = [f"{d.robot}: {len(m)} measured frequencies from {m.source}; baseline: "
           f"{', '.join(d.baseline.effects) or '(no effect)'}", ""]
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
        out.append(f"   {top.effect} and {', '.join(top.indistinguishable_from)} explain these data equally well "
                   "(dAICc < 2, or predictions less than 3 sigma apart in total on the measured rows): these data cannot "
                   "tell them apart.")
    elif top:
        out.append(f"   yes: every other effect is worse by dAICc >= 2 and predicts these rows at least 3 sigma "
                   f"differently from {top.effect}.")
    if not top:
        out.append("   nothing to compare: no candidate effect")
    nm = d.next_measurement
    if nm:
        a, b = nm["between"]
        out.append(f"   measurement that separates {a} and {b} best: pose {_pose(nm['pose'])} m, k_a = {nm['k_a']:.4g} "
                   f"{nm.get('k_a_unit', 'N m/rad')}, mode {nm['mode']}: {nm['predicted_hz'][a]:.4g} vs {nm['predicted_hz'][b]:.4g} Hz "
                   f"({nm['separation_sigma']:.1f} sigma apart at sigma = {nm['sigma_hz']:.3g} Hz)")
        alt = nm.get("with_measured_modes")
        if alt and alt["mode"] != nm["mode"]:
            out.append(f"   with a mode you already measure: pose {_pose(alt['pose'])} m, k_a = {alt['k_a']:.4g} "
                       f"{alt.get('k_a_unit', nm.get('k_a_unit', 'N m/rad'))}, mode {alt['mode']}: {alt['predicted_hz'][a]:.4g} vs {alt['predicted_hz'][b]:.4g} Hz "
                       f"({alt['separation_sigma']:.1f} sigma)")
    title = "4. Effects added by hand" if d.manual else "4. Forward selection (add the best significant effect, repeat)"
    out += ["", title, _steps_table(d.steps, ev)]
    f = d.final
    out.append(f"   final model: {', '.join(f.effects) or '(no effect)'}; RMS {f.rms_pct:.2f} %, max {f.max_pct:.2f} %")
    if f.values:
        out.append(f"   fitted: {format_params(f.values, f.std, ev)}")
    from .scope import sentence

    for item in f.effects:
        text = sentence(ev, item, f.values, f.effects)
        if text:
            out.append(f"   {text}")
    if f.at_bound:
        out.append(f"   warning: {', '.join(f.at_bound)} ended at the edge of the search range (default/1000 ... "
                   "1000 x default, within physical bounds): the value is not physically meaningful")
    out.append(f"   {d.message}")
    if not d.explained:
        out.append("   where the final model still fails:")
        out += ["     " + t for t in failing_text(f.comparison)]
        out += ["     - " + h for h in d.final_hints]
    if show_rows:
        out += ["", comparison_table(f.comparison)]
    out += ["", "criteria:"] + [f"   {k}: {v}" for k, v in CRITERIA.items()]
    return "\n".join(out)
