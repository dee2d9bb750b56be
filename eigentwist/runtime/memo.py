"""Content keys and a bounded memo for work that depends only on some of a call's inputs.

A diagnosis evaluates the same poses hundreds of times while it varies stiffnesses: what the
poses and the geometric parameters alone decide (the inverse kinematics, the parallel
singularity screen) is computed once per distinct content. The key holds the exact bytes of
every input the work reads, so a changed pose or parameter value never meets a stale answer.
"""

from __future__ import annotations

import numpy as np

__all__ = ["content_key", "BoundedMemo", "NewestKept"]


def content_key(poses: np.ndarray, values: dict, names) -> tuple:
    """A hashable key of ``poses`` and the values of ``names`` in ``values`` (exact bytes of
    each array with its shape; a scalar by its float64 value). A name absent from ``values``
    is keyed as absent."""
    parts: list = [np.ascontiguousarray(poses, dtype=np.float64).tobytes(), np.shape(poses)]
    for name in names:
        if name not in values:
            parts.append((name, None))
            continue
        arr = np.asarray(values[name], dtype=np.float64)
        parts.append((name, float(arr) if arr.ndim == 0 else (arr.shape, np.ascontiguousarray(arr).tobytes())))
    return tuple(parts)


class BoundedMemo:
    """A dict of at most ``size`` entries, emptied when full (the keys of one fit repeat)."""

    def __init__(self, size: int = 32):
        self.size = size
        self._data: dict = {}

    def get(self, key, default=None):
        return self._data.get(key, default)

    def put(self, key, value) -> None:
        if len(self._data) >= self.size:
            self._data.clear()
        self._data[key] = value

    def __len__(self) -> int:
        return len(self._data)


class NewestKept(dict):
    """A dict that keeps its ``size`` newest entries: :meth:`put` drops the oldest beyond
    that (for work held between two calls that usually follow each other, e.g. a derivation
    kept for a second backend's code)."""

    def __init__(self, size: int):
        super().__init__()
        self.size = size

    def put(self, key, value) -> None:
        self.pop(key, None)
        self[key] = value
        for old in list(self)[: -self.size]:
            del self[old]
