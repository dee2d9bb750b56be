"""Backward elimination after forward selection: take back a step no longer needed.

Forward selection adds one effect at a time; an effect added early can become unnecessary
once a later one explains the same deviation better (a per-leg ``actuator_loss@2``
standing in for a spring to ground added later). Each selected effect is tested against
the final model *without it*, refitted as a whole (every other fitted parameter free),
by the rule that added it: it stays when its p-value (F test of the nested models;
:func:`~.stats.switch_test` for an effect without fitted parameters) is below
alpha/m, with m the number of candidates of the step that added it (the same
Bonferroni count), *and* it lowers AICc. The least needed effect (largest p-value) that
fails is removed, and the test repeated on the smaller model until every selected effect
is needed. The baseline's effects are never removed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import scope
from .fit import FitResult, fit
from .stats import f_test, switch_test

__all__ = ["Removal", "without", "removal_test", "eliminate"]


@dataclass
class Removal:
    """``effect`` taken out of the model: its p-value against the model without it, the
    AICc with and without it, the effects added after it (``after``), and the fit
    without it (``fit``)."""

    effect: str
    p_value: float
    aicc_with: float
    aicc_without: float
    after: tuple
    fit: FitResult

    @property
    def reason(self) -> str:
        """``"actuator_loss@2 removed: not needed once chain_spring was added"``."""
        if self.after:
            verb = "was" if len(self.after) == 1 else "were"
            return f"{self.effect} removed: not needed once {', '.join(self.after)} {verb} added"
        return f"{self.effect} removed: not needed in the final model"

    def to_json(self) -> dict:
        return {
            "effect": self.effect,
            "p_value": self.p_value,
            "aicc_with": self.aicc_with,
            "aicc_without": self.aicc_without,
            "after": list(self.after),
            "reason": self.reason,
            "effects": list(self.fit.effects),
            "params": self.fit.values,
            "param_std": self.fit.std,
        }


def without(meas, ev, final: FitResult, effect: str) -> FitResult:
    """``final`` with ``effect`` and its parameters taken out, the rest refitted from its values."""
    dropped = set(scope.parameter_names(ev, effect))
    effects = scope.order(ev, [e for e in final.effects if e != effect])
    names = tuple(n for n in final.names if n not in dropped)
    fixed = {k: v for k, v in final.fixed.items() if k not in dropped}
    return fit(meas, effects, ev, names, start=fixed, fixed=fixed, explore=())


def removal_test(final: FitResult, smaller: FitResult) -> float:
    """p-value of keeping the effect that ``final`` has and ``smaller`` lacks (the forward test)."""
    if final.k > smaller.k:
        return f_test(smaller.chi2, smaller.k, final.chi2, final.k, final.n)
    return switch_test(smaller.chi2, final.chi2, final.n, final.k)


def _needed(p: float, final: FitResult, smaller: FitResult, m: int, alpha: float) -> bool:
    return math.isfinite(p) and p < alpha / max(m, 1) and final.aicc < smaller.aicc


def eliminate(meas, ev, final: FitResult, added: list, alpha: float) -> list[Removal]:
    """Remove, one at a time, the selected effects the final model no longer needs.

    ``added``: (effect, m) of each effect the selection added, in order, with the number
    of candidates of its step. Returns the removals in order; the last one's ``fit`` is
    the new final model (none: ``final`` stands).
    """
    out: list[Removal] = []
    kept = [(e, m) for e, m in added if e in final.effects]
    while kept:
        tests = []
        for e, m in kept:
            smaller = without(meas, ev, final, e)
            p = removal_test(final, smaller)
            if not _needed(p, final, smaller, m, alpha):
                tests.append((p if math.isfinite(p) else math.inf, e, smaller))
        if not tests:
            break
        p, e, smaller = max(tests, key=lambda t: (t[0], -[k for k, _ in kept].index(t[1])))
        names = [k for k, _ in kept]
        after = tuple(names[names.index(e) + 1 :])
        out.append(Removal(e, p, final.aicc, smaller.aicc, after, smaller))
        final = smaller
        kept = [(k, m) for k, m in kept if k != e]
    return out
