"""Which poses a model can be evaluated at: reachability and singularity, one place.

Both backends compute the same check quantities (the IK arguments ``sin_q3`` and
``cos_q2``, which must lie in [-1, 1], and the actuation lever w_a1 . t_a1 / l1, which
must not vanish); this module turns them into a per-row mask or into the error that
names the first bad pose, its leg and the violated condition.
"""
from __future__ import annotations

import numpy as np

from .errors import SingularPoseError, UnreachablePoseError

__all__ = ["LEVER_TOL", "LEVER_SCALE", "STATUS", "IK_CHECKS", "reachable_mask", "lever_mask", "raise_unreachable", "raise_singular"]

LEVER_TOL = 1e-3   # |w_a1 . t_a1| / l1 below this is treated as singular
LEVER_SCALE = "l1"  # the lever is compared relative to this parameter (the lower link length)
# per-pose status codes of the C backend's fused pass (the generated C prints the same
# table in its signature; the loader checks they agree)
STATUS = {"ok": 0, "unreachable": 1, "singular": 2, "not_finite": 3, "unstable": 4}
IK_CHECKS = {
    "sin_q3": "the parallelogram cannot tilt that far",
    "cos_q2": "the lower link and parallelogram cannot span that distance",
    # the hexapod: the strut along its base U joint's fixed axis locks the joint;
    # a zero leg length makes the strut direction NaN, which fails here too
    "cos_u": "the strut lies along its U joint's fixed axis or has zero length",
    # a leg of a described robot (examples/robots/): a cosine or sine of its
    # closed-form IK, out of [-1, 1] where the leg cannot span the distance
    "reach": "the leg cannot span that distance",
    # a leg solved numerically: Newton's method did not close its loop from the
    # reference configuration, or converged on another assembly branch
    "closure": "Newton's method found no configuration of the leg that closes its loop on the description's "
               "assembly branch (out of reach, or past a singularity)",
}


def _bad_ik(arg) -> np.ndarray:
    return ~(np.abs(np.asarray(arg)) <= 1.0)          # NaN counts as bad


def reachable_mask(ik: dict) -> np.ndarray:
    """(n,) bool: every IK check quantity of every leg within [-1, 1]."""
    ok = None
    for key in IK_CHECKS:
        if key in ik:
            bad = _bad_ik(ik[key]).any(axis=-1)
            ok = ~bad if ok is None else ok & ~bad
    return ok


def lever_mask(lever_ratio) -> np.ndarray:
    """(n,) bool: |w_a1 . t_a1 / l1| > LEVER_TOL for every leg."""
    return (np.abs(np.asarray(lever_ratio)) > LEVER_TOL).all(axis=-1)


def raise_unreachable(legs, poses, ik: dict) -> None:
    """Raise :class:`UnreachablePoseError` for the first row whose IK check fails (if any)."""
    for key, what in IK_CHECKS.items():
        if key not in ik:
            continue
        bad = _bad_ik(ik[key])
        if bad.any():
            k, leg = np.argwhere(bad)[0]
            unit = "m" if len(poses[k]) == 3 else "(m, rad)"
            raise UnreachablePoseError(
                f"pose {np.asarray(poses[k], dtype=float).tolist()} {unit} is unreachable for {legs[leg].name}: "
                f"{what} ({key} = {ik[key][k, leg]:.4g}, expected within [-1, 1])")


def raise_singular(legs, poses, lever_ratio, scale: str | None = LEVER_SCALE) -> None:
    """Raise :class:`SingularPoseError` for the first row with a vanishing lever (if any).

    ``scale``: the parameter the lever was divided by (None: a robot without it, the
    hexapod, whose lever w_a.t_a is compared as it is)."""
    lever_ratio = np.asarray(lever_ratio)
    bad = ~(np.abs(lever_ratio) > LEVER_TOL)
    if bad.any():
        k, leg = np.argwhere(bad)[0]
        what = f"w_a1.t_a1/{scale}" if scale else "w_a.t_a (the leg's unit twists are dependent)"
        unit = "m" if len(poses[k]) == 3 else "(m, rad)"
        raise SingularPoseError(
            f"pose {np.asarray(poses[k], dtype=float).tolist()} {unit} is singular for {legs[leg].name}: actuation "
            f"lever {what} = {lever_ratio[k, leg]:.3g} (expected |.| > {LEVER_TOL:g})")
