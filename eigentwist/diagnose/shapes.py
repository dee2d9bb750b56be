"""Measured mode shapes as evidence: transport, MAC, matching by shape, the shape residual.

A measured mode shape is the translation of one point of the end-effector (the sensor)
in a mode: a real unit 3-vector ``phi = (phi_x, phi_y, phi_z)`` in the base frame's axes
(the platform does not rotate between poses, so platform and base axes are parallel).
The model's counterpart is the eigentwist ``t = [omega; v]`` of Eq. 6 (rotation, rad;
translation of the end-effector origin, m) transported to the sensor at offset ``r``
(m, from the end-effector origin):

    u = v + omega x r = T(r) t,   T(r) = [-[r]x, I3]   (3 x 6).

A rigid model (3x3, translations only) has no rotation: ``u = v`` whatever ``r``.
A shape measured over other DOFs (uniaxial accelerometers at several nodes, a
roving hammer) is compared through its projection ``P`` (D, 6), rows ``e_d^T T(r_d)``
(direction e_d at node r_d; :attr:`.measurements.Measurements.shape_projection`): the
model's shape there is ``P t``. Every function below taking ``sensor`` offsets (..., 3)
also takes such a projection (N, D, 6); a row's DOFs left blank (NaN) are left out of
its MAC, and a row has a shape when at least two of its DOFs are measured.

* :func:`mac` compares shapes: ``MAC(a, b) = |a^H b|^2 / ((a^H a)(b^H b))`` in [0, 1]:
  1 for parallel shapes (any scale, sign or phase), 0 for orthogonal ones.
* :func:`match_by_shape` assigns the rows of one setting (same pose, k_a, parameters
  and sensor) to model modes by the largest total MAC (Hungarian method), among the
  model modes along a translation (eigentwist's largest entry x, y or z; a mode along a
  rotation only when no translational one is left): where two frequencies cross or veer, the shape, not the
  order or the largest component, says which mode is which. Rows without a shape keep
  the mode their label names (:mod:`.matching`).
* :func:`shape_residuals` is the shape term the diagnosis may add to its weighted
  residuals (``SHAPE_CRITERION``): the angle between measured and model shape,
  ``theta = arccos(sqrt(MAC))`` (rad), in units of its standard uncertainty
  ``SIGMA_SHAPE_RAD``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np


__all__ = [
    "transport_matrix",
    "sensor_shapes",
    "mac",
    "match_by_shape",
    "SettingGroups",
    "setting_rows",
    "has_shape",
    "shape_residuals",
    "row_mac",
    "SIGMA_SHAPE_RAD",
    "SHAPE_CRITERION",
    "SHAPE_COLUMNS",
]

SHAPE_COLUMNS = ("phi_x", "phi_y", "phi_z")
SIGMA_SHAPE_RAD = 0.05  # standard uncertainty of a measured shape's direction, rad (about 3 degrees)
SHAPE_CRITERION = (
    "shape residual per row with a measured shape: theta / sigma_theta, theta = arccos(sqrt(MAC)) "
    "the angle between the measured shape and the model's eigentwist transported to the sensor "
    f"(v + omega x r), sigma_theta = {SIGMA_SHAPE_RAD} rad; rows are matched to model modes by the "
    "largest total MAC among the translational modes of their setting (Hungarian method)"
)


def transport_matrix(r) -> np.ndarray:
    """``T(r) = [-[r]x, I3]`` (..., 3, 6): sensor translation from an eigentwist [omega; v].

    ``r`` (..., 3) is the sensor offset from the end-effector origin, m.
    """
    r = np.asarray(r, dtype=float)
    T = np.zeros(r.shape[:-1] + (3, 6))
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    # -[r]x = [[0, z, -y], [-z, 0, x], [y, -x, 0]]
    T[..., 0, 1], T[..., 0, 2] = z, -y
    T[..., 1, 0], T[..., 1, 2] = -z, x
    T[..., 2, 0], T[..., 2, 1] = y, -x
    T[..., 0, 3] = T[..., 1, 4] = T[..., 2, 5] = 1.0
    return T


def sensor_shapes(eigentwists, sensor=None) -> np.ndarray:
    """Translations at the sensor of every mode: (N, 3, n) from eigentwists (N, n, n).

    ``sensor`` (N, 3) or (3,) offsets in m (None: the end-effector origin). Rigid
    models (n = 3) are translations already. With a projection ``sensor`` (N, D, 6)
    (module doc): the (N, D, n) shapes over its DOFs.
    """
    V = np.asarray(eigentwists)
    if sensor is not None and np.ndim(sensor) == 3 and np.shape(sensor)[-1] == 6:
        P = np.asarray(sensor, dtype=float)
        return (P[..., 3:] if V.shape[-2] == 3 else P) @ V
    if V.shape[-2] == 3:
        return V
    r = np.zeros(3) if sensor is None else np.asarray(sensor, dtype=float)
    return np.broadcast_to(transport_matrix(r), V.shape[:-2] + (3, 6)) @ V


def mac(a, b, nb=None) -> np.ndarray:
    """MAC between shapes ``a`` (..., k) and ``b`` (..., k), real or complex: (...,) in [0, 1].
    ``nb``: ``b^H b`` (...,) where known (a measured shape's, computed once)."""
    a = np.asarray(a)
    b = np.asarray(b)
    if a.dtype.kind == "f" and b.dtype.kind == "f":  # real: |x|^2 = x x, bit for bit
        cross = np.sum(a * b, axis=-1)
        cross *= cross
        na = np.sum(a * a, axis=-1)
    else:
        cross = np.abs(np.sum(np.conj(a) * b, axis=-1)) ** 2
        na = np.sum(np.abs(a) ** 2, axis=-1)
    if nb is None:
        nb = np.sum(np.abs(b) ** 2, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where((na > 0) & (nb > 0), cross / (na * nb), 0.0)


class MeasuredShapes:
    """Measured shapes (N, D) (NaN: a DOF not measured) with what every matching of them
    reads, computed once: ``values``, ``finite`` (N, D), ``clean`` (NaN as 0), ``has``
    (N,) (:func:`has_shape`) and ``norm2`` (N,) each row's ``b^H b`` (:func:`mac`). A fit
    matches the same measured shapes at every evaluation (:func:`match_by_shape`)."""

    __slots__ = ("values", "finite", "clean", "has", "norm2")

    def __init__(self, shapes):
        values = np.asarray(shapes, dtype=float)
        self.values = values
        self.finite = np.isfinite(values)
        self.clean = np.nan_to_num(values)
        self.has = np.sum(self.finite, axis=1) >= 2
        self.norm2 = np.sum(np.abs(self.clean) ** 2, axis=-1)

    def __len__(self) -> int:
        return len(self.values)


def setting_rows(keys: np.ndarray) -> tuple:
    """The rows of each setting from a (N, k) array of setting keys (rows with keys equal
    to 12 decimals share one; NaN keys never equal): a tuple of index arrays, one per
    setting, each in ascending order."""
    rounded = np.round(np.asarray(keys, dtype=float), 12) + 0.0  # -0.0 -> 0.0
    if not len(rounded):
        return ()
    # rows sorted by their keys, first column first (a stable sort: each setting's rows stay
    # in ascending order); a setting starts where a key differs from the row before
    order = np.lexsort(rounded.T[::-1]) if rounded.shape[1] else np.arange(len(rounded))
    ordered = rounded[order]
    starts = np.flatnonzero((ordered[1:] != ordered[:-1]).any(axis=1)) + 1
    return tuple(np.split(order, starts))


class SettingGroups(tuple):
    """The settings' row-index arrays (a tuple, as :func:`match_by_shape` takes them) with
    their rows stacked once by setting size: ``by_size``, one (G, size) array per size,
    ascending. A fit matches the same settings at every evaluation."""

    by_size: tuple

    def __new__(cls, groups):
        obj = super().__new__(cls, groups)
        sizes = sorted({len(g) for g in obj})
        obj.by_size = tuple(np.stack([g for g in obj if len(g) == size]) for size in sizes)
        return obj


def match_by_shape(modes, shapes, groups, fallback, sensor=None) -> np.ndarray:
    """Model mode of each row with a measured shape, by MAC; ``fallback`` for the others.

    Parameters
    ----------
    modes : :class:`eigentwist.runtime.Modes` of N rows.
    shapes : (N, D) measured shapes (NaN: a DOF not measured), or the same as
        :class:`MeasuredShapes` (prepared once for many matchings).
    groups : the settings (same pose, k_a, parameters, sensor) of the rows with a shape:
        row-index arrays (:func:`eigentwist.diagnose.predict.setting_groups`; a
        :class:`SettingGroups` is stacked already); each setting's rows take distinct modes.
    fallback : (N,) indices from the labels (used for rows without a shape).
    sensor : (N, 3) sensor offsets, m (None: the end-effector origin).

    Returns
    -------
    (N,) int model mode index per row.
    """
    from scipy.optimize import linear_sum_assignment  # on first use: commands without it start faster

    measured = shapes if isinstance(shapes, MeasuredShapes) else MeasuredShapes(shapes)
    idx = np.array(fallback, dtype=int, copy=True)
    if not measured.has.any():
        return idx
    U = sensor_shapes(modes.eigentwists, sensor) * measured.finite[:, :, None]  # (N, D, n)
    score = mac(np.swapaxes(U, -1, -2), measured.clean[:, None, :], measured.norm2[:, None])  # (N, n)
    seen = modes.direction >= 3  # x, y, z (AXES index)
    score = np.where(seen, score, score - 2.0)  # rotations only if nothing else fits
    stacked = groups if isinstance(groups, SettingGroups) else SettingGroups(groups)
    for members in stacked.by_size:  # (G, size) each
        S = score[members]  # (G, size, n)
        cols, unique = _best_assignments(S)
        idx[members[unique]] = cols[unique]
        for m in members[~unique]:  # a (near) tie, or too many rows to enumerate: the Hungarian method
            r, c = linear_sum_assignment(-score[m])
            idx[m[r]] = c
    return idx


#: the most injective assignments of a setting's rows to the modes enumerated at once
#: (6 modes: 3 rows give 120, 4 rows 360); larger settings go to the Hungarian method
ENUMERATED = 400
#: two assignments whose total scores (sums of MAC, each in [0, 1], or MAC - 2) differ by
#: less than this are a tie, left to the Hungarian method: far above the sums' round-off
#: (~1e-15), far below any difference a shape can measure
TIE = 1e-9


@lru_cache(maxsize=64)
def _assignments(k: int, n: int) -> np.ndarray:
    """(m, k) every injective assignment of k rows to n columns, in lexicographic order
    (read-only)."""
    from itertools import permutations

    out = np.array(list(permutations(range(n), k)), dtype=int).reshape(-1, k)
    out.setflags(write=False)
    return out


def _best_assignments(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For G equal-sized score matrices ``S`` (G, k, n): each one's column per row
    maximising the total score over injective assignments (k <= n), found by enumeration,
    and whether that maximum is unique (ahead of every other assignment by more than
    :data:`TIE`): ``(cols (G, k) int, unique (G,) bool)``. Where it is not unique, or
    the assignments are too many (:data:`ENUMERATED`) or the rows outnumber the columns,
    ``unique`` is False and the caller solves that matrix by the Hungarian method."""
    G, k, n = S.shape
    cols = np.zeros((G, k), dtype=int)
    count = np.prod(np.arange(n - k + 1, n + 1), dtype=float) if k <= n else np.inf
    if count > ENUMERATED or G == 0:
        return cols, np.zeros(G, dtype=bool)
    P = _assignments(k, n)  # (m, k)
    total = S[:, np.arange(k), P].sum(axis=-1)  # (G, m)
    best = np.argmax(total, axis=1)
    top = total[np.arange(G), best]
    if len(P) > 1:
        runner = np.partition(total, -2, axis=1)[:, -2]
        unique = np.isfinite(top) & (top - runner > TIE)
    else:
        unique = np.isfinite(top)
    return P[best], unique


def shape_residuals(meas_shapes, modes, idx, sensor=None, sigma: float = SIGMA_SHAPE_RAD) -> np.ndarray:
    """(N,) shape residual of each row, ``arccos(sqrt(MAC)) / sigma`` (NaN where no shape).

    ``idx`` is the matched model mode per row (e.g. from :func:`match_by_shape`);
    the diagnosis may append the finite entries to its frequency residuals
    ``(f_pred - f_meas) / sigma_hz`` (``SHAPE_CRITERION``).
    """
    m = np.clip(row_mac(modes, idx, meas_shapes, sensor), 0.0, 1.0)
    return np.arccos(np.sqrt(m)) / sigma


def row_mac(modes, idx, meas_shapes, sensor=None) -> np.ndarray:
    """(N,) MAC between each row's measured shape and its matched model mode (NaN: no shape)."""
    shapes = np.asarray(meas_shapes, dtype=float)
    U = sensor_shapes(modes.eigentwists, sensor) * np.isfinite(shapes)[:, :, None]
    u = np.take_along_axis(U, np.asarray(idx)[:, None, None], axis=2)[..., 0]
    return np.where(has_shape(shapes), mac(u, np.nan_to_num(shapes)), np.nan)


def has_shape(shapes) -> np.ndarray:
    """(N,) rows of ``shapes`` (N, D) with a measured shape: at least two finite components
    (``shapes`` may be :class:`MeasuredShapes`)."""
    if isinstance(shapes, MeasuredShapes):
        return shapes.has
    return np.sum(np.isfinite(np.asarray(shapes, dtype=float)), axis=1) >= 2
