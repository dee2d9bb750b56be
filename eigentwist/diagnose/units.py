"""Frequencies written in another unit: one line naming the likely one.

The diagnosis reads frequencies in Hz. Data written in kHz are ~1000 times smaller than the
model's, data in rad/s ~2 pi times larger; every catalogue effect would then be fitted to a
scale error and the verdict would blame an effect outside the catalogue. The median ratio
of the measured to the baseline's frequencies is compared with each unit's factor: within
``UNIT_TOL`` of it (and farther than that from 1), the line names the unit.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["UNITS", "UNIT_TOL", "frequency_ratio", "unit_note"]

# measured / model when the data were written in this unit instead of Hz
UNITS = (("kHz", 1e-3), ("mHz", 1e3), ("rad/s", 2 * math.pi), ("rad/ms", 2 * math.pi * 1e-3))
UNIT_TOL = 1.5  # a ratio within this factor of a unit's factor names it (a model is rarely 50 % off)


def frequency_ratio(measured, predicted) -> float:
    """The median of measured/predicted over the rows with a finite prediction (nan: none)."""
    measured, predicted = np.asarray(measured, dtype=float), np.asarray(predicted, dtype=float)
    ok = np.isfinite(predicted) & (predicted > 0) & np.isfinite(measured) & (measured > 0)
    return float(np.exp(np.median(np.log(measured[ok] / predicted[ok])))) if ok.any() else math.nan


def unit_note(measured, predicted) -> str | None:
    """One line naming the likely unit of frequencies ``measured`` (Hz expected) given the
    model's ``predicted`` (Hz), or None when they agree within ``UNIT_TOL``."""
    r = frequency_ratio(measured, predicted)
    if not math.isfinite(r) or abs(math.log(r)) < math.log(UNIT_TOL):
        return None
    for unit, factor in UNITS:
        if abs(math.log(r / factor)) < math.log(UNIT_TOL):
            return f"Units: the measured frequencies are ~{r:.4g} x the model's: written in {unit}? (freq_hz is in Hz)"
    return None
