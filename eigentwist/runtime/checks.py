"""Pose checks: where the kernels may be evaluated, and the error of the first pose they may not.

A stage of an evaluation (:class:`~eigentwist.runtime.evaluator.Evaluator` holds one as
``ev.checks``, after pose completion, :mod:`.completion`): the inverse kinematics with its
reachability checks, the legs' levers (serial singularity) and the platform's actuation and
constraint rows (parallel singularity), each turned into a per-pose mask or into the error
that names the first bad pose, its leg and the violated condition (the rules:
:mod:`.validity`). The parallel check is remembered per content of the poses and the inputs
of the kernels it runs (:mod:`.memo`).
"""

from __future__ import annotations

import numpy as np

from ..description.pose import FULL
from .c_route import above_screen
from .completion import chunks, masked, take
from .memo import BoundedMemo, content_key
from .validity import (
    LEVER_SCALE,
    POSE_STATUS,
    STATUS,
    conditioning,
    lever_mask,
    parallel_mask,
    platform_rows,
    raise_parallel,
    raise_singular,
    raise_unreachable,
    reachable_mask,
)

__all__ = ["PoseChecks"]


class PoseChecks:
    """Reachability and singularity of one robot's completed poses.

    robot : the description; completion : its :class:`~eigentwist.runtime.completion.PoseCompletion`
    (the pose by name, the numerically solved legs' branch); kernels : ``() ->`` the backend's
    kernels (:class:`~eigentwist.runtime.kernels.Kernels`).
    """

    def __init__(self, robot, completion, kernels):
        self.robot = robot
        self.completion = completion
        self._kernels_of = kernels
        #: names of the pose coordinates (what an error names a pose by)
        self.pose_names = completion.pose_names
        self.space = completion.space
        #: a point platform's translations (6 x d): the only twists its legs' rows must fix
        self.freedoms = self.space.basis if getattr(self.space, "point", False) else None
        #: content of poses and kernel inputs -> :meth:`parallel_ok`'s mask
        self.parallel_memo = BoundedMemo()

    @property
    def kernels(self):
        """The backend's kernels (the NumPy module or the C library's)."""
        return self._kernels_of()

    def check_rows(self, poses: np.ndarray, p: dict, strict: bool):
        """Inverse kinematics with the reachability and singularity checks.

        Returns ``(q, jacobians, ok)``: joint angles (n, legs, 3), the ``jacobians``
        kernel output for the valid rows (None when none is valid) and the (n,) mask of
        valid rows. With ``strict`` the first invalid row raises an error naming the
        pose, the leg and the violated condition (:mod:`.validity`).
        """
        n = len(poses)
        legs = self.robot.legs
        kernels = self.kernels
        if strict:
            self.raise_unfollowed(poses)
        p = self.completion.with_pose(poses, p)
        with np.errstate(invalid="ignore", divide="ignore"):
            out = kernels.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], p)
        if strict:
            self.completion.raise_off_branch(poses, p)
            raise_unreachable(legs, poses, out, self.pose_names)
        ok = reachable_mask(out)
        q, jac = out["q"], None
        if ok.any():
            sub = p if ok.all() else masked(p, ok, n)
            with np.errstate(invalid="ignore", divide="ignore"):
                jac = kernels.jacobians(q if ok.all() else q[ok], sub)
            lever = jac["lever"] / np.asarray(sub.get(LEVER_SCALE, 1.0), dtype=float)[..., None]
            rows = platform_rows(jac["J_rows"], legs, self.freedoms)
            if strict:  # each raises on the first row its mask would drop: none is left to drop
                raise_singular(legs, poses[ok], lever, LEVER_SCALE if LEVER_SCALE in sub else None, self.pose_names)
                raise_parallel(poses[ok], rows, self.pose_names)
            else:
                ok[ok] = lever_mask(lever) & parallel_mask(rows)
        return q, jac, ok

    def ik(self, poses: np.ndarray, p: dict) -> np.ndarray:
        """(n, legs, k) joint coordinates at ``poses``, every pose checked (:meth:`check_rows`
        with ``strict``: the first unreachable or singular one raises)."""
        return self.check_rows(poses, p, strict=True)[0]

    def platform_rows(self, poses: np.ndarray, pp: dict) -> np.ndarray:
        """(n, r, 6) the platform's actuation and constraint rows at reachable poses
        (:func:`~.validity.platform_rows`; the IK and jacobians kernels of either backend);
        ``pp`` the kernels' inputs with the pose (:meth:`.PoseCompletion.with_pose`)."""
        kernels = self.kernels
        with np.errstate(invalid="ignore", divide="ignore"):
            q = kernels.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], pp)["q"]
            return platform_rows(kernels.jacobians(q, pp)["J_rows"], self.robot.legs, self.freedoms)

    def geometry_names(self):
        """The inputs the inverse-kinematics and jacobians kernels read (the C library's
        signature); None for kernels that do not declare them (no memo)."""
        spec = getattr(self.kernels, "_spec", None)
        if spec is None:
            return None
        return sorted(
            {name for k in ("inverse_kinematics", "jacobians") for group, name, _ in spec[k]["inputs"] if group != "q"}
        )

    def parallel_ok(self, poses: np.ndarray, p: dict, rows: np.ndarray, strict: bool) -> np.ndarray:
        """(len(rows),) bool: the poses ``rows`` (indices) are not parallel singular; with
        ``strict`` the first that is raises :class:`SingularPoseError`. Remembered per content
        of the poses and every input of the kernels it runs (:mod:`.memo`): the stiffnesses a
        fit varies leave it unchanged, a geometric parameter or a pose computes it anew."""
        if not len(rows):
            return np.ones(0, dtype=bool)
        n = len(poses)
        mask = np.zeros(n, dtype=bool)
        mask[rows] = True
        sub = p if mask.all() else masked(p, mask, n)
        at = poses[mask]
        pp = self.completion.with_pose(at, sub)
        names = self.geometry_names()
        key = None if names is None else content_key(at, pp, names)
        ok = None if key is None else self.parallel_memo.get(key)
        if ok is None:
            ok = parallel_mask(self.platform_rows(at, pp))
            if key is not None:
                ok.flags.writeable = False
                self.parallel_memo.put(key, ok)
        if strict and not ok.all():
            raise_parallel(at, self.platform_rows(at, pp), self.pose_names)
        return ok.copy()

    def raise_unfollowed(self, poses: np.ndarray) -> None:
        """Raise :class:`UnreachablePoseError` for the first pose whose followers did not
        converge (NaN, :mod:`.platform`), naming its commanded coordinates."""
        bad = np.isnan(poses).any(axis=1)
        if bad.any():
            from .errors import UnreachablePoseError
            from .platform import MAX_STEPS

            k = int(np.argmax(bad))
            given = ", ".join(f"{c} = {poses[k, FULL.index(c)]:.6g}" for c in self.pose_names)
            raise UnreachablePoseError(
                f"pose {given} ({self.completion.pose_units()}) is unreachable for {self.robot.name}: its "
                f"{', '.join(self.space.followers)} did not converge (damped Newton on the legs' closures, "
                f"{MAX_STEPS} steps from the reference and from the previous pose)"
            )

    def raise_first(self, poses: np.ndarray, p: dict, bad: np.ndarray) -> None:
        """Raise the error of the first pose flagged in ``bad`` by the C pass (unreachable,
        singular, ...)."""
        self.raise_unfollowed(poses)
        if self.completion.numeric_ik:
            self.completion.raise_off_branch(poses, self.completion.with_pose(poses, p))
        k = int(np.argmax(bad))
        self.kernels.raise_invalid(
            k,
            poses[:, 0],
            poses[:, 1],
            poses[:, 2],
            self.completion.with_pose(poses, p),
            (len(poses),),
            legs=self.robot.legs,
            names=self.pose_names,
        )

    def valid(
        self,
        poses: np.ndarray,
        p: dict,
        status: np.ndarray | None = None,
        freq_hz: np.ndarray | None = None,
        threads: int = 1,
    ) -> np.ndarray:
        """(N,) bool: which completed ``poses`` are reachable and neither serial nor parallel
        singular with the kernels' inputs ``p``. ``status``: the C pass's status of each pose
        (:data:`~.validity.STATUS`), which then stands for the IK and the lever checks; None:
        every check run here, chunk by chunk. ``freq_hz`` (N, n): the same pass's frequencies
        (Hz, ascending), which screen the parallel check as in the C route's modes: a pose
        whose lowest is above :data:`~.c_route.PARALLEL_SCREEN` times its highest is not
        parallel singular, the others get the exact check (:meth:`parallel_ok`); None: every
        reachable pose gets it."""
        if status is not None:
            ok = (status != STATUS["unreachable"]) & (status != STATUS["singular"])
            suspect = ok if freq_hz is None else ok & ~above_screen(freq_hz, threads)
            ok[suspect] = self.parallel_ok(poses, p, np.flatnonzero(suspect), strict=False)
            return ok
        return np.concatenate([self.check_rows(poses[sl], take(p, sl), strict=False)[2] for sl in chunks(len(poses))])

    def pose_status(self, poses: np.ndarray, p: dict) -> dict:
        """Each completed pose's status and conditioning with the kernels' inputs ``p``, never an
        error: ``{"status", "code", "conditioning", "lever"}`` as
        :meth:`~eigentwist.runtime.evaluator.Evaluator.pose_status` gives them."""
        n = len(poses)
        kernels = self.kernels
        code = np.full(n, POSE_STATUS.index("unreachable"), dtype=np.int8)
        cond, lever_min = np.full(n, np.nan), np.full(n, np.nan)
        for sl in chunks(n):
            pc = self.completion.with_pose(poses[sl], take(p, sl))
            with np.errstate(invalid="ignore", divide="ignore"):
                ik = kernels.inverse_kinematics(poses[sl, 0], poses[sl, 1], poses[sl, 2], pc)
            reach = reachable_mask(ik) & np.isfinite(poses[sl]).all(axis=1)
            if not reach.any():
                continue
            sub = masked(pc, reach, len(reach)) if not reach.all() else pc
            with np.errstate(invalid="ignore", divide="ignore"):
                jac = kernels.jacobians(ik["q"][reach], sub)
            lever = jac["lever"] / np.asarray(sub.get(LEVER_SCALE, 1.0), dtype=float)[..., None]
            rows = platform_rows(jac["J_rows"], self.robot.legs, self.freedoms)
            idx = np.arange(sl.start, sl.stop)[reach]
            cond[idx] = conditioning(rows)
            lever_min[idx] = np.abs(lever).min(axis=-1)
            code[idx] = np.where(
                ~lever_mask(lever),
                POSE_STATUS.index("serial singular"),
                np.where(~parallel_mask(rows), POSE_STATUS.index("parallel singular"), POSE_STATUS.index("reachable")),
            )
        return {
            "status": np.array(POSE_STATUS, dtype=object)[code],
            "code": code,
            "conditioning": cond,
            "lever": lever_min,
        }
