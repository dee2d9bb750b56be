"""From the user's pose coordinates to the full platform pose the kernels read.

A pose space (:mod:`eigentwist.description.pose`) names the coordinates a user gives
(``coordinates``) among the six of a rigid platform (``FULL``: x, y, z in m, then the
rotation vector rot_x, rot_y, rot_z in rad). Any coordinate that is neither given nor a
follower is 0 (a planar platform's z, rot_x, rot_y). The followers of a lower-mobility
space (a 3-PRS platform's x, y, rot_z) are solved per pose from the legs' closure
equations (the generated ``followers`` kernel) by the damped Newton method of the legs'
numeric IK (:func:`eigentwist.runtime.levenberg_marquardt.solve`): batched over the poses from the
reference (followers 0), then warm-started from the previous pose. A pose that still does
not converge has NaN followers: the evaluator reports it unreachable.
"""

from __future__ import annotations

import numpy as np

from ..description.pose import FULL
from .poses import rotation_entries

_ROTATION_NAMES = tuple(f"R_{i}{j}" for i in range(3) for j in range(3))

__all__ = ["commanded", "full_poses", "follow", "follow_legs", "left_jacobian", "along_followers", "TOL_M", "MAX_STEPS"]

TOL_M = 1e-12  # a closure below this (m) counts as met
MAX_STEPS = 40  # Newton steps per attempt


def left_jacobian(rotvec: np.ndarray) -> np.ndarray:
    """(..., 3, 3) left Jacobian of SO(3) at rotation vectors ``rotvec`` (rad): the
    platform's angular velocity (base axes) per unit rate of the rotation vector,
    ``omega = J_l(phi) dphi/dt``, ``J_l = I + (1 - cos t)/t^2 [phi]x + (t - sin t)/t^3 [phi]x^2``."""
    r = np.asarray(rotvec, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    xx, yy, zz = x * x, y * y, z * z
    a, b, _ = _left_jacobian_factors(r)
    ax, ay, az = a * x, a * y, a * z
    bxy, bxz, byz = b * (x * y), b * (x * z), b * (y * z)
    # I + a [r]x + b [r]x^2, entry by entry ([r]x^2 = r r^T - |r|^2 I)
    return np.stack(
        [
            1 + b * (-zz - yy),
            -az + bxy,
            ay + bxz,
            az + bxy,
            1 + b * (-zz - xx),
            -ax + byz,
            -ay + bxz,
            ax + byz,
            1 + b * (-yy - xx),
        ],
        axis=-1,
    ).reshape(r.shape[:-1] + (3, 3))


def _left_jacobian_factors(rotvec: np.ndarray):
    """``(a, b, t^2)`` (...) of ``J_l = I + a [phi]x + b [phi]x^2`` at rotation vectors
    (..., 3) rad, with the series below t^2 = 1e-10 (:func:`left_jacobian`)."""
    x, y, z = rotvec[..., 0], rotvec[..., 1], rotvec[..., 2]
    t2 = x * x + y * y + z * z
    small = t2 < 1e-10
    t = np.sqrt(np.where(small, 1.0, t2))
    a = np.where(small, 0.5 - t2 / 24, (1 - np.cos(t)) / t**2)
    b = np.where(small, 1 / 6 - t2 / 120, (t - np.sin(t)) / t**3)
    return a, b, t2


def along_followers(rate: np.ndarray, full: np.ndarray, followers: list) -> np.ndarray:
    """``rate @ T``: rates (N, ..., 6) along the platform's unit twists ``[omega; v]``
    turned into rates (N, ..., followers) along each follower at the full poses ``full``
    (N, 6). Column c of ``T`` (N, 6, followers) is the twist per unit rate of follower c: a
    position follower's translation; a rotation-vector follower's left-Jacobian column
    ``J_l e_e = e_e + a phi x e_e + b (phi phi_e - t^2 e_e)`` (:func:`left_jacobian`; only
    the followers' columns are formed)."""
    n = len(full)
    T = np.zeros((n, 6, len(followers)))
    if any(k >= 3 for k in followers):
        phi = full[:, 3:6]
        a, b, t2 = _left_jacobian_factors(phi)
    for c, k in enumerate(followers):
        if k < 3:
            T[:, 3 + k, c] = 1.0
            continue
        e = k - 3
        bp = b * phi[:, e]
        for i in range(3):
            T[:, i, c] = bp * phi[:, i]
        T[:, e, c] += 1.0 - b * t2
        T[:, (e + 1) % 3, c] += a * phi[:, (e + 2) % 3]
        T[:, (e + 2) % 3, c] -= a * phi[:, (e + 1) % 3]
    return rate @ T.reshape((n,) + (1,) * (rate.ndim - 3) + T.shape[1:])


def _kernel_inputs(full: np.ndarray, p: dict) -> dict:
    out = dict(p)
    out.update({"x": full[:, 0], "y": full[:, 1], "z": full[:, 2]})
    out.update(zip(_ROTATION_NAMES, rotation_entries(full[:, 3:6])))
    return out


def _follower_closure(closure, followers: list):
    """The ``followers`` kernel as :func:`eigentwist.runtime.levenberg_marquardt.solve` takes a closure:
    unknowns (n, 1, followers), the commanded full poses in ``p["_full"]`` (n, 6); residual
    (n, 1, closures) and its Jacobian (n, 1, closures, followers) by the rates along the twist
    of each follower (a position follower: a translation; a rotation-vector follower: the
    left Jacobian's column)."""

    def evaluate(q, p):
        full = np.array(p["_full"], dtype=float)
        full[:, followers] = q[:, 0, :]
        n = len(full)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            out = closure(full[:, 0], full[:, 1], full[:, 2], _kernel_inputs(full, p))
        r = out["closure"].reshape(n, -1)
        rate = out["closure_rate"].reshape(n, -1, 6)
        return {"residual": r[:, None, :], "dresidual": along_followers(rate, full, followers)[:, None]}

    return evaluate


def _legs_closure(kernel, followers: list, shape: tuple):
    """The legs' loop closures (the generated ``followers`` kernel of legs solved
    numerically) as :func:`eigentwist.runtime.levenberg_marquardt.solve` takes a closure:
    one system per pose whose unknowns (n, 1, followers + legs * n_q) are the followers,
    then every leg's coordinates (``shape`` = (legs, n_q)); residual (n, 1, legs * rows),
    every leg's rows, and its Jacobian: the rows' rates along the followers' twists
    (``dresidual_pose``), and each leg's own block ``dresidual`` on its coordinates."""
    legs, nq = shape
    nf = len(followers)

    def evaluate(z, p):
        full = np.array(p["_full"], dtype=float)
        full[:, followers] = z[:, 0, :nf]
        n = len(full)
        q = z[:, 0, nf:].reshape(n, legs, nq)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            out = kernel(q, _kernel_inputs(full, p))
        r = out["residual"].reshape(n, legs, -1)
        rows = r.shape[-1]
        J = np.zeros((n, legs * rows, nf + legs * nq))
        J[:, :, :nf] = (along_followers(out["dresidual_pose"].reshape(n, legs, rows, 6), full, followers)).reshape(
            n, legs * rows, nf
        )
        A = out["dresidual"].reshape(n, legs, rows, nq)
        for i in range(legs):
            J[:, i * rows : (i + 1) * rows, nf + i * nq : nf + (i + 1) * nq] = A[:, i]
        return {"residual": r.reshape(n, 1, legs * rows), "dresidual": J[:, None]}

    return evaluate


def follow_legs(kernel, full: np.ndarray, followers: list, p: dict, reference: np.ndarray) -> np.ndarray:
    """:func:`follow` for legs solved numerically, which name no closures: the followers
    and every leg's joint coordinates solved together from the legs' loop closures (the
    generated ``followers`` kernel: residual, its Jacobian on the coordinates and its rates
    along the platform's twists) by the damped Newton method of the legs' IK
    (:func:`eigentwist.runtime.levenberg_marquardt.solve`), started from the followers 0 and
    the legs' ``reference`` (legs, n_q; rad, m for P). Returns the completed (N, 6) poses,
    NaN followers where Newton does not converge; the legs' coordinates are solved again,
    on their assembly branches, from the completed poses."""
    from .levenberg_marquardt import solve

    full = np.array(full, dtype=float)
    reference = np.asarray(reference, dtype=float)
    z0 = np.concatenate([np.zeros(len(followers)), reference.ravel()])[None]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        z = solve(_legs_closure(kernel, followers, reference.shape), z0, {**p, "_full": full}, len(full))
    full[:, followers] = z[:, 0, : len(followers)]
    return full


def follow(closure, full: np.ndarray, followers: list, p: dict, iterate=None) -> np.ndarray:
    """Solve the followers (indices into ``FULL``) of the poses ``full`` (N, 6; the
    commanded coordinates set, the followers' starting values 0) so that every leg's
    closure vanishes; returns the completed (N, 6) poses, NaN followers where Newton did not
    converge (:func:`eigentwist.runtime.levenberg_marquardt.solve`: batched from the reference, then
    warm-started from the previous pose). ``closure(x, y, z, p)`` is the generated
    ``followers`` kernel; ``p`` holds the parameters as the kernels take them.
    ``iterate``: the same iterations by other means (the C driver:
    :meth:`eigentwist.runtime.c_kernels.CKernels.follow`), as
    :func:`~eigentwist.runtime.levenberg_marquardt.solve` takes it."""
    from .levenberg_marquardt import solve

    full = np.array(full, dtype=float)
    q = solve(
        _follower_closure(closure, followers),
        np.zeros((1, len(followers))),
        {**p, "_full": full},
        len(full),
        iterations=MAX_STEPS,
        tol=TOL_M,
        iterate=iterate,
    )
    full[:, followers] = q[:, 0, :]
    return full


def commanded(space, given: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """The (N, 6) full poses (x, y, z m; rotation vector rad) of the user's poses ``given``
    (N, len(space.coordinates)) in pose space ``space`` with every other coordinate 0 (a
    follower's reference, before :func:`follow`); into ``out`` (N, 6) where given."""
    if out is None:
        out = np.zeros((len(given), 6))
    else:
        out[:] = 0.0
    for c, name in enumerate(space.coordinates):
        out[:, FULL.index(name)] = given[:, c]
    return out


def full_poses(
    space, given: np.ndarray, closure=None, p: dict | None = None, reference=None, iterate=None
) -> np.ndarray:
    """The (N, 6) full poses (x, y, z m; rotation vector rad) of the user's poses
    ``given`` (N, len(space.coordinates)) in pose space ``space``: the given coordinates,
    the followers solved (:func:`follow`; legs solved numerically, their ``reference``
    configuration (legs, n_q) given: :func:`follow_legs`; NaN rows where they do not
    converge), 0 else; ``iterate``: :func:`follow`'s."""
    full = commanded(space, given)
    followers = [FULL.index(c) for c in getattr(space, "followers", ())]
    if followers and reference is not None:
        full = follow_legs(closure, full, followers, p or {}, reference)
    elif followers:
        full = follow(closure, full, followers, p or {}, iterate)
    return full
