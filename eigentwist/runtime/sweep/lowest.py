"""Per design, the worst-case lowest natural frequency over the poses (what a designer maximises)."""

from __future__ import annotations

import numpy as np

from .spec import SweepSpec

__all__ = ["LowestTracker", "lowest"]


class LowestTracker:
    """Per case (design x k_a), the lowest mode-1 frequency over reachable poses.

    Updated chunk by chunk (memory: a few arrays of ``spec.n_cases``); ties go to the
    lowest pose index, so the result does not depend on the chunk order.
    """

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        c = spec.n_cases
        self.freq = np.full(c, np.nan)
        self.pose_index = np.full(c, -1, np.int64)
        self.direction = np.full(c, -1, np.int8)
        self.n_reachable = np.zeros(c, np.int64)

    def update(self, chunk: dict) -> None:
        f = chunk["freq_hz"][:, 0]
        ok = chunk["reachable"] & np.isfinite(f)
        case, f, pidx = chunk["case"][ok], f[ok], chunk["pose_index"][ok]
        if not len(case):
            return
        self.n_reachable += np.bincount(case, minlength=self.spec.n_cases)
        order = np.lexsort((pidx, f, case))
        first = order[np.r_[True, case[order][1:] != case[order][:-1]]]
        c, fc, pc = case[first], f[first], pidx[first]
        old_f, old_p = self.freq[c], self.pose_index[c]
        better = np.isnan(old_f) | (fc < old_f) | ((fc == old_f) & (pc < old_p))
        c = c[better]
        self.freq[c], self.pose_index[c] = fc[better], pc[better]
        self.direction[c] = chunk["direction"][ok][first][better, 0]

    def result(self) -> dict:
        """Arrays per case: case, k_a, design, freq_hz (NaN where no pose is reachable),
        pose (m) and pose_index where it occurs, direction (mode 1 there), n_reachable."""
        case = np.arange(self.spec.n_cases, dtype=np.int64)
        k_a, design = self.spec.case_values(case)
        pose = np.full((len(case), len(self.spec.poses.box)), np.nan)
        found = self.pose_index >= 0
        pose[found] = self.spec.poses.take(self.pose_index[found])
        return {
            "case": case,
            "k_a": k_a,
            "design": design,
            "freq_hz": self.freq.copy(),
            "pose": pose,
            "pose_index": self.pose_index.copy(),
            "direction": self.direction.copy(),
            "n_reachable": self.n_reachable.copy(),
        }


def lowest(columns: dict, spec: SweepSpec) -> dict:
    """The :class:`LowestTracker` result of sweep columns already in memory
    (``load_sweep(path).columns`` or a concatenation of :func:`evaluate_chunk` results)."""
    tracker = LowestTracker(spec)
    tracker.update(columns)
    return tracker.result()
