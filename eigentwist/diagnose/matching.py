"""Which model mode a measured frequency belongs to.

A measurement's ``mode`` is either a rank (``"1"`` = the model's lowest mode) or a
direction (``"x"``, ``"y"``, ``"z"``, ``"rx"``, ``"ry"``, ``"rz"``): the mode that carries
the largest share of its energy along that axis (:mod:`eigentwist.runtime.labels`: a
unit-free share, not the largest entry of an eigentwist that mixes rad and m), the way
the paper excites omega_1 and omega_2 with steps in X and Y (Sec. 5). Matching by
direction follows the mode shape, not the order, so it survives modes that swap order
when k_a, the pose or a parameter changes. Among several modes along the same axis the
lowest is taken (a step excites the lowest one most).

Modes closer in frequency than ``DEGENERATE_REL`` (1 %, below the default 2 % uncertainty
and the resolution of a few-second record) are one measured peak, and their eigentwists
are any basis of one eigenspace (exactly so for the Delta on its axis): a basis that
rotates with a 1 mm pose change must not change the answer. Such a group is matched as a
whole: it points along the m axes with the largest group shares (m its size; the group
share of an axis is basis-independent), and the frequency of a direction is the mean of
the group's frequencies weighted by that axis's energy shares (the frequency of the
group's motion along the axis; exact when the pair is degenerate or aligned with the
axes). Across the 1 % edge the matched frequency moves by at most half the gap.
"""

from __future__ import annotations

import numpy as np

from ..description.names import did_you_mean
from ..runtime import AXES, InputError
from ..runtime.memo import BoundedMemo
from ..runtime.labels import DEGENERATE_REL, degenerate_groups, energy_shares, group_shares

__all__ = [
    "ModeMatchError",
    "parse_mode",
    "match_modes",
    "match_frequencies",
    "directions_asked",
    "DIRECTIONS",
    "DEGENERATE_REL",
]

DIRECTIONS = AXES  # ("rx", "ry", "rz", "x", "y", "z")


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
    raise InputError(
        f"unknown mode label {label!r}{did_you_mean(text, DIRECTIONS)}: expected a rank 1, 2, ... (1 = lowest) "
        f"or a direction {', '.join(DIRECTIONS)}"
    )


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
        tilt a mode; the diagnosis where the model's labels are ambiguous at a pose), the
        mode (group) with the largest share along the axis among the modes that repeat a
        lower mode's direction is taken (frequency order and shape), else among all.
    lines : optional N source line numbers, used in error messages.

    Returns
    -------
    (N,) int array; within a group of near-equal modes, the member with the largest
    share along the label's axis.
    """
    return match_frequencies(modes, labels, strict, lines)[1]


def match_frequencies(modes, labels, strict: bool = True, lines=None):
    """Frequency (Hz) and mode index of each row's label (see :func:`match_modes`).

    Returns
    -------
    freq : (N,) Hz: the matched mode's, or for a group of near-equal modes the
        share-weighted mean (module doc); index : (N,) int.
    """
    n_rows, n_modes = modes.freq_hz.shape
    ranked_rows, ranks, axis_rows, axis = _label_codes(modes, labels, lines)
    idx = np.zeros(n_rows, dtype=int)
    freq = np.full(n_rows, np.nan)
    if ranked_rows.size:
        idx[ranked_rows] = ranks
        freq[ranked_rows] = modes.freq_hz[ranked_rows, ranks]
    if axis_rows.size:
        every = axis_rows.size == n_rows  # the rows as they are: no copy
        rows = axis_rows
        f = modes.freq_hz if every else modes.freq_hz[rows]
        if modes.shares is not None:
            shares = modes.shares if every else modes.shares[rows]
        else:
            shares = energy_shares(modes.eigentwists if every else modes.eigentwists[rows])
        split = np.diff(f, axis=-1) > DEGENERATE_REL * np.abs(f[:, 1:])
        if split.all():  # every mode its own group
            idx[rows], freq[rows] = _match_single(modes, shares, f, axis, rows, labels, strict, lines)
        else:
            groups = degenerate_groups(f)
            idx[rows], freq[rows] = _match_axes(modes, shares, groups, axis, rows, labels, strict, lines, f)
    return freq, idx


def directions_asked(modes, labels, lines=None) -> bool:
    """Whether a label is a direction (matched by the modes' energy shares); raises
    :class:`ModeMatchError` for a label ``modes`` cannot provide, as :func:`match_frequencies`."""
    return _label_codes(modes, labels, lines)[2].size > 0


#: label sequences seen, with the number of modes and their axes -> _label_codes' arrays
_CODES_SIZE = 64
_CODES = BoundedMemo(_CODES_SIZE)


def _label_codes(modes, labels, lines):
    """``(ranked_rows, ranks, axis_rows, axis)``: the rows whose label is a rank and their
    0-based mode index, the rows whose label is a direction and its index into ``modes.axes``.
    A sequence of labels (str) met before with as many modes along the same axes is not
    parsed again."""
    n_modes = modes.freq_hz.shape[1]
    key = None
    if type(labels) in (list, tuple) and set(map(type, labels)) <= {str}:
        key = (tuple(labels), n_modes, tuple(modes.axes))
        found = _CODES.get(key)
        if found is not None:
            return found
    labels = np.asarray(labels).astype(str)  # whole-array conversion: no per-row Python
    distinct, firsts, inverse = np.unique(labels, return_index=True, return_inverse=True)
    code = {}  # label -> rank - 1 (>= 0), or -1 - local axis (< 0)
    for label, first in zip(map(str, distinct), firsts):  # errors in label order, as the labels sort
        if label.isdigit():
            rank = int(label)
            if rank > n_modes:
                raise ModeMatchError(
                    f"{_where(first, lines)}mode rank {rank} does not exist: the {modes.stiffness_model} "
                    f"model has {n_modes} modes (ranks 1..{n_modes})"
                )
            code[label] = rank - 1
            continue
        if label not in modes.axes:
            raise ModeMatchError(
                f"{_where(first, lines)}mode {label!r}: the {modes.stiffness_model} model has no mode along "
                f"{label} (its modes are along {', '.join(modes.axes)}); use a flexible model "
                "(a structural compliance effect, e.g. --model paper) or a rank"
            )
        code[label] = -1 - modes.axes.index(label)
    codes = np.array([code[str(label)] for label in distinct], dtype=int)[np.reshape(inverse, -1)]
    ranked = codes >= 0
    ranked_rows, axis_rows = np.flatnonzero(ranked), np.flatnonzero(~ranked)
    found = (ranked_rows, codes[ranked_rows], axis_rows, -1 - codes[axis_rows])
    for arr in found:
        arr.flags.writeable = False
    if key is not None:
        _CODES.put(key, found)
    return found


def _by_order(direction: np.ndarray, share: np.ndarray) -> np.ndarray:
    """For rows whose axis no mode points along: the mode with the largest share along it among
    the modes that are not the lowest along their own direction (at a pose where the model
    labels two modes "x, x", a measured "y" takes the second), else among all modes."""
    n = direction.shape[1]
    earlier = np.tril(np.ones((n, n), dtype=bool), -1)  # [j, i]: i < j
    repeat = np.any((direction[:, :, None] == direction[:, None, :]) & earlier[None], axis=2)
    share = np.nan_to_num(share, nan=-np.inf)
    pick = np.argmax(np.where(repeat, share, -np.inf), axis=1)
    return np.where(repeat.any(axis=1), pick, np.argmax(share, axis=1))


def _missing(modes, missing, rows, labels, lines):
    """The :class:`ModeMatchError` of the first row (as the labels sort) whose axis no mode
    points along."""
    labels = np.asarray(labels).astype(str)
    k = min(np.flatnonzero(missing), key=lambda i: (labels[rows[i]], i))  # as the labels sort
    direction = modes.direction[rows[k]]
    return ModeMatchError(
        f"{_where(rows[k], lines)}no mode of the {modes.stiffness_model} model points along "
        f"{labels[rows[k]]} at this row (mode directions: "
        f"{', '.join(DIRECTIONS[d] for d in direction)}); use a rank instead"
    )


def _match_single(modes, shares, f, axis, rows, labels, strict, lines):
    """:func:`_match_axes` where every mode of every row is a group of its own (no two modes
    within ``DEGENERATE_REL``): the same numbers with a group's sums reduced to its one mode
    (a mode is along the axis where no other axis has a larger share; its frequency is
    ``(w f) / w`` with ``w`` its clipped share, or 1 where that is not positive)."""
    r = np.arange(len(rows))
    total = shares if np.isfinite(shares).all() else np.nan_to_num(shares)  # (rows, axes, modes)
    target = total[r, axis]  # (rows, modes) the axis's shares
    largest = total[:, 0]
    for i in range(1, total.shape[1]):  # the largest share of each mode (a loop: faster than max on axis 1)
        largest = np.maximum(largest, total[:, i])
    along = target >= largest  # no axis with a larger share
    first = np.argmax(along, axis=1)  # lowest mode along the axis
    missing = ~along[r, first]
    if missing.any():
        if strict:
            raise _missing(modes, missing, rows, labels, lines)
        first = np.where(missing, _by_order(modes.direction[rows], target), first)
    own = shares[r, axis, first]
    w = np.maximum(own, 0.0)  # NaN stays NaN, as np.clip keeps it
    w = np.where(w > 0, w, 1.0)
    at = f[r, first]
    freq = (w * (at if np.isfinite(at).all() else np.nan_to_num(at))) / w
    index = np.where(own == -np.inf, 0, first)
    return index, np.where(np.isfinite(f[:, 0]), freq, np.nan)


def _match_axes(modes, shares, groups, axis, rows, labels, strict, lines, f=None):
    """(index, frequency) of the lowest mode group along each row's local ``axis``; ``f``:
    the rows' frequencies (``modes.freq_hz[rows]``) where known."""
    r = np.arange(len(rows))
    f = modes.freq_hz[rows] if f is None else f
    total = group_shares(shares, groups)  # (rows, axes, modes)
    size = (groups[:, :, None] == groups[:, None, :]).sum(axis=1)  # (rows, modes) group sizes
    rank = (total > total[r, axis][:, None, :]).sum(axis=1)  # axes with a larger group share
    along = rank < size
    first = np.argmax(along, axis=1)  # lowest mode (group) along the axis
    missing = ~along.any(axis=1)
    own_share = shares[r, axis]  # (rows, modes) the axis's shares
    if missing.any():
        if strict:
            raise _missing(modes, missing, rows, labels, lines)
        first = np.where(missing, _by_order(modes.direction[rows], total[r, axis]), first)
    member = groups == groups[r, first][:, None]  # (rows, modes) the chosen group
    own = np.where(member, np.clip(own_share, 0.0, None), 0.0)
    weight = np.where(own.sum(axis=1, keepdims=True) > 0, own, member.astype(float))
    freq = np.sum(weight * np.nan_to_num(f), axis=1) / weight.sum(axis=1)
    index = np.argmax(np.where(member, own_share, -np.inf), axis=1)
    return index, np.where(np.isfinite(f[:, 0]), freq, np.nan)
