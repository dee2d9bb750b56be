"""The answer first: what a diagnosis found, in at most :data:`MAX_LINES` lines.

In this order, each a short sentence wrapped at :data:`WIDTH` characters:

1. the verdict: explained or not, chi2/nu, p, the RMS error before and after (a model that
   needs a value outside its plausible range is never explained); why not, or, when the only
   explanation is implausible, the inputs to check (:func:`check_inputs`);
2. what was added, where (all legs, leg N) and its fitted values ± standard errors with units;
   where a damping effect was selected or tested, which damping effects the data support and,
   where two fit alike, the measurement that separates them (:mod:`.damping_support`);
3. what these data cannot tell apart (mirror images at the measured poses grouped,
   :mod:`.mirror`);
4. outliers, settings set aside and the verdict on the stated uncertainty, as a sentence;
5. the one next measurement.

:func:`answer` returns the lines and their parts as plain data (JSON key ``answer``); the
CLI prints ``lines``, the HTML report shows the parts. The full ranking, the residual
patterns and the criteria are in ``eigentwist diagnose --details`` and the JSON.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from ..description.effects import split_scope
from ..text import format_estimate
from . import scope
from .damping_support import damping_sentence, damping_support
from .plausible import is_plausible
from .mirror import collapse, group_label, mirror_groups
from .stats import gof_p_value

__all__ = ["answer", "answer_text", "uncertainty_sentence", "check_inputs", "WIDTH", "MAX_LINES", "DAMPING_LINES"]

WIDTH = 100  # characters per line of the default output
MAX_LINES = 8  # lines of the answer block
DAMPING_LINES = 4  # further lines where the answer has a damping part
MAX_TIES = 2  # subsets of the search named beside the selected one (the rest: the JSON's search.ties)


def _pose(p) -> str:
    unit = "m" if len(p) == 3 else "m, rad"
    return "[" + ", ".join(f"{v:g}" for v in np.round(p, 4)) + f"] {unit}"


def _verdict(d) -> str:
    f = d.final
    rms = f"RMS {d.baseline.rms_pct:.3g} % -> {f.rms_pct:.3g} %"
    if f.dof <= 0:
        return f"Cannot judge: the final model has {f.k} fitted parameters for {f.n} rows; {rms}."
    p = gof_p_value(f.chi2, f.n, f.k)
    stat = f"chi2/nu = {f.chi2:.3g}/{f.dof} = {f.chi2 / f.dof:.3g}"
    if d.explained:
        return f"Explained within the stated sigma ({stat}, p = {p:.2g}); {rms}."
    if getattr(d, "implausible", None) and p > d.alpha:
        names = ", ".join(d.implausible)
        return f"NOT explained: it fits ({stat}, p = {p:.2g}) only with {names} outside the plausible range; {rms}."
    return f"NOT explained within the stated sigma ({stat}, p = {p:.2g}); {rms}."


def _value(v: float, unit: str) -> str:
    return f"{v:.3g} {unit}".rstrip() if unit not in ("-", "") else f"{v:.3g}"


def check_inputs(d, ev) -> str | None:
    """When the only explanation is implausible (a value of the final model outside its plausible
    range, or a candidate that would be significant but for its value), the inputs to check: its
    fitted value beside the effect's other, given parameters (the tube's radii beside its modulus)."""
    found = None
    if getattr(d, "implausible", None):
        name, (value, rng) = next(iter(d.implausible.items()))
        owner = _owner(ev, d.final.effects, name)
        found = (owner, name, value, rng, d.final)
    elif not d.explained and not d.manual:
        from .significance import significant

        last = d.steps[-1].ranking
        for c in last:
            if c.plausible or not significant(c, d.final, len(last), d.alpha, False):
                continue
            own = {n: v for n, v in c.implausible.items() if n in c.names} or c.implausible
            name, value = next(iter(own.items()))
            found = (c.effect, name, value, tuple(ev.parameter(name).plausible_range), c.fit)
            break
    if found is None or found[0] is None:
        return None
    effect, name, value, (lo, hi), f = found
    base, legs = split_scope(effect)
    unit = ev.parameter(name).unit
    fitted = set(f.names)
    given = []
    for n in scope.parameter_names(ev, effect):
        if n in fitted or n == name or not ev.accepts(n):
            continue
        v = f.fixed.get(n, f.fixed.get(n.partition("@")[0], ev.parameter(n).default))
        given.append((n, float(v), ev.parameter(n).unit))
    component = getattr(ev.robot.effect(base), "component", "") or base
    what = "dimensions" if any(u == "m" for _, _, u in given) else "values"
    with_given = (" with " + ", ".join(f"{n} = {_value(v, u)}" for n, v, u in given)) if given else ""
    return (
        f"Check the inputs: {effect} needs {name} = {_value(value, unit)} (plausible {lo:.3g} ... "
        f"{_value(hi, unit)}){with_given}: check the {component}'s {what}."
    )


def _why(d, short: bool = False) -> str:
    """Why the final model misfits, in one sentence (the long form: :func:`.report.verdict_text`)."""
    u = d.uncertainty
    if d.manual:
        return "Why: the effects added by hand are not enough (run without --add to search the catalogue)."
    if u is not None and u.verdict == "too few rows":
        return "Why: too few rows to tell a missing effect from the stated uncertainty."
    if any(a.replaced is None for a in d.alternatives):
        return "Why: catalogue effects would explain it, but not significantly with these rows."
    if u is not None and u.verdict == "understated":
        return "Why: the residuals look like noise: the stated uncertainty is too small."
    pattern = f"; systematic: {'; '.join(u.pattern)}" if u is not None and u.pattern and not short else ""
    return f"Why: an effect outside the catalogue is missing (none in it helps further{pattern})."


def _ranges(ev, names) -> dict:
    return {n: tuple(ev.parameter(n).plausible_range) for n in names if ev.accepts(n)}


def _owner(ev, effects, name: str) -> str | None:
    for e in effects:
        if name in scope.parameter_names(ev, e):
            return e
    return None


def added_effects(d, ev) -> list[dict]:
    """Each effect the final model has beyond the baseline: name, legs, fitted values."""
    base = set(d.baseline.effects)
    effects = [e for e in d.final.effects if e not in base]
    out = []
    for e in effects:
        names = [n for n in d.final.names if _owner(ev, [e], n) == e]
        params = []
        for n in names:
            unit = ev.parameter(n).unit if ev.accepts(n) else ""
            value, std = d.final.values.get(n), d.final.std.get(n, math.inf)
            text = f"{n} = {format_estimate(value, std, unit)}"
            bounds = _ranges(ev, (n,)).get(n)
            plausible = is_plausible(value, std, bounds, n in d.final.at_bound)
            if not plausible and bounds:
                shown = "" if unit in ("-", "") else f" {unit}"  # a ratio's "-" is dropped, as in its value
                text += f" (IMPLAUSIBLE: plausible {bounds[0]:.2g} ... {bounds[1]:.2g}{shown})"
            params.append(
                {
                    "name": n,
                    "value": value,
                    "std": std,
                    "unit": unit,
                    "plausible": plausible,
                    "plausible_range": list(bounds) if bounds else None,
                    "text": text,
                }
            )
        leg_level = bool(getattr(ev.robot.effect(split_scope(e)[0]), "leg_level", False))
        out.append({"effect": e, "legs": scope.where(e), "leg_level": leg_level, "params": params})
    return out


def _where(legs) -> str:
    return "all legs" if not legs else ("leg " + " or ".join(str(k) for k in legs))


def _added(d, items: list[dict], groups) -> str:
    if not items:
        if d.manual:
            return "Added: nothing by hand."
        return "Added: nothing (no catalogue effect improves the baseline significantly)."
    parts = []
    for it in items:
        legs = list(it["legs"])
        label = it["effect"]
        g = next((g for g in groups if any(c.effect == label for c in g)), None)
        if g is not None and len(g) > 1 and legs:
            label = group_label([c.effect for c in g])
            legs = [split_scope(c.effect)[1] for c in g]
        values = ", ".join(p["text"] for p in it["params"]) or "switched on, nothing fitted"
        where = f" ({_where(legs)})" if it["leg_level"] else ""
        parts.append(f"{label}{where}: {values}")
    return ("Added by hand: " if d.manual else "Added: ") + "; ".join(parts) + "." + _removed(d)


def _removed(d) -> str:
    """Effects backward elimination took back (:class:`~.backward.Removal`), with its reason
    ("actuator_loss@2 removed: not needed once chain_spring was added")."""
    reasons = [r.reason for r in (getattr(d, "removed", None) or [])]
    return (" " + "; ".join(reasons) + ".") if reasons else ""


def _groups_at(d, k: int) -> list:
    """Mirror groups among the candidates of step ``k``'s ranking (the choice of step k + 1)."""
    ranking = d.steps[k].ranking if k < len(d.steps) and d.steps[k].ranking else (d.ranking if k == 0 else [])
    return mirror_groups(ranking, d.meas.sigma_hz) if ranking else []


def _added_groups(d) -> list:
    """The mirror groups of each effect the selection added, from the ranking it was chosen in."""
    out = []
    for k, s in enumerate(d.steps[1:]):
        out += [g for g in _groups_at(d, k) if any(c.effect == s.added for c in g)]
    return out


def _apart(d) -> tuple[list[str], bool]:
    """Sets of effects these data cannot tell apart, mirror images as one, and whether every
    one of them is a single model under several names (:func:`~.separate.equivalent`)."""
    sets = []
    for k, s in enumerate(d.steps[1:]):
        if s.added and s.alternatives:
            sets.append(([s.added] + list(s.alternatives), _groups_at(d, k)))
    first = _groups_at(d, 0)
    for a in d.alternatives:
        if a.replaced is None:
            continue
        pair = [a.replaced, a.by]
        if not any(set(pair) <= set(x) for x, _ in sets):
            sets.append((pair, first))
    unproven = [a.by for a in d.alternatives if a.replaced is None]
    if len(unproven) > 1:
        sets.append((unproven, _groups_at(d, len(d.steps) - 1)))
    out, equal = [], True
    same = {frozenset((a.replaced, a.by)) for a in d.alternatives if a.equivalent and a.replaced}
    for x, groups in sets:
        names = collapse(x, groups)
        if len(names) > 1:
            out.append(" or ".join(names))
            equal &= all(frozenset((x[0], b)) in same for b in x[1:])
        elif len(x) > 1:  # only mirror images: one effect, which leg is open
            out.append(f"{names[0]} (mirror images at the measured poses)")
            equal = False
    return out, equal and bool(out)


def uncertainty_sentence(u: dict | None, explained: bool) -> str:
    """The verdict on the stated uncertainty as a sentence (``u``: JSON ``uncertainty``)."""
    if not u:
        return "The stated uncertainty was not judged."
    b = u.get("birge_ratio")
    birge = "" if b is None or not math.isfinite(b) else f" (Birge ratio {b:.3g})"
    v = u.get("verdict")
    if v == "too few rows":
        return "Too few rows to judge the stated uncertainty."
    if v == "overstated":
        return f"The stated uncertainty looks overstated: the fit is better than it allows{birge}."
    if v == "understated":
        return f"The stated uncertainty looks understated{birge}; no effect is missing."
    if v == "cannot be judged" or (v == "consistent" and (u.get("possibly_understated") or not explained)):
        return f"The stated uncertainty cannot be judged: the misfit is systematic{birge}."
    if v == "consistent":
        return f"The stated uncertainty is consistent with the fit{birge}."
    return f"Stated uncertainty: {v}{birge}."


def _rows_sentence(d) -> str:
    parts = []
    if d.outliers:
        lines = ", ".join(str(o.line) for o in d.outliers)
        parts.append(f"Outlier(s) set aside: CSV line {lines}.")
    else:
        parts.append("No outliers.")
    for a in getattr(d, "setting_anomalies", None) or []:  # :class:`~.settings.SettingAnomaly`
        lines = ", ".join(str(x) for x in a.lines)
        if a.what == "k_a":
            what = f"k_a written {a.k_a:g}, its modes fit k_a = {a.best_k_a:.4g}"
        else:
            what = f"pose written {_pose(a.pose)}, its modes fit {_pose(a.best_pose)}"
        parts.append(f"Setting set aside: lines {lines} ({what}).")
    return " ".join(parts)


def _allowed(d) -> set:
    """Effects a next measurement may be about: the selected ones and their plausible
    alternatives (step ties and alternative final models), never one backward elimination removed."""
    names = set(d.selected) | {a for s in d.steps if s.added in d.selected for a in s.alternatives}
    names |= {e for a in d.alternatives for e in a.effects} | {a.by for a in d.alternatives}
    return names - {r.effect for r in (getattr(d, "removed", None) or [])}


def _about_allowed(nm, d) -> bool:
    allowed = _allowed(d) | set(d.baseline.effects)
    return all(e in allowed for side in nm["between"] for e in side.split(","))


def next_choice(d) -> dict | None:
    """The next measurement the answer proposes: between two models made of allowed effects
    (:func:`_allowed`), the selection's own first, then an alternative final model's; None."""
    options = [d.next_measurement] + [a.next_measurement for a in d.alternatives]
    return next((nm for nm in options if nm and _about_allowed(nm, d)), None)


def _runner_up(d):
    """The best other candidate of the step that added the last selected effect (None)."""
    for k in range(len(d.steps) - 1, 0, -1):
        s = d.steps[k]
        if s.added and s.added in d.selected:
            rest = [c for c in d.steps[k - 1].ranking if c.effect != s.added and c.plausible]
            return (s.added, rest[0]) if rest else None
    return None


def _next(d, ev, apart: list, equal: bool) -> str:
    nm = next_choice(d)
    if nm:
        a, b = nm["between"]
        pred = nm["predicted_hz"]
        return (
            f"Next: measure mode {nm['mode']} at {_pose(nm['pose'])}, k_a = {nm['k_a']:.4g} "
            f"{nm.get('k_a_unit', ev.parameter('k_a').unit)}: {a} {pred[a]:.4g} Hz, {b} "
            f"{pred[b]:.4g} Hz ({nm['separation_sigma']:.1f} sigma apart)."
        )
    u = d.uncertainty
    if u is not None and u.verdict == "too few rows":
        need = max(d.untestable.values()) if d.untestable else d.final.k + 3
        return (
            f"Next: measure more rows (at least {max(need - len(d.meas), 1)}): more k_a values, "
            "another pose or other mode directions."
        )
    if apart:
        if equal:
            return "Next: no measurement tells them apart: they are one model (equal frequencies everywhere)."
        return (
            "Next: no mode in the measured band and directions tells them apart: measure another "
            "direction or a wider band."
        )
    if not d.explained:
        fails = d.final.comparison.where_it_fails()
        if fails:
            w = fails[0]
            lo, hi = w["k_a_range"]
            unit = d.meas.k_a_unit
            ka = f"k_a = {lo:g} {unit}" if lo == hi else f"k_a {lo:g}-{hi:g} {unit}"
            return (
                f"Next: measure more where the final model still fails (mode {w['mode']}, {ka}, "
                f"{_pose(w['poses'][0])}): other poses at the same k_a."
            )
    ru = _runner_up(d)
    if ru is not None:
        added, other = ru
        return (
            f"Next: none needed: the data already tell {added} from the runner-up {other.effect} "
            f"(dAICc = {_gap(d, added, other):.3g})."
        )
    return "Next: no measurement needed to choose between the candidates."


def _gap(d, added: str, other) -> float:
    """AICc of ``other`` minus that of ``added`` in the ranking they were compared in."""
    for k in range(1, len(d.steps)):
        if d.steps[k].added == added:
            ranking = d.steps[k - 1].ranking
            mine = next((c.fit.aicc for c in ranking if c.effect == added), math.nan)
            return other.fit.aicc - mine
    return math.nan


def _wrap(text: str, width: int) -> list[str]:
    return textwrap.wrap(text, width=width, subsequent_indent="  ", break_on_hyphens=False, break_long_words=False) or [
        ""
    ]


def _lines(parts: dict, width: int) -> list[str]:
    out = []
    for key in ("verdict", "notes", "why", "added", "damping", "search", "apart", "rows", "next"):
        if parts[key]:
            out += _wrap(parts[key], width)
    return out


def answer(d, ev, width: int = WIDTH) -> dict:
    """The answer block of diagnosis ``d`` (see module doc): ``lines`` (at most
    :data:`MAX_LINES`, :data:`DAMPING_LINES` more with a damping part; each at most
    ``width`` characters), its parts (``damping``: the damping sentence, "" without one) and
    ``damping_support`` (:func:`~.damping_support.damping_support`: the damping effects
    supported and not, the pair that fits alike and the measurement that separates it; None
    when no damping effect was selected or tested)."""
    groups = _added_groups(d)
    items = added_effects(d, ev)
    u = (
        None
        if d.uncertainty is None
        else {k: getattr(d.uncertainty, k) for k in ("verdict", "birge_ratio", "possibly_understated")}
    )
    check = check_inputs(d, ev)
    parts = {
        "verdict": _verdict(d),
        "why": "" if d.explained or d.final.dof <= 0 else (check or _why(d)),
        "added": _added(d, items, groups),
    }
    apart, equal = _apart(d)
    search = getattr(d, "search", None)
    if search is not None and search.ties and not d.manual:  # subsets the search found as good
        chosen = " + ".join(e for e in d.final.effects if e not in d.baseline.effects) or "nothing"
        apart.append(" or ".join([chosen] + [" + ".join(t.effects) for t in search.ties[:MAX_TIES]]))
        equal = False
    if apart and equal:
        parts["apart"] = "One model under two names (equal frequencies everywhere): " + "; ".join(apart) + "."
    else:
        parts["apart"] = ("Cannot tell apart: " + "; ".join(apart) + ".") if apart else ""
    parts["search"] = getattr(d, "search", None) and d.search.sentence or ""
    parts["notes"] = " ".join(getattr(d, "notes", None) or [])
    parts["rows"] = _rows_sentence(d) + " " + uncertainty_sentence(u, d.explained)
    parts["next"] = _next(d, ev, apart, equal)
    support = damping_support(d, ev)
    parts["damping"] = damping_sentence(support)
    most = MAX_LINES + (DAMPING_LINES if parts["damping"] else 0)
    lines = _lines(parts, width)
    if len(lines) > most and parts["why"] and not check:
        parts["why"] = _why(d, short=True)
        lines = _lines(parts, width)
    if len(lines) > most:
        lines = lines[: most - 1] + ["  ... (the rest: --details)"]
    mirrors = [[c.effect for c in g] for g in _groups_at(d, 0) if len(g) > 1]
    unique = []
    for g in mirrors:
        if g not in unique:
            unique.append(g)
    return {
        "lines": lines,
        **parts,
        "effects": items,
        "cannot_tell_apart": apart,
        "mirror_images": unique,
        "damping_support": support,
    }


def answer_text(d, ev, width: int = WIDTH) -> str:
    """The answer block as the CLI prints it."""
    return "\n".join(answer(d, ev, width)["lines"])
