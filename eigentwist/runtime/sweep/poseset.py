"""The poses of a sweep: a grid or seeded random poses in a box (m), drawn by index.

Random poses come in seeded blocks of :data:`POSE_BLOCK`, so that any row's pose is found
without drawing the ones before it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["PoseSet", "POSE_BLOCK"]

POSE_BLOCK = 65536  # random poses are drawn in seeded blocks of this many


@dataclass(frozen=True)
class PoseSet:
    """End-effector positions in a box ``((xlo, xhi), (ylo, yhi), (zlo, zhi))`` (m); for a
    6-DoF robot six ranges, the rotation vector's three in rad (poses (n, 6)).

    ``sampling="grid"``: ``shape = (nx, ny, nz)`` points per axis (six counts for a 6-DoF
    box), ends included (an axis with one point sits at the middle of its interval),
    the first axis slowest, the last fastest.
    ``sampling="random"``: ``n`` uniform samples, reproducible from ``seed`` and
    independent of the chunk size (drawn in blocks of :data:`POSE_BLOCK`).
    """

    sampling: str
    box: tuple
    shape: tuple = ()
    n: int = 0
    seed: int = 0

    @property
    def count(self) -> int:
        return int(np.prod(self.shape)) if self.sampling == "grid" else int(self.n)

    def axis(self, k: int) -> np.ndarray:
        """Grid coordinates (m) along axis ``k`` (0: x, 1: y, 2: z)."""
        lo, hi = self.box[k]
        return np.array([0.5 * (lo + hi)]) if self.shape[k] == 1 else np.linspace(lo, hi, self.shape[k])

    def take(self, index: np.ndarray) -> np.ndarray:
        """Poses, shape (len(index), len(box)), of the poses numbered ``index``."""
        index = np.asarray(index, dtype=np.int64)
        dim = len(self.box)
        if self.sampling == "grid":
            ijk = np.unravel_index(index, self.shape)
            return np.column_stack([self.axis(k)[ijk[k]] for k in range(dim)])
        lo = np.array([b[0] for b in self.box])
        hi = np.array([b[1] for b in self.box])
        block, row = np.divmod(index, POSE_BLOCK)
        unit = np.empty((len(index), dim))
        for b in np.unique(block):
            here = block == b
            unit[here] = _random_block(self.seed, int(b), dim)[row[here]]
        return lo + (hi - lo) * unit


@lru_cache(maxsize=4)
def _random_block(seed: int, block: int, dim: int = 3) -> np.ndarray:
    """Uniform [0, 1) samples, (POSE_BLOCK, dim), of block ``block`` of stream ``seed``."""
    out = np.random.default_rng([seed, block]).random((POSE_BLOCK, dim))
    out.flags.writeable = False
    return out
