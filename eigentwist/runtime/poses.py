"""6-DoF poses: position (m) and rotation vector (axis x angle, rad) of the platform frame."""

from __future__ import annotations

import numpy as np

__all__ = ["rotation_matrix", "rotation_entries", "rotation_vector", "exp_twist"]


def _rodrigues(r: np.ndarray) -> tuple:
    """``x, y, z, xx, yy, zz, a, b`` of rotation vectors ``r`` (..., 3): the components,
    their squares and Rodrigues' ``a = sin(t)/t``, ``b = (1 - cos t)/t^2`` (their series
    below t^2 = 1e-12)."""
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    xx, yy, zz = x * x, y * y, z * z
    t2 = xx + yy + zz
    small = t2 < 1e-12
    if np.any(small):
        safe = np.where(small, 1.0, np.sqrt(t2))
        a = np.where(small, 1 - t2 / 6, np.sin(safe) / safe)
        b = np.where(small, 0.5 - t2 / 24, (1 - np.cos(safe)) / safe**2)
    else:  # no series term selected: the same values
        safe = np.sqrt(t2)
        a = np.sin(safe) / safe
        b = (1 - np.cos(safe)) / safe**2
    return x, y, z, xx, yy, zz, a, b


#: entry k = 3 i + j of R = I + a [r]x + b [r]x^2 from :func:`_rodrigues`'s terms, into ``out``
_ENTRIES = (
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(1, b * (-zz - yy), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(-(a * z), b * (x * y), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(a * y, b * (x * z), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(a * z, b * (x * y), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(1, b * (-zz - xx), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(-(a * x), b * (y * z), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(-(a * y), b * (x * z), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(a * x, b * (y * z), out=out),
    lambda x, y, z, xx, yy, zz, a, b, out: np.add(1, b * (-yy - xx), out=out),
)


def rotation_entries(rotvec, out=None) -> list:
    """The nine entries ``[R_00, R_01, ..., R_22]`` of the rotation matrices of rotation
    vectors (..., 3) (rad), each an array of shape (...): Rodrigues' formula
    ``R = I + a [r]x + b [r]x^2``, ``a = sin(t)/t``, ``b = (1 - cos t)/t^2``, with their
    series near t = 0 (the arithmetic of :func:`rotation_matrix`, element by element).
    ``out``: nine arrays of shape (...) written in place (and returned)."""
    terms = _rodrigues(np.asarray(rotvec, dtype=float))
    return [entry(*terms, None if out is None else o) for entry, o in zip(_ENTRIES, out or [None] * 9)]


def rotation_matrix(rotvec) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) by Rodrigues' formula,
    with the series of sin(t)/t and (1 - cos t)/t^2 near t = 0."""
    r = np.asarray(rotvec, dtype=float)
    return np.stack(rotation_entries(r), axis=-1).reshape(r.shape[:-1] + (3, 3))


def rotation_vector(R) -> np.ndarray:
    """Rotation vector (3,) of a rotation matrix (angle below pi)."""
    R = np.asarray(R, dtype=float)
    c = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    angle = np.arccos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2
    return w if angle < 1e-12 else w * angle / np.sin(angle)


def exp_twist(pose, twist, eps: float) -> np.ndarray:
    """The pose (6,) reached from ``pose`` by moving along the platform twist
    ``[omega; v]`` (at the platform origin, base axes) for ``eps`` seconds: the origin
    moves by ``eps v``, the frame rotates by ``exp(eps [omega]x)`` in base axes."""
    pose, twist = np.asarray(pose, dtype=float), np.asarray(twist, dtype=float)
    R = rotation_matrix(eps * twist[:3]) @ rotation_matrix(pose[3:])
    return np.concatenate([pose[:3] + eps * twist[3:], rotation_vector(R)])
