"""The JSON object of ``eigentwist diagnose --json``, rendered from a :class:`~.select.Diagnosis`.

Beside the baseline, ranking, steps and final model it holds ``steps[k].alternatives``,
``final.alternatives`` (lists of effect names), ``outliers``, ``uncertainty`` and, per
ranking entry, ``plausible`` and ``plausible_range``. ``answer`` is :func:`.answer.answer`:
its lines and parts, ``damping`` (the damping sentence) and ``damping_support``
(:func:`.damping_support.damping_support`: the damping effects supported and not, with
p-values, the two that fit alike and the measurement that separates them; null when no
damping effect was selected or tested).
"""

from __future__ import annotations

import json
from dataclasses import asdict

from ..text import json_safe as clean
from .stats import CRITERIA, gof_p_value

__all__ = ["diagnosis_json", "candidate_json", "step_json", "shape_json", "clean", "dumps"]


def dumps(obj, **kwargs) -> str:
    return json.dumps(obj, allow_nan=False, **kwargs)


def candidate_json(c) -> dict:
    f = c.fit
    return {
        "effect": c.effect,
        "where": c.where,
        "sentence": c.sentence,
        "params": c.params,
        "param_std": c.param_std,
        "rms_pct": f.rms_pct,
        "max_pct": f.max_pct,
        "aicc": f.aicc,
        "delta_aicc": c.delta_aicc,
        "p_value": c.p_value,
        "indistinguishable_from": list(c.indistinguishable_from),
        "chi2": f.chi2,
        "k": f.k,
        "at_bound": list(f.at_bound),
        "all_params": f.values,
        "all_param_std": f.std,
        "plausible": c.plausible,
        "plausible_range": {n: list(c.plausible_range[n]) for n in c.params},
        "implausible": c.implausible,
    }


def step_json(s) -> dict:
    f = s.fit
    return {
        "effects": list(f.effects),
        "added": s.added,
        "rms_pct": f.rms_pct,
        "max_pct": f.max_pct,
        "chi2": f.chi2,
        "k": f.k,
        "aicc": f.aicc,
        "p_value": s.p_value,
        "params": f.values,
        "param_std": f.std,
        "alternatives": list(s.alternatives),
        "removed": s.removed,
    }


def _final(d) -> dict:
    from .verdict import verdict_text

    f = d.final
    return {
        "effects": list(f.effects),
        "rms_pct": f.rms_pct,
        "max_pct": f.max_pct,
        "explained": d.explained,
        "chi2": f.chi2,
        "dof": f.dof,
        "implausible": {k: {"value": v, "plausible_range": list(r)} for k, (v, r) in d.implausible.items()},
        "p_value": gof_p_value(f.chi2, f.n, f.k),
        "params": f.values,
        "param_std": f.std,
        "message": verdict_text(d),
        "failing": f.comparison.where_it_fails(),
        "hints": d.final_hints,
        "alternatives": [list(a.effects) for a in d.alternatives],
        "alternatives_detail": [
            {
                "effects": list(a.effects),
                "replaces": a.replaced,
                "by": a.by,
                "params": a.fit.values,
                "param_std": a.fit.std,
                "aicc": a.fit.aicc,
                "next_measurement": a.next_measurement,
                "equivalent": a.equivalent,
            }
            for a in d.alternatives
        ],
        # alternatives that are the final model under another name (same frequencies everywhere)
        "equivalent": [[a.replaced, a.by] for a in d.alternatives if a.equivalent and a.replaced],
    }


def _uncertainty(u) -> dict:
    out = asdict(u)
    return {"verdict": out.pop("verdict"), "birge_ratio": out.pop("birge_ratio"), **out}


def shape_json(d):
    """The final model's mode-shape residual term (:func:`.shape_term.shape_term`), or None."""
    from .evaluators import evaluator
    from .shape_term import shape_term

    term = shape_term(d.meas, d.final.effects, evaluator(d.robot), d.final.fixed)
    return term and {k: v for k, v in term.items() if k != "residuals"}


def diagnosis_json(d) -> dict:
    """The diagnosis as one JSON-safe dict (see module doc)."""
    from .answer import answer
    from .evaluators import evaluator

    out = {
        "answer": answer(d, evaluator(d.robot)),  # the answer first: lines and their parts
        "robot": d.robot,
        "n_rows": len(d.meas),
        "source": d.meas.source,
        "baseline": {
            **d.baseline.summary(),
            "chi2": d.baseline.chi2,
            "failing": d.baseline.where_it_fails(),
            "hints": d.hints,
        },
        "ranking": [candidate_json(c) for c in d.ranking],
        "selected": list(d.selected),
        "steps": [step_json(s) for s in d.steps],
        "final": _final(d),
        "next_measurement": d.next_measurement,
        "outliers": [asdict(o) for o in d.outliers],
        "removed": [r.to_json() for r in d.removed],  # backward elimination
        "setting_anomalies": [a.to_json() for a in d.setting_anomalies],  # whole settings set aside
        "search": d.search.to_json() if d.search else None,  # the subset search off the stepwise path
        "uncertainty": _uncertainty(d.uncertainty) if d.uncertainty else None,
        "untestable": dict(d.untestable),
        "manual": d.manual,
        "alpha": d.alpha,
        "criteria": CRITERIA,
        "shapes": shape_json(d),  # measured mode shapes, else None
        "parameters": d.parameters,  # the values used: default, given (--set), data column, fitted
    }
    if d.all_rows is not None:
        a = d.all_rows
        out["all_rows"] = {
            "n_rows": len(a.meas),
            "selected": list(a.selected),
            "steps": [step_json(s) for s in a.steps],
            "final": _final(a),
            "uncertainty": _uncertainty(a.uncertainty) if a.uncertainty else None,
        }
    return clean(out)
