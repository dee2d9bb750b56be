"""Model predictions of measured frequencies, batched over rows and parameter sets.

Every prediction is one call of the generated evaluator: parameters go in as per-row
arrays, so B parameter sets for N measurements are B*N rows of a single batch (the
finite-difference Jacobian of a fit costs one call). Effects are switched by the
evaluator's 0/1 switches; nothing is re-derived.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..runtime import InputError
from ..runtime.memo import BoundedMemo, content_key
from ..runtime.labels import energy_shares
from .matching import directions_asked, match_frequencies
from .shapes import MeasuredShapes, SettingGroups, has_shape, match_by_shape, setting_rows

__all__ = [
    "evaluate",
    "Predictor",
    "FirstSet",
    "EVAL_BLOCK",
    "distinct_rows",
    "take_rows",
    "setting_keys",
    "setting_groups",
]

#: rows evaluated per call when no modes are returned and no row has a shape: the memory
#: of a comparison stays that of one block (the model's matrices and modes of every row
#: at once would take gigabytes for a million rows)
EVAL_BLOCK = 65536


def evaluate(
    ev,
    effects,
    poses,
    labels,
    params: dict,
    strict: bool = True,
    lines=None,
    shapes=None,
    sensor=None,
    return_modes: bool = False,
    joints=None,
    damped=None,
    unique=None,
    groups=None,
):
    """Frequency (Hz) of the mode each row's label names.

    Parameters
    ----------
    ev : evaluator; effects : tuple of effect names (the model).
    poses : (N, 3) m; labels : N normalised mode labels.
    params : parameter name -> scalar or (N,) array (SI units).
    strict, lines : see :func:`eigentwist.diagnose.matching.match_modes`.
    shapes, sensor : optional (N, D) measured mode shapes (NaN: not measured; or
        :class:`~.shapes.MeasuredShapes` of them, prepared once for many calls) and sensor
        offsets (N, 3) m or the shapes' projection (N, D, 6): rows with a shape are matched
        by MAC (:mod:`.shapes`).
    return_modes : also return the model's :class:`~eigentwist.runtime.Modes`.
    joints : optional (N, legs, coordinates) measured joint coordinates, used instead of
        the poses' inverse kinematics (``Evaluator.modes(..., joints=)``).
    damped : optional (N,) bool: rows whose measured value is a damped frequency; a model
        with a damping effect predicts omega_d / 2 pi there and omega_n / 2 pi (its poles'
        modulus) on the other rows (like with like).
    unique : optional ``(first, inverse)`` index arrays: rows ``first`` hold every distinct
        (pose, per-row parameters, joints) and row i's model is row ``first[inverse[i]]``'s
        (:func:`distinct_rows`): the model is evaluated on rows ``first`` only (each row is
        evaluated on its own, so the numbers are those of every row evaluated).
    groups : optional settings of the rows with a shape, for matching by shape (a tuple of
        row-index arrays, :func:`setting_groups`); None: from the rows' poses, sensors and
        parameters (:func:`setting_keys`).

    Returns
    -------
    freq : (N,) Hz; index : (N,) matched mode index into the model's ascending modes
    (by label: :func:`eigentwist.diagnose.matching.match_frequencies`, which gives a group
    of near-equal modes its share-weighted frequency; rows matched by shape: that mode's).
    Without shapes and modes asked for, more than :data:`EVAL_BLOCK` rows are evaluated a
    block at a time (the same numbers: each row is evaluated on its own).
    """
    n = len(poses)
    if shapes is None and not return_modes and n > EVAL_BLOCK:
        freq, idx = np.empty(n), np.empty(n, dtype=int)
        for start in range(0, n, EVAL_BLOCK):
            rows = slice(start, start + EVAL_BLOCK)
            part = {k: (v[rows] if np.ndim(v) >= 1 and np.shape(v)[0] == n else v) for k, v in params.items()}
            freq[rows], idx[rows] = evaluate(
                ev,
                effects,
                poses[rows],
                labels[rows],
                part,
                strict,
                None if lines is None else lines[rows],
                joints=None if joints is None else joints[rows],
            )
        return freq, idx
    try:
        with np.errstate(all="ignore"):  # overflow is detected below and named
            if unique is None:
                modes = _modes(ev, effects, poses, params, joints)
            else:
                first, inverse = unique
                at = {k: (v[first] if np.ndim(v) >= 1 and np.shape(v)[0] == n else v) for k, v in params.items()}
                modes = _modes(ev, effects, poses[first], at, None if joints is None else joints[first])
    except np.linalg.LinAlgError as exc:
        raise InputError(_numerical_failure(ev, effects, poses, params, lines, exc)) from None
    if unique is not None:
        if modes.shares is None and modes.eigentwists is not None and directions_asked(modes, labels, lines):
            modes.shares = energy_shares(modes.eigentwists)  # once per distinct row, as matching would
        modes = take_rows(modes, unique[1])
    freq, idx = match_frequencies(modes, labels, strict=strict, lines=lines)
    if shapes is not None:
        n = len(idx)
        if groups is None:
            groups = setting_groups(shapes, setting_keys(poses, sensor, list(params.values())))
        by_label = idx
        idx = match_by_shape(modes, shapes, groups, idx, sensor)
        shaped = has_shape(shapes) | (idx != by_label)
        freq = np.where(shaped, modes.freq_hz[np.arange(n), idx], freq)
    if modes.damping is not None:
        rows = np.arange(len(idx))
        kind = np.zeros(len(idx), dtype=bool) if damped is None else np.asarray(damped, dtype=bool)
        freq = np.where(kind, modes.damped_hz[rows, idx], modes.natural_hz[rows, idx])
    if strict and not np.all(np.isfinite(freq)):
        raise InputError(
            _numerical_failure(
                ev, effects, poses, params, lines, "non-finite frequency", int(np.argmin(np.isfinite(freq)))
            )
        )
    return (freq, idx, modes) if return_modes else (freq, idx)


class FirstSet:
    """The first parameter set's rows of a :meth:`Predictor.predict_sets` call, taken when
    asked (:meth:`predict`): ``(freq_hz (N,), mode index (N,), Modes)`` as
    ``Predictor.predict(values, strict=False, return_modes=True)`` gives them."""

    __slots__ = ("freq", "idx", "modes", "n")

    def __init__(self, freq: np.ndarray, idx: np.ndarray, modes, n: int):
        self.freq, self.idx, self.modes, self.n = freq, idx, modes, n

    def predict(self) -> tuple:
        """``(freq_hz (N,) Hz, mode index (N,), Modes of the N rows)`` of the first set."""
        rows = np.arange(self.n)
        return self.freq[rows], self.idx[rows], take_rows(self.modes, rows)


def setting_keys(poses, sensor, values) -> np.ndarray:
    """(N, k) what defines each row's setting for matching by shape: its pose, its sensor
    offsets (N, 3) m or shape projection (N, D, 6) (None: the end-effector origin) and
    the parameter ``values`` (scalars or (N,) arrays, SI units)."""
    poses = np.asarray(poses, dtype=float)
    n = len(poses)
    return np.column_stack(
        [
            poses,
            np.reshape(sensor, (n, -1)) if sensor is not None else np.zeros((n, 3)),
            *(np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in values),
        ]
    )


def setting_groups(shapes, keys) -> tuple:
    """The settings of the rows with a measured shape (:func:`.shapes.has_shape`): a
    tuple of row-index arrays, rows whose ``keys`` agree to 12 decimals together."""
    rows = np.flatnonzero(has_shape(shapes))
    return SettingGroups(rows[g] for g in setting_rows(np.asarray(keys, dtype=float)[rows]))


def _modes(ev, effects, poses, params: dict, joints):
    if joints is None:
        return ev.modes(poses, tuple(effects), **params)
    return ev.modes(poses, tuple(effects), joints=joints, **params)


def distinct_rows(columns: list, n: int):
    """``(first, inverse)`` of the rows of ``columns`` ((n,) or (n, ...) arrays, compared by
    their exact values): ``first`` the first row of each distinct row in order of appearance,
    ``inverse`` (n,) each row's position in ``first``; None where every row is distinct or a
    value is NaN (never equal to itself: nothing is merged)."""
    key = np.column_stack([np.reshape(np.asarray(c, dtype=float), (n, -1)) for c in columns])
    if np.isnan(key).any():
        return None
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    if len(first) == n:
        return None
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return first[order], rank[np.reshape(inverse, -1)]


def take_rows(modes, index: np.ndarray):
    """``modes`` (:class:`~eigentwist.runtime.Modes`) at rows ``index``: every per-row array
    (frequencies, eigentwists, validity, shares, the damped modes' arrays) indexed, the
    rest kept; the exact condensation's arrays (``legs``) dropped."""
    n = len(modes.freq_hz)

    def rows(obj):
        if isinstance(obj, np.ndarray):
            return obj[index] if obj.ndim >= 1 and obj.shape[0] == n else obj
        if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
            return dataclasses.replace(obj, **{name: rows(getattr(obj, name)) for name in _field_names(type(obj))})
        return obj

    out = dataclasses.replace(
        modes, **{name: rows(getattr(modes, name)) for name in _field_names(type(modes)) if name != "legs"}
    )
    out.legs = None
    return out


@functools.cache
def _field_names(cls) -> tuple:
    """A dataclass's field names, looked up once per class."""
    return tuple(f.name for f in dataclasses.fields(cls))


def _numerical_failure(ev, effects, poses, params, lines, exc, row: int | None = None) -> str:
    """One line naming the first row whose model cannot be evaluated, and its values."""
    n = len(poses)
    rows = [row] if row is not None else range(n)
    for i in rows:
        one = {k: (np.asarray(v)[i] if np.ndim(v) == 1 and np.shape(v)[0] == n else v) for k, v in params.items()}
        try:
            with np.errstate(all="ignore"):
                ok = np.all(np.isfinite(ev.modes(poses[i], tuple(effects), **one).freq_hz))
        except np.linalg.LinAlgError:
            ok = False
        if not ok:
            where = f"line {lines[i]}" if lines is not None else f"row {i}"
            values = ", ".join(
                f"{k} = {float(np.asarray(v)):g}" for k, v in one.items() if np.ndim(v) == 0 and k in ev.parameters
            )
            return (
                f"{where}: the model cannot be evaluated there ({exc}): the values are beyond what it can "
                f"represent ({values}); expected physically plausible values in SI units"
            )
    return f"the model cannot be evaluated for these inputs ({exc}): check them for extreme values"


_DISTINCT_UNSET = object()
_DISTINCT = BoundedMemo(8)  # content of the rows' poses, per-row parameters, joints -> distinct_rows


class Predictor:
    """Predictions of one model (a set of effects) for one set of measurements.

    ``fixed`` are parameter values (SI, scalars) that replace the defaults, e.g. values
    fitted at an earlier step; the measurements' own per-row parameter columns always
    win over them.
    """

    def __init__(self, meas, effects, ev, fixed: dict | None = None):
        self.meas = meas
        self.effects = tuple(effects)
        self.ev = ev
        self.fixed = {k: float(v) for k, v in (fixed or {}).items() if k not in meas.params}
        self._distinct = _DISTINCT_UNSET
        self._measured_shapes = None  # (shapes, projection, settings) or () without shapes: _shapes
        self._repeated = BoundedMemo(8)  # repeat -> the measured rows' arrays repeated (_repeated_rows)
        self._repeated_shapes = BoundedMemo(8)  # repeat -> the shapes, sensors and settings tiled (_shapes)

    def _unique(self, repeat: int = 1):
        """``(first, inverse)`` of the measured rows tiled ``repeat`` times (the model is
        evaluated once per distinct pose, per-row parameters and joints: the paper's x and y
        rows of one setting share it); None where every row is distinct."""
        if self._distinct is _DISTINCT_UNSET:
            n = len(self.meas)
            per_row = {k: v for k, v in self.meas.evaluation_params().items() if np.ndim(v) >= 1}
            joints = getattr(self.meas, "joints", None)
            if joints is not None:
                per_row[" joints"] = joints
            key = content_key(self.meas.poses, per_row, sorted(per_row))  # each fit's Predictor: found once
            self._distinct = _DISTINCT.get(key, _DISTINCT_UNSET)
            if self._distinct is _DISTINCT_UNSET:
                self._distinct = distinct_rows([self.meas.poses, *per_row.values()], n)
                _DISTINCT.put(key, self._distinct)
        if self._distinct is None:
            return None
        first, inverse = self._distinct
        n, u = len(self.meas), len(first)
        sets = np.arange(repeat)[:, None]
        return (sets * n + first).reshape(-1), (sets * u + inverse).reshape(-1)

    def _repeated_rows(self, repeat: int) -> dict:
        """The measured rows' arrays for ``repeat`` parameter sets, built once per count
        (read-only): ``params`` (k_a and the per-row columns), ``poses``, ``labels``,
        ``lines``, ``joints``, ``damped``, ``unique``."""
        rows = self._repeated.get(repeat)
        if rows is None:
            rows = {
                "params": {k: np.tile(v, repeat) for k, v in self.meas.evaluation_params().items()},
                "poses": np.tile(self.meas.poses, (repeat, 1)),
                "labels": self.meas.mode * repeat,
                "lines": np.tile(self.meas.lines, repeat),
                "joints": self._joints(repeat),
                "damped": self._damped(repeat),
                "unique": self._unique(repeat),
            }
            for arr in [*rows["params"].values(), rows["poses"], rows["lines"], rows["joints"], rows["damped"]]:
                if isinstance(arr, np.ndarray):
                    arr.flags.writeable = False
            for arr in rows["unique"] or ():
                arr.flags.writeable = False
            self._repeated.put(repeat, rows)
        return rows

    def _params(self, values: dict, repeat: int = 1) -> dict:
        n = len(self.meas)
        out = dict(self._repeated_rows(repeat)["params"])
        for k, v in {**self.fixed, **values}.items():
            if k in self.meas.params:
                continue
            arr = np.asarray(v, dtype=float)
            out[k] = np.repeat(arr, n) if arr.ndim == 1 else arr
        return out

    def _joints(self, repeat: int = 1):
        """The measured joint coordinates (CSV columns ``q<m>@<leg>``), tiled; None: none."""
        joints = getattr(self.meas, "joints", None)
        return None if joints is None else np.tile(joints, (repeat, 1, 1))

    def _shapes(self, repeat: int = 1):
        """The measured shapes and their projections (:mod:`.shapes`), tiled ``repeat``
        times (read-only, built once per count: every evaluation of a fit asks for the
        same); {} without shape columns."""
        if self._measured_shapes is None:
            shapes = getattr(self.meas, "shapes", None)
            if shapes is None:
                self._measured_shapes = ()
            else:
                projection = self.meas.shape_projection
                per_row = [
                    np.asarray(v, dtype=float) for v in self.meas.evaluation_params().values() if np.ndim(v) >= 1
                ]
                keys = setting_keys(self.meas.poses, projection, per_row)
                self._measured_shapes = (shapes, projection, setting_groups(shapes, keys))
        if not self._measured_shapes:
            return {}
        tiled = self._repeated_shapes.get(repeat)
        if tiled is None:
            shapes, projection, groups = self._measured_shapes
            n = len(self.meas)
            tiled = {
                "shapes": MeasuredShapes(np.tile(shapes, (repeat, 1))),
                "sensor": np.tile(projection, (repeat, 1, 1)),
                # each parameter set's settings on their own (two sets of equal values stay apart)
                "groups": SettingGroups(g + k * n for k in range(repeat) for g in groups),
            }
            measured = tiled["shapes"]
            for arr in (
                tiled["sensor"],
                *tiled["groups"],
                *tiled["groups"].by_size,
                *(getattr(measured, name) for name in MeasuredShapes.__slots__),
            ):
                arr.flags.writeable = False
            self._repeated_shapes.put(repeat, tiled)
        return dict(tiled)

    def predict(self, values: dict | None = None, strict: bool = True, return_modes: bool = False):
        """(freq_hz (N,), mode index (N,)) with parameter ``values`` (name -> scalar);
        with ``return_modes`` also the model's modes."""
        return evaluate(
            self.ev,
            self.effects,
            self.meas.poses,
            self.meas.mode,
            self._params(values or {}),
            strict,
            self.meas.lines,
            return_modes=return_modes,
            joints=self._joints(),
            damped=self._damped(),
            unique=self._unique(),
            **self._shapes(),
        )

    def _damped(self, repeat: int = 1):
        """(N * repeat,) bool: the rows measured as damped frequencies (``kind``), tiled."""
        damped = getattr(self.meas, "damped", None)
        return None if damped is None else np.tile(damped, repeat)

    def predict_sets(self, names, table: np.ndarray, strict: bool = False, zeta: bool = False, first: bool = False):
        """Predictions for B parameter sets in one call: ``table`` is (B, P) values of
        ``names``; returns (B, N) Hz, and with ``zeta`` also the (B, N) damping ratios of
        the matched modes and the (B, N) least damping ratio of each row's modes. With
        ``first``, ``(that, FirstSet)``: the first set's :meth:`predict` with its modes, kept
        for later (:class:`FirstSet`; each row is evaluated on its own, so these are the numbers
        :meth:`predict` gives for that set)."""
        table = np.atleast_2d(np.asarray(table, dtype=float))
        b = table.shape[0]
        values = {name: table[:, j] for j, name in enumerate(names)}
        params = self._params(values, repeat=b)
        rows = self._repeated_rows(b)
        freq, idx, modes = evaluate(
            self.ev,
            self.effects,
            rows["poses"],
            rows["labels"],
            params,
            strict,
            rows["lines"],
            joints=rows["joints"],
            damped=rows["damped"],
            return_modes=True,
            unique=rows["unique"],
            **self._shapes(b),
        )
        if zeta:
            z = modes.damping_ratio[np.arange(len(idx)), idx]
            with np.errstate(invalid="ignore"):
                least = np.nanmin(np.where(np.isnan(modes.damping_ratio), np.inf, modes.damping_ratio), axis=1)
            out = tuple(v.reshape(b, len(self.meas)) for v in (freq, z, least))
        else:
            out = freq.reshape(b, len(self.meas))
        return (out, FirstSet(freq, idx, modes, len(self.meas))) if first else out

    def predict_with_jacobian(self, names, values, strict: bool = False):
        """Predictions and their exact derivatives for one parameter set.

        ``values`` (P,) of ``names``; returns ``(freq_hz (N,), dfdp (N, P))`` in Hz and Hz
        per SI unit of each parameter, from the generated sensitivity kernel (one call:
        :meth:`~eigentwist.runtime.Evaluator.modes_and_sensitivities`). The kernel is
        generated once for every fitted parameter of the robot's catalogue and each leg's own
        value of the leg-level ones (plus ``names``), so each candidate's fit reuses it.
        Raises ``InputError`` for models without generated sensitivities (gravity preload).
        """
        from ..description.effects import EFFECTS
        from ..runtime.errors import InputError
        from ..runtime.sensitivity import check_model, sensitivity_kernels

        fitted = {n for e in self.ev.effects if e in EFFECTS for n in EFFECTS[e].fit} | set(names)
        wrt = tuple(n for n in self.ev.parameters if n in fitted)
        # each leg's own value of the leg-level ones (eta_a@3), so per-leg candidates share the kernel
        wrt += tuple(f"{n}@{k}" for n in wrt if n in self.ev.leg_parameters for k in range(1, self.ev.n_legs + 1))
        wrt += tuple(n for n in names if n not in wrt)
        params = self._params({name: float(v) for name, v in zip(names, values)})
        check_model(self.effects)
        # the reverse-mode kernel of the model's stiffness, loaded (or generated) once for the
        # superset; ``names`` select its rows
        sensitivity_kernels(self.ev, wrt, kind=self.ev.stiffness_model(self.effects))
        modes, dfdp = self.ev.modes_and_sensitivities(self.meas.poses, tuple(names), self.effects, **params)
        freq, idx = match_frequencies(modes, self.meas.mode, strict=strict, lines=self.meas.lines)
        rows = np.arange(len(idx))
        single = modes.freq_hz[rows, idx]
        if self._shapes() or not np.allclose(freq, single, rtol=1e-13, atol=0.0, equal_nan=True):
            # shape-matched rows or share-weighted groups of near-equal modes: no per-mode derivative
            raise InputError("exact Jacobian only for rows matched to one mode by label")
        return single, dfdp[rows, idx]
