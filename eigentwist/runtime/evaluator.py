"""The evaluator users import: validated batches in, matrices and frequencies out."""

from __future__ import annotations

import warnings
from types import ModuleType

import numpy as np

from ..description import RobotDescription
from ..description.joints import joint_kind
from ..description.pose import TWIST_AXIS, twist_order
from .errors import InputError
from .c_route import CPassRoute
from .checks import PoseChecks
from .mode_solver import MATRICES, ModeSolver
from .completion import PoseCompletion, chunks, take, user_rows
from .inputs import InputResolver
from .kernels import Kernels
from .routes import choose_route
from .sensitivity_route import SensitivityRoute
from .modes import AXES, Modes
from .threads import resolve_threads
from .validity import (
    CONDITIONING_TOL,
    LEVER_SCALE,
    LEVER_TOL,
    POSE_STATUS,
    STATUS,
    raise_singular,
)

__all__ = ["Evaluator", "Modes", "AXES", "LEVER_TOL", "CONDITIONING_TOL", "POSE_STATUS"]

MATRIX_CHUNK = 65536  # default chunk of Evaluator.iter_matrices: 3 x 18 MiB of (6, 6) matrices


class Evaluator:
    """Evaluate a generated model for batches of poses and parameter values.

    Obtain one with :func:`eigentwist.load`. Poses are end-effector positions (m) in
    the base frame, shape (N, 3) or (3,), for a 3-DoF robot; a 6-DoF robot (the hexapod)
    takes (N, 6) or (6,): the platform origin (m) and the rotation vector of the platform
    frame (axis x angle, rad; ``robot.pose`` names the coordinates); parameters are keyword arguments, scalars or
    (N,) arrays, overriding the description's defaults (SI units, see
    ``evaluator.parameters``). ``model`` is a preset (``"rigid"``, ``"paper"``) or a
    comma-separated list of effects.

    ``threads`` (C backend): threads of one C pass; None takes ``EIGENTWIST_THREADS``, else
    1 inside a Dask worker, else every core (:mod:`eigentwist.runtime.threads`). Results
    do not depend on it, bit for bit.

    A call runs in stages: the inputs resolver (``ev.resolver``, :mod:`.inputs`: model and
    values -> the kernels' inputs), pose completion (``ev.completion``, :mod:`.completion`:
    poses -> the kernels' coordinates, legs solved by Newton), the pose checks (``ev.checks``,
    :mod:`.checks`: reachable, not singular), the kernels (``ev.kernels``,
    :mod:`.kernels`: the generated NumPy module or the C library), and the route that solves
    the modes (:mod:`.routes`): the fused C pass (``ev.c_route``, :mod:`.c_route`) or the
    matrices and the eigen-solver (``ev.solver``, :mod:`.mode_solver`); the frequencies'
    derivatives: ``ev.sensitivity_route`` (:mod:`.sensitivity_route`).
    """

    def __init__(
        self, robot: RobotDescription, module: ModuleType, backend: str, kernels: Kernels | None = None, threads=None
    ):
        self.robot = robot
        self.module = module
        self.backend = backend
        self._kernels = kernels or module
        self.threads = None if threads is None else resolve_threads(threads)
        #: the inputs resolver (model and parameter values -> the kernels' inputs, :mod:`.inputs`)
        self.resolver = InputResolver(robot)
        #: pose completion (poses -> the kernels' coordinates, legs solved by Newton: :mod:`.completion`)
        self.completion = PoseCompletion(robot, module, self.resolver, lambda: self._kernels, self._c_threads)
        #: pose checks (reachability, serial and parallel singularity: :mod:`.checks`)
        self.checks = PoseChecks(robot, self.completion, lambda: self._kernels)
        self.defaults = robot.defaults
        self.effects = robot.effects
        self.n_legs = len(robot.legs)
        #: what :func:`eigentwist.load` was given: a shipped robot's name or a description file's path
        self.spec = robot.name
        #: names of the pose coordinates (``x, y, z``; a 6-DoF robot adds ``rot_x, rot_y, rot_z``)
        self.pose_names = self.completion.pose_names
        self.dof = self.completion.dof
        #: how the pose enters the kernels (:mod:`eigentwist.description.pose`)
        self.space = self.completion.space
        #: True when the kernels take a rigid platform's six coordinates (rotation included)
        self._six = self.completion.six
        #: C backend: run the Newton iterations of legs in URDF form and of a platform's followers in C
        #: (:mod:`.c_levenberg_marquardt`)
        self.c_newton = True
        #: the fused C pass and its route of the modes (:mod:`.c_route`)
        self.c_route = CPassRoute(self)
        #: the matrices route and what both routes share: the constraints' treatment, the
        #: exact condensation, the damped modes' inputs, the eigen-solver (:mod:`.mode_solver`)
        self.solver = ModeSolver(self)
        #: the frequencies' derivatives with respect to the parameters (:mod:`.sensitivity_route`)
        self.sensitivity_route = SensitivityRoute(self)
        if self.numeric_ik:
            self.assembly()  # a reference on no branch is refused at load

    @property
    def parameters(self) -> dict:
        """Parameter name -> :class:`~eigentwist.description.parameters.Parameter` (unit, default,
        bounds): the names a call takes (``NAME@N`` too for a leg-level one, :meth:`accepts`)."""
        return self.resolver.parameters

    @property
    def leg_parameters(self) -> dict:
        """Parameter name -> the leg-level effect that owns it (these take ``NAME@N``)."""
        return self.resolver.leg_parameters

    @property
    def constraints(self) -> list:
        """The description's constraints between parameters, compiled (checked on every call)."""
        return self.resolver.constraints

    def _c_threads(self):
        """The threads of the Newton iterations in C (the C backend with ``c_newton``), else None."""
        return self.c_route.nthreads() if self.c_route.fused and self.c_newton else None

    def __repr__(self) -> str:
        return f"<eigentwist evaluator {self.robot.name!r} backend={self.backend!r}>"

    # ------------------------------------------------- poses and inputs (the stages)
    def completed_poses(self, poses, **params) -> np.ndarray:
        """The poses completed to the kernels' six coordinates (x, y, z in m, rot_x, rot_y,
        rot_z in rad): a lower-mobility platform's followers solved from its commanded
        coordinates with ``params`` (:mod:`.platform`), a planar robot's missing ones zero.
        An array this returns is taken as complete when given back (no follower solved)."""
        return self.completion.poses(poses, params)

    def kernel_pose_inputs(self, poses) -> dict:
        """The pose inputs the generated kernels read from their parameter dict, (N,)
        arrays by name: none for a 3-DoF robot (its kernels take x, y, z as arguments);
        for a 6-DoF robot the position ``x, y, z`` (m) and the rotation matrix entries
        ``R_ij`` of the rotation vector (Rodrigues, :func:`~eigentwist.runtime.poses.rotation_matrix`),
        and the rotation vector itself ``rot_x, rot_y, rot_z`` (rad), from which the C pass
        computes the ``R_ij`` it reads."""
        return self.completion.kernel_pose_inputs(poses)

    @property
    def numeric_ik(self) -> bool:
        """True when the legs' IK is solved by Newton's method (legs in URDF form,
        :mod:`eigentwist.description.serial`), not in closed form."""
        return self.completion.numeric_ik

    def numeric_joints(self, poses, p: dict) -> dict:
        """Joint coordinates of legs solved numerically at ``poses`` (:mod:`.levenberg_marquardt`: damped
        Newton from the description's reference configuration, warm-started from the
        previous pose), as the IK kernel's inputs ``q<m>_<leg>`` ((N,) arrays, NaN where it
        does not converge: the IK's closure check then reports the pose unreachable)."""
        return self.completion.numeric_joints(poses, p)

    def assembly(self) -> dict:
        """Each leg's assembly branch, recorded at ``x_ref`` with the default parameters
        (legs solved numerically, :mod:`eigentwist.description.serial`).

        Returns ``{"q": (legs, n_q) the closed configuration connected to the reference
        (:func:`~.levenberg_marquardt.continuation`), "sign": (legs,) the sign of each leg's determinant
        there (the branch every solution must keep), "residual": (legs,) |r| of the
        reference itself (m and rad)}``. Raises :class:`AssemblyError` naming the leg and
        the residual when a reference closes on no branch (a singularity between) or
        Newton's method from it closes on another branch than the one it is connected to.
        """
        return self.completion.assembly()

    def solve_joints(self, poses, p: dict) -> np.ndarray:
        """(N, legs, n_q) joint coordinates by Newton (:func:`eigentwist.runtime.levenberg_marquardt.solve`),
        on each leg's assembly branch recorded at x_ref (:meth:`assembly`)."""
        return self.completion.solve_joints(poses, p)

    @property
    def kernels(self) -> Kernels:
        """The generated kernels of this backend: the NumPy module, or the C library's
        :class:`~eigentwist.runtime.c_kernels.CKernels` (same functions and outputs; the
        protocol :class:`~eigentwist.runtime.kernels.Kernels`)."""
        return self._kernels

    def pose_inputs(self, poses: np.ndarray) -> dict:
        """The pose as the kernels read it by name: x, y, z (m), and a 6-DoF robot's
        rotation matrix entries (:meth:`kernel_pose_inputs`)."""
        return self.completion.pose_inputs(poses)

    def closure_inputs(self, poses: np.ndarray, p: dict) -> dict:
        """The ``loop_closure`` kernel's inputs at ``poses``: ``p`` and the pose by name."""
        return self.completion.closure_inputs(poses, p)

    def joint_sensitivities(self, poses, wrt=None, **params) -> np.ndarray:
        """d q / d p of legs solved numerically: (N, legs, n_q, len(wrt)), rad (m for a
        prismatic joint) per SI unit of each parameter, by the implicit function theorem on
        the loop closure ``r(q, p) = 0``: ``J_q dq/dp = -dr/dp`` (:mod:`.implicit`; J_q the
        closure's exact Jacobian, dr/dp by central differences of the residual at fixed q).
        ``wrt``: parameter names (default: every parameter; ``P@N`` one leg's own value)."""
        from .implicit import joint_derivatives
        from .sensitivity import check_wrt

        if not self.numeric_ik:
            raise InputError(
                f"joint_sensitivities of {self.robot.name}: its legs have a closed-form inverse "
                "kinematics (no loop closure is solved); differentiate joint_angles instead"
            )
        poses = self.completion.poses(poses, params)
        return joint_derivatives(self, poses, check_wrt(self, wrt), params)[1]

    def rigid_size(self) -> int:
        """Size of the rigid model's eigenproblem: the number of the platform's allowed
        twists, one per pose coordinate (3 for a Delta, a 3-PRS, a planar robot; 6 for
        the hexapod)."""
        return self.dof

    def axes(self, stiffness_model: str) -> tuple:
        """Names of the modes' coordinates for a ``"rigid"`` or ``"flexible"`` stiffness model:
        the rigid model's are the allowed twists (:mod:`.allowed`), named by the pose
        coordinates they start from (``rot_z`` -> ``rz``)."""
        if stiffness_model != "rigid":
            return AXES
        return tuple(AXES[TWIST_AXIS[c]] for c in twist_order(self.pose_names))

    def parameter(self, name: str):
        """The :class:`Parameter` ``name``; ``NAME@N`` gives leg N's copy (same unit, bounds)."""
        return self.resolver.parameter(name)

    def accepts(self, name: str) -> bool:
        """True when ``name`` is a parameter, or ``NAME@N`` of a leg-level one with N a leg."""
        return self.resolver.accepts(name)

    def inputs(self, model="paper", values: dict | None = None, **params) -> dict:
        """The full input dict of the generated code for ``model`` and parameter ``values``.

        What the generated NumPy module's functions take as ``p`` (``ev.module.matrices(q,
        ev.inputs(...))``) and what ``<robot>_c.h`` lists as the C library's inputs: every
        parameter (SI units; the description's default unless given), each effect's switch
        ``on_<effect>`` or, for a leg-level effect, ``on_<effect>__N`` per leg (1.0 on, 0.0
        off), and each leg's copy ``P__N`` of a leg-level effect's parameter P (leg N's own
        value when ``values`` has ``P@N``, else P's). ``values`` and keyword arguments are
        parameter values by name (``P@N`` for one leg), checked as :meth:`frequencies`
        checks them. Scalars come back as floats, (N,) arrays as arrays. A 6-DoF robot's
        kernels also read the pose from ``p``: add :meth:`kernel_pose_inputs`.
        """
        return self.resolver.inputs(model, values, **params)

    def stiffness_model(self, model) -> str:
        """``"flexible"`` (K_F, Eq. 13) when the model has a structural compliance, else
        ``"rigid"`` (K_R, Eq. 14)."""
        return self.resolver.stiffness_model(model)

    def kind(self, model) -> str:
        """Deprecated name of :meth:`stiffness_model`."""
        warnings.warn("Evaluator.kind is deprecated: use Evaluator.stiffness_model", DeprecationWarning, stacklevel=2)
        return self.stiffness_model(model)

    # ---------------------------------------------------------------- kernels
    def _run(self, kernel: str, poses, model, params: dict) -> dict:
        poses = self.completion.poses(poses, params)
        n = len(poses)
        p = self.resolver.resolve(n, params, model)
        results: dict = {}
        for sl in chunks(n):
            pc = take(p, sl)
            q, jac, _ = self.checks.check_rows(poses[sl], pc, strict=True)
            # the checks already evaluated the jacobians kernel: every result carries it
            out = (
                {"q": q, **jac}
                if kernel == "jacobians"
                else {"q": q, **jac, **getattr(self._kernels, kernel)(q, self.completion.with_pose(poses[sl], pc))}
            )
            for key, val in out.items():
                results.setdefault(key, []).append(val)
        return {k: np.concatenate(v, axis=0) for k, v in results.items()}

    # ----------------------------------------------------------------- public
    def valid(self, poses, model="paper", **params) -> np.ndarray:
        """(N,) bool: which poses are reachable and neither serial nor parallel singular
        for these parameters (:meth:`pose_status` says which).

        The per-row form of the checks that make :meth:`modes` raise; use it to filter
        a batch (e.g. a sweep over a workspace box) instead of catching errors. With the C
        pass, as in :meth:`modes`: the pass checks reachability and the levers, and solves
        the model where it can (:meth:`.CPassRoute.pass_model`), so that only the poses below the
        parallel screen (:data:`~.c_route.PARALLEL_SCREEN`) get the exact parallel check.
        """
        poses = self.completion.poses(poses, params)
        p = self.resolver.resolve(len(poses), params, model)
        if not self.c_route.fused:
            return self.checks.valid(poses, p)
        out = self.c_route.run(poses, p, matrices=(), model=self.c_route.pass_model(model))
        return self.checks.valid(poses, p, out["status"], out.get("freq_hz"), self.c_route.nthreads())

    def pose_status(self, poses, model="paper", **params) -> dict:
        """Each pose's status and conditioning, never an error.

        Returns ``{"status": (N,) str, "code": (N,) int8, "conditioning": (N,),
        "lever": (N,)}``. ``status`` is one of :data:`~.validity.POSE_STATUS`
        (``code`` its position): ``"reachable"``; ``"unreachable"`` (a leg's check left
        [-1, 1], its joint coordinates are not finite, or the followers did not converge);
        ``"serial singular"`` (a leg's unit twists are dependent: its smallest
        ``|lever|``, relative to ``l1`` where the robot has it, at or below ``LEVER_TOL``);
        ``"parallel singular"`` (the legs' actuation and constraint wrenches leave a
        platform twist free: ``conditioning``, the inverse condition number 0..1 of
        their unit rows, at or below :data:`~.validity.CONDITIONING_TOL`). ``conditioning``
        and ``lever`` are NaN where the pose is unreachable. :meth:`modes` raises
        :class:`SingularPoseError` at either singularity and :meth:`valid` is False there.
        """
        poses = self.completion.poses(poses, params)
        return self.checks.pose_status(poses, self.resolver.resolve(len(poses), params, model))

    def joint_angles(self, poses, **params) -> np.ndarray:
        """Joint coordinates from the closed-form IK, shape (N, legs, k): (q1, q2, q3) per
        leg in rad for the Heli4/Delta (k = 3); the leg length in m for the hexapod (k = 1)."""
        poses = self.completion.poses(poses, params)
        p = self.resolver.resolve(len(poses), params, "paper")
        return np.concatenate([self.checks.ik(poses[sl], take(p, sl)) for sl in chunks(len(poses))])

    def jacobians(self, poses, **params) -> dict:
        """Inverse-Jacobian rows ``J_rows`` (N, legs, 4, 6), (N, legs, 6, 6) for the hexapod
        (the actuated joint's row first), and levers ``lever`` (N, legs)."""
        return self._run("jacobians", poses, "paper", params)

    def parameter_values(self, n: int, model="paper", **params) -> dict:
        """The generated kernels' parameter input for ``n`` poses, validated.

        Every parameter of the robot (``params`` overriding the defaults, SI units) as an
        array that broadcasts with the poses, plus the 0/1 switch of every effect (the
        caller's own arrays: writing into them changes nothing here).
        """
        return {k: np.array(v) for k, v in self.resolver.resolve(n, params, model).items()}

    def run_kernel(self, kernel: str, poses, model="paper", **params) -> dict:
        """Outputs of the generated kernel ``kernel`` (e.g. ``"gravity"``) for ``poses``.

        Poses are checked (reachable, not singular) as in :meth:`matrices`; the result
        also holds the joint angles ``q`` and the ``jacobians`` kernel's outputs.
        """
        return self._run(kernel, poses, model, params)

    def matrices(self, poses, model="paper", *, out: dict | None = None, joints=None, **params) -> dict:
        """``M``, ``K_R``, ``K_F`` at the EE origin, each (N, 6, 6) (Eqs. 12, 14, 13).

        ``model`` switches effects on or off (K_R uses only the actuator-side effects).
        ``joints``: measured joint coordinates (N, legs, coordinates), e.g. encoder
        readings, used instead of the inverse kinematics (:meth:`joint_matrices`).
        ``out`` maps any of ``"M"``, ``"K_R"``, ``"K_F"`` to a preallocated C-contiguous
        float64 (N, 6, 6) array (e.g. a ``numpy.memmap``) that is written in place and
        returned; nothing else of that size is allocated. For batches too large to hold,
        :meth:`iter_matrices` yields them chunk by chunk.
        """
        if joints is not None:
            mats = self.joint_matrices(poses, joints, model, **params)
            for k, arr in self._check_out(out, len(mats["M"])).items():
                arr[...] = mats[k]
                mats[k] = arr
            return mats
        poses = self.completion.poses(poses, params)
        n = len(poses)
        p = self.resolver.resolve(n, params, model)
        out = self._check_out(out, n)
        if self.c_route.fused:
            res = self.c_route.run(poses, p, matrices=MATRICES, out=out)
            bad = res["status"] != STATUS["ok"]
            if bad.any():
                self.checks.raise_first(poses, p, bad)
            self.checks.parallel_ok(poses, p, np.arange(n), strict=True)
            return {k: res[k] for k in MATRICES}
        return self.solver.matrices_q(poses, p, out)[0]

    @staticmethod
    def _check_out(out, n: int) -> dict:
        out = dict(out or {})
        unknown = sorted(set(out) - set(MATRICES))
        if unknown:
            raise InputError(f"out has unknown key(s) {unknown}: expected some of {list(MATRICES)}")
        for k, arr in out.items():
            if (
                not isinstance(arr, np.ndarray)
                or arr.shape != (n, 6, 6)
                or arr.dtype != np.float64
                or not arr.flags.c_contiguous
                or not arr.flags.writeable
            ):
                raise InputError(
                    f"out[{k!r}]: expected a writeable C-contiguous float64 array of shape ({n}, 6, 6), "
                    f"got {getattr(arr, 'shape', None)} {getattr(arr, 'dtype', type(arr).__name__)}"
                )
        return out

    @property
    def joint_units(self) -> tuple:
        """Unit of each joint coordinate per leg (the last axis of :meth:`joint_angles`):
        ``"m"`` for a prismatic joint's, ``"rad"`` for the others' (a Pi joint's angle too).
        Leg 1's where legs differ (:attr:`leg_joint_units` gives each leg's)."""
        return self.leg_joint_units[0]

    @property
    def leg_joint_units(self) -> tuple:
        """Each leg's coordinate units, one tuple per leg of its own length (legs that differ:
        :meth:`joint_angles` pads a shorter leg's coordinates with zeros after them)."""
        return tuple(
            tuple(joint_kind(leg.joints[c[0]].kind).unit for c in leg.kinematics.coordinates) for leg in self.robot.legs
        )

    def joint_coordinates(self, joints, poses=None) -> tuple:
        """Validate measured joint coordinates: ``(joints (N, legs, k), poses (N, dof))``.

        ``joints`` has the shape :meth:`joint_angles` returns (rad; m for a prismatic
        joint). ``poses`` may be None when the model reads the joint coordinates only
        (a translational platform); a 6-DoF robot's model reads the pose too."""
        q = np.asarray(joints, dtype=float)
        if q.ndim == 2:
            q = q[None]
        nq = max(len(leg.kinematics.coordinates) for leg in self.robot.legs)  # legs that differ: padded
        if q.ndim != 3 or q.shape[1:] != (self.n_legs, nq):
            raise InputError(
                f"joints has shape {np.shape(joints)}: expected (N, {self.n_legs}, {nq}) joint "
                f"coordinates of {self.robot.name} (legs x coordinates, as joint_angles returns)"
            )
        if not np.isfinite(q).all():
            k = int(np.argmax(~np.isfinite(q).reshape(len(q), -1).all(axis=1)))
            raise InputError(f"joints[{k}] is not finite: expected numbers (rad; m for a prismatic joint)")
        if poses is None:
            if self._six:
                raise InputError(
                    f"joints without poses: the model of {self.robot.name} reads the pose too "
                    f"({', '.join(self.pose_names)}): give both"
                )
            poses = np.zeros((len(q), 3))
        poses = self.completion.poses(poses)
        if len(poses) != len(q):
            raise InputError(f"joints has {len(q)} rows and poses {len(poses)}: expected one pose per row of joints")
        return q, poses

    def joint_matrices(self, poses, joints, model="paper", **params) -> dict:
        """``M``, ``K_R``, ``K_F`` (N, 6, 6) at measured joint coordinates ``joints``
        (N, legs, coordinates: rad, m for a prismatic joint; :meth:`joint_angles`'s
        layout), instead of the inverse kinematics of ``poses``. The model is a function
        of the joint coordinates and the design parameters (and, for a 6-DoF robot, of the
        pose); where both exist, the joints of a pose give what the pose gives. A
        singular configuration raises as for a pose."""
        q, poses = self.joint_coordinates(joints, poses)
        p = self.resolver.resolve(len(q), params, model)
        pk = {
            **p,
            **(self.kernel_pose_inputs(poses) if self._six else {"x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}),
        }
        with np.errstate(invalid="ignore", divide="ignore"):
            lever = self._kernels.jacobians(q, pk)["lever"]
        lever = lever / np.asarray(pk.get(LEVER_SCALE, 1.0), dtype=float)[..., None]
        raise_singular(self.robot.legs, poses, lever, LEVER_SCALE if LEVER_SCALE in pk else None, self.pose_names)
        out = self._kernels.matrices(q, pk)
        return {k: out[k] for k in MATRICES}

    def iter_matrices(self, poses, model="paper", *, chunk: int = MATRIX_CHUNK, **params):
        """Yield ``(rows, matrices)`` chunk by chunk: ``rows`` a slice of ``poses``,
        ``matrices`` what :meth:`matrices` returns for those rows.

        Memory stays bounded by the chunk whatever the batch: 3 x 288 B per pose, 57 MB for
        the default 65536 poses, twice that while the caller still holds the previous chunk.
        Every input is checked before the first chunk; an unreachable or singular pose raises
        when its chunk is reached.
        """
        poses = self.completion.poses(poses, params)
        n = len(poses)
        if not isinstance(chunk, (int, np.integer)) or chunk < 1:
            raise InputError(f"chunk = {chunk!r}: expected a whole number of poses >= 1")
        self.resolver.resolve(n, params, model)
        for start in range(0, n, int(chunk)):
            sl = slice(start, min(n, start + int(chunk)))
            yield sl, self.matrices(poses[sl], model, **user_rows(params, sl, n))

    def stiffness(self, poses, model="paper", **params):
        """The (M, K) pair the model's eigenproblem uses, with the gravity preload if on.

        Rigid models of a 3-DoF robot use the 3x3 translational subsets of M and K_R (as
        the paper does); a 6-DoF robot's rigid model the full 6x6 M and K_R; flexible
        models the full 6x6 M and K_F.
        """
        return self.solver.stiffness(poses, model, params)

    def allowed_twists(self, poses, **params) -> np.ndarray:
        """(N, 6, n) orthonormal bases of the platform's allowed twists ``[omega; v]`` at
        ``poses`` (:mod:`.allowed`): the null space of the legs' constraint wrenches, from
        the pose coordinates' unit twists. A pose space that fixes them (a translational
        platform: the translations; a free one: all six) gives them without computing
        (``tests/test_pose_spaces.py`` checks they are the rule's)."""
        poses = self.completion.poses(poses, params)
        fixed = getattr(self.space, "basis", None)
        if fixed is not None:
            return np.broadcast_to(np.asarray(fixed, dtype=float), (len(poses), 6, len(fixed[0])))
        if self.c_route.fused:  # the C pass: IK, checks and J_rows at once
            p = self.resolver.resolve(len(poses), params, "paper")
            res = self.c_route.run(poses, p, matrices=(), jacobians=("J_rows",))
            bad = res["status"] != STATUS["ok"]
            if bad.any():
                self.checks.raise_first(poses, p, bad)
            rows = res["J_rows"]
        else:
            rows = self.jacobians(poses, **params)["J_rows"]
        return self.solver.basis(rows)

    def modes(
        self,
        poses,
        model="paper",
        *,
        invalid: str = "raise",
        vectors: bool = True,
        unstable: str = "nan",
        joints=None,
        complex_shapes: bool = False,
        **params,
    ) -> Modes:
        """Natural frequencies (Hz) and eigentwists of ``det(omega^2 M - K) = 0`` (Eq. 7).

        ``invalid="raise"`` (the default) raises on the first unreachable or singular
        pose; ``invalid="nan"`` evaluates the valid poses only, fills the others with NaN
        and reports them in ``Modes.valid`` (for sweeps over a workspace box).
        ``vectors=False`` skips the eigentwists (``Modes.eigentwists`` is None): faster.
        An unstable mode (negative stiffness) is NaN and its pose False in ``Modes.stable``
        (``unstable="nan"``, the default) or raises :class:`UnstablePoseError` naming the
        pose and the mode (``unstable="raise"``, for single-pose commands).
        ``joints``: measured joint coordinates (N, legs, coordinates) used instead of the
        inverse kinematics (:meth:`joint_matrices`; ``poses`` may be None for a
        translational robot).
        A flexible model's finite modes condense the legs' rigid constraint directions
        exactly (:mod:`.condense`: solved on the admissible motions, no ``c_rigid``
        penalty, couplings and the gravity preload included); a rigid constraint's own
        mode (infinite frequency) keeps K_F's stand-in value (~1e6 Hz) in its column,
        marked in ``Modes.constrained``.
        A model with a damping effect (``servo_damping``, ``servo_delay``,
        ``structural_loss``) also gives each mode's pole: ``Modes.natural_hz``,
        ``Modes.damped_hz`` and ``Modes.damping_ratio`` (:mod:`.damped`; ``freq_hz`` stays
        the undamped model's), and ``complex_shapes=True`` the complex eigentwists
        ``Modes.complex_eigentwists``; a growing mode makes its pose unstable.
        """
        if invalid not in ("raise", "nan"):
            raise InputError(f"invalid={invalid!r}: expected 'raise' or 'nan'")
        if unstable not in ("raise", "nan"):
            raise InputError(f"unstable={unstable!r}: expected 'raise' or 'nan'")
        if joints is None and not complex_shapes:
            plan = self.c_route.plan(model, params, invalid, unstable, vectors)
            modes = plan and self.c_route.planned_modes(plan, poses)
            if modes is not None:
                return modes
        if joints is not None:
            if complex_shapes or self.damped_model(model):
                raise InputError(
                    "joints= with a damping effect or complex_shapes: not supported (the damped "
                    "modes need the pose's inverse kinematics); give poses"
                )
            return self.solver.joint_modes(poses, joints, model, vectors, unstable, params)
        poses = self.completion.poses(poses, params)
        effects = self.resolver.model_effects(model)
        params, exact = self.solver.route(effects, params)
        damped = complex_shapes or self.damped_model(effects)
        route = choose_route(
            c_pass=self.c_route.pass_model(effects) is not None,
            exact=exact,
            damped=damped,
            pass_solves=lambda: not complex_shapes and self.solver.one_pass(effects, exact),
            c_backend=self.c_route.fused,
        )
        if route.solver == "pass":
            modes = self.c_route.modes(poses, effects, params, invalid == "raise", vectors, exact, route.how)
        else:
            stash = {} if route.keep else None
            modes = self.solver.solved_modes(poses, effects, params, invalid == "raise", vectors, stash)
            if exact:
                modes = self.solver.exact_modes(
                    poses, effects, params, modes, vectors, q=stash.get("q"), M=stash.get("M")
                )
            elif stash and stash.get("q") is not None:  # the NumPy path's kernel outputs, for _damping_inputs
                rows = np.ones(len(poses), dtype=bool) if modes.valid is None else np.asarray(modes.valid, dtype=bool)
                modes.legs = {"rows": rows, **{k: v[rows] for k, v in stash.items()}}
        if damped:
            if modes.damping is None:  # not solved in the fused pass
                from .damped_modes import damped_of

                modes.damping = damped_of(
                    self, effects, self.solver.damping_inputs(poses, effects, params, modes), modes, complex_shapes
                )
            modes.stable = modes.stable & modes.damping.stable
        modes.legs = None  # the exact condensation's arrays: not kept with the result
        if unstable == "raise" and not modes.stable.all():
            self.solver.raise_unstable(poses, modes, effects)
        return modes

    def damped_model(self, model) -> bool:
        """Whether ``model`` has a damping effect (its modes have poles: :mod:`.damped`)."""
        return self.solver.damped_model(model)

    def constraint_route(self, model="paper", **params) -> tuple[dict, bool]:
        """``(params, condensed)``: the parameters :meth:`modes` solves ``model`` with
        (``c_rigid`` = 0 where no leg of the model has a rigid constraint direction: then
        :meth:`matrices` with them gives the K_F of the frequencies), and whether its
        finite modes come from the exact condensation instead (rigid directions; K_F then
        keeps the ``c_rigid`` penalty); :mod:`.condense`."""
        return self.solver.route(self.resolver.model_effects(model), params)

    def sensitivities(
        self,
        poses,
        wrt=None,
        model="paper",
        *,
        rtol: float = 1e-6,
        progress=None,
        method: str = "exact",
        lowest: int | None = None,
        **params,
    ) -> np.ndarray:
        """d f / d p of the model's natural frequencies, (N, n_modes, len(wrt)), Hz per SI unit;
        with ``lowest=k``, of the k lowest modes only, (N, k, len(wrt)) (the exact method's
        kernel then sweeps k modes a pose instead of every mode: a design study of the lowest
        frequency asks ``lowest=1``).

        ``wrt``: parameter names (default: every parameter of the description); ``P@N`` is
        leg N's own value of a leg-level parameter (a model may scope effects, ``EFFECT@N``,
        and ``params`` may give legs their own values: then d/dP moves only the legs that
        follow the shared P). Modes in
        ascending order; frequencies within ``rtol`` (relative) of each other form a cluster
        whose individual derivatives are returned (sorted ascending, never the mean). The
        code is generated on first use for each ``wrt`` and cached (see
        :mod:`eigentwist.runtime.sensitivity`); ``method="differences"`` derives nothing
        (central differences of the matrices, see :meth:`modes_and_sensitivities`); models
        with ``gravity_preload`` raise. Legs solved by Newton and rigid models on allowed
        twists that turn with the pose are differentiated through their solved coordinates
        (:mod:`eigentwist.runtime.implicit`).
        """
        return self.modes_and_sensitivities(
            poses, wrt, model, rtol=rtol, progress=progress, method=method, lowest=lowest, **params
        )[1]

    def modes_and_sensitivities(
        self,
        poses,
        wrt=None,
        model="paper",
        *,
        rtol: float = 1e-6,
        progress=None,
        method: str = "exact",
        lowest: int | None = None,
        **params,
    ):
        """``(Modes, dfdp)``: :meth:`modes` and :meth:`sensitivities` (``lowest`` as there: every
        mode in ``Modes``, the derivatives of the lowest ``lowest``) from one kernel call.

        ``method="exact"`` (the default) uses the generated sensitivity kernel (derived and
        cached on first use per ``wrt``); ``"differences"`` derives nothing: dM/dp and
        dK/dp by central differences of :meth:`matrices` (relative step 1e-5; the matrices
        are smooth in the parameters even where frequencies cross), then the same
        eigenvalue perturbation (clusters included), ~1e-9 relative from the exact one.

        Where no sensitivity kernel can be generated, both methods differentiate through
        the solved coordinates (:mod:`.implicit`): legs solved by Newton (URDF form) take
        dq/dp from the implicit function theorem on their loop closure and the matrices'
        central differences along that tangent (no Newton solve repeated); the rigid model
        of a lower-mobility platform (allowed twists that turn with the pose) takes central
        differences of its reduced pencil (B^T K_R B, B^T M B), followers re-solved; its
        flexible models add the followers' motion with each parameter to every route
        (:func:`.implicit.follower_terms`)."""
        return self.sensitivity_route.modes_and_sensitivities(poses, wrt, model, rtol, progress, method, params, lowest)

    def matrix_derivatives(self, poses, wrt, model="paper", **params) -> dict:
        """``M``, ``K_R``, ``K_F`` (N, 6, 6) and their derivatives ``dM``, ``dK_R``, ``dK_F``
        (N, len(wrt), 6, 6; per SI unit of each parameter) by central differences of
        :meth:`matrices` (relative step :data:`.sensitivity.DIFFERENCE_STEP`; second-order
        one-sided, away from it, where a step would cross a parameter's bound or a constraint
        between parameters: ``r_i < r_o``, the inertia triangle inequality): the output of the
        generated sensitivity kernel without deriving anything. ``wrt`` names parameters,
        ``P@N`` a leg's own value."""
        return self.sensitivity_route.matrix_derivatives(poses, wrt, model, params)

    def frequencies(self, poses, model="paper", *, joints=None, **params) -> np.ndarray:
        """Natural frequencies in Hz, shape (N, 6) for flexible models (the default,
        ``"paper"``) or (N, 3) for ``"rigid"`` (a 6-DoF robot: (N, 6) always), ascending.
        Unstable modes are NaN. ``joints``: measured joint coordinates (N, legs,
        coordinates) instead of the inverse kinematics (see :meth:`modes`)."""
        return self.modes(poses, model, vectors=False, joints=joints, **params).freq_hz
