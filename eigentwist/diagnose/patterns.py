"""What the shape of a model's error over k_a suggests physically.

The log ratio rho = ln(f_meas / f_pred) of each measured mode is compared with three
one-parameter shapes over the commanded actuator stiffness k_a (N m/rad):

* ``constant``  rho = c: the same ratio at every k_a, i.e. a wrong inertia (the
  frequencies scale as 1/sqrt(mass)) or a wrong stiffness factor;
* ``series``    rho = -ln(1 + k_a/k_s)/2: the error grows with k_a and saturates, the
  signature of a compliance 1/k_s in series with the actuators (structure, transmission);
* ``parallel``  rho = +ln(1 + k_s/k_a)/2: the measurement is stiffer than the model at low
  k_a and the error fades as 1/k_a, the signature of a stiffness k_s in parallel
  (a preload, a spring, a cable).

Weights are (f_meas/sigma)^2 (rho's variance is (sigma/f)^2). A shape counts only if it
improves significantly on "no error" (F test, p < ``ALPHA``); the best one wins.
"""

from __future__ import annotations

import numpy as np

from .stats import ALPHA, f_test

__all__ = ["classify", "hints", "systematic", "log_ratio", "pose_spread", "SHAPES", "POSE_SPREAD"]

POSE_SPREAD = 3.0  # per-pose mean errors this many standard errors apart: the error depends on the pose

SHAPES = {
    "constant": "a constant ratio across k_a: a missing or wrong inertia (mass, rotor inertia) or a stiffness factor",
    "series": "an error that grows with k_a and saturates: a compliance in series with the actuators is missing",
    "parallel": "an error largest at low k_a that fades as 1/k_a: a stiffness in parallel with the actuators "
    "is missing (a preload, a spring)",
}


def _fit_shape(rho, w, basis):
    """Best chi2 over a family of curves ``basis`` (G, N), with a free amplitude of 1."""
    r = rho[None, :] - basis
    chi2 = np.sum(w * r * r, axis=1)
    k = int(np.argmin(chi2))
    return float(chi2[k]), k


def classify(k_a, rho, weight) -> dict:
    """Shape of rho(k_a) (see module doc): ``{"shape": name or None, "chi2": {...}, "k_s": in k_a's unit}``."""
    k_a, rho, w = (np.asarray(v, dtype=float) for v in (k_a, rho, weight))
    n = len(rho)
    if not np.sum(w) > 0:
        return {"shape": None, "chi2": {}, "ratio": float("nan"), "k_s": float("nan")}
    chi2 = {"none": float(np.sum(w * rho * rho))}
    c = float(np.sum(w * rho) / np.sum(w))
    chi2["constant"] = float(np.sum(w * (rho - c) ** 2))
    k_s = np.geomspace(k_a.min() / 1e3, k_a.max() * 1e3, 400)
    chi2["series"], i_s = _fit_shape(rho, w, -0.5 * np.log1p(k_a[None, :] / k_s[:, None]))
    chi2["parallel"], i_p = _fit_shape(rho, w, 0.5 * np.log1p(k_s[:, None] / k_a[None, :]))
    best = min(("constant", "series", "parallel"), key=lambda s: chi2[s])
    out = {
        "shape": None,
        "chi2": chi2,
        "ratio": float(np.exp(c)),
        "k_s": float(k_s[i_s] if best == "series" else k_s[i_p] if best == "parallel" else np.nan),
    }
    if n >= 3 and len(np.unique(k_a)) >= 2 and f_test(chi2["none"], 0, chi2[best], 1, n) < ALPHA:
        out["shape"] = best
    return out


def hints(comparison, signatures: dict | None = None, scale: float = 1.0) -> list[str]:
    """Sentences on the residual pattern of ``comparison`` (per mode and over poses).

    ``scale`` divides the pose spread (the Birge ratio, when the scatter exceeds sigma).

    ``signatures`` (effect -> shape) name the catalogue effects whose own effect on
    the frequencies has the shape found.
    """
    meas = comparison.meas
    unit = meas.k_a_unit
    labels = np.asarray(meas.mode)
    rho, w = log_ratio(comparison)
    out = []
    for label in dict.fromkeys(meas.mode):
        rows = labels == label
        res = classify(meas.k_a[rows], rho[rows], w[rows])
        if res["shape"] is None:
            fail = comparison.failing[rows]
            if not np.any(fail):
                continue
            k_fail, k_all = meas.k_a[rows][fail], meas.k_a[rows]
            if np.all(k_fail == k_all.min()) and k_all.max() > k_all.min():
                where = f"only at the lowest k_a ({k_all.min():g} {unit}), without a trend over the others"
            elif np.all(k_fail == k_all.max()) and k_all.max() > k_all.min():
                where = f"only at the highest k_a ({k_all.max():g} {unit}), without a trend over the others"
            else:
                where = "without a clear trend over k_a (scatter or a pose dependence)"
            out.append(f"mode {label}: fails {where}")
            continue
        text = f"mode {label}: {SHAPES[res['shape']]}"
        if res["shape"] == "constant":
            text += f" (measured/predicted = {res['ratio']:.3f})"
        elif res["shape"] == "series":
            text += f" (as if a stiffness of ~{res['k_s']:.3g} {unit} were in series with each actuator)"
        else:
            text += f" (as if a stiffness of ~{res['k_s']:.3g} {unit} acted beside each actuator)"
        if signatures:
            like = [e for e, s in signatures.items() if s == res["shape"]]
            if like:
                text += f"; catalogue effects with this signature: {', '.join(like)}"
        out.append(text)
    spread, worst = pose_spread(meas, rho, w)
    if spread / scale > POSE_SPREAD:
        out.append(
            f"the mean error differs between poses ({spread / scale:.0f} sigma; largest at "
            f"{np.round(worst, 4).tolist()} m): the missing effect depends on the pose"
        )
    return out


def log_ratio(comparison):
    """(rho, weight): ln(f_meas/f_pred) per row and its weight (f/sigma)^2 (0 where undefined)."""
    meas = comparison.meas
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.log(meas.freq_hz / comparison.predicted)
    w = np.where(np.isfinite(rho), (meas.freq_hz / meas.sigma_hz) ** 2, 0.0)  # a zero prediction carries no shape
    return np.where(np.isfinite(rho), rho, 0.0), w


def pose_spread(meas, rho, w):
    """(largest difference of the per-pose mean error in its standard errors, pose where |mean| is largest)."""
    poses, pose_of = np.unique(np.round(meas.poses, 6), axis=0, return_inverse=True)
    if len(poses) < 2:
        return 0.0, None
    pose_of = np.reshape(pose_of, -1)  # each row's pose (to the micrometre): one pass, no loop over poses
    weight = np.bincount(pose_of, weights=w, minlength=len(poses))
    means = np.bincount(pose_of, weights=w * rho, minlength=len(poses)) / weight
    errs = 1.0 / np.sqrt(weight)
    spread = (means.max() - means.min()) / np.hypot(errs[np.argmax(means)], errs[np.argmin(means)])
    return float(spread), poses[np.argmax(np.abs(means))]


def systematic(comparison, scale: float = 1.0) -> list[str]:
    """What is systematic in the residuals: modes with a shape over k_a, ``"pose"`` when the
    mean error differs between poses by more than ``POSE_SPREAD`` standard errors (these
    scaled by ``scale``, the Birge ratio, so that understated sigma alone does not count)."""
    meas = comparison.meas
    labels = np.asarray(meas.mode)
    rho, w = log_ratio(comparison)
    out = [
        lb
        for lb in dict.fromkeys(meas.mode)
        if classify(meas.k_a[labels == lb], rho[labels == lb], w[labels == lb])["shape"] is not None
    ]
    if pose_spread(meas, rho, w)[0] / scale > POSE_SPREAD:
        out.append("pose")
    return out
