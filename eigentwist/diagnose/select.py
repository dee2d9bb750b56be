"""Which catalogue effect is missing: rank candidates, select forward, name every tie.

``diagnose(meas, baseline)`` returns plain data (:class:`Diagnosis`); the text
(:mod:`.verdict`), the JSON (:mod:`.render_json`) and the HTML report render it.

1. **Too few rows** is decided before any ranking: a candidate with k parameters needs
   n > k + 2 rows (AICc is infinite otherwise); the ones that cannot be tested are named
   with the rows they need (:mod:`.misfit`).
2. The baseline (its parameters at their defaults) is compared and its residual pattern
   described (:mod:`.patterns`).
3. Every catalogue effect the robot has and the model lacks (:func:`candidates_for`) is
   fitted on top of the current model: its ``Effect.fit`` parameters, plus those the data
   identify (:mod:`.identifiable`, e.g. the payload offsets when rotational modes are
   measured), jointly with those selected before. Each gets an AICc, a p-value (F test; a
   switched effect without fitted parameters: the chi2_1 test of :func:`~.stats.switch_test`)
   and a plausibility verdict: a fitted value outside its parameter's ``plausible`` range
   by more than 3 standard errors, or at a search bound, makes the candidate
   *implausible*; it is reported with the value it would need and never selected.
4. Candidates are ranked by ``sorted`` with the explicit key (implausible last, AICc to
   0.01, catalogue position); every candidate indistinguishable from the one added
   (:func:`~.stats.indistinguishable`, on the frequencies and any measured damping ratios:
   :func:`~.damping.whitened_predictions`) is listed as that step's ``alternatives``, so no tie
   is broken silently. The best plausible candidate is added while it is significant
   (Bonferroni over the step's candidates) and lowers AICc.
   Then backward elimination (:mod:`.backward`): each selected effect is tested against
   the final model without it by the same rule, the least needed one that fails is
   removed (a step of the path, ``Step.removed``, with the reason in ``Diagnosis.removed``)
   and forward selection resumes on the smaller model, until stable.
5. The final model's alternatives: the ties along the path, each refitted as a whole
   model and kept when the data support it equally.
6. Outliers: isolated rows beyond the alpha/n threshold (:mod:`.misfit`) are set aside
   and the selection rerun without them; the all-rows result is kept beside. Then whole
   settings (pose x k_a) that fit the model at another k_a or pose far better than at
   their own (:mod:`.settings`) are set aside the same way.
7. The stated uncertainty is judged from the final model's Birge ratio (:mod:`.misfit`).

An effect that shares parameters with one already in the model (two descriptions of the
same physical part, e.g. ``ee_compliance`` and ``ee_coupling``) is an alternative to it,
not an addition, and is not offered once the other is in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import scope
from ..description.effects import EFFECTS, resolve_model
from ..description.names import did_you_mean
from ..runtime import InputError
from .compare import Comparison, compare
from .evaluators import resolve
from .damping import carries_damping, whitened_predictions
from .fit import FitResult, fit
from .backward import eliminate
from .identifiable import extra_parameters, sign_free, trial_value
from .matching import ModeMatchError
from .misfit import Uncertainty, find_outliers, judge_uncertainty, untestable
from .patterns import classify, hints
from .plausible import PLAUSIBLE_SIGMA  # noqa: F401 (re-exported: the rule's threshold)
from .plausible import is_plausible as _plausible
from .plausible import outside_plausible
from .predict import Predictor
from .separate import equivalent, next_measurement
from .search import SearchResult, search_subsets
from .settings import find_setting_anomalies, rescored
from .significance import significant
from .units import unit_note
from .stats import ALPHA, explained, f_test, indistinguishable, switch_test
from .values import used_parameters

__all__ = [
    "Candidate",
    "Step",
    "Alternative",
    "Diagnosis",
    "diagnose",
    "rank_candidates",
    "candidates_for",
    "MAX_OUTLIER_SHARE",
]

CANDIDATE_NFEV = 60  # solver budget of a candidate's fit: one the data do not want crawls towards its
# "switched off" limit (stiffness -> inf) without converging; the ones that matter need < 30
AICC_DIGITS = 2  # AICc differences below 0.01 are optimiser noise: the next key decides (and the tie is reported)
MAX_OUTLIER_SHARE = 0.1  # at most this share of the rows (and at least one) is set aside as outliers


@dataclass
class Candidate:
    """One effect fitted on top of the current model.

    names : this effect's own fitted parameters (its ``fit`` tuple and those the data
    identify); plausible_range : name -> (low, high) of every parameter of the fit.
    """

    effect: str
    fit: FitResult
    p_value: float
    names: tuple = ()
    plausible_range: dict = field(default_factory=dict)
    delta_aicc: float = 0.0
    indistinguishable_from: list = field(default_factory=list)
    signature: str | None = None
    sentence: str | None = None

    @property
    def params(self) -> dict:
        """Fitted values of this effect's own parameters (SI)."""
        return {k: self.fit.values[k] for k in self.names if k in self.fit.values}

    @property
    def where(self) -> list[int]:
        """Leg numbers the effect acts on alone (``[3]`` for ``EFFECT@3``), ``[]`` for all legs."""
        return scope.where(self.effect)

    @property
    def order(self) -> tuple:
        """Tie-break position: the catalogue's order, all legs before each leg alone."""
        return scope.rank(self.effect)

    @property
    def param_std(self) -> dict:
        return {k: self.fit.std[k] for k in self.params}

    @property
    def implausible(self) -> dict:
        """Fitted parameters at a search bound, or outside their plausible range by more than
        ``PLAUSIBLE_SIGMA`` standard errors: name -> the value it would need."""
        return {
            n: v
            for n, v in self.fit.values.items()
            if not _plausible(v, self.fit.std.get(n, math.inf), self.plausible_range.get(n), n in self.fit.at_bound)
        }

    @property
    def plausible(self) -> bool:
        return not self.implausible


@dataclass
class Step:
    """The model after one step of the selection (the first step is the baseline).

    alternatives : effects indistinguishable from ``added`` (plausible ones only).
    removed : the effect this step took out (backward elimination, :mod:`.backward`;
    ``p_value`` is then its test against the model without it).
    """

    fit: FitResult
    added: str | None = None
    p_value: float | None = None
    ranking: list = field(default_factory=list)
    alternatives: list = field(default_factory=list)
    removed: str | None = None

    @property
    def change(self) -> str:
        """``"+EFFECT"``, ``"-EFFECT"`` (removed) or ``"baseline"``."""
        return f"+{self.added}" if self.added else f"-{self.removed}" if self.removed else "baseline"


@dataclass
class Alternative:
    """A final model the data support as well as the one selected: ``replaced`` -> ``by``
    (``replaced`` None: ``by`` added to a final model that misfits, which it would explain
    though these rows cannot show it significantly). ``equivalent``: the evidence that the
    two are one model under two names (:func:`~.separate.equivalent`; then no
    ``next_measurement``), else None."""

    effects: tuple
    replaced: str | None
    by: str
    fit: FitResult
    next_measurement: dict | None = None
    equivalent: dict | None = None


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`: plain data; rendered by :mod:`.verdict` (text) and
    :mod:`.render_json` (``to_json()``).

    untestable : effect -> rows needed, for candidates these data have too few rows for.
    removed : :class:`~.backward.Removal` of each effect taken back by backward elimination.
    setting_anomalies : :class:`~.settings.SettingAnomaly` of each whole setting set aside.
    search : :class:`~.search.SearchResult` of the subset search (None: not run).
    implausible : the final model's fitted values outside their plausible range (name ->
    (value, (low, high))); such a model is never ``explained``.
    notes : one-line remarks on the input, each said once: the likely unit of frequencies
    that are ~1000 or ~2 pi times the model's (:mod:`.units`), rows matched by shape where
    the model's labels are ambiguous at a pose.
    alternatives : :class:`Alternative` final models. outliers : :class:`Outlier` rows
    set aside (the selection and fits are those without them); all_rows : the diagnosis
    with every row, when some were set aside. uncertainty : :class:`Uncertainty`.
    """

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
    parameters: list = field(default_factory=list)
    alternatives: list = field(default_factory=list)
    uncertainty: Uncertainty | None = None
    outliers: list = field(default_factory=list)
    all_rows: "Diagnosis | None" = None
    untestable: dict = field(default_factory=dict)
    removed: list = field(default_factory=list)
    setting_anomalies: list = field(default_factory=list)
    search: SearchResult | None = None
    implausible: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    @property
    def final_comparison(self) -> Comparison:
        return self.final.comparison

    @property
    def final_hints(self) -> list:
        """Residual pattern of the final model (empty when it explains the data)."""
        return [] if self.explained else hints(self.final.comparison)

    @property
    def message(self) -> str:
        """The verdict in sentences (rendered by :func:`.report.verdict_text`)."""
        from .verdict import verdict_text

        return verdict_text(self)

    def to_json(self) -> dict:
        """The JSON object of ``eigentwist diagnose --json`` (rendered by :mod:`.render_json`)."""
        from .render_json import diagnosis_json

        return diagnosis_json(self)

    def json(self, **kwargs) -> str:
        from .render_json import dumps

        return dumps(self.to_json(), **kwargs)

    def text(self, show_rows: bool = False) -> str:
        """The diagnosis as the plain-text report the CLI prints."""
        from .evaluators import evaluator
        from .verdict import diagnosis_text

        return diagnosis_text(self, evaluator(self.robot), show_rows)


def candidates_for(ev, effects, meas=None) -> list[str]:
    """Effects the robot has, not in ``effects`` and not an alternative to one of them;
    each leg-level effect also on each leg alone (``EFFECT@N``, :mod:`.scope`), so the
    multiple-test correction counts the per-leg candidates. A damping effect only where
    ``meas`` carries damping (:func:`.damping.carries_damping`)."""
    return scope.candidates(ev, effects, per_leg=True, damping=meas is None or carries_damping(meas))


def _starts(ev, names) -> tuple[dict, dict]:
    """Start values and screened starts of parameters the data identify: both signs of an offset."""
    start, starts = {}, {}
    for name in names:
        p = ev.parameter(name)
        start[name] = trial_value(p)
        if sign_free(p):
            starts[name] = (-start[name], start[name])
    return start, starts


def _fit_effect(meas, ev, current: FitResult, effect: str) -> tuple[FitResult, tuple]:
    """``effect`` fitted on top of ``current``: (fit, its own fitted parameter names)."""
    effects = scope.order(ev, current.effects + (effect,))
    own = tuple(p for p in scope.fit_names(ev, effect) if p not in current.names and p not in meas.params)
    f = fit(
        meas,
        effects,
        ev,
        current.names + own,
        start=current.values,
        fixed=current.fixed,
        explore=own,
        max_nfev=CANDIDATE_NFEV,
    )
    try:
        extra = extra_parameters(meas, ev, effects, effect, f.values, f.fixed)
        if not extra:
            return f, own
        start, starts = _starts(ev, extra)
        g = fit(
            meas,
            effects,
            ev,
            f.names + extra,
            start={**f.values, **start},
            fixed=f.fixed,
            explore=(),
            starts=starts,
            max_nfev=CANDIDATE_NFEV,
        )
    except InputError:  # the extra parameters left their joint constraints (r_i < r_o): not identifiable
        return f, own
    if not _determined(ev, g, f, extra) or (_implausible(ev, g) and not _implausible(ev, f)):
        return f, own  # the extra parameters ran away: keep what the data pin down
    if g.chi2 > f.chi2:
        return f, own  # the larger fit nests f yet ends worse: a local minimum, keep f
    return g, own + extra


def _determined(ev, g: FitResult, f: FitResult, extra) -> bool:
    """Whether the fit with the ``extra`` parameters still determines every parameter: each extra
    within a quarter of its plausible range, no other standard error inflated tenfold."""
    for name in extra:
        lo, hi = ev.parameter(name).plausible_range
        if not g.std[name] <= 0.25 * (hi - lo):
            return False
    return all(g.std[n] <= 10 * f.std[n] for n in f.names if math.isfinite(f.std[n]))


def _ranges(ev, names) -> dict:
    return {n: tuple(ev.parameter(n).plausible_range) for n in names}


def _implausible(ev, f: FitResult) -> bool:
    return not all(
        _plausible(v, f.std.get(n, math.inf), ev.parameter(n).plausible_range, n in f.at_bound)
        for n, v in f.values.items()
    )


def _candidate(meas, ev, current: FitResult, effect: str) -> Candidate:
    f, own = _fit_effect(meas, ev, current, effect)
    if f.k > current.k:
        p = f_test(current.chi2, current.k, f.chi2, f.k, f.n)
    else:
        p = switch_test(current.chi2, f.chi2, f.n, f.k)
    return Candidate(effect, f, p, own, _ranges(ev, f.names), sentence=scope.sentence(ev, effect, f.values, f.effects))


def _rank_key(c: Candidate) -> tuple:
    aicc = round(c.fit.aicc, AICC_DIGITS) if math.isfinite(c.fit.aicc) else math.inf
    return (not c.plausible, aicc, c.order)


def rank_candidates(meas, ev, current: FitResult, candidates, progress=None) -> list[Candidate]:
    """Fit each candidate on top of ``current``; plausible first, then by AICc (ties reported)."""
    items = progress(candidates, desc="fitting effects", leave=False) if progress else candidates
    out = sorted((_candidate(meas, ev, current, e) for e in items), key=_rank_key)
    if out:
        best = out[0]
        for c in out:
            c.delta_aicc = c.fit.aicc - best.fit.aicc
        whitened = {c.effect: whitened_predictions(c.fit.comparison) for c in out}
        for a in out:
            a.indistinguishable_from = [
                b.effect
                for b in out
                if b is not a and indistinguishable(a.fit.aicc, b.fit.aicc, whitened[a.effect], whitened[b.effect], 1.0)
            ]
        for c in out:
            c.signature = _signature(meas, ev, current, c.effect)
    return out


def _signature(meas, ev, current: FitResult, effect: str) -> str | None:
    """Shape (patterns.SHAPES) of what ``effect`` at its default values does to the mode it changes most."""
    with_effect, _ = Predictor(meas, scope.order(ev, current.effects + (effect,)), ev, current.fixed).predict(
        strict=False
    )
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


def _separation(ev, meas, ranking) -> dict | None:
    """The measurement telling the top candidate from its closest rival that is a different model
    (ties first; a rival equivalent to it everywhere is one model, never to be separated)."""
    if len(ranking) < 2:
        return None
    top = ranking[0]
    rivals = sorted(ranking[1:], key=lambda c: c.effect not in top.indistinguishable_from)
    for rival in rivals[:MAX_RIVALS]:
        out = _between(ev, meas, top.fit, rival.fit, rival.effect in top.indistinguishable_from)
        if out is not None:
            return out
    return None


MAX_RIVALS = 4  # rivals tried for the next measurement (equivalent ones are skipped)


def _between(ev, meas, fit_a, fit_b, tied: bool) -> dict | None:
    """The next measurement between two fitted models; None when they are one model (or share no mode)."""
    if equivalent(ev, meas, fit_a, fit_b):
        return None
    out = next_measurement(ev, meas, fit_a, fit_b)
    if out is not None:
        out["indistinguishable"] = tied
        a, b = out["between"]
        pose = ", ".join(f"{v:g}" for v in np.round(out["pose"], 4))
        out["message"] = (
            f"to tell {a} from {b}, measure mode {out['mode']} at pose [{pose}] m with k_a = "
            f"{out['k_a']:.4g} {out['k_a_unit']}: {a} predicts {out['predicted_hz'][a]:.4g} Hz, {b} "
            f"{out['predicted_hz'][b]:.4g} Hz ({out['separation_sigma']:.1f} sigma apart)"
        )
    return out


def _effect_list(add, ev) -> list[str]:
    """Effects named in ``add`` (a comma-separated string or a list), in order, validated."""
    items = add.split(",") if isinstance(add, str) else list(add)
    names = [str(x).strip() for x in items if str(x).strip()]
    for name in names:
        if name.partition("@")[0] not in EFFECTS and name.partition("@")[0] not in ev.effects:
            raise InputError(
                f"add {name!r}: not an effect{did_you_mean(name.partition('@')[0], ev.effects)}; "
                f"expected one of {', '.join(ev.effects)}"
            )
        resolve_model(name, ev.robot)  # raises if the robot lacks it (or the leg does not exist)
    return names


def _check_manual(ev, order, model) -> None:
    model = list(model)
    for e in order:
        if e in model:
            raise InputError(f"add {e!r}: the effect is already in the model ({', '.join(model)})")
        shared = set(scope.parameter_names(ev, e)) & scope.taken(ev, model)
        if shared:
            raise InputError(
                f"add {e!r}: it describes the same part as an effect already in the model "
                f"(shares {', '.join(sorted(shared))}); remove that one from the baseline instead"
            )
        model.append(e)


def _manual_steps(meas, ev, current: FitResult, order) -> list[Step]:
    steps = [Step(current)]
    for e in order:
        c = _candidate(meas, ev, current, e)
        steps.append(Step(c.fit, e, c.p_value))
        current = c.fit
    return steps


def _forward(meas, ev, steps: list[Step], alpha: float, progress, removed=()) -> list[Step]:
    """Add the best significant candidate to ``steps[-1]``'s model while there is one; an
    effect taken back earlier (``removed``) is not added again (the path stays finite)."""
    current = steps[-1].fit
    while True:
        cands = candidates_for(ev, current.effects, meas)
        if not cands:
            break
        ranking = rank_candidates(meas, ev, current, cands, progress)
        steps[-1].ranking = ranking
        best = ranking[0]
        if best.effect in removed or not significant(best, current, len(cands), alpha):
            break
        alternatives = [c.effect for c in ranking[1:] if c.plausible and c.effect in best.indistinguishable_from]
        steps.append(Step(best.fit, best.effect, best.p_value, alternatives=alternatives))
        current = best.fit
    return steps


MAX_ROUNDS = 5  # forward-backward rounds at most (each removal is followed by a forward pass)


def _stepwise(meas, ev, current: FitResult, alpha: float, progress) -> tuple[list[Step], list]:
    """Forward selection, then backward elimination (:mod:`.backward`), repeated until stable:
    (steps, removals). A removal is a step of the path (``Step.removed``)."""
    steps = _forward(meas, ev, [Step(current)], alpha, progress)
    removals: list = []
    for _ in range(MAX_ROUNDS):
        added = [(s.added, len(steps[k - 1].ranking)) for k, s in enumerate(steps) if s.added]
        found = eliminate(meas, ev, steps[-1].fit, added, alpha)
        if not found:
            break
        for r in found:
            steps.append(Step(r.fit, None, r.p_value, removed=r.effect))
        removals += found
        steps = _forward(meas, ev, steps, alpha, progress, {r.effect for r in removals})
    return steps, removals


def _search(meas, ev, base: FitResult, steps: list[Step], m: int, alpha: float, progress=None) -> SearchResult | None:
    """The subset search (:mod:`.search`) when the stepwise result misfits or holds two or more
    effects; None when it is not run."""
    final = steps[-1].fit
    chosen = tuple(e for e in final.effects if e not in base.effects)
    if explained(final.chi2, final.n, final.k, alpha) and len(chosen) < 2:
        return None
    return search_subsets(meas, ev, base, steps[0].ranking, final, chosen, m, alpha, progress)


def _path(meas, ev, first: Step, found: SearchResult) -> list[Step]:
    """The selection path to the search's subset: its members in the order of their single fits,
    each step ranked among the member and its equivalent singles (the step's alternatives)."""
    by = {c.effect: c for c in first.ranking}
    order = sorted(found.best.effects, key=lambda e: (by[e].fit.aicc, by[e].order))
    steps = [Step(first.fit, ranking=first.ranking)]
    current = first.fit
    for k, e in enumerate(order):
        if k == 0:
            ranking = first.ranking
        else:
            names = [x for x in [e] + found.same.get(e, []) if x in candidates_for(ev, current.effects)]
            ranking = rank_candidates(meas, ev, current, names)
            steps[-1].ranking = ranking
        c = next(x for x in ranking if x.effect == e)
        same = found.same.get(e, [])
        alternatives = [
            x.effect
            for x in ranking
            if x is not c and x.plausible and x.effect in same and x.effect in c.indistinguishable_from
        ]
        steps.append(Step(c.fit, e, c.p_value, alternatives=alternatives))
        current = c.fit
    return steps


def _swap(meas, ev, final: FitResult, step: Step, rival: Candidate) -> FitResult | None:
    """The final model with ``step.added`` replaced by ``rival``, refitted as a whole (None: not a model)."""
    dropped = set(scope.parameter_names(ev, step.added))
    effects = [e for e in final.effects if e != step.added]
    if set(scope.parameter_names(ev, rival.effect)) & scope.taken(ev, effects):
        return None
    kept = tuple(n for n in final.names if n not in dropped)
    names = kept + tuple(n for n in rival.names if n not in kept)
    fixed = {k: v for k, v in final.fixed.items() if k not in dropped}
    start = {**fixed, **rival.params}
    return fit(meas, scope.order(ev, effects + [rival.effect]), ev, names, start=start, fixed=fixed, explore=())


def final_alternatives(meas, ev, steps: list[Step]) -> list[Alternative]:
    """Final models the data support equally: each tie along the path, refitted as a whole model."""
    final = steps[-1].fit
    out = []
    for k, step in enumerate(steps[1:], start=1):
        if step.added not in final.effects:
            continue  # taken back by backward elimination
        for name in step.alternatives:
            rival = next(c for c in steps[k - 1].ranking if c.effect == name)
            g = _swap(meas, ev, final, step, rival)
            if g is None or _implausible(ev, g):
                continue
            if indistinguishable(
                final.aicc, g.aicc, whitened_predictions(final.comparison), whitened_predictions(g.comparison), 1.0
            ):
                same = equivalent(ev, meas, final, g)
                out.append(
                    Alternative(
                        g.effects, step.added, name, g, None if same else _between(ev, meas, final, g, True), same
                    )
                )
    return out


def unproven(meas, ev, steps, alpha: float) -> list[Alternative]:
    """When the final model misfits: plausible candidates of the last step that would explain
    the data (chi2 test) without being significant (too few rows for the F test), and their
    equals."""
    final, last = steps[-1].fit, steps[-1].ranking
    if explained(final.chi2, final.n, final.k, alpha):
        return []
    good = [c for c in last if c.plausible and explained(c.fit.chi2, c.fit.n, c.fit.k, alpha)]
    names = {c.effect for c in good} | {e for c in good for e in c.indistinguishable_from}
    chosen = [c for c in last if c.effect in names and c.plausible]
    out = []
    for k, c in enumerate(chosen):
        rival = chosen[1] if k == 0 and len(chosen) > 1 else chosen[0]
        same = equivalent(ev, meas, c.fit, rival.fit) if rival is not c else None
        out.append(
            Alternative(
                c.fit.effects,
                None,
                c.effect,
                c.fit,
                _between(ev, meas, c.fit, rival.fit, True) if rival is not c and not same else None,
                same,
            )
        )
    return out


def _select(
    meas, ev, base_effects, add, alpha, progress, values: dict | None = None, search: bool = False
) -> Diagnosis:
    """Rank, select and judge on these rows (no outlier handling); ``values``: see :func:`diagnose`;
    ``search``: run the subset search (:func:`_searched`) on the stepwise result."""
    base_cmp, notes = _baseline(meas, ev, base_effects, values)
    current = fit(meas, base_effects, ev, (), fixed=values)
    manual = add is not None
    cands = candidates_for(ev, current.effects, meas)
    removed: list = []
    if manual:
        _check_manual(ev, add, current.effects)
        steps = _manual_steps(meas, ev, current, add)
        first = rank_candidates(meas, ev, current, cands, progress)
    else:
        steps, removed = _stepwise(meas, ev, current, alpha, progress)
        first = steps[0].ranking
    d = _diagnosis(meas, ev, base_cmp, first, steps, removed, manual, alpha, values, notes)
    return _searched(d, ev, progress, values) if search and not manual else d


def _diagnosis(meas, ev, base_cmp, first, steps, removed, manual, alpha, values, notes, search=None) -> Diagnosis:
    """The :class:`Diagnosis` of a selection path ``steps`` on these rows."""
    final = steps[-1].fit
    signatures = {c.effect: c.signature for c in first}
    return Diagnosis(
        robot=ev.spec,
        meas=meas,
        baseline=base_cmp,
        ranking=first,
        selected=[s.added for s in steps[1:] if s.added in final.effects],
        steps=steps,
        final=final,
        removed=removed,
        explained=explained(final.chi2, final.n, final.k, alpha) and not outside_plausible(ev, final),
        implausible=outside_plausible(ev, final),
        next_measurement=_separation(ev, meas, first),
        hints=hints(base_cmp, signatures),
        alpha=alpha,
        manual=manual,
        alternatives=[] if manual else final_alternatives(meas, ev, steps) + unproven(meas, ev, steps, alpha),
        untestable=_untestable(meas, ev, steps if not manual else steps[:1]),
        parameters=used_parameters(ev, final.effects, values, meas, final.values),
        search=search,
        notes=notes,
    )


def _searched(d: Diagnosis, ev, progress, values=None) -> Diagnosis:
    """``d`` with the subset search (:mod:`.search`) run on its rows: the path to the search's
    subset when it beats the stepwise result (rows set aside carried over), else ``d`` with
    the search's findings (ties) attached."""
    base = d.steps[0].fit
    found = _search(d.meas, ev, base, d.steps, len(candidates_for(ev, base.effects)), d.alpha, progress)
    if found is None or not found.changed:
        d.search = found
        return d
    steps = _forward(d.meas, ev, _path(d.meas, ev, d.steps[0], found), d.alpha, progress)
    out = _diagnosis(d.meas, ev, d.baseline, d.ranking, steps, [], False, d.alpha, values, d.notes, found)
    out.outliers, out.all_rows, out.setting_anomalies = d.outliers, d.all_rows, d.setting_anomalies
    return out


def _baseline(meas, ev, base_effects, values) -> tuple[Comparison, list]:
    """The baseline's comparison (mode labels matched strictly where the model's labels allow)
    and the notes on the input (see :class:`Diagnosis`)."""
    notes = []
    try:
        base_cmp = compare(meas, base_effects, ev, values, check=False)
    except ModeMatchError as exc:
        if "points along" not in str(exc):
            raise
        base_cmp = compare(meas, base_effects, ev, values, check=False, strict=False)
        where = str(exc).partition(":")[0]
        notes.append(
            f"Mode labels: at some poses no model mode points along a measured direction ({where} first); "
            "those rows are matched by frequency order and shape."
        )
    unit = unit_note(meas.freq_hz, base_cmp.predicted)
    if unit:
        notes.insert(0, unit)
    return base_cmp, notes


def _untestable(meas, ev, steps) -> dict:
    """Candidates of each step that these rows are too few to test: effect -> rows needed."""
    out: dict = {}
    for s in steps:
        cands = candidates_for(ev, s.fit.effects, meas)
        for e, need in untestable(len(meas), s.fit.k, {c: len(scope.fit_names(ev, c)) for c in cands}).items():
            out.setdefault(e, need)
    return out


def _judge(d: Diagnosis) -> Diagnosis:
    last = d.steps[-1].ranking
    effect = any(significant(c, d.final, len(last), d.alpha, False) for c in last) or any(
        a.replaced is None for a in d.alternatives
    )
    d.uncertainty = judge_uncertainty(d.final, d.untestable, effect, d.alpha)
    return d


def _without_outliers(
    meas, ev, d_all: Diagnosis, base_effects, alpha, progress, values=None, search: bool = False
) -> Diagnosis:
    """Set aside isolated outlying rows one at a time (worst first), rerunning the selection."""
    d, removed = d_all, []
    limit = max(1, int(MAX_OUTLIER_SHARE * len(meas)))
    while len(removed) < limit:
        found = find_outliers(d.final.comparison, d.final.k, alpha)
        if not found:
            break
        removed.append(found[0])
        keep = ~np.isin(meas.lines, [o.line for o in removed])
        d = _select(meas.subset(keep), ev, base_effects, None, alpha, progress, values, search)
    if removed:
        d.outliers, d.all_rows = removed, _judge(d_all)
    return d


MAX_SETTING_SHARE = 0.25  # at most this share of the rows is set aside as whole settings


def _without_settings(
    meas, ev, d: Diagnosis, base_effects, alpha, progress, values=None, search: bool = False
) -> Diagnosis:
    """Set aside whole settings that fit another k_a (or pose) far better (:mod:`.settings`), worst
    first, one at a time, rerunning the selection; the all-rows result is kept beside."""
    d_all, found = d.all_rows or d, []
    outliers = list(d.outliers)
    while True:
        anomalies = find_setting_anomalies(d.meas, ev, d.final, alpha)
        gone = sum(a.n_rows for a in found)
        if not anomalies or gone + anomalies[0].n_rows > MAX_SETTING_SHARE * len(meas):
            break
        found.append(anomalies[0])
        keep = ~np.isin(d.meas.lines, anomalies[0].lines)
        d = _select(d.meas.subset(keep), ev, base_effects, None, alpha, progress, values, search)
    if found:
        found = [rescored(a, meas, ev, d.final) for a in found]
        d.setting_anomalies, d.outliers, d.all_rows = found, outliers, d_all
        if d_all.uncertainty is None:
            _judge(d_all)
    return d


def diagnose(
    meas,
    baseline="rigid",
    robot: str | None = None,
    ev=None,
    add=None,
    alpha: float = ALPHA,
    progress=None,
    backend: str = "numpy",
    values: dict | None = None,
) -> Diagnosis:
    """Diagnose what ``baseline`` misses on the measurements ``meas``.

    Parameters
    ----------
    meas : :class:`~eigentwist.diagnose.measurements.Measurements`, or a path to a CSV file.
    baseline : preset, comma-separated effects, or ``"none"``; its parameters stay at the
        defaults (or the data's columns).
    robot : robot name (default: the measurements' robot).
    add : effects to add by hand, in order (fitted, no automatic selection, no outlier
        handling); None: forward selection.
    alpha : significance level (F test; goodness of fit; outliers, Bonferroni over rows).
    progress : optional wrapper of an iterable (e.g. ``eigentwist.cli.common.progress``).
    values : parameter values (SI) of the model instead of the robot's defaults (``--set``;
        the measurements' columns win); a fitted parameter starts from its value here.
        A parameter column whose effect is in neither the baseline nor ``add`` is an error.
    backend : evaluator backend when ``ev`` is not given (``"numpy"``, ``"c"``, ``"auto"``).

    Returns
    -------
    :class:`Diagnosis`.
    """
    from .measurements import check_columns, load_measurements

    values = dict(values or {})
    if not hasattr(meas, "freq_hz"):
        meas = load_measurements(meas, robot or "heli4", ev, values)
    ev = resolve(ev, robot or meas.robot, backend)
    base_effects = resolve_model(baseline, ev.robot)
    manual_effects = [] if add is None else _effect_list(add, ev)
    check_columns(
        meas,
        tuple(base_effects) + tuple(manual_effects),
        ev,
        "the baseline" + (" with the added effects" if manual_effects else ""),
    )
    order = None if add is None else manual_effects
    d = _select(meas, ev, base_effects, order, alpha, progress, values)
    if order is None:
        d = _rows_and_search(meas, ev, d, base_effects, alpha, progress, values)
    return _judge(d)


MIN_DOF_ROWS = 3  # degrees of freedom the final model needs before rows or settings are set aside


def rows_checked(d) -> bool:
    """Whether the outlier and setting checks run on ``d``: every candidate testable and the
    final model with at least MIN_DOF_ROWS degrees of freedom (fewer: the residuals cannot
    tell a bad row from the model's own misfit)."""
    return not d.untestable and d.final.dof >= MIN_DOF_ROWS


def _rows_and_search(meas, ev, d: Diagnosis, base_effects, alpha, progress, values) -> Diagnosis:
    """Outliers and settings set aside under the stepwise result, then the subset search on the
    rows kept (cheap where the stepwise result already explains them with one effect). Where
    the search changes the result and rows were set aside under the stepwise one, the whole
    diagnosis is redone with the search in every selection (rows set aside under its model)."""
    d0 = d
    if rows_checked(d):
        d = _without_outliers(meas, ev, d, base_effects, alpha, progress, values)
        d = _without_settings(meas, ev, d, base_effects, alpha, progress, values)
    s = _searched(d, ev, progress, values)
    if not (s.search is not None and s.search.changed and (d.outliers or d.setting_anomalies)):
        return s
    d = _searched(d0, ev, progress, values)
    if rows_checked(d):
        d = _without_outliers(meas, ev, d, base_effects, alpha, progress, values, search=True)
        d = _without_settings(meas, ev, d, base_effects, alpha, progress, values, search=True)
    return d
