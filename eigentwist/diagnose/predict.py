"""Model predictions of measured frequencies, batched over rows and parameter sets.

Every prediction is one call of the generated evaluator: parameters go in as per-row
arrays, so B parameter sets for N measurements are B*N rows of a single batch (the
finite-difference Jacobian of a fit costs one call). Effects are switched by the
evaluator's 0/1 switches; nothing is re-derived.
"""
from __future__ import annotations

import numpy as np

from .matching import match_frequencies
from .shapes import match_by_shape

__all__ = ["evaluate", "Predictor"]


def evaluate(ev, effects, poses, labels, params: dict, strict: bool = True, lines=None, shapes=None,
             sensor=None, return_modes: bool = False):
    """Frequency (Hz) of the mode each row's label names.

    Parameters
    ----------
    ev : evaluator; effects : tuple of effect names (the model).
    poses : (N, 3) m; labels : N normalised mode labels.
    params : parameter name -> scalar or (N,) array (SI units).
    strict, lines : see :func:`eigentwist.diagnose.matching.match_modes`.
    shapes, sensor : optional (N, 3) measured mode shapes (NaN rows: none) and sensor
        offsets (m): rows with a shape are matched by MAC (:mod:`.shapes`).
    return_modes : also return the model's :class:`~eigentwist.runtime.Modes`.

    Returns
    -------
    freq : (N,) Hz; index : (N,) matched mode index into the model's ascending modes
    (by label: :func:`eigentwist.diagnose.matching.match_frequencies`, which gives a group
    of near-equal modes its share-weighted frequency; rows matched by shape: that mode's).
    """
    modes = ev.modes(poses, tuple(effects), **params)
    freq, idx = match_frequencies(modes, labels, strict=strict, lines=lines)
    if shapes is not None:
        n = len(idx)
        keys = np.column_stack([poses, sensor if sensor is not None else np.zeros((n, 3)),
                                *(np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in params.values())])
        by_label = idx
        idx = match_by_shape(modes, shapes, keys, idx, sensor)
        shaped = np.all(np.isfinite(np.asarray(shapes, dtype=float)), axis=1) | (idx != by_label)
        freq = np.where(shaped, modes.freq_hz[np.arange(n), idx], freq)
    return (freq, idx, modes) if return_modes else (freq, idx)


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

    def _params(self, values: dict, repeat: int = 1) -> dict:
        n = len(self.meas)
        out = {k: np.tile(v, repeat) for k, v in self.meas.evaluation_params().items()}
        for k, v in {**self.fixed, **values}.items():
            if k in self.meas.params:
                continue
            arr = np.asarray(v, dtype=float)
            out[k] = np.repeat(arr, n) if arr.ndim == 1 else arr
        return out

    def _shapes(self, repeat: int = 1):
        shapes = getattr(self.meas, "shapes", None)
        if shapes is None:
            return {}
        return {"shapes": np.tile(shapes, (repeat, 1)), "sensor": np.tile(self.meas.sensor, (repeat, 1))}

    def predict(self, values: dict | None = None, strict: bool = True, return_modes: bool = False):
        """(freq_hz (N,), mode index (N,)) with parameter ``values`` (name -> scalar);
        with ``return_modes`` also the model's modes."""
        return evaluate(self.ev, self.effects, self.meas.poses, self.meas.mode, self._params(values or {}),
                        strict, self.meas.lines, return_modes=return_modes, **self._shapes())

    def predict_sets(self, names, table: np.ndarray, strict: bool = False) -> np.ndarray:
        """Predictions for B parameter sets in one call: ``table`` is (B, P) values of
        ``names``; returns (B, N) Hz."""
        table = np.atleast_2d(np.asarray(table, dtype=float))
        b = table.shape[0]
        values = {name: table[:, j] for j, name in enumerate(names)}
        params = self._params(values, repeat=b)
        poses = np.tile(self.meas.poses, (b, 1))
        labels = self.meas.mode * b
        freq, _ = evaluate(self.ev, self.effects, poses, labels, params, strict, np.tile(self.meas.lines, b),
                           **self._shapes(b))
        return freq.reshape(b, len(self.meas))
