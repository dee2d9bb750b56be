"""Which of an effect's parameters these measurements can identify: the fit grows with the data.

An effect fits its ``Effect.fit`` parameters always. Its other parameters (the payload's
offsets p_x, p_y, p_z; the lower link's radii) join the fit only when the data are
sensitive to them beyond what the parameters already fitted can absorb:

* the whitened Jacobian J (rows: (f(p + h) - f(p - h)) / (2 sigma), one column per
  parameter, h a physically meaningful change) is taken at *trial* values: a parameter
  whose default is 0 (an offset) is set to ``TRIAL_FRACTION`` of its plausible half-width
  (0.05 m for the payload offsets), because frequencies are even in an offset at a
  symmetric pose and J is singular at 0;
* a candidate parameter is kept when its column, projected out of the columns already
  kept (the component no other parameter can mimic: the smallest singular direction it
  adds), still moves the predictions by at least ``MIN_SIGMA`` standard uncertainties,
  and its multiple correlation with them is below ``MAX_CORRELATION`` (a lower link's
  outer radius and its Young's modulus both scale the bending stiffness: correlation
  > 0.99, so only E_l1 is fitted).

After the fit, the extras are kept only if the fit still determines every parameter
(:func:`eigentwist.diagnose.select` checks the standard errors); otherwise the effect is
fitted with its ``fit`` tuple alone.

A switched effect (empty ``fit``: ``gravity_preload``) stays switched: its parameters
are known constants. Parameters given as data columns are never fitted.
"""

from __future__ import annotations

import numpy as np

from .scope import fit_names, parameter_names
from .predict import Predictor

__all__ = ["extra_parameters", "trial_value", "sign_free", "TRIAL_FRACTION", "MIN_SIGMA"]

TRIAL_FRACTION = 1 / 6  # trial offset: this fraction of the plausible half-width (0.3 m -> 0.05 m)
REL_STEP = 0.1  # the change h of a parameter with a nonzero value: 10 % of it
MIN_SIGMA = 3.0  # an identifiable parameter moves the predictions >= 3 sigma beyond the others
MAX_CORRELATION = 0.99  # ... and its column's multiple correlation with the others' stays below this
MIN_SINE = float(np.sqrt(1.0 - MAX_CORRELATION**2))


def sign_free(parameter) -> bool:
    """True for a parameter whose default is 0 inside a range of both signs (an offset)."""
    lo, hi = parameter.plausible_range
    return parameter.default == 0 and lo < 0 < hi


def trial_value(parameter) -> float:
    """Where to judge the sensitivity to ``parameter`` (see module doc)."""
    if sign_free(parameter):
        lo, hi = parameter.plausible_range
        return TRIAL_FRACTION * 0.5 * (hi - lo)
    return float(parameter.default)


def _step(parameter, value: float) -> float:
    return abs(value) if sign_free(parameter) else REL_STEP * abs(value)


def _sensitivity(meas, ev, effects, fixed: dict, names: list, values: list) -> np.ndarray:
    """(N, P) whitened change of the predictions per change h of each parameter (one batch)."""
    steps = [_step(ev.parameter(nm), v) for nm, v in zip(names, values)]
    table = np.repeat(np.array(values, dtype=float)[None, :], 2 * len(names), axis=0)
    for j, h in enumerate(steps):
        table[2 * j, j] -= h
        table[2 * j + 1, j] += h
    f = Predictor(meas, effects, ev, fixed).predict_sets(names, table, strict=False)
    jac = (f[1::2] - f[0::2]) / (2.0 * meas.sigma_hz[None, :])
    return np.nan_to_num(jac.T, nan=0.0)


def extra_parameters(meas, ev, effects, effect: str, fitted: dict, fixed: dict) -> tuple[str, ...]:
    """Parameters of ``effect`` beyond its ``fit`` tuple that these data identify.

    ``fitted``: the values of the parameters fitted so far (the effect's own included);
    ``fixed``: every other parameter value differing from the defaults.
    """
    own = fit_names(ev, effect)  # scoped like the effect: E_l1@2 for lower_link_compliance@2
    if not own:
        return ()
    extras = [p for p in parameter_names(ev, effect) if p not in own and p not in meas.params and p not in fitted]
    if not extras:
        return ()
    base = [p for p in fitted if p not in meas.params]
    values = [float(fitted[p]) for p in base] + [trial_value(ev.parameter(p)) for p in extras]
    others = {k: v for k, v in fixed.items() if k not in base and k not in extras}
    jac = _sensitivity(meas, ev, effects, others, base + extras, values)
    keep: list[int] = list(range(len(base)))
    for j in range(len(base), len(base) + len(extras)):
        col = jac[:, j]
        if keep:
            q, _ = np.linalg.qr(jac[:, keep])
            col = col - q @ (q.T @ col)
        norm = float(np.linalg.norm(col))
        if norm >= MIN_SIGMA and norm >= MIN_SINE * float(np.linalg.norm(jac[:, j])):
            keep.append(j)
    return tuple(extras[j - len(base)] for j in keep[len(base) :])
