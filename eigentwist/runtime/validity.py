"""Which poses a model can be evaluated at: reachability and singularity, one place.

Both backends compute the same check quantities (the IK arguments ``sin_q3`` and
``cos_q2``, which must lie in [-1, 1], and the actuation lever w_a1 . t_a1 / l1, which
must not vanish); this module turns them into a per-row mask or into the error that
names the first bad pose, its leg and the violated condition.
"""

from __future__ import annotations

import numpy as np

from ..description.pose import FULL
from .allowed import constraint_positions
from .errors import SingularPoseError, UnreachablePoseError

__all__ = [
    "CONDITIONING_TOL",
    "POSE_STATUS",
    "platform_rows",
    "conditioning",
    "parallel_mask",
    "raise_parallel",
    "LEVER_TOL",
    "LEVER_SCALE",
    "STATUS",
    "IK_CHECKS",
    "check_names",
    "reachable_mask",
    "lever_mask",
    "raise_unreachable",
    "raise_singular",
]

LEVER_TOL = 1e-3  # |w_a1 . t_a1| / l1 below this is treated as singular
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
    return ~(np.abs(np.asarray(arg)) <= 1.0)  # NaN counts as bad


def check_names(ik: dict) -> list:
    """The check quantities of an IK kernel's outputs: every output but the joint
    coordinates ``q``, whatever its name (a description's ``checks``), the known ones first."""
    known = [k for k in IK_CHECKS if k in ik]
    return known + [k for k in ik if k != "q" and k not in IK_CHECKS]


def check_meaning(name: str) -> str:
    """What a failed check says: the runtime's words for its known names, else the name."""
    return IK_CHECKS.get(name, f"the leg's check {name!r} left [-1, 1]")


def reachable_mask(ik: dict) -> np.ndarray:
    """(n,) bool: every IK check quantity of every leg within [-1, 1] and every joint
    coordinate finite (a robot whose legs name no check: the coordinates only)."""
    q = np.asarray(ik["q"])
    ok = np.isfinite(q.reshape(len(q), -1)).all(axis=1)
    for key in check_names(ik):
        ok &= ~_bad_ik(ik[key]).any(axis=-1)
    return ok


def lever_mask(lever_ratio) -> np.ndarray:
    """(n,) bool: |w_a1 . t_a1 / l1| > LEVER_TOL for every leg."""
    return (np.abs(np.asarray(lever_ratio)) > LEVER_TOL).all(axis=-1)


def pose_text(pose, names=None) -> str:
    """A pose for a message, with its units: ``[x, y, z] m``, ``[...] (m, rad)`` with rotations.

    ``names``: the robot's own pose coordinates (``Evaluator.pose_names``); a completed pose
    (the six coordinates of :data:`~eigentwist.description.pose.FULL`, or the position x, y, z)
    of a robot with fewer is shown in those, as the user gave it (a five-bar's ``[x, y] m``).
    Without ``names`` a pose of three values is in m, any other in m and rad."""
    values = np.asarray(pose, dtype=float)
    if names is not None and len(names) < len(values):  # completed: the named coordinates
        values = values[[FULL.index(c) for c in names]]
    rotation = any(c.startswith("rot") for c in names) if names is not None else len(values) != 3
    return f"{values.tolist()} {'(m, rad)' if rotation else 'm'}"


def raise_unreachable(legs, poses, ik: dict, names=None) -> None:
    """Raise :class:`UnreachablePoseError` for the first row whose IK check fails (if any),
    naming the pose (:func:`pose_text` with the robot's pose ``names``) and the leg."""
    for key in check_names(ik):
        what = check_meaning(key)
        bad = _bad_ik(ik[key])
        if bad.any():
            k, leg = np.argwhere(bad)[0]
            raise UnreachablePoseError(
                f"pose {pose_text(poses[k], names)} is unreachable for {legs[leg].name}: "
                f"{what} ({key} = {ik[key][k, leg]:.4g}, expected within [-1, 1])"
            )
    if "q" in ik:
        q = np.asarray(ik["q"])
        bad = ~np.isfinite(q.reshape(q.shape[0], q.shape[1], -1)).all(axis=-1)
        if bad.any():
            k, leg = np.argwhere(bad)[0]
            raise UnreachablePoseError(
                f"pose {pose_text(poses[k], names)} is unreachable for {legs[leg].name}: its "
                "inverse kinematics gives no finite joint coordinates (expected a pose the leg can span)"
            )


def raise_singular(legs, poses, lever_ratio, scale: str | None = LEVER_SCALE, names=None) -> None:
    """Raise :class:`SingularPoseError` for the first row with a vanishing lever (if any).

    ``scale``: the parameter the lever was divided by (None: a robot without it, the
    hexapod, whose lever w_a.t_a is compared as it is); ``names``: the robot's pose
    coordinates (:func:`pose_text`)."""
    lever_ratio = np.asarray(lever_ratio)
    bad = ~(np.abs(lever_ratio) > LEVER_TOL)
    if bad.any():
        k, leg = np.argwhere(bad)[0]
        what = f"w_a1.t_a1/{scale}" if scale else "w_a.t_a (the leg's unit twists are dependent)"
        raise SingularPoseError(
            f"pose {pose_text(poses[k], names)} is serial singular for {legs[leg].name}: "
            f"actuation "
            f"lever {what} = {lever_ratio[k, leg]:.3g} (expected |.| > {LEVER_TOL:g})"
        )


#: per-pose status names of :meth:`eigentwist.runtime.Evaluator.pose_status` and the
#: sweep's ``status`` column (its codes: the position in this tuple)
POSE_STATUS = ("reachable", "unreachable", "serial singular", "parallel singular")

#: below this inverse condition number of the platform's unit wrench rows the pose is
#: parallel singular. The lowest omega^2 scales with its square and is computed with an
#: error of about eps times the largest (float64), so above it omega^2 keeps a relative
#: error below eps / tol^2 = 1e-4; below it the lowest frequency has no significant digit.
CONDITIONING_TOL = 100.0 * float(np.sqrt(np.finfo(float).eps))
#: metres per radian between the rotational and translational parts of a twist in the
#: conditioning (the rows act on ``[L omega; v]``)
CONDITIONING_LENGTH = 1.0


def _unit(W: np.ndarray) -> np.ndarray:
    norm = np.sqrt(np.einsum("...i,...i->...", W, W))[..., None]
    with np.errstate(invalid="ignore", divide="ignore"):
        return W / np.where(norm > 0, norm, 1.0)


def _layout(legs) -> tuple:
    """(leg indices, row indices) of every leg's actuated row and constraint rows in
    ``J_rows``, and the (start, stop) of each leg's constraint block of two or more rows."""
    legs_idx, rows_idx, blocks = [], [], []
    for i, leg in enumerate(legs):
        c = constraint_positions(leg)
        legs_idx += [i] * (1 + len(c))
        rows_idx += [0] + c
        if len(c) > 1:
            blocks.append((len(rows_idx) - len(c), len(rows_idx)))
    return legs_idx, rows_idx, blocks


def platform_rows(J_rows, legs, basis=None) -> np.ndarray:
    """(n, r, d) the platform's unit actuation and constraint rows, legs in order: each
    leg's actuated inverse-Jacobian row (the first of its ``J_rows``) scaled to unit
    length, then an orthonormal basis of its virtual joints' rows (the span of its
    constraint wrenches: the basis Huang's method happens to give does not matter), each
    acting on ``[L omega; v]`` (L = :data:`CONDITIONING_LENGTH`). Together they fix the
    platform's six twists unless the pose is parallel singular. ``basis`` (6 x d, or None:
    the six unit twists): the platform's freedoms when the pose space fixes fewer than six
    (a point's translations: its rotations are no freedom of the mechanism, so the rows
    need fix only those d twists); the rows are then their components along it."""
    legs_idx, rows_idx, blocks = _layout(legs)
    W = np.asarray(J_rows, dtype=float)[:, legs_idx, rows_idx, :]
    if CONDITIONING_LENGTH != 1.0:
        W[..., :3] /= CONDITIONING_LENGTH
    W = _unit(W)
    for start, stop in blocks:  # Gram-Schmidt, twice, within the leg's block
        for k in range(start + 1, stop):
            v = W[:, k, :].copy()
            for _ in range(2):
                for m in range(start, k):
                    v -= np.einsum("ni,ni->n", W[:, m, :], v)[:, None] * W[:, m, :]
            W[:, k, :] = _unit(v)
    return W if basis is None else W @ np.asarray(basis, dtype=float)


def _gram(rows: np.ndarray) -> np.ndarray:
    return np.swapaxes(rows, 1, 2) @ rows


def conditioning(rows: np.ndarray) -> np.ndarray:
    """(n,) inverse condition number sigma_min / sigma_max (0 to 1) of the platform's
    unit wrench rows (:func:`platform_rows`): 1 where the rows fix every twist alike, 0
    where a twist escapes them (a parallel singularity); NaN where a row is not finite."""
    rows = np.asarray(rows, dtype=float)
    out = np.full(len(rows), np.nan)
    finite = np.isfinite(rows).all(axis=(1, 2))
    if rows.shape[1] < rows.shape[2]:
        out[finite] = 0.0
        return out
    if finite.any():
        lam = np.linalg.eigvalsh(_gram(rows[finite]))
        out[finite] = np.sqrt(np.clip(lam[:, 0], 0.0, None) / lam[:, -1])
    return out


def parallel_mask(rows: np.ndarray) -> np.ndarray:
    """(n,) bool: the conditioning of the rows is above :data:`CONDITIONING_TOL` (not
    parallel singular). ``det(G) / tr(G)^d`` of the d x d Gram matrix G bounds the squared
    conditioning from below (det G <= lam_min lam_max^(d-1), lam_max <= tr G): the exact
    value is computed only where that bound does not settle it."""
    rows = np.asarray(rows, dtype=float)
    d = rows.shape[2]
    if rows.shape[1] < d:
        return np.zeros(len(rows), dtype=bool)
    with np.errstate(invalid="ignore", over="ignore"):
        finite = np.isfinite(rows.reshape(len(rows), -1).sum(axis=1))
    ok = np.zeros(len(rows), dtype=bool)
    G = _gram(rows if finite.all() else rows[finite])
    tr = np.einsum("nii->n", G)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        sure = np.linalg.det(G) / tr**d > CONDITIONING_TOL**2
    good = sure.copy()
    if (~sure).any():
        lam = np.linalg.eigvalsh(G[~sure])
        good[~sure] = np.sqrt(np.clip(lam[:, 0], 0.0, None) / lam[:, -1]) > CONDITIONING_TOL
    ok[finite] = good
    return ok


def raise_parallel(poses, rows, names=None) -> None:
    """Raise :class:`SingularPoseError` for the first pose whose platform rows are parallel
    singular (if any), naming the pose (:func:`pose_text` with the robot's pose ``names``) and
    its conditioning."""
    bad = ~parallel_mask(rows)
    if bad.any():
        k = int(np.argmax(bad))
        cond = conditioning(np.asarray(rows)[k : k + 1])[0]
        raise SingularPoseError(
            f"pose {pose_text(poses[k], names)} is parallel singular: the legs' actuation "
            f"and constraint wrenches leave a twist of the platform free (conditioning {cond:.3g}, expected above "
            f"{CONDITIONING_TOL:.3g})"
        )
