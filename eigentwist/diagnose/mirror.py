"""Candidates that are mirror images at the measured poses: one row, not two.

At a symmetric pose two legs of a symmetric robot are each other's image (the Heli4's legs
1 and 2 at x = y = 0), so ``transmission_compliance@1`` and ``transmission_compliance@2``
fit the data identically: the same chi2, the same fitted value, the same prediction on every
measured row. They are one candidate with two names, shown as
``transmission_compliance@1 or @2``.

Detected from the fits, not from names: two per-leg candidates of the same effect on
different legs are mirror images when their fitted predictions agree on every measured row
to within :data:`MIRROR_SIGMA` of that row's sigma (round-off and the optimiser's tolerance;
a real difference between two legs shows in at least one row far beyond it).
"""

from __future__ import annotations

import numpy as np

from ..description.effects import split_scope

__all__ = ["MIRROR_SIGMA", "mirror_groups", "group_label", "same_fit"]

# largest |prediction difference| / sigma on any measured row of two mirror images: the fits'
# own convergence tolerance (central-difference Jacobians) leaves up to ~0.06 sigma between two
# mirror images (the paper data's rod_compliance@1 and @2, NumPy backend); a real difference
# between two legs shows in at least one row far beyond it
MIRROR_SIGMA = 0.1


def same_fit(a, b, sigma) -> bool:
    """Whether two fits (:class:`~.fit.FitResult`) predict every measured row alike (see module doc)."""
    pa, pb = np.asarray(a.comparison.predicted, float), np.asarray(b.comparison.predicted, float)
    if pa.shape != pb.shape or not (np.all(np.isfinite(pa)) and np.all(np.isfinite(pb))):
        return False
    return bool(np.max(np.abs(pa - pb) / np.asarray(sigma, float), initial=0.0) <= MIRROR_SIGMA)


def mirror_groups(candidates, sigma) -> list[list]:
    """``candidates`` (with ``.effect`` and ``.fit``) in groups of mirror images, in the
    order of each group's first member; a candidate without an image is a group of one."""
    groups: list[list] = []
    for c in candidates:
        name, leg = split_scope(c.effect)
        home = None
        if leg is not None:
            for g in groups:
                gname, gleg = split_scope(g[0].effect)
                if gname == name and gleg is not None and gleg != leg and same_fit(g[0].fit, c.fit, sigma):
                    home = g
                    break
        if home is None:
            groups.append([c])
        else:
            home.append(c)
    return groups


def group_label(effects) -> str:
    """``["transmission_compliance@1", "transmission_compliance@2"]`` ->
    ``"transmission_compliance@1 or @2"``; one name is itself."""
    effects = list(effects)
    if len(effects) == 1:
        return effects[0]
    legs = [f"@{split_scope(e)[1]}" for e in effects[1:]]
    return (
        effects[0] + " or " + " or ".join(legs)
        if len(legs) == 1
        else effects[0] + ", " + ", ".join(legs[:-1]) + " or " + legs[-1]
    )


def collapse(names, groups) -> list[str]:
    """Effect ``names`` with every mirror group present among them written once
    (:func:`group_label`), in the order of first appearance."""
    of = {c.effect: g for g in groups for c in g}
    out, seen = [], set()
    for n in names:
        g = of.get(n)
        members = [c.effect for c in g if c.effect in names or c.effect == n] if g else [n]
        key = tuple(members)
        if key in seen:
            continue
        seen.add(key)
        out.append(group_label(members))
    return out
