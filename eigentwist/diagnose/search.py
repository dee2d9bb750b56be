"""A search over subsets of the scoped candidates, off the greedy path of forward selection.

Forward selection cannot undo a wrong early step: with two faults at once (struts 2 and 5
of a hexapod softer) the best single effect may be a third leg that stands for both, and
every later step builds on it. When the stepwise result leaves the data unexplained or has
selected two or more effects, a beam search runs over subsets of the scoped single
candidates that are plausible and lower AICc on their own: each of the ``BEAM`` best
(distinct) singles is fitted jointly with every other one, then, while no subset of that
size explains the data, each of the ``BEAM`` best plausible subsets with every other
single, up to ``MAX_SIZE`` effects. Each joint fit is warm-started from the members' single
fits (no start grid) and each subset is fitted once. A subset counts when

* every fitted value is plausible (:mod:`.plausible`; never at a search or hard bound), and
* each member is needed: the subset against the subset without it (both fitted here) by
  the forward rule, p < alpha/m (Bonferroni over the m candidates of the baseline's step)
  and a lower AICc.

The counted subset with the lowest AICc replaces the stepwise result when its AICc is lower
by more than :data:`BETTER`; counted subsets within ``DELTA_AICC`` of the result are stated
as its ties. Singles whose fitted predictions (frequencies and any measured damping ratios,
:func:`~.damping.whitened_predictions`) stay within :data:`SAME` (chi distance) of a
better one's (a strut's and its joints' series compliances) are one entry of the search,
named as its equivalents (the path's alternatives).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import scope
from .damping import whitened_predictions
from .fit import FitResult, fit
from .plausible import is_plausible
from .stats import DELTA_AICC, explained, f_test, separation

__all__ = ["Subset", "SearchResult", "search_subsets", "replaces", "BEAM", "MAX_SIZE", "SAME", "BETTER"]

BEAM = 5  # subsets kept at each size of the beam search
MAX_SIZE = 3  # largest subset searched
SAME = 0.1  # two single fits whose predictions stay within this chi distance are one pool entry
BETTER = 0.01  # AICc by which the search's subset must beat the stepwise result (optimiser noise below)
SEARCH_NFEV = 40  # solver budget of a warm-started subset fit


@dataclass
class Subset:
    """A set of effects fitted jointly on top of the baseline, with the verdict of the rules."""

    effects: tuple
    fit: FitResult
    plausible: bool
    needed: bool
    p_values: dict = field(default_factory=dict)

    @property
    def counts(self) -> bool:
        return self.plausible and self.needed


@dataclass
class SearchResult:
    """What the subset search found: ``best`` (None: no subset counts), the stepwise result
    (``greedy``, its AICc ``greedy_aicc``), whether the best replaced it (``changed``),
    ``ties`` (counted subsets within DELTA_AICC of the result), ``same`` (each searched
    single -> its equivalent singles) and how many subsets were fitted (``fitted``)."""

    greedy: tuple
    best: Subset | None
    changed: bool
    ties: list
    same: dict
    fitted: int
    greedy_aicc: float = math.nan

    def to_json(self) -> dict:
        return {
            "greedy": list(self.greedy),
            "best": list(self.best.effects) if self.best else None,
            "changed": self.changed,
            "ties": [list(t.effects) for t in self.ties],
            "equivalent": {k: list(v) for k, v in self.same.items()},
            "subsets_fitted": self.fitted,
            "aicc": self.best.fit.aicc if self.best else None,
        }

    @property
    def sentence(self) -> str | None:
        """One sentence for the answer when the search changed the stepwise result (else None)."""
        if not self.changed or self.best is None:
            return None
        was = " + ".join(self.greedy) or "nothing"
        return (
            f"Search: {' + '.join(self.best.effects)} fits better than the stepwise path's {was} "
            f"(dAICc = {self.best.fit.aicc - self.greedy_aicc:.3g})."
        )


def _plausible_fit(ev, f: FitResult) -> bool:
    return all(
        is_plausible(v, f.std.get(n, math.inf), ev.parameter(n).plausible_range, n in f.at_bound)
        for n, v in f.values.items()
    )


def _distinct(meas, ranking) -> tuple[list, dict]:
    """The plausible singles of ``ranking`` with distinct predictions, best first; rep -> its
    equivalent singles (predictions never more than SAME sigma apart)."""
    pool, same = [], {}
    for c in ranking:
        if not c.plausible or not math.isfinite(c.fit.aicc):
            continue
        rep = next(
            (
                p
                for p in pool
                if separation(
                    whitened_predictions(p.fit.comparison, meas), whitened_predictions(c.fit.comparison, meas), 1.0
                )
                < SAME
            ),
            None,
        )
        if rep is not None:
            same.setdefault(rep.effect, []).append(c.effect)
        else:
            pool.append(c)
    return pool, same


class _Fits:
    """Joint fits of subsets of single candidates on ``base``, each fitted once (warm-started
    from the members' single fits, no start grid)."""

    def __init__(self, meas, ev, base: FitResult, singles):
        self.meas, self.ev, self.base = meas, ev, base
        self.by = {c.effect: c for c in singles}
        self.fits: dict = {frozenset((c.effect,)): c.fit for c in singles}
        self.fitted = 0

    def __call__(self, effects) -> FitResult | None:
        key = frozenset(effects)
        if key not in self.fits:
            order = sorted(key, key=lambda e: self.by[e].fit.aicc)
            effects = self._model(order)  # None: a member shares a part with another
            self.fits[key] = None if effects is None else self._no_worse(order, effects, self._joint(order, effects))
        return self.fits[key]

    def _model(self, order) -> list | None:
        """The baseline's effects and ``order``'s, ordered; None where a member shares a part
        with another."""
        effects = list(self.base.effects)
        for e in order:
            if e not in scope.candidates(self.ev, effects, per_leg=True):
                return None
            effects.append(e)
        return scope.order(self.ev, effects)

    def _no_worse(self, order, effects, f: FitResult) -> FitResult:
        """``f``, or, where it ends above a subset it contains by more than DELTA_AICC (a model
        it nests: that subset with the member's parameters at the ends of their ranges), the
        lower of ``f`` and the joint model fitted again from the lowest such subset's values,
        the member's parameters screened from its single fit's values and the corners of their
        ranges (:func:`.fit.fit`'s ``explore``). A warm start from the members' single fits can
        end in a local minimum far above the model it extends (an actuator loss beside a joint
        compliance on another leg)."""
        nested = []
        for e in order:
            rest = [x for x in order if x != e]
            smaller = self(rest)  # a subset of one member at least: the singles are preloaded
            if smaller is not None and f.chi2 > smaller.chi2 + DELTA_AICC:
                nested.append((smaller.chi2, e, smaller))
        if not nested:
            return f
        _, e, smaller = min(nested)  # the lowest subset; equal ones by the dropped member's name
        member = self.by[e]
        start = {**smaller.values, **{n: member.fit.values[n] for n in member.names}}
        g = self._fit(effects, f.names, start, member.names)
        return g if g.chi2 < f.chi2 else f

    def _joint(self, order, effects) -> FitResult:
        """The joint fit of ``order``'s members (the model ``effects``), warm-started from the
        baseline's and the members' single values, no start grid."""
        base = self.base
        members = [self.by[e] for e in order]
        names = base.names + tuple(n for c in members for n in c.names)
        start = dict(base.values)
        for c in members:
            start.update({n: c.fit.values[n] for n in c.names})
        self.fitted += 1
        return self._fit(effects, names, start, ())

    def _fit(self, effects, names, start: dict, explore) -> FitResult:
        """The model ``effects`` fitted in ``names`` from ``start`` (the grid only over
        ``explore``), the baseline's fixed values, within the search's solver budget."""
        return fit(
            self.meas,
            effects,
            self.ev,
            names,
            start=start,
            fixed=self.base.fixed,
            explore=explore,
            max_nfev=SEARCH_NFEV,
        )


def _needed(sub: FitResult, smaller: FitResult, m: int, alpha: float) -> tuple[bool, float]:
    p = f_test(smaller.chi2, smaller.k, sub.chi2, sub.k, sub.n)
    return (math.isfinite(p) and p < alpha / max(m, 1) and sub.aicc < smaller.aicc), p


def _judge(fits: _Fits, key, base: FitResult, m: int, alpha: float, ev) -> Subset | None:
    f = fits(key)
    if f is None:
        return None
    tests = {}
    for e in key:
        rest = [x for x in key if x != e]
        smaller = fits(rest) if rest else base
        if smaller is None:
            return None
        tests[e] = _needed(f, smaller, m, alpha)
    order = tuple(sorted(key, key=lambda e: (fits.by[e].fit.aicc, fits.by[e].order)))
    return Subset(
        order, f, _plausible_fit(ev, f), all(ok for ok, _ in tests.values()), {e: p for e, (_, p) in tests.items()}
    )


def replaces(best: Subset | None, greedy_effects, greedy_aicc: float) -> bool:
    """Whether the search's ``best`` subset replaces the stepwise result (its effects
    ``greedy_effects``, AICc ``greedy_aicc``): another set of effects, AICc lower by more than BETTER."""
    return bool(best is not None and set(best.effects) != set(greedy_effects) and best.fit.aicc < greedy_aicc - BETTER)


def search_subsets(
    meas,
    ev,
    base: FitResult,
    ranking,
    greedy: FitResult,
    greedy_effects: tuple,
    m: int,
    alpha: float,
    progress=None,
) -> SearchResult:
    """A beam search over subsets of the plausible single candidates ``ranking`` (fitted on
    ``base``): each of the BEAM best distinct singles with every other distinct single, then
    (when no pair explains the data) each of the BEAM best pairs with every other single; each
    subset judged (module doc) and the best compared with the stepwise result ``greedy`` (its
    effects beyond the baseline: ``greedy_effects``). ``progress``: a tqdm-like wrapper shown
    over each level's subsets (pairs, triples)."""
    singles, same = _distinct(meas, ranking)
    singles = [c for c in singles if c.fit.aicc < base.aicc]  # a member must help on its own
    fits = _Fits(meas, ev, base, singles)
    judged: dict = {}

    def judge(key):
        key = frozenset(key)
        if key not in judged:
            judged[key] = _judge(fits, key, base, m, alpha, ev)
        return judged[key]

    level = [judge((c.effect,)) for c in singles]
    for _ in range(MAX_SIZE - 1):
        beam = sorted((s for s in level if s is not None and s.plausible), key=lambda s: s.fit.aicc)[:BEAM]
        # each subset once (a pair is reached from either member): the beam holds distinct subsets
        keys = list(
            dict.fromkeys(frozenset(s.effects) | {c.effect} for s in beam for c in singles if c.effect not in s.effects)
        )
        size = len(beam[0].effects) + 1 if beam else 0
        shown = progress(keys, desc=f"searching subsets of {size}", leave=False) if progress and keys else keys
        level = [judge(key) for key in shown]
        best_level = min((s for s in level if s is not None and s.counts), key=lambda s: s.fit.aicc, default=None)
        if best_level is None or explained(best_level.fit.chi2, best_level.fit.n, best_level.fit.k, alpha):
            break
    counted = sorted(
        (s for s in judged.values() if s is not None and s.counts), key=lambda s: (s.fit.aicc, len(s.effects))
    )
    best = counted[0] if counted else None
    changed = replaces(best, greedy_effects, greedy.aicc)
    top_aicc = best.fit.aicc if changed else greedy.aicc
    ties = [
        s
        for s in counted
        if s is not best and set(s.effects) != set(greedy_effects) and abs(s.fit.aicc - top_aicc) < DELTA_AICC
    ]
    return SearchResult(tuple(greedy_effects), best, changed, ties, same, fits.fitted, greedy.aicc)
