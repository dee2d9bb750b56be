"""From the user's pose coordinates to the full platform pose the kernels read (issue 21).

A pose space (:mod:`eigentwist.description.pose`) names the coordinates a user gives
(``coordinates``) among the six of a rigid platform (``FULL``: x, y, z in m, then the
rotation vector rot_x, rot_y, rot_z in rad). Any coordinate that is neither given nor a
follower is 0 (a planar platform's z, rot_x, rot_y). The followers of a lower-mobility
space (a 3-PRS platform's x, y, rot_z) are solved per pose from the legs' closure
equations (the generated ``followers`` kernel) by a damped Newton method: batched over the
poses from the reference (followers 0), then each pose that did not converge again,
warm-started from the nearest earlier pose of the batch that did. A pose that still does
not converge has NaN followers: the evaluator reports it unreachable.
"""
from __future__ import annotations

import numpy as np

from ..description.pose import FULL
from .poses import rotation_matrix

__all__ = ["full_poses", "follow", "left_jacobian", "TOL_M", "MAX_STEPS"]

TOL_M = 1e-12          # a closure below this (m) counts as met
MAX_STEPS = 40         # Newton steps per attempt
MAX_STEP = 0.2         # largest follower step per iteration (m or rad): the damping


def left_jacobian(rotvec: np.ndarray) -> np.ndarray:
    """(..., 3, 3) left Jacobian of SO(3) at rotation vectors ``rotvec`` (rad): the
    platform's angular velocity (base axes) per unit rate of the rotation vector,
    ``omega = J_l(phi) dphi/dt``, ``J_l = I + (1 - cos t)/t^2 [phi]x + (t - sin t)/t^3 [phi]x^2``."""
    r = np.asarray(rotvec, dtype=float)
    t2 = np.sum(r * r, axis=-1)[..., None, None]
    small = t2 < 1e-10
    t = np.sqrt(np.where(small, 1.0, t2))
    a = np.where(small, 0.5 - t2 / 24, (1 - np.cos(t)) / t**2)
    b = np.where(small, 1 / 6 - t2 / 120, (t - np.sin(t)) / t**3)
    K = np.zeros(r.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -r[..., 2], r[..., 1], -r[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = r[..., 2], -r[..., 1], r[..., 0]
    return np.eye(3) + a * K + b * (K @ K)


def _kernel_inputs(full: np.ndarray, p: dict) -> dict:
    R = rotation_matrix(full[:, 3:6])
    out = dict(p)
    out.update({"x": full[:, 0], "y": full[:, 1], "z": full[:, 2]})
    out.update({f"R_{i}{j}": R[:, i, j] for i in range(3) for j in range(3)})
    return out


def _rows(p: dict, rows: np.ndarray, n: int) -> dict:
    return {k: (np.asarray(v)[rows] if np.ndim(v) == 1 and np.shape(v)[0] == n and n > 1 else v)
            for k, v in p.items()}


def _newton(closure, full: np.ndarray, followers: list, p: dict):
    """Damped Newton steps on the followers of ``full`` (N, 6), in place; returns the
    (N,) mask of poses whose closures fell below :data:`TOL_M`."""
    n = len(full)
    done = np.zeros(n, dtype=bool)
    for _ in range(MAX_STEPS):
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            out = closure(full[:, 0], full[:, 1], full[:, 2], _kernel_inputs(full, p))
        r = out["closure"].reshape(n, -1)
        rate = out["closure_rate"].reshape(n, -1, 6)
        done = np.isfinite(r).all(axis=1) & (np.abs(r).max(axis=1, initial=0.0) < TOL_M)
        if done.all():
            break
        T = np.zeros((n, 6, len(followers)))            # twist [omega; v] per unit follower rate
        Jl = left_jacobian(full[:, 3:6])
        for c, k in enumerate(followers):
            if k < 3:
                T[:, 3 + k, c] = 1.0
            else:
                T[:, :3, c] = Jl[:, :, k - 3]
        J = rate @ T                                      # (N, closures, followers)
        JtJ = np.swapaxes(J, 1, 2) @ J
        mu = 1e-12 * np.trace(JtJ, axis1=1, axis2=2)[:, None, None] + 1e-300
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            try:
                step = -np.linalg.solve(JtJ + mu * np.eye(len(followers)), (np.swapaxes(J, 1, 2) @ r[..., None]))[..., 0]
            except np.linalg.LinAlgError:
                step = np.full((n, len(followers)), np.nan)
        size = np.abs(step).max(axis=1, keepdims=True)
        step = np.where(size > MAX_STEP, step * (MAX_STEP / np.where(size > 0, size, 1.0)), step)
        step[done] = 0.0
        full[:, followers] += np.where(np.isfinite(step), step, 0.0)
    return done


def follow(closure, full: np.ndarray, followers: list, p: dict) -> np.ndarray:
    """Solve the followers (indices into ``FULL``) of the poses ``full`` (N, 6; the
    commanded coordinates set, the followers' starting values 0) so that every leg's
    closure vanishes; returns the completed (N, 6) poses, NaN followers where Newton did not
    converge (batched from the reference, then warm-started from the nearest earlier
    converged pose). ``closure(x, y, z, p)`` is the generated ``followers`` kernel; ``p`` holds the
    parameters as the kernels take them."""
    full = np.array(full, dtype=float)
    n = len(full)
    done = _newton(closure, full, followers, p)
    for k in np.flatnonzero(~done):
        earlier = np.flatnonzero(done[:k])
        if not len(earlier):
            continue
        row = full[k:k + 1].copy()
        row[0, followers] = full[earlier[-1], followers]
        if _newton(closure, row, followers, _rows(p, np.array([k]), n))[0]:
            full[k], done[k] = row[0], True
    full[np.ix_(~done, followers)] = np.nan
    return full


def full_poses(space, given: np.ndarray, closure=None, p: dict | None = None) -> np.ndarray:
    """The (N, 6) full poses (x, y, z m; rotation vector rad) of the user's poses
    ``given`` (N, len(space.coordinates)) in pose space ``space``: the given coordinates,
    the followers solved (:func:`follow`, NaN rows where they do not converge), 0 else."""
    full = np.zeros((len(given), 6))
    for c, name in enumerate(space.coordinates):
        full[:, FULL.index(name)] = given[:, c]
    followers = [FULL.index(c) for c in getattr(space, "followers", ())]
    if followers:
        full = follow(closure, full, followers, p or {})
    return full
