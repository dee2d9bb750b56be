"""Evaluate one chunk of a sweep: natural frequencies of a block of product rows."""

from __future__ import annotations

import numpy as np

from ..evaluator import Evaluator
from .spec import SweepSpec, stiffness_parameter, sweep_evaluator

__all__ = ["reachable_rows", "evaluate_chunk", "COLUMNS", "DAMPED_COLUMNS"]

COLUMNS = ("pose", "k_a", "design", "freq_hz", "direction", "reachable", "status", "pose_index", "case")
#: the columns a sweep of a model with damping adds (:attr:`Modes.damped_hz`, :attr:`Modes.damping_ratio`)
DAMPED_COLUMNS = ("damped_hz", "damping_ratio")


def reachable_rows(ev: Evaluator, poses: np.ndarray, params: dict, model) -> np.ndarray:
    """(N,) bool: the poses that :meth:`Evaluator.modes` accepts (reachable, not singular)."""
    return ev.valid(poses, model, **params)


def evaluate_chunk(spec: SweepSpec, chunk: int) -> dict:
    """Evaluate chunk ``chunk`` of the sweep: a dict of arrays, one row per product row.

    pose (n, 3) m; k_a (n,) N m/rad; design (n, len(vary)) SI units, columns in the
    order of ``spec.vary``; freq_hz (n, n_modes) ascending, Hz; direction (n, n_modes)
    int8, index into ``AXES`` of the axis carrying the largest share of each mode's energy; reachable (n,)
    bool; status (n,) int8, the position in :data:`~eigentwist.runtime.validity.POSE_STATUS`
    (0 reachable, 1 unreachable, 2 serial singular, 3 parallel singular: the singular
    region mapped); pose_index (n,), case (n,) int64. A model with damping (servo damping,
    a torque lag, a loss factor) adds damped_hz (n, n_modes), the damped frequency omega_d/2pi
    of each mode in Hz, and damping_ratio (n, n_modes), its zeta (:attr:`Modes.damped_hz`,
    :attr:`Modes.damping_ratio`, mode k the undamped model's mode k). Unreachable or
    singular rows have NaN frequencies (and damping), direction -1 and ``reachable=False``:
    they never stop the sweep.
    Deterministic: the same spec and chunk give the same bits in any process.
    """
    span = spec.chunk_rows(chunk)
    rows = np.arange(span.start, span.stop, dtype=np.int64)
    case, pose_index = np.divmod(rows, spec.n_poses)
    poses = spec.poses.take(pose_index)
    k_a, design = spec.case_values(case)
    ev = sweep_evaluator(spec.robot, spec.backend)
    params = {
        **dict(spec.fixed),
        stiffness_parameter(ev): k_a,
        **{name: design[:, k] for k, name in enumerate(spec.design_names)},
    }
    # invalid="nan": unreachable or singular rows are NaN and marked, never raise
    modes = ev.modes(poses, spec.model, invalid="nan", **params)
    reachable = np.ones(len(rows), bool) if modes.valid is None else np.asarray(modes.valid, bool)
    freq = modes.freq_hz
    direction = modes.direction.astype(np.int8)
    freq[~reachable] = np.nan
    direction[~reachable] = -1
    status = np.zeros(len(rows), dtype=np.int8)
    bad = ~reachable
    if bad.any():  # why each refused row was refused (its rows only)
        n = len(rows)
        sub = {k: (np.asarray(v)[bad] if np.ndim(v) == 1 and np.shape(v)[0] == n else v) for k, v in params.items()}
        status[bad] = ev.pose_status(poses[bad], spec.model, **sub)["code"]
    out = {
        "pose": poses,
        "k_a": k_a,
        "design": design,
        "freq_hz": freq,
        "direction": direction,
        "reachable": reachable,
        "status": status,
        "pose_index": pose_index,
        "case": case,
    }
    if ev.damped_model(spec.model):  # the decision LowestTracker makes too
        for key in DAMPED_COLUMNS:
            values = np.array(getattr(modes, key), dtype=float)
            values[~reachable] = np.nan
            out[key] = values
    return out
