"""The mode-shape residual term of a fitted model (measured shapes against the model's modes).

Apart from :mod:`.shapes` (the residual and MAC of one row, used by the predictions in
:mod:`.predict`) because it evaluates the model through :class:`.predict.Predictor`.
"""

from __future__ import annotations

import numpy as np

from .predict import Predictor
from .shapes import SHAPE_CRITERION, has_shape, row_mac, shape_residuals
from .stats import chi2_sf

__all__ = ["shape_term"]


def shape_term(meas, effects, ev, values: dict | None = None) -> dict | None:
    """The shape residual term of a model on measurements with shapes (None without).

    Returns ``{"chi2", "n", "p_value", "mac_min", "mac_mean", "residuals", "criterion"}``:
    chi2 = sum of squared :func:`shape_residuals` over the rows with a shape, n those
    rows, p_value = P(chi2_n >= chi2) (the shapes' goodness of fit, nothing fitted to
    them). A fit may append ``residuals`` (finite entries) to its frequency residuals.
    """
    shapes = getattr(meas, "shapes", None)
    if shapes is None or not has_shape(shapes).any():
        return None
    _, idx, modes = Predictor(meas, effects, ev, values).predict(strict=False, return_modes=True)
    res = shape_residuals(shapes, modes, idx, meas.shape_projection)
    macs = row_mac(modes, idx, shapes, meas.shape_projection)
    ok = np.isfinite(res)
    chi2 = float(np.sum(res[ok] ** 2))
    return {
        "chi2": chi2,
        "n": int(ok.sum()),
        "p_value": chi2_sf(chi2, int(ok.sum())),
        "mac_min": float(np.nanmin(macs)),
        "mac_mean": float(np.nanmean(macs)),
        "residuals": res.tolist(),
        "criterion": SHAPE_CRITERION,
    }
