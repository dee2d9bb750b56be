"""The matrices route of the modes, and what both routes share.

A stage of an evaluation (:class:`~eigentwist.runtime.evaluator.Evaluator` holds one as
``ev.solver``): M and K (Eqs. 12-14, the gravity preload added, a rigid model reduced to the
platform's allowed twists, :mod:`.allowed`), then the batched eigen-solver of
``det(omega^2 M - K) = 0`` (Eq. 7; the C Jacobi solver where it has the size). Both routes
(:mod:`.routes`; the fused C pass: :mod:`.c_route`) take from it how a flexible model treats
its legs' rigid constraint directions (``c_rigid`` exact, or the exact condensation of the
finite modes, :mod:`.condense`), the inputs of the damped modes (:mod:`.damped_modes`) and the
error of an unstable pose.
"""

from __future__ import annotations

import queue

import numpy as np

from ..description.effects import base_name
from ..description.pose import twist_order
from . import condense
from .allowed import allowed_twists, constraint_positions, coordinate_twists, reduce
from .completion import CHUNK, chunks, map_chunks, masked, take, user_rows
from .eigen import frequencies_and_stability, generalized_eigh, normalize_eigentwists
from .errors import InputError, UnstablePoseError
from .modes import Modes
from .validity import STATUS

__all__ = ["ModeSolver", "MATRICES"]

#: the kernels' matrices at the EE origin: mass, rigid and flexible stiffness (Eqs. 12, 14, 13)
MATRICES = ("M", "K_R", "K_F")


class ModeSolver:
    """The matrices route of one evaluator's modes, the constraints' treatment and the damped
    modes' inputs.

    ev : the :class:`~eigentwist.runtime.evaluator.Evaluator` (its kernels, stages and models;
    ``ev.c_route``, :class:`~eigentwist.runtime.c_route.CPassRoute`: the C pass where the
    backend has it).
    """

    def __init__(self, ev):
        self.ev = ev
        self.robot = ev.robot
        self._rigid_models: dict = {}  # model -> whether a leg has a rigid direction (route)
        #: rows per leg of J_rows -> (the constraint rows' positions, the pose coordinates' unit twists)
        self._constraint_rows: dict = {}

    @property
    def kernels(self):
        """The evaluator's kernels (:class:`~eigentwist.runtime.kernels.Kernels`)."""
        return self.ev.kernels

    def matrices_q(self, poses: np.ndarray, p: dict, out: dict | None = None):
        """``(matrices, q)`` of the NumPy path: the joint coordinates come along (for
        :meth:`exact_modes`)."""
        n = len(poses)
        out = out or {}
        mats = {k: out.get(k) if k in out else np.empty((n, 6, 6)) for k in MATRICES}
        qs = []
        for sl in chunks(n):
            pc = take(p, sl)
            q = self.ev.checks.check_rows(poses[sl], pc, strict=True)[0]
            qs.append(q)
            chunk = self.kernels.matrices(q, self.ev.completion.with_pose(poses[sl], pc))
            for k in MATRICES:
                mats[k][sl] = chunk[k]
        return mats, np.concatenate(qs) if qs else None

    def stiffness(self, poses, model, params: dict, stash: dict | None = None):
        """``Evaluator.stiffness``; ``stash`` (a dict) receives the joint coordinates ``q`` and the
        matrices ``M``, ``K_R``, ``K_F`` of the NumPy path (for :meth:`exact_modes` and the
        damped modes, :meth:`damping_inputs`)."""
        poses_arr = self.ev.completion.poses(poses, params)
        effects = self.ev.resolver.model_effects(model)
        rigid = self.ev.stiffness_model(effects) == "rigid"
        if (
            rigid
            and self.ev.c_route.fused
            and stash is None
            and self.ev.space.basis is None
            and not self.ev.resolver.preloaded(effects)
        ):
            # allowed twists that turn with the pose: M, K_R and J_rows from one C pass, their
            # basis and the reductions chunk by chunk (CHUNK poses: the 6 x 6 matrices stay in
            # cache), whole chunks side by side on the threads; every pose on its own, so the
            # chunks change no result
            p = self.ev.resolver.resolve(len(poses_arr), params, effects)
            pk = self.ev.completion.with_pose(poses_arr, p)
            n, threads = len(poses_arr), self.ev.c_route.nthreads()
            # the pass's outputs of a chunk in a set of CHUNK-pose buffers that one chunk uses at
            # a time, kept for this solver's later calls (:meth:`chunk_buffers`): fresh memory
            # for each chunk or call has its pages faulted in and zeroed again, at a cost near
            # the pass's own
            free = self.chunk_buffers()

            def part(sl, inner):
                at = poses_arr[sl]
                try:
                    held = free.get_nowait()
                except queue.Empty:  # more chunks at once than sets so far: one more set
                    held = self.new_chunk_buffers()
                try:
                    m = len(at)
                    res = self.kernels.fused(
                        at[:, 0],
                        at[:, 1],
                        at[:, 2],
                        take(pk, sl) if n > 1 else pk,
                        status=True,
                        threads=inner,
                        matrices=("M", "K_R"),
                        jacobians=("J_rows",),
                        out={k: v[:m] for k, v in held.items()},
                    )
                    bad = res["status"] != STATUS["ok"]
                    if bad.any():
                        self.ev.checks.raise_first(at, take(p, sl) if n > 1 else p, bad)
                    B = self.basis(res["J_rows"], inner)
                    for k, into in zip(("M", "K_R"), reduced):
                        reduce(res[k], B, compiled=True, threads=inner, out=into[sl])
                finally:
                    free.put(held)

            size = self.ev.rigid_size()
            reduced = (np.empty((n, size, size)), np.empty((n, size, size)))
            map_chunks(part, n, threads, CHUNK)
            return reduced
        if stash is not None and not self.ev.c_route.fused:
            mats, stash["q"] = self.matrices_q(poses_arr, self.ev.resolver.resolve(len(poses_arr), params, effects))
            stash.update((k, mats[k]) for k in MATRICES)
        else:
            mats = self.ev.matrices(poses_arr, effects, **params)
        B = self.ev.allowed_twists(poses_arr, **params) if rigid else None
        threads = self.ev.c_route.nthreads()
        M = reduce(mats["M"], B, self.ev.c_route.fused, threads) if rigid else mats["M"]
        K = reduce(mats["K_R"], B, self.ev.c_route.fused, threads) if rigid else mats["K_F"]
        if self.ev.resolver.preloaded(effects):
            from .gravity import gravity_stiffness

            K = K + gravity_stiffness(self.ev, poses_arr, effects, params, mats, rigid, B)
        return M, K

    def new_chunk_buffers(self) -> dict:
        """One set of the C pass's outputs for :data:`~.completion.CHUNK` poses of a rigid model on
        allowed twists that turn with the pose (:meth:`stiffness`): M, K_R (6 x 6) and the
        legs' inverse-Jacobian rows J_rows, uninitialised."""
        shapes = {"M": (6, 6), "K_R": (6, 6), "J_rows": tuple(self.kernels.OUTPUTS["jacobians"]["J_rows"])}
        return {k: np.empty((CHUNK,) + v) for k, v in shapes.items()}

    def chunk_buffers(self) -> queue.SimpleQueue:
        """The sets of :meth:`new_chunk_buffers` not in use, kept for this solver's calls (as
        many as have run at once; a set is taken by one chunk and put back after it); a new
        queue where :data:`~.completion.CHUNK` or the kernels changed."""
        held = self.__dict__.get("_chunk_buffers")
        if held is None or held[0] != CHUNK or held[1] is not self.kernels:
            held = self.__dict__["_chunk_buffers"] = (CHUNK, self.kernels, queue.SimpleQueue())
        return held[2]

    def basis(self, rows: np.ndarray, threads: int | None = None) -> np.ndarray:
        """The allowed twists (N, 6, n) from the legs' inverse-Jacobian rows (N, legs, r, 6):
        the null space of their virtual joints' rows (:func:`.allowed.allowed_twists`), on
        ``threads`` threads (None: the evaluator's)."""
        per_leg = rows.shape[2]
        found = self._constraint_rows.get(per_leg)
        if found is None:  # the robot's: worked out once per row layout
            picks = tuple(i * per_leg + r for i, leg in enumerate(self.robot.legs) for r in constraint_positions(leg))
            candidates = coordinate_twists(twist_order(self.ev.pose_names))
            candidates.flags.writeable = False
            found = self._constraint_rows[per_leg] = (picks, candidates)
        picks, candidates = found
        threads = self.ev.c_route.nthreads() if threads is None else threads
        return allowed_twists(rows, candidates, compiled=self.ev.c_route.fused, threads=threads, picks=picks)

    def damped_model(self, model) -> bool:
        """Whether ``model`` has a damping effect (its modes have poles: :mod:`.damped`)."""
        return any(
            "damping" in self.robot.effect(base_name(e)).primitives for e in self.ev.resolver.model_effects(model)
        )

    def damping_inputs(self, poses, effects, params: dict, modes: Modes) -> dict | None:
        """What :func:`.damped_modes.damped_of` needs from the kernels for the valid rows of
        ``modes``: their poses, parameters (``params``, the generated inputs ``p``), the
        ``legs`` kernel's outputs and the matrices (``M`` and the admissible twists ``B``
        the exact condensation found, where it ran), whether the route condenses rigid
        directions (``exact``) and the gravity preload; None where no row is valid."""
        if "legs" not in getattr(self.kernels, "OUTPUTS", {}):
            raise InputError(
                f"damped modes of {self.robot.name}: its generated code has no legs kernel (joint "
                "compliances); regenerate it"
            )
        N = len(modes.freq_hz)
        rows = np.ones(N, dtype=bool) if modes.valid is None else np.asarray(modes.valid, dtype=bool)
        if not rows.any():
            return None
        pr = np.asarray(poses, dtype=float)[rows]
        sub = user_rows(params, rows, N)
        known = modes.legs if modes.legs is not None and np.array_equal(modes.legs["rows"], rows) else None
        if known is None:
            p = self.ev.resolver.resolve(len(pr), sub, effects)
            q = self.ev.checks.ik(pr, p)
            legs = self.kernels.legs(q, self.ev.completion.with_pose(pr, p))
        else:  # the kernels' outputs of modes' own pass (the legs kernel where it did not run)
            q = known["q"]
            p = known["p"] if "p" in known else self.ev.resolver.resolve(len(pr), sub, effects)
            legs = known["out"] if "out" in known else self.kernels.legs(q, self.ev.completion.with_pose(pr, p))
        reuse = known is not None and "B" in known and self.ev.stiffness_model(effects) != "rigid"
        rigid = self.ev.stiffness_model(effects) == "rigid"
        need = MATRICES if self.ev.resolver.preloaded(effects) else ("M", "K_R" if rigid else "K_F")
        if known is not None and all(k in known for k in need):
            mats = {k: known[k] for k in need}
        else:
            mats = {"M": known["M"]} if reuse else self.kernels.matrices(q, self.ev.completion.with_pose(pr, p))
        return {
            "rows": rows,
            "poses": pr,
            "params": sub,
            "p": p,
            "legs": legs,
            "mats": mats,
            "B": known["B"] if reuse else None,
            "exact": self._rigid_models.get(tuple(effects), True),
            "preloaded": self.ev.resolver.preloaded(effects),
        }

    def one_pass(self, effects, exact: bool = False) -> bool:
        """Whether the fused C pass solves the damped modes of ``effects`` itself
        (:func:`.damped_modes.one_pass_takes`): the rigid model on its fixed allowed twists,
        a flexible one whose legs have no rigid direction (K_F exact, the six twists), or with
        ``exact`` (the route condenses rigid directions, :meth:`route`) the exact
        condensation of legs on the tool body and its damped modes
        (:func:`.damped_modes.fused_exact`)."""
        if self.ev.numeric_ik:
            return False
        flexible = self.ev.stiffness_model(effects) == "flexible"
        if not exact and flexible and self._rigid_models.get(tuple(effects)) is not False:
            return False
        from .damped_modes import one_pass_takes

        return one_pass_takes(self.ev, effects)

    def route(self, effects, params: dict) -> tuple[dict, bool]:
        """How ``Evaluator.modes`` solves ``effects`` exactly: ``(params, condense)``.

        * not a flexible model of legs with virtual joints (or no generated ``legs``
          kernel), or ``c_rigid`` given with a value other than the description's default
          (the user's finite constraint compliance): ``(params, False)``, K_F as is;
        * no leg has a rigid direction in this model (e.g. every rod compliant; probed
          once per model at the reference pose ``x_ref``: which effects are on decides):
          ``({**params, "c_rigid": condense.EXACT}, False)``, K_F exact with c_rigid = 0;
        * else ``(params, True)``: the finite modes come from :meth:`exact_modes`, also
          where the probe fails (x_ref out of reach with these values, or values refused):
          that answer is for this call only, the next call probes again.
        """
        outputs = getattr(self.kernels, "OUTPUTS", {})
        if self.ev.stiffness_model(effects) != "flexible" or "legs" not in outputs or outputs["legs"]["Je"][1] < 2:
            return params, False
        default = self.ev.parameters["c_rigid"].default if "c_rigid" in self.ev.parameters else None
        if "c_rigid" in params and default is not None and np.any(np.asarray(params["c_rigid"]) != default):
            return params, False
        key = tuple(effects)
        rigid = self._rigid_models.get(key)
        if rigid is None:
            rigid = self.probe_rigid(effects, params)
            if rigid is None:  # no answer at x_ref with these values: condense, remember nothing
                return params, True
            self._rigid_models[key] = rigid
        if rigid or default is None:
            return params, rigid
        return {**params, "c_rigid": condense.EXACT}, False

    def probe_rigid(self, effects, params: dict) -> bool | None:
        """Whether a leg of ``effects`` has a rigid direction: its joint compliance at the
        reference pose with the first pose's parameters; None where that fails (x_ref out of
        reach with these values, or the values refused)."""
        first = {
            k: (np.asarray(v).reshape(-1)[:1] if np.ndim(v) == 1 else v) for k, v in params.items() if np.ndim(v) <= 1
        }
        x = np.array([self.robot.x_ref], dtype=float)
        try:
            p = self.ev.resolver.resolve(1, first, effects)
            Cq = self.kernels.legs(self.ev.checks.ik(x, p), self.ev.completion.with_pose(x, p))["Cq"]
        except Exception:  # an unreachable reference, or refused values (the call names them)
            return None
        return condense.has_rigid_direction(Cq)

    def exact_modes(self, poses, effects, params: dict, modes: Modes, vectors: bool, q=None, M=None, p=None) -> Modes:
        """``modes`` (K_F's) with the exact condensation's finite modes on its valid rows
        (:func:`.condense.compliance_from_legs`, :func:`.condense.compliance_eigh`,
        :func:`.condense.merge_modes`). ``q``, ``M`` and the validated inputs ``p`` of every
        row, when the caller has them (the fused C pass), are not recomputed."""
        rows = np.ones(len(modes.freq_hz), dtype=bool) if modes.valid is None else np.asarray(modes.valid, dtype=bool)
        if not rows.any():
            return modes
        poses = np.asarray(poses, dtype=float)
        n = len(poses)
        sub = user_rows(params, rows, n)
        pr = poses[rows]
        p = self.ev.resolver.resolve(len(pr), sub, effects) if p is None else (p if rows.all() else masked(p, rows, n))
        q = self.ev.checks.ik(pr, p) if q is None else q[rows]
        pk = self.ev.completion.with_pose(pr, p)
        out = self.kernels.legs(q, pk)
        M = np.broadcast_to(self.kernels.matrices(q, pk)["M"] if M is None else M[rows], (len(pr), 6, 6))
        modes.legs = {"rows": rows, "q": q, "p": p, "out": out, "M": M}  # the damped modes reuse them
        coupled = any(c.effect in set(effects) for c in self.robot.couplings)
        preloaded = self.ev.resolver.preloaded(effects)
        if not coupled and not preloaded:  # legs on the tool: stiffness form, admissible twists
            f, V = condense.condensed_modes(out["Je"], out["Cq"], out["K_ground"], M, self.eigh, basis=modes.legs)
            return condense.merge_modes(modes, rows, f, V, vectors)
        K_G = None
        if preloaded:
            from .gravity import gravity_stiffness

            K_G = gravity_stiffness(self.ev, pr, effects, sub, self.ev.matrices(pr, effects, **sub), False)
        f, V = condense.compliance_eigh(condense.compliance_from_legs(self.robot, effects, out, K_G), M)
        return condense.merge_modes(modes, rows, f, V, vectors)

    def eigh(self, K: np.ndarray, M: np.ndarray):
        """``K v = lambda M v`` for a batch: the C Jacobi solver where it has the size, else
        :func:`.eigen.generalized_eigh`."""
        if self.ev.c_route.fused and K.shape[-1] in self.kernels.signature["eigh"]["dims"] and len(K):
            return self.kernels.generalized_eigh(K, M, threads=self.ev.c_route.nthreads())
        return generalized_eigh(K, M)

    def joint_modes(self, poses, joints, model, vectors: bool, unstable: str, params: dict) -> Modes:
        """``Evaluator.modes`` at measured joint coordinates (no gravity preload: its static
        deflection needs the pose's inverse kinematics)."""
        effects = self.ev.resolver.model_effects(model)
        if self.ev.resolver.preloaded(effects):
            raise InputError(
                "joints= with a gravity preload: not supported (the preload's derivative needs the "
                "inverse kinematics); drop gravity_preload from the model or give poses only"
            )
        q, poses = self.ev.joint_coordinates(joints, poses)
        params, exact = self.route(effects, params)
        mats = self.ev.joint_matrices(poses, q, effects, **params)
        stiffness = self.ev.stiffness_model(effects)
        if stiffness == "rigid":
            if getattr(self.ev.space, "basis", None) is None:
                raise InputError(
                    f"joints= with {self.robot.name}'s rigid model (allowed twists that turn with the "
                    "pose): not supported; give poses"
                )
            B = self.ev.allowed_twists(poses)
            M, K = reduce(mats["M"], B), reduce(mats["K_R"], B)
        else:
            M, K = mats["M"], mats["K_F"]
        modes = self.solve(M, K, vectors, stiffness)
        if exact:
            modes = self.exact_modes(poses, effects, params, modes, vectors, q=q, M=M)
            modes.legs = None
        if unstable == "raise" and not modes.stable.all():
            self.raise_unstable(poses, modes, effects)
        return modes

    def solved_modes(self, poses, effects, params, check: bool, vectors: bool, stash: dict | None = None) -> Modes:
        """Matrices (and the gravity preload), then the batched eigen-solver; ``stash``
        receives ``q`` and ``M`` of every row (NaN where invalid) on the NumPy path."""
        if check:
            return self.solve(*self.stiffness(poses, effects, params, stash), vectors, self.ev.stiffness_model(effects))
        ok = self.ev.valid(poses, effects, **params)
        n = len(poses)
        stiffness = self.ev.stiffness_model(effects)
        if ok.all():  # every row solved as it is: no copy into NaN-filled arrays
            m = self.solve(*self.stiffness(poses, effects, params, stash), vectors, stiffness)
            return Modes(m.freq_hz, m.eigentwists, self.ev.axes(stiffness), stiffness, ok, m.stable)
        size = self.ev.rigid_size() if stiffness == "rigid" else 6
        freq = np.full((n, size), np.nan)
        vec = np.full((n, size, size), np.nan) if vectors else None
        stable = np.ones(n, dtype=bool)
        if ok.any():
            part = {} if stash is not None else None
            m = self.solve(*self.stiffness(poses[ok], effects, user_rows(params, ok, n), part), vectors, stiffness)
            freq[ok], stable[ok] = m.freq_hz, m.stable
            if vectors:
                vec[ok] = m.eigentwists
            for key, val in (part or {}).items():
                stash[key] = np.full((n,) + val.shape[1:], np.nan)
                stash[key][ok] = val
        return Modes(freq, vec, self.ev.axes(stiffness), stiffness, ok, stable)

    def solve(self, M, K, vectors: bool, stiffness: str) -> Modes:
        """:class:`Modes` of the pencils ``K v = omega^2 M v`` (Eq. 7), a batch (N, n, n): the C
        Jacobi solver where it has the size, else :func:`.eigen.generalized_eigh`; ``stiffness``
        names the model (``"rigid"`` or ``"flexible"``: the result's axes)."""
        if self.ev.c_route.fused and K.shape[-1] in self.kernels.signature["eigh"]["dims"]:  # the C solver's sizes
            n, dim = K.shape[0], K.shape[-1]
            freq, stable = np.empty((n, dim)), np.empty(n, dtype=bool)

            def post(lam, V, rows):  # on the thread that solved these rows
                freq[rows], stable[rows] = frequencies_and_stability(lam[rows])
                if V is not None:
                    V[rows] = normalize_eigentwists(V[rows])

            _, V = self.kernels.generalized_eigh(K, M, vectors=vectors, threads=self.ev.c_route.nthreads(), post=post)
            return Modes(freq, V, self.ev.axes(stiffness), stiffness, stable=stable)
        # LAPACK's eigenvalue-only driver rounds differently: solving with vectors keeps
        # frequencies() bit-identical to modes().freq_hz (C: the same Jacobi rotations)
        lam, V = generalized_eigh(K, M)
        freq, stable = frequencies_and_stability(lam)
        return Modes(
            freq,
            normalize_eigentwists(V) if vectors else None,
            self.ev.axes(stiffness),
            stiffness,
            stable=stable,
        )

    def raise_unstable(self, poses, modes: Modes, effects) -> None:
        """Raise :class:`UnstablePoseError` naming the first pose of ``modes`` that is not
        stable, and its negative-stiffness modes or growing pole."""
        k = int(np.argmax(~modes.stable))
        bad = np.flatnonzero(np.isnan(modes.freq_hz[k]))
        if not len(bad) and modes.damping is not None:
            zeta = modes.damping_ratio[k]
            j = int(np.nanargmin(zeta)) if np.isfinite(zeta).any() else 0
            raise UnstablePoseError(
                f"pose {poses[k].tolist()} m is unstable in model {','.join(effects)}: a pole grows (mode {j + 1} has "
                f"damping ratio {zeta[j]:.3g}, or an actuator's internal pole); check the torque lag t_d against "
                "c_a / k_a and negative damping"
            )
        which = ", ".join(str(j + 1) for j in bad)
        raise UnstablePoseError(
            f"pose {poses[k].tolist()} m is unstable in model {','.join(effects)}: mode{'s' if len(bad) > 1 else ''} "
            f"{which} of {modes.freq_hz.shape[1]} {'have' if len(bad) > 1 else 'has'} a negative stiffness "
            "(omega^2 < 0, no natural frequency); check negative or extreme parameters and the gravity preload"
        )
