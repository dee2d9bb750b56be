"""Which catalogue effect is missing: rank candidates, select forward, say if explained.

``diagnose(meas, baseline)``:

1. compares the baseline (its parameters at their defaults) and describes where and how
   it fails (:mod:`~eigentwist.diagnose.patterns`);
2. fits every catalogue effect the robot has and the model lacks (its ``Effect.fit``
   parameters, jointly with those of effects selected before), ranks them by AICc and
   gives each an F-test p-value against the current model (:mod:`~.stats`);
3. marks candidates indistinguishable from the best and proposes the measurement that
   separates the best two (:mod:`~.separate`);
4. adds the best effect while it is significant (Bonferroni over the candidates of the
   step) and repeats; the final model is *explained* when its chi2 is consistent with
   the stated uncertainties, otherwise an effect outside the catalogue is missing.

An effect that shares parameters with one already in the model (two descriptions of the
same physical part, e.g. ``ee_compliance`` and ``ee_coupling``) is an alternative to it,
not an addition, and is not offered once the other is in.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from . import scope
from ..description.effects import EFFECTS, resolve_model
from .compare import Comparison, compare
from .evaluators import resolve
from .fit import FitResult, fit
from .predict import Predictor
from .patterns import classify, hints
from .separate import next_measurement
from .stats import ALPHA, CRITERIA, explained, f_test, gof_p_value, indistinguishable

__all__ = ["Candidate", "Step", "Diagnosis", "diagnose", "rank_candidates", "candidates_for"]

TIE = 0.01        # AICc differences below this are optimiser noise: ties keep catalogue order


@dataclass
class Candidate:
    """One effect fitted on top of the current model."""

    effect: str
    fit: FitResult
    p_value: float
    delta_aicc: float = 0.0
    indistinguishable_from: list = field(default_factory=list)
    signature: str | None = None
    own: tuple = ()
    sentence: str | None = None

    @property
    def params(self) -> dict:
        """Fitted values of this effect's own parameters (SI)."""
        return {k: self.fit.values[k] for k in self.own if k in self.fit.values}

    @property
    def where(self) -> list[int]:
        """Leg numbers the effect acts on alone (``[3]`` for ``EFFECT@3``), ``[]`` for all legs."""
        return scope.where(self.effect)

    @property
    def param_std(self) -> dict:
        return {k: self.fit.std[k] for k in self.params}

    def to_json(self) -> dict:
        return {"effect": self.effect, "where": self.where, "sentence": self.sentence,
                "params": self.params, "param_std": self.param_std,
                "rms_pct": self.fit.rms_pct, "max_pct": self.fit.max_pct, "aicc": self.fit.aicc,
                "delta_aicc": self.delta_aicc, "p_value": self.p_value,
                "indistinguishable_from": list(self.indistinguishable_from), "chi2": self.fit.chi2,
                "k": self.fit.k, "at_bound": list(self.fit.at_bound), "all_params": self.fit.values,
                "all_param_std": self.fit.std}


@dataclass
class Step:
    """The model after one step of the selection (the first step is the baseline)."""

    fit: FitResult
    added: str | None = None
    p_value: float | None = None
    ranking: list = field(default_factory=list)

    def to_json(self) -> dict:
        return {"effects": list(self.fit.effects), "added": self.added, "rms_pct": self.fit.rms_pct,
                "max_pct": self.fit.max_pct, "chi2": self.fit.chi2, "k": self.fit.k, "aicc": self.fit.aicc,
                "p_value": self.p_value, "params": self.fit.values, "param_std": self.fit.std}


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`; ``to_json()`` gives the issue's JSON object."""

    robot: str
    meas: object
    baseline: Comparison
    ranking: list
    selected: list
    steps: list
    final: FitResult
    explained: bool
    next_measurement: dict | None
    hints: list
    alpha: float = ALPHA
    manual: bool = False

    @property
    def final_comparison(self) -> Comparison:
        return self.final.comparison

    @property
    def final_hints(self) -> list:
        """Residual pattern of the final model (empty when it explains the data)."""
        return [] if self.explained else hints(self.final.comparison)

    @property
    def message(self) -> str:
        f = self.final
        if f.dof <= 0:
            return (f"cannot judge whether the final model explains the data: it has {f.k} fitted parameters for "
                    f"{f.n} measurements (measure more)")
        p = gof_p_value(f.chi2, f.n, f.k)
        stat = f"chi2 = {f.chi2:.1f} for {f.dof} degrees of freedom (reduced {f.reduced_chi2:.2f}, p = {p:.3g})"
        if self.explained:
            return (f"the final model explains the data within the measurement uncertainty: {stat}")
        head = f"the final model does NOT explain the data within the measurement uncertainty: {stat} <= alpha = {self.alpha:g}. "
        last = self.steps[-1].ranking
        if self.manual:
            why = ("The effects added by hand are not enough; run without --add to let the catalogue be searched, or "
                   "an effect outside the catalogue is missing")
        elif not last:
            why = "Every catalogue effect this robot has is already in the model: an effect outside the catalogue is missing"
        elif all(c.p_value is None or not math.isfinite(c.p_value) for c in last):
            why = (f"With {f.n} measurements no further effect can be tested (too few rows for its parameters); "
                   "measure more")
        else:
            why = "No catalogue effect improves it significantly any more: an effect outside the catalogue is missing"
        return head + why + " (or the stated uncertainties are too small)"

    def to_json(self) -> dict:
        f = self.final
        return _clean({
            "robot": self.robot, "n_rows": len(self.meas), "source": self.meas.source,
            "baseline": {**self.baseline.summary(), "chi2": self.baseline.chi2,
                         "failing": self.baseline.where_it_fails(), "hints": self.hints},
            "ranking": [c.to_json() for c in self.ranking],
            "selected": list(self.selected),
            "steps": [s.to_json() for s in self.steps],
            "final": {"effects": list(f.effects), "rms_pct": f.rms_pct, "max_pct": f.max_pct,
                      "explained": self.explained, "chi2": f.chi2, "dof": f.dof,
                      "p_value": gof_p_value(f.chi2, f.n, f.k), "params": f.values, "param_std": f.std,
                      "message": self.message, "failing": f.comparison.where_it_fails(),
                      "hints": self.final_hints},
            "next_measurement": self.next_measurement,
            "manual": self.manual, "alpha": self.alpha, "criteria": CRITERIA,
            "shapes": _shape_term(self),          # measured mode shapes (issue 14), else None
        })

    def json(self, **kwargs) -> str:
        return json.dumps(self.to_json(), allow_nan=False, **kwargs)

    def text(self, show_rows: bool = False) -> str:
        """The diagnosis as the plain-text report the CLI prints."""
        from .evaluators import evaluator
        from .report import diagnosis_text

        return diagnosis_text(self, evaluator(self.robot), show_rows)


def _shape_term(d: Diagnosis):
    """Hook: the final model's shape residual term (:func:`.shapes.shape_term`), or None."""
    from .evaluators import evaluator
    from .shapes import shape_term

    term = shape_term(d.meas, d.final.effects, evaluator(d.robot), d.final.fixed)
    return term and {k: v for k, v in term.items() if k != "residuals"}


def _clean(obj):
    """JSON-safe: numpy scalars to float, NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def candidates_for(ev, effects) -> list[str]:
    """Effects the robot has, not in ``effects`` and not an alternative to one of them;
    each leg-level effect also on each leg alone (``EFFECT@N``, :mod:`.scope`)."""
    return scope.candidates(ev, effects, per_leg=True)


def _own(ev, current: FitResult, effect: str) -> tuple:
    return tuple(p for p in scope.fit_names(ev, effect) if p not in current.names)


def _fit_candidate(meas, ev, current: FitResult, effect: str) -> FitResult:
    effects = scope.order(ev, current.effects + (effect,))
    own = _own(ev, current, effect)
    names = current.names + own
    return fit(meas, effects, ev, names, start=current.values, fixed=current.fixed, explore=own)


def rank_candidates(meas, ev, current: FitResult, candidates, progress=None) -> list[Candidate]:
    """Fit each candidate on top of ``current``; best (lowest AICc) first."""
    out = []
    items = progress(candidates, desc="fitting effects", leave=False) if progress else candidates
    for effect in items:
        f = _fit_candidate(meas, ev, current, effect)
        out.append(Candidate(effect, f, f_test(current.chi2, current.k, f.chi2, f.k, f.n), own=_own(ev, current, effect),
                             sentence=scope.sentence(ev, effect, f.values, f.effects)))
    order = list(candidates)
    out.sort(key=lambda c: (c.fit.aicc if math.isfinite(c.fit.aicc) else math.inf, order.index(c.effect)))
    for i in range(len(out) - 1):          # optimiser-noise ties: catalogue order
        for j in range(len(out) - 1 - i):
            a, b = out[j], out[j + 1]
            if abs(a.fit.aicc - b.fit.aicc) < TIE and order.index(b.effect) < order.index(a.effect):
                out[j], out[j + 1] = b, a
    if out:
        best = out[0]
        for c in out:
            c.delta_aicc = c.fit.aicc - best.fit.aicc
        for a in out:
            a.indistinguishable_from = [b.effect for b in out if b is not a and indistinguishable(
                a.fit.aicc, b.fit.aicc, a.fit.comparison.predicted, b.fit.comparison.predicted, meas.sigma_hz)]
        for c in out:
            c.signature = _signature(meas, ev, current, c.effect)
    return out


def _signature(meas, ev, current: FitResult, effect: str) -> str | None:
    """Shape (patterns.SHAPES) of what ``effect`` at its default values does to the mode it changes most."""
    with_effect, _ = Predictor(meas, scope.order(ev, current.effects + (effect,)), ev, current.fixed).predict(strict=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.log(with_effect / current.comparison.predicted)
    if not np.all(np.isfinite(rho)):
        return None
    labels = np.asarray(meas.mode)
    best = max(dict.fromkeys(meas.mode), key=lambda lb: float(np.sum(np.abs(rho[labels == lb]))))
    rows = labels == best
    if not np.any(np.abs(rho[rows]) > 1e-7):
        return None
    return classify(meas.k_a[rows], rho[rows], np.full(int(rows.sum()), 1e12))["shape"]


def _significant(best: Candidate, current: FitResult, m: int, alpha: float) -> bool:
    return (best.p_value is not None and math.isfinite(best.p_value) and best.p_value < alpha / max(m, 1)
            and best.fit.aicc < current.aicc)


def _separation(ev, meas, ranking) -> dict | None:
    if len(ranking) < 2:
        return None
    top = ranking[0]
    rival = next((c for c in ranking[1:] if c.effect in top.indistinguishable_from), ranking[1])
    out = next_measurement(ev, meas, top.fit, rival.fit)
    if out is not None:
        out["indistinguishable"] = rival.effect in top.indistinguishable_from
        a, b = out["between"]
        pose = ", ".join(f"{v:g}" for v in np.round(out["pose"], 4))
        out["message"] = (f"to tell {a} from {b}, measure mode {out['mode']} at pose [{pose}] m with k_a = "
                          f"{out['k_a']:.4g} {out['k_a_unit']}: {a} predicts {out['predicted_hz'][a]:.4g} Hz, {b} "
                          f"{out['predicted_hz'][b]:.4g} Hz ({out['separation_sigma']:.1f} sigma apart)")
    return out


def _effect_list(add, ev) -> list[str]:
    """Effects named in ``add`` (a comma-separated string or a list), in order, validated."""
    items = add.split(",") if isinstance(add, str) else list(add)
    names = [str(x).strip() for x in items if str(x).strip()]
    for name in names:
        if name.partition("@")[0] not in ev.effects and name.partition("@")[0] not in EFFECTS:
            raise ValueError(f"add {name!r}: not an effect; expected one of {', '.join(ev.effects)} (EFFECT@N for one leg)")
        resolve_model(name, ev.robot)  # raises if the robot lacks it
    return names


def diagnose(meas, baseline="rigid", robot: str | None = None, ev=None, add=None, alpha: float = ALPHA,
             progress=None, backend: str = "numpy") -> Diagnosis:
    """Diagnose what ``baseline`` misses on the measurements ``meas``.

    Parameters
    ----------
    meas : :class:`~eigentwist.diagnose.measurements.Measurements`, or a path to a CSV file.
    baseline : preset, comma-separated effects, or ``"none"``; its parameters stay at the
        defaults (or the data's columns).
    robot : robot name (default: the measurements' robot).
    add : effects to add by hand, in order (fitted, no automatic selection); None: forward
        selection.
    alpha : significance level (F test; goodness of fit for ``explained``).
    progress : optional wrapper of an iterable (e.g. ``eigentwist.cli.common.progress``).

    Returns
    -------
    :class:`Diagnosis`.
    """
    from .measurements import load_measurements

    if not hasattr(meas, "freq_hz"):
        meas = load_measurements(meas, robot or "heli4", ev)
    ev = resolve(ev, robot or meas.robot, backend)
    base_effects = resolve_model(baseline, ev.robot)
    base_cmp = compare(meas, base_effects, ev)                       # strict mode matching
    current = fit(meas, base_effects, ev, ())
    steps = [Step(current)]
    first = None
    manual = add is not None
    if manual:
        order = _effect_list(add, ev)
        model = list(current.effects)
        for e in order:
            if e in model:
                raise ValueError(f"add {e!r}: the effect is already in the model ({', '.join(model)})")
            shared = set(scope.parameter_names(ev, e)) & scope.taken(ev, model)
            if shared:
                raise ValueError(f"add {e!r}: it describes the same part as an effect already in the model "
                                 f"(shares {', '.join(sorted(shared))}); remove that one from the baseline instead")
            model.append(e)
        first = rank_candidates(meas, ev, current, candidates_for(ev, current.effects), progress)
        for e in order:
            f = _fit_candidate(meas, ev, current, e)
            steps.append(Step(f, e, f_test(current.chi2, current.k, f.chi2, f.k, f.n)))
            current = f
    else:
        while True:
            cands = candidates_for(ev, current.effects)
            if not cands:
                break
            ranking = rank_candidates(meas, ev, current, cands, progress)
            steps[-1].ranking = ranking
            if first is None:
                first = ranking
            best = ranking[0]
            if not _significant(best, current, len(cands), alpha):
                break
            steps.append(Step(best.fit, best.effect, best.p_value))
            current = best.fit
    first = first or []
    signatures = {c.effect: c.signature for c in first}
    return Diagnosis(
        robot=ev.spec, meas=meas, baseline=base_cmp, ranking=first,
        selected=[s.added for s in steps[1:]], steps=steps, final=current,
        explained=explained(current.chi2, current.n, current.k, alpha),
        next_measurement=_separation(ev, meas, first), hints=hints(base_cmp, signatures), alpha=alpha,
        manual=manual)
