"""The C backend's route: one fused pass from poses to checked frequencies and eigentwists.

A stage of an evaluation (:class:`~eigentwist.runtime.evaluator.Evaluator` holds one as
``ev.c_route``): the generated C library's fused pass (IK, checks, M, K, the eigen-solver, on
the evaluator's threads) run over a batch, its refusals named by the pose checks
(:mod:`.checks`), the poses whose lowest frequency falls below :data:`PARALLEL_SCREEN` checked
exactly for a parallel singularity, and a small call of scalar values served by a pass prepared
once per model and values (:meth:`CPassRoute.plan`, :mod:`.fused_call`). Which models take this
route: :mod:`.routes`.
"""

from __future__ import annotations

import numpy as np

from ..description.pose import FULL, twist_order
from .addresses import address
from .completion import CompletedPoses, map_ranges, masked
from .memo import BoundedMemo
from .modes import Modes
from .threads import resolve_threads
from .validity import STATUS

__all__ = ["CPassRoute", "PARALLEL_SCREEN", "above_screen"]

#: the fused C pass's route (``modes``, ``frequencies``, ``valid``) checks a pose exactly for
#: a parallel singularity when its lowest frequency is 0, NaN or below this fraction of its
#: highest: a twist escaping the legs' wrenches with a conditioning c has omega about c times
#: the others' (the stiffness along it scales with c^2), so at CONDITIONING_TOL (1.5e-6) it
#: lies ~700 times below this screen. A loss of every allowed twist at once keeps the ratio
#: and is caught where the frequencies reach 0 or NaN; the other paths (NumPy, matrices,
#: pose_status) check every pose exactly.
PARALLEL_SCREEN = 1e-3


def above_screen(freq: np.ndarray, threads: int = 1, screen: float = PARALLEL_SCREEN) -> np.ndarray:
    """(N,) whether each pose's lowest frequency (a row of ``freq``, Hz) lies above
    ``screen`` (:data:`PARALLEL_SCREEN`) times its highest; False where the row holds a NaN. One pass per
    column: NumPy's reductions along a short last axis cost about 100 ns a pose, more than
    the C pass's checks (a NaN propagates through minimum and maximum and compares False).
    By ranges of rows, side by side on ``threads`` threads (:func:`~.completion.map_ranges`)."""
    above = np.empty(len(freq), dtype=bool)

    def part(rows):
        lo = freq[rows, 0].copy()
        hi = lo.copy()
        for j in range(1, freq.shape[1]):
            np.minimum(lo, freq[rows, j], out=lo)
            np.maximum(hi, freq[rows, j], out=hi)
        np.greater(lo, screen * hi, out=above[rows])

    map_ranges(part, len(freq), threads)
    return above


class CPassRoute:
    """The fused C pass of one evaluator, and the modes it solves.

    ev : the :class:`~eigentwist.runtime.evaluator.Evaluator` (its kernels, threads, stages and
    models; ``ev.solver``, :class:`~eigentwist.runtime.mode_solver.ModeSolver`: the constraints'
    treatment, the exact condensation, the error of an unstable pose).
    """

    def __init__(self, ev):
        self.ev = ev
        completion = ev.completion
        #: names of the pose coordinates, how the pose enters the kernels, their number
        self.pose_names, self.space, self.dof = completion.pose_names, completion.space, completion.dof
        #: True when the kernels take a rigid platform's six coordinates (rotation included)
        self.six = completion.six
        #: (values key, invalid, unstable, vectors) -> the prepared C pass (:meth:`plan`)
        self.plans = BoundedMemo(64)
        self._planned_for = ev.kernels  # the kernels the plans were prepared for

    @property
    def kernels(self):
        """The evaluator's kernels (the C library's :class:`~eigentwist.runtime.c_kernels.CKernels`
        where this route runs)."""
        return self.ev.kernels

    @property
    def fused(self) -> bool:
        """Whether the kernels have the C backend's fused pass."""
        return hasattr(self.kernels, "fused")

    def nthreads(self) -> int:
        """The threads of one C pass: the evaluator's ``threads`` resolved (:mod:`.threads`)."""
        return resolve_threads(self.ev.threads)

    def run(self, poses: np.ndarray, p: dict, **kw) -> dict:
        """One fused C pass over the batch (status included), on the evaluator's threads."""
        return self.kernels.fused(
            poses[:, 0],
            poses[:, 1],
            poses[:, 2],
            self.ev.completion.with_pose(poses, p),
            status=True,
            threads=self.nthreads(),
            **kw,
        )

    @property
    def c_rigid(self) -> bool:
        """Whether the rigid model's allowed twists are what the C pass reduces to: the
        three translations of a translational robot's 3x3 blocks or a free platform's six
        twists (a pose space's fixed basis of either). Any other pose space's rigid model
        (a point in a plane, a planar or lower-mobility platform) is reduced here."""
        basis = getattr(self.space, "basis", None)
        if basis is None:
            return False
        names = twist_order(self.pose_names)
        return names in (twist_order(("x", "y", "z")), twist_order(FULL)) and len(basis[0]) == len(names)

    @property
    def pass_rigid(self) -> bool:
        """Whether the C pass solves this robot's rigid model itself: :attr:`c_rigid`, or a
        point platform's translations that its generated pass takes as one block (the
        signature's ``offsets``: the 2x2 at [v_x, v_y] of a planar five-bar)."""
        if self.c_rigid:
            return True
        if not self.fused:
            return False
        spec = self.kernels.signature["fused"]
        if "offsets" not in spec or "rigid" not in spec["models"]:
            return False
        k = spec["models"].index("rigid")
        n, off = spec["dims"][k], spec["offsets"][k]
        basis = np.asarray(self.space.basis, dtype=float)
        return basis.shape == (6, n) and bool(np.array_equal(basis, np.eye(6)[:, off : off + n]))

    def pass_model(self, model) -> str | None:
        """The stiffness model (``"flexible"`` or ``"rigid"``) this pass solves for ``model`` (a
        model spec or its resolved effects); None where the C route does not take the model: no
        C pass, a rigid model the pass does not reduce (:attr:`pass_rigid`), a gravity preload."""
        if not self.fused:
            return None
        effects = self.ev.resolver.model_effects(model)
        stiffness = self.ev.stiffness_model(effects)
        if self.ev.resolver.preloaded(effects) or not (self.pass_rigid or stiffness == "flexible"):
            return None
        return stiffness

    def modes(
        self,
        poses,
        effects,
        params,
        check: bool,
        vectors: bool,
        exact: bool = False,
        damped: str | None = None,
        out: dict | None = None,
    ) -> Modes:
        """The C backend's single pass from poses to checked frequencies (and eigentwists),
        written straight into the result arrays; with ``exact`` the pass also returns the
        joint coordinates and M for :meth:`.ModeSolver.exact_modes`; ``damped="pass"``: the same C call
        also solves the damped modes (:func:`.damped_modes.fused_damped`, :meth:`.ModeSolver.one_pass`);
        ``"keep"``: the pass also returns the joint coordinates, M and the model's stiffness,
        kept in ``Modes.legs`` for :meth:`.ModeSolver.damping_inputs` (no kernel runs twice); ``"exact"``
        (with ``exact``): the same C call also runs the legs kernel, the exact condensation and
        a damped model's damped modes (:func:`.damped_modes.fused_exact`,
        :func:`.damped_modes.exact_merge`; where that does not stand for the condensation,
        :meth:`.ModeSolver.exact_modes` on the pass's q and M). ``out``:
        the pass's outputs where they are computed already (:meth:`planned_modes`, undamped)."""
        p = self.ev.resolver.resolve(len(poses), params, effects)
        stiffness = self.ev.stiffness_model(effects)
        # M for the energy shares of a flexible model's eigentwists (6x6: the pass's M as it is)
        shares = vectors and not exact and stiffness == "flexible"
        keep = ("K_R" if stiffness == "rigid" else "K_F",) if damped == "keep" else ()
        if out is None and damped == "exact":
            from .damped_modes import exact_merge, fused_exact

            pk = self.ev.completion.with_pose(poses, p)
            out, solved = fused_exact(
                self.ev, effects, poses, p, pk, vectors, self.ev.damped_model(effects), self.nthreads()
            )
        elif out is None and damped == "pass":
            from .damped_modes import fused_damped, pass_damping

            basis = getattr(self.space, "basis", None)
            pk = self.ev.completion.with_pose(poses, p)
            out, solved = fused_damped(self.ev, effects, poses, p, pk, vectors, basis, self.nthreads())
        elif out is None:
            out = self.run(
                poses,
                p,
                matrices=("M",) + keep if exact or shares or keep else (),
                ik=("q",) if exact or keep else (),
                model=stiffness,
                vectors=vectors,
                normalize=True,
                screen=PARALLEL_SCREEN,
            )
        st = out["status"]
        clean = out.pop("clean", False)  # every pose ok and above the screen: nothing to check
        valid = np.ones(len(st), dtype=bool) if clean else (st == STATUS["ok"]) | (st == STATUS["unstable"])
        if check and not clean and not valid.all():
            self.ev.checks.raise_first(poses, p, ~valid)
        # a parallel singularity drives the lowest frequency to 0: the poses whose lowest
        # mode is 0, NaN or below PARALLEL_SCREEN times their highest get the exact check
        freq = out["freq_hz"]
        suspect = np.empty(0, dtype=np.intp) if clean else np.flatnonzero(valid & ~above_screen(freq, self.nthreads()))
        singular = suspect[~self.ev.checks.parallel_ok(poses, p, suspect, strict=check)]
        if singular.size:
            valid[singular] = False
            out["freq_hz"][singular] = np.nan
            if out.get("eigentwists") is not None:
                out["eigentwists"][singular] = np.nan
        modes = Modes(
            out["freq_hz"],
            out.get("eigentwists"),
            self.ev.axes(stiffness),
            stiffness,
            None if check else valid,
            np.ones(len(st), dtype=bool) if clean else st != STATUS["unstable"],
        )
        if shares and out["eigentwists"].shape[-1] == 6:
            modes.inertia = out["M"]  # the energy shares, when read (Modes.shares)
        if damped == "pass":
            modes.damping = pass_damping(self.ev, effects, poses, params, p, solved, modes)
        elif keep:  # the damped modes' inputs, on the valid rows (_damping_inputs)
            rows = np.ones(len(poses), dtype=bool) if modes.valid is None else modes.valid
            n = len(poses)
            mats = {k: out[k][rows] for k in ("M",) + keep}
            modes.legs = {"rows": rows, "q": out["q"][rows], "p": p if rows.all() else masked(p, rows, n), **mats}
        merged = exact_merge(self.ev, effects, poses, params, p, solved, modes, vectors) if damped == "exact" else None
        if merged is not None:
            modes = merged
        elif exact:
            modes = self.ev.solver.exact_modes(poses, effects, params, modes, vectors, q=out["q"], M=out["M"], p=p)
        return modes

    def plan(self, model, params: dict, invalid: str, unstable: str, vectors: bool):
        """The prepared C pass of ``Evaluator.modes`` for ``model`` and these scalar ``params``
        (:class:`.fused_call.FusedCall`, with what the result needs), remembered per (model,
        values, options); None where ``Evaluator.modes`` takes another route (values per pose, the
        NumPy backend, numeric IK, a completed pose, the exact condensation, the gravity
        preload, damping) or where the values are refused (``Evaluator.modes`` raises)."""
        if self._planned_for is not self.kernels:
            self.plans, self._planned_for = BoundedMemo(64), self.kernels
        values = self.ev.resolver.key(params, model)
        if values is None:
            return None
        key = (values, invalid, unstable, vectors)
        plan = self.plans.get(key)
        if plan is None:
            plan = self.make_plan(model, params, invalid, unstable, vectors)
            if plan is None:
                return None
            self.plans.put(key, plan)
        return plan or None

    def make_plan(self, model, params: dict, invalid: str, unstable: str, vectors: bool):
        """:meth:`plan`'s answer computed: a tuple, False (another route) or None (refused)."""
        if (
            not hasattr(self.kernels, "prepare_fused")
            or self.ev.numeric_ik
            or (self.six and self.pose_names != FULL)
            or invalid not in ("raise", "nan")
            or unstable not in ("raise", "nan")
        ):
            return False
        try:
            effects = self.ev.resolver.model_effects(model)
            routed, exact = self.ev.solver.route(effects, params)
            stiffness = self.pass_model(effects)
            if exact or stiffness is None or self.ev.damped_model(effects):
                return False
            p = self.ev.resolver.resolve(1, routed, effects)
        except Exception:  # refused values: the general route raises
            return None
        # the poses' columns (a row of dof doubles apart): the position and the rotation vector
        names = {n: self.dof for n in FULL[: self.dof]}
        shares = vectors and stiffness == "flexible"
        try:
            call = self.kernels.prepare_fused(
                p, names, model=stiffness, vectors=vectors, matrices=("M",) if shares else ()
            )
        except (KeyError, ValueError):  # an input per pose (an array default) or not in p: the general route
            return False
        if call.pose_inputs != tuple(names)[: len(call.pose_inputs)] or len(call.pose_inputs) not in (3, self.dof):
            return False
        return (
            call,
            len(call.pose_inputs),
            effects,
            routed,
            stiffness,
            self.ev.axes(stiffness),
            invalid == "raise",
            vectors,
            unstable,
        )

    def planned_modes(self, plan: tuple, poses) -> Modes | None:
        """``Evaluator.modes`` by the prepared pass ``plan`` (:meth:`plan`); None for poses that
        ``Evaluator.modes`` refuses (it names them). A pose flagged by the pass (unreachable,
        singular, unstable) or by the parallel screen goes on to :meth:`modes` with
        the pass's outputs, which checks it as ``Evaluator.modes`` does."""
        call, columns, effects, routed, stiffness, axes, check, vectors, unstable = plan
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof or not arr.shape[0]:
            return None
        n = len(arr)
        if not arr.flags.c_contiguous:
            arr = np.ascontiguousarray(arr)
        base = address(arr)
        # poses checked finite first; then none flagged by the pass, none below the parallel
        # screen (the pass's frequencies ascend and are finite where no pose is flagged: the
        # lowest is the first, the highest the last)
        ran = call.screened([base + 8 * k for k in range(columns)], arr, self.nthreads(), PARALLEL_SCREEN)
        if ran is None:
            return None
        out, clean = ran
        freq = out["freq_hz"]
        if not clean:
            arr = arr.view(CompletedPoses)
            modes = self.modes(arr, effects, routed, check, vectors, out=out)
        else:
            valid = None if check else np.ones(n, dtype=bool)
            modes = Modes(freq, out.get("eigentwists"), axes, stiffness, valid, np.ones(n, dtype=bool))
            if "M" in out and out["eigentwists"].shape[-1] == 6:
                modes.inertia = out["M"]  # the energy shares, when read (Modes.shares)
        if unstable == "raise" and not modes.stable.all():
            self.ev.solver.raise_unstable(arr, modes, effects)
        return modes
