"""Pose completion: the user's poses validated and completed to the kernels' coordinates.

The second stage of an evaluation (:class:`~eigentwist.runtime.evaluator.Evaluator` holds one as
``ev.completion``, after the inputs resolver, :mod:`.inputs`): a batch of poses (the robot's own
coordinates, ``robot.pose``: m, and rad for rotations) is checked (shape, finite values), a
lower-mobility platform's followers are solved from its commanded coordinates
(:mod:`.platform`), a planar robot's missing coordinates set to zero, and the joint coordinates
of legs in URDF form solved by Newton's method on their loop closure
(:mod:`.levenberg_marquardt`; in C on the C backend, :mod:`.c_levenberg_marquardt`), on the
assembly branch recorded at ``x_ref``. What it gives the kernels: the pose by name
(:meth:`PoseCompletion.with_pose`).
"""

from __future__ import annotations

import numpy as np

from ..description.pose import FULL
from ..description.serial import padded_references, padded_units
from .errors import InputError

__all__ = [
    "PoseCompletion",
    "CompletedPoses",
    "CHUNK",
    "chunks",
    "map_chunks",
    "map_ranges",
    "take",
    "masked",
    "user_rows",
]

CHUNK = 4096  # poses per NumPy kernel call (temporaries stay in cache)
#: poses per chunk of numeric IK and followers, each chunk on one thread (a pose warm-starts
#: the next within its chunk): few enough chunks that their Python, which holds the GIL, does
#: not queue on it with 16 threads (benchmarks/README.md), enough to share a batch of 10^5
NEWTON_CHUNK = 8192
_ROTATION_NAMES = tuple(f"R_{i}{j}" for i in range(3) for j in range(3))


class CompletedPoses(np.ndarray):
    """Poses completed to the kernels' coordinates (:mod:`.platform`): what the public
    methods pass on to each other, so that a pose is completed once. Slices stay
    completed; arithmetic on them gives plain arrays."""

    def __array_wrap__(self, arr, context=None, return_scalar=False):
        arr = arr.view(np.ndarray)
        return arr[()] if return_scalar else arr


def chunks(n: int, size: int | None = None):
    """Slices of ``range(n)`` of at most ``size`` poses (default :data:`CHUNK`), in order."""
    size = size or CHUNK
    for start in range(0, n, size):
        yield slice(start, min(n, start + size))


def map_chunks(task, n: int, threads: int = 1, size: int | None = None) -> list:
    """``[task(rows, inner), ...]`` over the chunks of a batch of ``n`` poses (:func:`chunks`),
    in order: side by side on ``threads`` threads, each chunk on one (``inner`` = 1), where
    there are several chunks and threads; else one after another (``inner`` = ``threads``,
    for the chunk's own C calls). The chunks do not depend on ``threads``, so neither does
    what is computed chunk by chunk."""
    parts = list(chunks(n, size))
    if threads > 1 and len(parts) > 1:
        from .threads import map_tasks

        return map_tasks(lambda rows: task(rows, 1), parts, threads)
    return [task(rows, threads) for rows in parts]


def map_ranges(task, n: int, threads: int = 1) -> list:
    """``[task(rows), ...]`` over contiguous slices of ``range(n)``, in order: one slice on one
    thread, else at most ``threads`` × :data:`~.threads.TASKS_PER_THREAD` slices of whole
    chunks (:data:`CHUNK` poses) side by side. For work whose result does not depend on how the rows are
    split (a check, an elementwise conversion): each task is few large NumPy loops, which run
    without the GIL, where :func:`map_chunks`' fixed chunks would make many small tasks whose
    Python holds it (the tasks then queue on the GIL, not on the cores)."""
    if threads <= 1 or n <= CHUNK:
        return [task(slice(0, n))]
    from .threads import run_ranges

    return run_ranges(lambda begin, end: task(slice(begin, end)), n, CHUNK, threads)


def take(p: dict, sl: slice) -> dict:
    """The rows ``sl`` of a kernel input dict: per-pose (N,) arrays sliced, scalars as they are."""
    return {k: (v[sl] if v.ndim == 1 and v.shape[0] > 1 else v) for k, v in p.items()}


def masked(p: dict, mask: np.ndarray, n: int) -> dict:
    """The rows ``mask`` ((n,) bool) of a kernel input dict of n poses: (n,) arrays masked,
    scalars as they are."""
    return {k: (v[mask] if v.ndim == 1 and v.shape[0] == n and n > 1 else v) for k, v in p.items()}


def user_rows(params: dict, sl, n: int) -> dict:
    """The user's parameters for rows ``sl`` of n poses ((n,) arrays sliced, the rest kept)."""
    return {
        k: (np.asarray(v)[sl] if np.ndim(v) == 1 and np.shape(v)[0] == n and n > 1 else v) for k, v in params.items()
    }


class PoseCompletion:
    """Poses -> the kernels' coordinates of one robot, and its numerically solved legs.

    robot : the description; module : its generated NumPy module (whose ``followers`` and
    ``loop_closure`` kernels say what is solved numerically); resolver : the robot's
    :class:`~eigentwist.runtime.inputs.InputResolver`; kernels : ``() -> `` the backend's
    kernels (:class:`~eigentwist.runtime.kernels.Kernels`); c_threads : ``() ->`` the threads
    of the Newton iterations in C, or None where they run in NumPy.
    """

    def __init__(self, robot, module, resolver, kernels, c_threads):
        self.robot = robot
        self.module = module
        self.resolver = resolver
        self._kernels_of = kernels
        self.c_threads = c_threads
        self.n_legs = len(robot.legs)
        #: names of the pose coordinates (``x, y, z``; a 6-DoF robot adds ``rot_x, rot_y, rot_z``)
        self.pose_names = tuple(getattr(robot, "pose", ("x", "y", "z")))
        self.dof = len(self.pose_names)
        #: how the pose enters the kernels (:mod:`eigentwist.description.pose`)
        self.space = getattr(robot, "pose_space", None)
        #: True when the kernels take a rigid platform's six coordinates (rotation included)
        self.six = self.space is not None and len(self.space.inputs) > 3

    @property
    def kernels(self):
        """The backend's kernels (the NumPy module or the C library's)."""
        return self._kernels_of()

    def poses(self, poses, params: dict | None = None) -> np.ndarray:
        """The user's poses validated and completed to the kernels' coordinates (a planar
        or lower-mobility robot's six, followers solved with ``params``: :mod:`.platform`)."""
        if isinstance(poses, CompletedPoses):
            return poses
        arr = self.given(poses)
        if not self.six or self.pose_names == FULL:
            return arr.view(CompletedPoses)
        from .platform import full_poses

        if not self.space.followers:
            return full_poses(self.space, arr).view(CompletedPoses)
        p = self.resolver.resolve(len(arr), params or {}, "rigid")
        closure = getattr(self.module, "followers", None)
        reference = self.follower_reference()
        iterate_on = None  # inner threads -> the C iterations (levenberg_marquardt.solve's iterate)
        threads = self.c_threads()
        if threads is not None and reference is None and "followers" in self.kernels.OUTPUTS:
            from .c_levenberg_marquardt import followers_driver

            followers = [FULL.index(c) for c in self.space.followers]
            if followers_driver() is not None:  # the followers' Newton iterations in C

                def iterate_on(inner):
                    return lambda q, pp, its, tl: self.kernels.follow(q, pp, followers, its, tl, threads=inner)

        n = len(arr)
        full = np.empty((n, 6))

        def complete(sl, inner):
            its = None if iterate_on is None else iterate_on(inner)
            full[sl] = full_poses(self.space, arr[sl], closure, take(p, sl) if n > 1 else p, reference, its)

        if iterate_on is None:
            map_chunks(complete, n, 1, NEWTON_CHUNK)
            return full.view(CompletedPoses)
        # the first stage of every chunk's solve (:func:`.platform.follow`: the iterations from
        # the reference, 0) in one C call over the batch, its blocks on the threads; a chunk
        # with a pose that does not converge there is completed the long way (the same first
        # stage, then the warm starts: the same bits), fixed chunks as for numeric IK
        # (:meth:`solve_joints`), whole chunks side by side on the threads
        from .platform import MAX_STEPS, TOL_M, commanded

        commanded(self.space, arr, out=full)
        q, norm = iterate_on(threads)(np.zeros((n, 1, len(followers))), {**p, "_full": full}, MAX_STEPS, TOL_M)
        full[:, followers] = q[:, 0, :]
        ok = (norm < TOL_M).all(-1)
        again = [sl for sl in chunks(n, NEWTON_CHUNK) if not ok[sl].all()]
        map_chunks(lambda rows, inner: [complete(sl, inner) for sl in again[rows]], len(again), threads, 1)
        return full.view(CompletedPoses)

    def follower_reference(self):
        """The legs' reference configuration (legs, n_q) from which a lower-mobility
        platform's followers are solved with legs solved numerically (:func:`.platform.follow_legs`);
        None for legs in closed form (their closures give the followers)."""
        if not self.numeric_ik:
            return None
        return np.array(padded_references(self.robot.legs), dtype=float)

    def given(self, poses) -> np.ndarray:
        """``poses`` as an (N, dof) float array in the robot's own coordinates; InputError naming
        a wrong shape, an empty batch or a pose that is not finite."""
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise InputError(
                f"poses has shape {np.shape(poses)}: expected (N, {self.dof}) poses of "
                f"{self.robot.name}, columns {', '.join(self.pose_names)} ({self.pose_units()})"
            )
        if arr.shape[0] == 0:
            raise InputError(
                f"poses is empty: expected at least one ({', '.join(self.pose_names)}) pose ({self.pose_units()})"
            )
        if not np.isfinite(arr).all():  # one pass over the batch; per row only on failure
            k = int(np.argmax(~np.isfinite(arr).all(axis=1)))
            raise InputError(f"pose {k} = {arr[k].tolist()} is not finite: expected numbers ({self.pose_units()})")
        return arr

    def pose_units(self) -> str:
        """The units of the pose coordinates, for messages: ``"m"``, or ``"m and rad"``."""
        return "m" if not any(c.startswith("rot") for c in self.pose_names) else "m and rad"

    def kernel_pose_inputs(self, poses) -> dict:
        """The pose inputs the kernels read from their parameter dict, (N,) arrays by name
        (``Evaluator.kernel_pose_inputs`` documents them): none for a 3-DoF robot; a 6-DoF
        robot's position (m), rotation matrix entries ``R_ij`` and rotation vector (rad)."""
        if not self.six:
            return {}
        from .poses import rotation_entries

        poses = np.atleast_2d(np.asarray(poses, dtype=float))
        out = {"x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}
        out.update(rot_x=poses[:, 3], rot_y=poses[:, 4], rot_z=poses[:, 5])
        from .c_poses import rotation_entries as c_rotation_entries

        threads = self.c_threads()  # the C backend's: in C, on its threads (None: no library)
        entries = None if threads is None else c_rotation_entries(poses, threads)
        if entries is None and len(poses) <= CHUNK:
            entries = rotation_entries(poses[:, 3:6])
        elif entries is None:  # by chunks, side by side on the threads (NumPy lets go of the GIL in its loops)
            entries = [np.empty(len(poses)) for _ in _ROTATION_NAMES]
            map_ranges(
                lambda rows: rotation_entries(poses[rows, 3:6], [e[rows] for e in entries]), len(poses), threads or 1
            )
        out.update(zip(_ROTATION_NAMES, entries))
        return out

    def with_pose(self, poses: np.ndarray, p: dict) -> dict:
        """``p`` plus :meth:`kernel_pose_inputs` (a translational robot's: x, y, z), and for
        legs solved numerically their joint coordinates by name (:meth:`numeric_joints`)."""
        if self.six:
            p = {**p, **self.kernel_pose_inputs(poses)}
        else:
            # a translational robot's legs may read the position beyond the IK (a joint-list
            # leg's closed form): its kernels take it by name, the others ignore it
            p = {**p, "x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}
        return {**p, **self.numeric_joints(poses, p)} if self.numeric_ik else p

    @property
    def numeric_ik(self) -> bool:
        """True when the legs' IK is solved by Newton's method (legs in URDF form,
        :mod:`eigentwist.description.serial`), not in closed form."""
        return hasattr(self.module, "loop_closure")

    def numeric_joints(self, poses, p: dict) -> dict:
        """Joint coordinates of legs solved numerically at ``poses`` (:mod:`.levenberg_marquardt`:
        damped Newton from the first-order prediction :meth:`predictor`, else from the
        description's reference configuration, warm-started from the previous pose), as the IK
        kernel's inputs ``q<m>_<leg>`` ((N,) arrays, NaN where it does not converge: the IK's
        closure check then reports the pose unreachable)."""
        q = self.solve_joints(poses, p)
        return {f"q{m + 1}_{i + 1}": q[:, i, m] for i in range(q.shape[1]) for m in range(q.shape[2])}

    def assembly(self) -> dict:
        """Each leg's assembly branch recorded at ``x_ref`` with the default parameters,
        remembered: ``{"q", "sign", "residual"}`` (``Evaluator.assembly`` documents the record
        and the :class:`AssemblyError` it raises)."""
        if "_assembly" in self.__dict__:
            return self.__dict__["_assembly"]
        from .errors import AssemblyError
        from .levenberg_marquardt import continuation, same_configuration, solve

        reference = np.array(padded_references(self.robot.legs), dtype=float)
        kp = self.default_closure_inputs(self.reference_pose()[None])
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            r0 = self.kernels.loop_closure(reference[None], kp)["residual"][0]
            q_path, _ = continuation(self.kernels.loop_closure, reference, kp)
            q_direct = solve(self.kernels.loop_closure, reference, kp, 1)[0]
            lever = self.levers(q_path[None], kp)[0]
        residual = np.sqrt((r0 * r0).sum(-1))
        same = same_configuration(q_direct, q_path, np.array(padded_units(self.robot.legs)) == "rad")
        for i, leg in enumerate(self.robot.legs):
            ref = ", ".join(f"{v:.6g}" for v in reference[i])
            where = (
                f"{self.robot.name}: {leg.name}'s reference ({ref}) (rad; m for P) does not close its loop at "
                f"x_ref {list(self.robot.x_ref)}: residual {residual[i]:.3g} (m, rad)"
            )
            if not np.isfinite(q_path[i]).all():
                raise AssemblyError(
                    f"{where}, and no path of closed configurations leads from it there (a "
                    "singularity between): expected the leg's joint coordinates at x_ref"
                )
            if not same[i]:
                found = (
                    "does not converge"
                    if not np.isfinite(q_direct[i]).all()
                    else ("closes on another assembly branch (" + ", ".join(f"{v:.4g}" for v in q_direct[i]) + ")")
                )
                raise AssemblyError(
                    f"{where}; Newton's method from it {found}: expected a reference on its own "
                    f"branch, e.g. ({', '.join(f'{v:.6g}' for v in q_path[i])})"
                )
        record = {"q": q_path, "sign": np.sign(lever), "residual": residual}
        self.__dict__["_assembly"] = record
        return record

    def predictor(self):
        """``guess(poses) -> (N, legs, n_q)``: each leg's closed configuration predicted to
        first order from the assembly configuration at x_ref (:meth:`assembly`, default
        parameters), remembered; Newton's first guesses
        (:func:`eigentwist.runtime.levenberg_marquardt.predicted_start`). None where that
        configuration is singular."""
        if "_predictor" not in self.__dict__:
            from .levenberg_marquardt import predicted_start

            self.__dict__["_predictor"] = predicted_start(
                self.kernels.loop_closure, self.assembly()["q"], self.default_closure_inputs, self.reference_pose()
            )
        return self.__dict__["_predictor"]

    def reference_pose(self) -> np.ndarray:
        """(dof,) ``x_ref`` completed with the default parameters (:meth:`poses`)."""
        return self.poses(np.atleast_2d(np.asarray(self.robot.x_ref, dtype=float)), {})[0]

    def default_closure_inputs(self, x: np.ndarray) -> dict:
        """The ``loop_closure`` kernel's inputs at completed poses ``x`` (N, dof) with the
        default parameters (:meth:`closure_inputs`)."""
        return self.closure_inputs(x, self.resolver.resolve(len(x), {}, "none"))

    def levers(self, q: np.ndarray, kp: dict, threads: int | None = None) -> np.ndarray:
        """(N, legs) each leg's actuation lever (m) at joint coordinates ``q`` (N, legs, n_q)
        and the kernels' inputs ``kp``: the generated ``lever`` kernel where the legs are
        solved numerically (the jacobians kernel's output alone), else the jacobians kernel's;
        ``threads``: the C kernels' threads (None: the NumPy call)."""
        kernel = self.kernels.lever if "lever" in self.kernels.OUTPUTS else self.kernels.jacobians
        with np.errstate(invalid="ignore", divide="ignore"):
            if threads is None:
                return kernel(q, kp)["lever"]
            return kernel(q, kp, threads=threads)["lever"]

    def raise_off_branch(self, poses: np.ndarray, p: dict) -> None:
        """Raise :class:`UnreachablePoseError` for the first pose of the batch last solved
        whose Newton solution lies on another assembly branch than the one recorded at
        x_ref (:meth:`assembly`), naming the pose and the leg."""
        if not self.numeric_ik:
            return
        hit = self.__dict__.get("_newton_memo", {}).get(self.newton_key(np.atleast_2d(poses), p))
        if hit is None or not hit[1].any():
            return
        from .errors import UnreachablePoseError

        k, leg = np.argwhere(hit[1])[0]
        sign = self.assembly()["sign"][leg]
        raise UnreachablePoseError(
            f"pose {np.asarray(poses[k], dtype=float).tolist()} ({self.pose_units()}) is unreachable for "
            f"{self.robot.legs[leg].name} on its assembly branch: Newton's method closes the loop there only on "
            f"another branch (leg determinant of sign {-int(sign):+d}; {int(sign):+d} at x_ref, where the "
            "description's reference puts the robot)"
        )

    def solve_joints(self, poses, p: dict) -> np.ndarray:
        """(N, legs, n_q) joint coordinates by Newton (:func:`eigentwist.runtime.levenberg_marquardt.solve`),
        on each leg's assembly branch recorded at x_ref (:meth:`assembly`)."""
        from .levenberg_marquardt import GUESS_LAMBDA0, LAMBDA0, MAX_ITERATIONS, TOL, solve

        poses = np.atleast_2d(np.asarray(poses, dtype=float))
        key = self.newton_key(poses, p)
        memo = self.__dict__.setdefault("_newton_memo", {})
        if key in memo:
            return memo[key][0]
        n = len(poses)
        reference = np.array(padded_references(self.robot.legs), dtype=float)
        signs = self.assembly()["sign"]
        guess = self.predictor()
        iterate_on = None  # inner threads -> the C iterations (levenberg_marquardt.solve's iterate)
        threads = self.c_threads()
        if threads is not None:
            from . import c_levenberg_marquardt

            if c_levenberg_marquardt.driver() is not None:

                def iterate_on(inner):
                    def iterate(q, pp, its, tl, lambda0=None):
                        return self.kernels.newton(q, pp, its, tl, threads=inner, lambda0=lambda0)

                    return iterate

        # the pose inputs once for the batch (side by side: :meth:`kernel_pose_inputs`), or as
        # the caller computed them from these poses (:meth:`with_pose`)
        whole = p if self.pose_input_names() <= p.keys() else self.closure_inputs(poses, p)

        def one(sl, inner):
            kp = take(whole, sl) if n > 1 else whole
            its = None if iterate_on is None else iterate_on(inner)

            def branch(q):
                return self.levers(q, kp, None if its is None else inner)

            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                return solve(
                    self.kernels.loop_closure,
                    reference,
                    kp,
                    len(poses[sl]),
                    branch=branch,
                    signs=signs,
                    report=True,
                    iterate=its,
                    start=None if guess is None else guess(poses[sl]),
                )

        # bounded memory: (chunk, legs, rows, n_q) Jacobians in NumPy; the C iterations keep
        # theirs per block. A pose's warm start comes from the previous pose of its chunk
        # (:func:`map_chunks`: the same chunks on any thread count); on the C route whole
        # chunks run on the threads, so that their NumPy steps run side by side as well
        q = np.empty((n,) + reference.shape)
        off = np.zeros((n, len(reference)), dtype=bool)

        def into(sl, inner):
            q[sl], off[sl] = one(sl, inner)

        fast = None
        if iterate_on is not None and hasattr(self.kernels, "branch_solver"):
            fast = self.kernels.branch_solver(whole, n, signs)
        if fast is None:
            map_chunks(into, n, threads if iterate_on is not None else 1, NEWTON_CHUNK)
        else:
            # solve's first stage over the batch in C, its grains on the threads (each pose's
            # iterations its own); a chunk with a pose that does not converge on its branch
            # there is solved as above (the same first stage, then the retries): the same bits
            # the starts: the reference, or the predictor's, computed in C on each grain
            if guess is None:
                q[:] = reference
            done = fast(
                q,
                MAX_ITERATIONS,
                TOL,
                LAMBDA0 if guess is None else GUESS_LAMBDA0,
                threads,
                predict=None if guess is None else (poses, guess),
            )
            again = [sl for sl in chunks(n, NEWTON_CHUNK) if not done[sl].all()]

            def redo(rows, inner):  # the chunks again[rows], one by one
                for sl in again[rows]:
                    into(sl, inner)

            map_chunks(redo, len(again), threads, 1)
        memo.clear()
        memo[key] = (q, off)
        return q

    def pose_inputs(self, poses: np.ndarray) -> dict:
        """The pose as the kernels read it by name: x, y, z (m), and a 6-DoF robot's
        rotation matrix entries (:meth:`kernel_pose_inputs`)."""
        if self.six:
            return self.kernel_pose_inputs(poses)
        return {"x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}

    def closure_inputs(self, poses: np.ndarray, p: dict) -> dict:
        """The ``loop_closure`` kernel's inputs at ``poses``: ``p`` and the pose by name."""
        return {**p, **self.pose_inputs(poses)}

    def pose_input_names(self) -> frozenset:
        """Names of :meth:`pose_inputs`: x, y, z, and a 6-DoF robot's rot_x, rot_y, rot_z and
        rotation matrix entries R_ij (functions of the pose alone)."""
        names = {"x", "y", "z"}
        if self.six:
            names |= {"rot_x", "rot_y", "rot_z", *_ROTATION_NAMES}
        return frozenset(names)

    def joint_inputs(self) -> frozenset:
        """Names of the IK kernel's joint-coordinate inputs ``q<m>_<leg>`` (what
        :meth:`numeric_joints` adds to the inputs)."""
        names = self.__dict__.get("_joint_input_names")
        if names is None:
            nq = len(padded_references(self.robot.legs)[0])
            names = self._joint_input_names = frozenset(
                f"q{m + 1}_{i + 1}" for i in range(self.n_legs) for m in range(nq)
            )
        return names

    def newton_key(self, poses: np.ndarray, p: dict) -> tuple:
        """What a Newton solution depends on: the poses and every input (shape, dtype and
        bytes) but the joint coordinates it produces itself and the inputs computed from the
        pose (:meth:`pose_input_names`: the poses are in the key). The memo keeps one solution,
        so that a public call that reads the joints twice solves once."""
        skip = self.joint_inputs() | self.pose_input_names()
        return (poses.shape, poses.tobytes()) + tuple(
            (k, np.shape(v), np.asarray(v).dtype.str, np.asarray(v).tobytes())
            for k, v in sorted(p.items())
            if k not in skip
        )
