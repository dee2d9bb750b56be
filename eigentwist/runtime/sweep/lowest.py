"""Per design, the worst-case lowest natural frequency over the poses (what a designer maximises);
for a model with damping also the lowest damped frequency and the least damped mode."""

from __future__ import annotations

import numpy as np

from .spec import SweepSpec, sweep_evaluator

__all__ = ["LowestTracker", "lowest"]


class LowestTracker:
    """Per case (design x k_a), the lowest mode-1 frequency over reachable poses.

    For a model with damping (:meth:`Evaluator.damped_model`) also, per case, the lowest
    damped frequency over the poses and modes (``damped_hz``) and the least damped mode (the
    smallest damping ratio, ``damping_ratio``), each with its pose and mode. Updated chunk by
    chunk (memory: a few arrays of ``spec.n_cases``); ties go to the lowest pose index, so the
    result does not depend on the chunk order.
    """

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        c = spec.n_cases
        self.freq = np.full(c, np.nan)
        self.pose_index = np.full(c, -1, np.int64)
        self.direction = np.full(c, -1, np.int8)
        self.n_reachable = np.zeros(c, np.int64)
        damped = sweep_evaluator(spec.robot, spec.backend).damped_model(spec.model)
        keys = ("damped_hz", "damping_ratio") if damped else ()
        self.least = {k: (np.full(c, np.nan), np.full(c, -1, np.int64), np.full(c, -1, np.int64)) for k in keys}

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
        for key in self.least:
            self._least(key, chunk)

    def _least(self, key: str, chunk: dict) -> None:
        """Keep per case the row and mode of the smallest ``chunk[key]`` (damped frequency or
        damping ratio) over reachable rows and modes; ties: the lowest pose index, then mode."""
        values = chunk[key]
        ok = chunk["reachable"] & np.isfinite(values).any(axis=1)
        if not ok.any():
            return
        rows = values[ok]
        mode = np.argmin(np.where(np.isnan(rows), np.inf, rows), axis=1)
        v = rows[np.arange(len(rows)), mode]
        case, pidx = chunk["case"][ok], chunk["pose_index"][ok]
        order = np.lexsort((pidx, v, case))
        first = order[np.r_[True, case[order][1:] != case[order][:-1]]]
        c, vc, pc, mc = case[first], v[first], pidx[first], mode[first]
        best, where, which = self.least[key]
        better = np.isnan(best[c]) | (vc < best[c]) | ((vc == best[c]) & (pc < where[c]))
        c = c[better]
        best[c], where[c], which[c] = vc[better], pc[better], mc[better]

    def result(self) -> dict:
        """Arrays per case: case, k_a, design, freq_hz (NaN where no pose is reachable),
        pose (m) and pose_index where it occurs, direction (mode 1 there), n_reachable; with
        damping also damped_hz (Hz) and damping_ratio (-), each with ``<key>_pose``,
        ``<key>_pose_index`` and ``<key>_mode`` (0-based, in ascending undamped order)."""
        case = np.arange(self.spec.n_cases, dtype=np.int64)
        k_a, design = self.spec.case_values(case)
        pose = np.full((len(case), len(self.spec.poses.box)), np.nan)
        found = self.pose_index >= 0
        pose[found] = self.spec.poses.take(self.pose_index[found])
        out = {
            "case": case,
            "k_a": k_a,
            "design": design,
            "freq_hz": self.freq.copy(),
            "pose": pose,
            "pose_index": self.pose_index.copy(),
            "direction": self.direction.copy(),
            "n_reachable": self.n_reachable.copy(),
        }
        for key, (best, where, which) in self.least.items():
            at = np.full_like(pose, np.nan)
            at[where >= 0] = self.spec.poses.take(where[where >= 0])
            out[key] = best.copy()
            out.update({f"{key}_pose": at, f"{key}_pose_index": where.copy(), f"{key}_mode": which.copy()})
        return out


def lowest(columns: dict, spec: SweepSpec) -> dict:
    """The :class:`LowestTracker` result of sweep columns already in memory
    (``load_sweep(path).columns`` or a concatenation of :func:`evaluate_chunk` results)."""
    tracker = LowestTracker(spec)
    tracker.update(columns)
    return tracker.result()
