"""The plausibility rule of a fitted value (used by the selection and the answer).

A fitted value is plausible inside its parameter's plausible range (low, high), or within
:data:`PLAUSIBLE_SIGMA` standard errors of it (relative errors for a positive range, where the
fit is on the log), and never at a search bound.
"""

from __future__ import annotations

import math

__all__ = ["PLAUSIBLE_SIGMA", "is_plausible", "outside_plausible"]

PLAUSIBLE_SIGMA = 3.0  # a fit this many standard errors outside the plausible range is implausible


def is_plausible(value: float, std: float, bounds, at_bound: bool = False) -> bool:
    """Whether ``value`` (SI) with standard error ``std`` is plausible for ``bounds`` (low, high;
    None: any value): inside them or within PLAUSIBLE_SIGMA standard errors; never at a bound."""
    if at_bound:
        return False
    if bounds is None:
        return True
    lo, hi = bounds
    if lo <= value <= hi:
        return True
    if not math.isfinite(std):
        return False
    edge = lo if value < lo else hi
    if lo > 0 and value > 0:
        return abs(math.log(value / edge)) <= PLAUSIBLE_SIGMA * std / value
    return abs(value - edge) <= PLAUSIBLE_SIGMA * std


def outside_plausible(ev, f) -> dict:
    """Fitted values of ``f`` (a :class:`~.fit.FitResult`) outside their parameter's plausible
    range (closed; no allowance for the standard error) or at a search or hard bound: name ->
    (value, (low, high)). A model holding one is never "explained", however well it fits."""
    out = {}
    at_bound = set(getattr(f, "at_bound", ()) or ())
    for name, value in f.values.items():
        lo, hi = ev.parameter(name).plausible_range
        if not lo <= value <= hi or name in at_bound:
            out[name] = (float(value), (float(lo), float(hi)))
    return out
