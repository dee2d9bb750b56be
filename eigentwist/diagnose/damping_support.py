"""Which damping effects the data support, and the measurement that separates two that fit alike.

When a diagnosis selected or tested a damping effect (catalogue primitive ``damping``: servo
damping, a torque lag, a structural loss factor; offered only for data that carry damping,
:func:`~.damping.carries_damping`), its answer states for each of them

* **supported**: selected into the final model, with the p-value that added it (its fitted
  values are the answer's ``Added``);
* **not supported**, with its p-value: its test on top of the latest model it was tried on
  (the final model where forward selection stopped), or the test that took it back
  (backward elimination);

and, where two damping explanations fit alike, the condition that separates them
(:func:`~.separate.damping_measurement`: the pose, k_a and mode where their damping ratios
or frequencies differ most in sigma). Two damping explanations fit alike when a damping
effect not supported, fitted on top of the final model, is plausible and within
``DELTA_AICC`` of it (the final model with and without it), or when a final alternative
(:class:`~.select.Alternative`) differs from the final model in a damping effect.
"""

from __future__ import annotations

import math

from ..description.effects import split_scope
from ..text import format_estimate
from . import scope
from .separate import damping_measurement
from .stats import DELTA_AICC

__all__ = ["is_damping", "damping_support", "damping_sentence", "PRIMITIVE"]

PRIMITIVE = "damping"  # the catalogue primitive of the damping effects


def is_damping(ev, effect: str) -> bool:
    """Whether ``effect`` (``EFFECT`` or ``EFFECT@N``) is a damping effect of the catalogue."""
    try:
        return getattr(ev.robot.effect(split_scope(effect)[0]), "primitive", None) == PRIMITIVE
    except KeyError:  # not an effect of the catalogue nor of the robot: not a damping effect
        return False


def _tested(d, ev) -> dict:
    """Damping effect name (without its leg) -> the candidate of the latest ranking that
    tried it (the variant with the lowest p-value among its legs)."""
    out = {}
    rankings = [s.ranking for s in d.steps if s.ranking] or [d.ranking]
    for ranking in rankings:  # later rankings replace earlier ones
        latest = {}
        for c in ranking:
            if not is_damping(ev, c.effect):
                continue
            base = split_scope(c.effect)[0]
            p = c.p_value if c.p_value is not None and math.isfinite(c.p_value) else math.inf
            if base not in latest or p < latest[base][0]:
                latest[base] = (p, c)
        out.update({b: c for b, (_, c) in latest.items()})
    return out


def _on_final(d, c) -> bool:
    """Whether candidate ``c`` was fitted on top of the final model."""
    return set(c.fit.effects) == set(d.final.effects) | {c.effect}


def _values(ev, f, names) -> list[dict]:
    out = []
    for n in names:
        unit = ev.parameter(n).unit if ev.accepts(n) else ""
        value, std = f.values.get(n), f.std.get(n, math.inf)
        out.append(
            {"name": n, "value": value, "std": std, "unit": unit, "text": f"{n} = {format_estimate(value, std, unit)}"}
        )
    return out


def _owned(ev, effect: str, name: str) -> bool:
    """Whether parameter ``name`` belongs to ``effect`` (its fitted values: the alike model's)."""
    return name in scope.parameter_names(ev, effect)


def _model_name(effects) -> str:
    return " + ".join(effects) if effects else "no damping"


def damping_support(d, ev) -> dict | None:
    """What the data say about damping (module doc), or None when no damping effect was
    selected or tested. Keys: ``given`` (damping effects of the baseline model, taken as
    given), ``by_hand`` (the effects were added by hand: ``--add``), ``supported``
    (``effect``, ``p_value``: the test that added it), ``not_supported`` (``effect``, ``p_value``, ``params``: the
    values it would take, ``delta_aicc``: its AICc on top of the final model minus the final
    model's, None when not fitted there, ``fits_alike``), ``alike`` (``between``: the two
    models' damping effects, ``delta_aicc``, ``added``: the effect the second model has on
    top of the first, None for an alternative that swaps effects) and ``measurement``
    (:func:`~.separate.damping_measurement` between them), both None when nothing fits alike.
    Computed once per diagnosis."""
    cached = vars(d).get("_damping_support", False)
    if cached is not False:
        return cached
    out = _support(d, ev)
    vars(d)["_damping_support"] = out
    return out


def _support(d, ev) -> dict | None:
    base = set(d.baseline.effects)
    mine = [e for e in d.final.effects if e not in base and is_damping(ev, e)]
    tested = _tested(d, ev)
    removed = {r.effect: r for r in (getattr(d, "removed", None) or []) if is_damping(ev, r.effect)}
    given = [e for e in d.baseline.effects if is_damping(ev, e)]
    if not mine and not tested and not removed:
        return None
    added_p = {s.added: s.p_value for s in d.steps if s.added}
    supported = [{"effect": e, "p_value": added_p.get(e)} for e in mine]
    taken = {split_scope(e)[0] for e in mine}
    not_supported, alike = [], []
    for name, c in tested.items():
        if name in taken or c.effect in removed:
            continue
        on_final = _on_final(d, c)
        gap = c.fit.aicc - d.final.aicc if on_final else None
        fits_alike = bool(on_final and c.plausible and gap is not None and gap < DELTA_AICC)
        own = list(c.names) + [n for e in mine for n in c.fit.names if n not in c.names and _owned(ev, e, n)]
        not_supported.append(
            {
                "effect": c.effect,
                "p_value": c.p_value,
                "params": _values(ev, c.fit, own),
                "delta_aicc": gap,
                "fits_alike": fits_alike,
            }
        )
        if fits_alike:
            alike.append((gap, c.fit, (_model_name(given + mine), _model_name(given + mine + [c.effect])), c.effect))
    for e, r in removed.items():
        not_supported.append({"effect": e, "p_value": r.p_value, "params": [], "delta_aicc": None, "fits_alike": False})
    for a in d.alternatives:
        swapped = [e for e in (a.replaced, a.by) if e]
        if any(is_damping(ev, e) for e in swapped) and a.fit is not None:
            other = [e for e in a.fit.effects if is_damping(ev, e)]
            alike.append((a.fit.aicc - d.final.aicc, a.fit, (_model_name(given + mine), _model_name(other)), None))
    not_supported.sort(key=lambda x: (not x["fits_alike"], _sortable(x["p_value"])))
    out = {
        "given": given,
        "by_hand": bool(d.manual),
        "supported": supported,
        "not_supported": not_supported,
        "alike": None,
        "measurement": None,
    }
    if alike:
        gap, fit_b, names, added = min(alike, key=lambda x: abs(x[0]))
        out["alike"] = {"between": list(names), "delta_aicc": gap, "added": added}
        out["measurement"] = damping_measurement(ev, d.meas, d.final, fit_b, names=names)
    return out


def _sortable(p) -> float:
    return p if p is not None and math.isfinite(p) else math.inf


def _p(p) -> str:
    return "p undetermined" if p is None or not math.isfinite(p) else f"p = {p:.2g}"


QUANTITY_WORDS = {
    "damping_ratio": "the damping ratio",
    "damped_hz": "the damped frequency",
    "natural_hz": "the frequency",
}


def _pose(p) -> str:
    return "[" + ", ".join(f"{v:g}" for v in (round(float(x), 4) for x in p)) + "] m"


def _measurement(m: dict, added: str | None) -> str:
    """The separating measurement as a sentence; ``added``: the effect one model has on top of
    the other (the values are then "without it" and "with it")."""
    a, b = m["between"]
    fmt = ".2g" if m["quantity"] == "damping_ratio" else ".4g"
    unit = "" if m["unit"] == "-" else f" {m['unit']}"
    va, vb = (format(m["predicted"][x], fmt) + unit for x in (a, b))
    what = "To tell them apart" if added else f"To tell {a} from {b}"
    values = f"{va} without {added}, {vb} with it" if added else f"{a} {va}, {b} {vb}"
    return (
        f"{what}, measure {QUANTITY_WORDS[m['quantity']]} of mode {m['mode']} at {_pose(m['pose'])}, "
        f"k_a = {m['k_a']:.4g} {m['k_a_unit']}: {values} ({m['separation_sigma']:.1f} sigma apart)."
    )


def damping_sentence(s: dict | None) -> str:
    """The answer's damping part from :func:`damping_support` ("" for None)."""
    if not s:
        return ""
    yes = [f"{x['effect']} ({_p(x['p_value'])})" if x["p_value"] is not None else x["effect"] for x in s["supported"]]
    no = []
    for x in s["not_supported"]:
        text = f"{x['effect']} ({_p(x['p_value'])}"
        if x["fits_alike"]:
            values = ", ".join(v["text"] for v in x["params"])
            text += f", fits as well with {values}" if values else ", fits as well"
        no.append(text + ")")
    text = f"Damping given: {', '.join(s['given'])}; " if s.get("given") else "Damping "
    text += "added by hand: " if s.get("by_hand") else "supported: "
    text += ", ".join(yes) if yes else "none"
    text += ("; not supported: " + ", ".join(no)) if no else ""
    text += "."
    m = s.get("measurement")
    if m:
        text += " " + _measurement(m, (s.get("alike") or {}).get("added"))
    elif s.get("alike"):
        a, b = s["alike"]["between"]
        text += f" No measured mode direction and k_a tells {a} from {b}."
    return text
