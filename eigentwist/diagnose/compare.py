"""How a model compares with measurements: per-row errors, RMS/max, where it fails.

Errors are relative to the measured value, as in the paper's Appendix E:
``error_pct = 100 (f_pred - f_meas) / f_meas`` (signed here; the paper's |.|), and in
standard uncertainties ``error_sigma = (f_pred - f_meas) / sigma``. The model *fails* on
a row when ``|error_sigma| > 2``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..description.effects import resolve_model
from .evaluators import resolve
from .predict import Predictor
from .shapes import row_mac
from .stats import chi2_value

__all__ = ["Comparison", "compare", "FAIL_SIGMA"]

FAIL_SIGMA = 2.0


@dataclass
class Comparison:
    """A model's predictions beside the measurements.

    effects : the model; values : parameter values differing from the defaults (SI).
    predicted : (N,) Hz; mode_index : (N,) matched mode (0 = lowest) per row.
    mac : (N,) MAC between the measured mode shape and the model's (transported to the
        sensor), NaN on rows without a shape; None when the data have no shape columns.
    zeta : (N,) the model's damping ratio of each row's mode (a model with a damping
        effect, or data with damping), else None; zeta_residuals : the whitened damping-ratio residuals that
        :attr:`chi2` includes (measured ``damping_ratio`` values; a damped row's decay,
        ``eigentwist.diagnose.fit.zeta_residuals``), else None.
    """

    meas: object
    effects: tuple
    predicted: np.ndarray
    mode_index: np.ndarray
    values: dict = field(default_factory=dict)
    mac: np.ndarray | None = None
    zeta: np.ndarray | None = None
    zeta_residuals: np.ndarray | None = None

    @property
    def error_pct(self) -> np.ndarray:
        """(N,) signed relative error, % of the measured value."""
        return 100.0 * (self.predicted - self.meas.freq_hz) / self.meas.freq_hz

    @property
    def error_sigma(self) -> np.ndarray:
        """(N,) signed error in standard uncertainties."""
        return (self.predicted - self.meas.freq_hz) / self.meas.sigma_hz

    @property
    def rms_pct(self) -> float:
        return float(np.sqrt(np.mean(self.error_pct**2)))

    @property
    def max_pct(self) -> float:
        return float(np.max(np.abs(self.error_pct)))

    @property
    def chi2(self) -> float:
        extra = 0.0 if self.zeta_residuals is None else float(np.sum(np.square(self.zeta_residuals)))
        return chi2_value(self.predicted, self.meas.freq_hz, self.meas.sigma_hz) + extra

    @property
    def failing(self) -> np.ndarray:
        """(N,) bool: |error| > 2 sigma."""
        return np.abs(self.error_sigma) > FAIL_SIGMA

    def where_it_fails(self) -> list[dict]:
        """Per mode label with failing rows: k_a range (N m/rad), poses (m), rows, sign."""
        out = []
        fail = self.failing
        for label in dict.fromkeys(self.meas.mode):
            rows = np.flatnonzero(fail & (np.asarray(self.meas.mode) == label))
            if not len(rows):
                continue
            total = int(np.sum(np.asarray(self.meas.mode) == label))
            poses = np.unique(np.round(self.meas.poses[rows], 6), axis=0)
            err = self.error_pct[rows]
            out.append(
                {
                    "mode": label,
                    "rows": len(rows),
                    "of": total,
                    "k_a_range": [float(self.meas.k_a[rows].min()), float(self.meas.k_a[rows].max())],
                    "poses": poses.tolist(),
                    "predicted": "too high" if np.all(err > 0) else "too low" if np.all(err < 0) else "both ways",
                    "lines": [int(v) for v in self.meas.lines[rows]],
                }
            )
        return out

    def summary(self) -> dict:
        return {"effects": list(self.effects), "rms_pct": self.rms_pct, "max_pct": self.max_pct}


def compare(
    meas, model="rigid", ev=None, values: dict | None = None, check: bool = True, strict: bool = True
) -> Comparison:
    """Compare ``model`` (preset, effect list or ``"none"``) with the measurements.

    ``values`` override parameter defaults (SI units; the measurements' own parameter
    columns win). Mode labels are matched strictly: a direction no mode points along is
    an error naming the line. With ``check``, a parameter column of an effect the model
    lacks is an error naming the column (:func:`~.measurements.check_columns`). ``strict``
    False: a direction no mode points along at a row takes the mode with the largest share
    along it (:func:`~.matching.match_frequencies`).
    """
    from .measurements import check_columns

    ev = resolve(ev, meas.robot)
    effects = resolve_model(model, ev.robot)
    if check:
        check_columns(meas, effects, ev)
    shapes = getattr(meas, "shapes", None)
    predictor = Predictor(meas, effects, ev, values)
    from .damping import attach_damping, zeta_rows

    damped = bool(ev.damped_model(tuple(effects)))
    spec = zeta_rows(meas, damped)
    if shapes is None and not damped and spec is None:  # no modes kept: a large file is evaluated a block at a time
        pred, idx = predictor.predict(strict=strict)
        return Comparison(meas, effects, pred, idx, dict(values or {}), None)
    pred, idx, modes = predictor.predict(strict=strict, return_modes=True)
    mac = None if shapes is None else row_mac(modes, idx, shapes, meas.shape_projection)
    comp = Comparison(meas, effects, pred, idx, dict(values or {}), mac)
    if modes.damping is not None or spec is not None:
        attach_damping(comp, meas, modes, idx, spec)
    return comp
