"""Which model mode a measured frequency belongs to.

A measurement's ``mode`` is either a rank (``"1"`` = the model's lowest mode) or a
direction (``"x"``, ``"y"``, ``"z"``, ``"rx"``, ``"ry"``, ``"rz"``): the mode whose
eigentwist has its largest component along that axis, the way the paper excites
omega_1 and omega_2 with steps in X and Y (Sec. 5). Matching by direction follows the
mode shape, not the order, so it survives modes that swap order when k_a, the pose or a
parameter changes. Among several modes along the same axis the lowest is taken (a step
excites the lowest one most).
"""
from __future__ import annotations

import numpy as np

from ..description.names import did_you_mean
from ..runtime import AXES, InputError

__all__ = ["ModeMatchError", "parse_mode", "match_modes", "DIRECTIONS"]

DIRECTIONS = AXES   # ("rx", "ry", "rz", "x", "y", "z")


class ModeMatchError(InputError):
    """A measured mode label that the model cannot provide (axis absent, rank too high)."""


def parse_mode(label) -> str:
    """Normalise a mode label: ``"X"`` -> ``"x"``, ``" 2 "`` -> ``"2"``.

    Raises ``ValueError`` naming the label and the accepted forms.
    """
    text = str(label).strip().lower()
    if text in DIRECTIONS:
        return text
    if text.isdigit() and int(text) >= 1:
        return str(int(text))
    raise ValueError(f"unknown mode label {label!r}{did_you_mean(text, DIRECTIONS)}: expected a rank 1, 2, ... (1 = lowest) "
                     f"or a direction {', '.join(DIRECTIONS)}")


def _where(i: int, lines) -> str:
    return f"line {lines[i]}: " if lines is not None else f"row {i}: "


def match_modes(modes, labels, strict: bool = True, lines=None) -> np.ndarray:
    """Index (into ``modes.freq_hz[k]``) of the mode each row's label names.

    Parameters
    ----------
    modes : :class:`eigentwist.runtime.Modes` of N rows.
    labels : N normalised labels (:func:`parse_mode`).
    strict : when True, a direction that no mode of a row points along raises
        :class:`ModeMatchError`. When False (inside fits, where a trial parameter may
        tilt a mode), the mode with the largest component along the axis is taken.
    lines : optional N source line numbers, used in error messages.

    Returns
    -------
    (N,) int array.
    """
    labels = np.asarray(labels, dtype=object)
    n_rows, n_modes = modes.freq_hz.shape
    idx = np.zeros(n_rows, dtype=int)
    direction = modes.direction
    for label in np.unique(labels):
        rows = np.flatnonzero(labels == label)
        if label.isdigit():
            rank = int(label)
            if rank > n_modes:
                raise ModeMatchError(f"{_where(rows[0], lines)}mode rank {rank} does not exist: the {modes.kind} "
                                     f"model has {n_modes} modes (ranks 1..{n_modes})")
            idx[rows] = rank - 1
            continue
        axis = DIRECTIONS.index(label)
        if label not in modes.axes:
            raise ModeMatchError(f"{_where(rows[0], lines)}mode {label!r}: the {modes.kind} model has no mode along "
                                 f"{label} (its modes are along {', '.join(modes.axes)}); use a flexible model "
                                 "(a structural compliance effect, e.g. --model paper) or a rank")
        along = direction[rows] == axis
        first = np.argmax(along, axis=1)                      # lowest mode along the axis
        missing = ~along.any(axis=1)
        if missing.any():
            if strict:
                k = rows[np.argmax(missing)]
                raise ModeMatchError(f"{_where(k, lines)}no mode of the {modes.kind} model points along {label} "
                                     f"at this row (mode directions: "
                                     f"{', '.join(DIRECTIONS[d] for d in direction[k])}); use a rank instead")
            local = modes.axes.index(label)
            weight = np.abs(modes.eigentwists[rows][:, local, :])   # (rows, modes), largest entry is 1
            first = np.where(missing, np.argmax(weight, axis=1), first)
        idx[rows] = first
    return idx
