"""The evaluator users import: validated batches in, matrices and frequencies out."""
from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import numpy as np

from ..description import RobotDescription
from ..description.effects import (base_name, leg_input_name, leg_switch_name, resolve_model, split_scope,
                                   switch_name)
from .eigen import frequencies_hz, generalized_eigh, normalize_eigentwists
from .constraints import check_constraints, compile_constraints
from .errors import InputError
from .validity import LEVER_TOL, lever_mask, raise_singular, raise_unreachable, reachable_mask

__all__ = ["Evaluator", "Modes", "AXES", "LEVER_TOL"]

AXES = ("rx", "ry", "rz", "x", "y", "z")
CHUNK = 4096


@dataclass
class Modes:
    """Natural frequencies and eigentwists of a batch of poses.

    freq_hz : (N, n) ascending, Hz.
    eigentwists : (N, n, n), one column per mode, largest entry +1 (Eqs. 57, 65).
    axes : names of the n coordinates (``("x", "y", "z")`` for the rigid model,
        ``("rx", "ry", "rz", "x", "y", "z")`` for the flexible one).
    kind : ``"rigid"`` (K_R with the 3x3 translational subsets) or ``"flexible"`` (K_F).
    valid : (N,) bool, which poses were evaluated (reachable, not singular); the others
        hold NaN. Set by ``modes(..., invalid="nan")``; None when every pose is valid.
    """

    freq_hz: np.ndarray
    eigentwists: np.ndarray
    axes: tuple
    kind: str
    valid: np.ndarray | None = None

    @property
    def direction(self) -> np.ndarray:
        """(N, n) axis index (into :data:`AXES`) of each mode's largest eigentwist entry."""
        local = np.argmax(np.abs(self.eigentwists), axis=-2)
        offset = 3 if self.kind == "rigid" else 0
        return local + offset


class Evaluator:
    """Evaluate a generated model for batches of poses and parameter values.

    Obtain one with :func:`eigentwist.load`. Poses are end-effector positions (m) in
    the base frame, shape (N, 3) or (3,); parameters are keyword arguments, scalars or
    (N,) arrays, overriding the description's defaults (SI units, see
    ``evaluator.parameters``). ``model`` is a preset (``"rigid"``, ``"paper"``) or a
    comma-separated list of effects.
    """

    def __init__(self, robot: RobotDescription, module: ModuleType, backend: str, kernels=None):
        self.robot = robot
        self.module = module
        self.backend = backend
        self._kernels = kernels or module
        self.parameters = {p.name: p for p in robot.parameters}
        self.defaults = robot.defaults
        self.effects = robot.effects
        self.n_legs = len(robot.legs)
        #: what :func:`eigentwist.load` was given: a shipped robot's name or a description file's path
        self.spec = robot.name
        #: parameter name -> the leg-level effect that owns it (these take ``NAME@N``)
        self.leg_parameters = {q.name: e for e in robot.effects if robot.effect(e).leg_level
                               for q in robot.effect(e).params}
        self.constraints = compile_constraints(robot)

    def __repr__(self) -> str:
        return f"<eigentwist evaluator {self.robot.name!r} backend={self.backend!r}>"

    # ----------------------------------------------------------------- inputs
    def _poses(self, poses) -> np.ndarray:
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise InputError(f"poses has shape {np.shape(poses)}: expected (N, 3) end-effector positions in m")
        if arr.shape[0] == 0:
            raise InputError("poses is empty: expected at least one (x, y, z) position in m")
        bad = ~np.isfinite(arr).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise InputError(f"pose {k} = {arr[k].tolist()} is not finite: expected numbers in m")
        return arr

    def parameter(self, name: str):
        """The :class:`Parameter` ``name``; ``NAME@N`` gives leg N's copy (same unit, bounds)."""
        if name in self.parameters:
            return self.parameters[name]
        if not self.accepts(name):
            self._scoped({name: 0.0})                      # raises the one-line error
        return self.parameters[name.partition("@")[0]].with_values(name=name)

    def accepts(self, name: str) -> bool:
        """True when ``name`` is a parameter, or ``NAME@N`` of a leg-level one with N a leg."""
        if name in self.parameters:
            return True
        try:
            self._scoped({name: 0.0})
        except InputError:
            return False
        return True

    def _scoped(self, params: dict) -> dict:
        """``{"eta_a@3": v}`` -> ``{("eta_a", 3): v}``; unknown names raise one line."""
        scoped, unknown = {}, []
        for key, value in params.items():
            if key in self.parameters:
                continue
            name, at, _ = key.partition("@")
            if not at or name not in self.parameters:
                unknown.append(key)
                continue
            if name not in self.leg_parameters:
                raise InputError(f"parameter {key!r}: {name} belongs to no leg-level effect, so it has no per-leg "
                                 f"value (leg-level parameters: {', '.join(self.leg_parameters) or 'none'})")
            try:
                scoped[split_scope(key, self.n_legs, "parameter")] = value
            except ValueError as exc:
                raise InputError(str(exc)) from None
        if unknown:
            raise InputError(f"unknown parameter(s) {', '.join(map(repr, unknown))} for {self.robot.name}: "
                             f"expected names from {', '.join(self.parameters)} (NAME@N for one leg)")
        return scoped

    def _array(self, name: str, value, n: int, check: bool) -> np.ndarray:
        arr = np.asarray(value, dtype=float)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in (1, n)):
            raise InputError(f"parameter {name!r} has shape {arr.shape}: expected a scalar or ({n},) for {n} poses")
        if check:
            try:
                self.parameters[name.partition("@")[0]].check(arr)
            except ValueError as exc:
                raise InputError(str(exc).replace(f"parameter {name.partition('@')[0]!r}", f"parameter {name!r}")) from None
        return arr

    def _params(self, n: int, params: dict, model) -> dict:
        """The generated code's inputs: parameters, effect switches and each leg's copies."""
        scoped = self._scoped(params)
        effects = resolve_model(model, self.robot)
        on = {base_name(e) for e in effects}
        out = {}
        for name, p in self.parameters.items():
            check = name in params or p.effect is None or p.effect in on
            out[name] = self._array(name, params.get(name, p.default), n, check)
        for e in self.effects:
            effect = self.robot.effect(e)
            if not effect.leg_level:
                out[switch_name(e)] = np.asarray(1.0 if e in effects else 0.0)
                continue
            for k in range(1, self.n_legs + 1):
                out[leg_switch_name(e, k)] = np.asarray(1.0 if e in effects or f"{e}@{k}" in effects else 0.0)
                for q in effect.params:
                    own = (q.name, k) in scoped
                    value = self._array(f"{q.name}@{k}", scoped[(q.name, k)], n, True) if own else out[q.name]
                    out[leg_input_name(q.name, k)] = value
        check_constraints(self.constraints, out, on)
        self._check_leg_constraints(out, effects, scoped)
        return out

    def _check_leg_constraints(self, out: dict, effects, scoped: dict) -> None:
        """A leg's own values meet its effect's constraints (``r_i_l1@2 < r_o_l1@2``)."""
        for c in self.constraints:
            if c.effect is None or not self.robot.effect(c.effect).leg_level:
                continue
            for k in sorted({k for (_, k) in scoped}):
                if c.effect in effects or f"{c.effect}@{k}" in effects:
                    values = {n: out.get(leg_input_name(n, k), out.get(n)) for n in c.names}
                    try:
                        check_constraints([c], values, {c.effect})
                    except InputError as exc:
                        raise InputError(f"leg {k}: {exc}") from None

    def kind(self, model) -> str:
        """``"flexible"`` when the model has a structural compliance, else ``"rigid"``."""
        effects = resolve_model(model, self.robot)
        return "flexible" if any(self.robot.effect(base_name(e)).structural for e in effects) else "rigid"

    # ---------------------------------------------------------------- kernels
    def _chunks(self, n: int):
        for start in range(0, n, CHUNK):
            yield slice(start, min(n, start + CHUNK))

    @staticmethod
    def _take(p: dict, sl: slice) -> dict:
        return {k: (v[sl] if v.ndim == 1 and v.shape[0] > 1 else v) for k, v in p.items()}

    def _check_rows(self, poses: np.ndarray, p: dict, strict: bool):
        """Inverse kinematics with the reachability and singularity checks.

        Returns ``(q, jacobians, ok)``: joint angles (n, legs, 3), the ``jacobians``
        kernel output for the valid rows (None when none is valid) and the (n,) mask of
        valid rows. With ``strict`` the first invalid row raises an error naming the
        pose, the leg and the violated condition (:mod:`.validity`).
        """
        n = len(poses)
        legs = self.robot.legs
        with np.errstate(invalid="ignore", divide="ignore"):
            out = self._kernels.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], p)
        if strict:
            raise_unreachable(legs, poses, out)
        ok = reachable_mask(out)
        q, jac = out["q"], None
        if ok.any():
            sub = p if ok.all() else self._mask(p, ok, n)
            with np.errstate(invalid="ignore", divide="ignore"):
                jac = self._kernels.jacobians(q if ok.all() else q[ok], sub)
            lever = jac["lever"] / np.asarray(sub["l1"], dtype=float)[..., None]
            if strict:
                raise_singular(legs, poses[ok], lever)
            ok[ok] = lever_mask(lever)
        return q, jac, ok

    @staticmethod
    def _mask(p: dict, mask: np.ndarray, n: int) -> dict:
        return {k: (v[mask] if v.ndim == 1 and v.shape[0] == n and n > 1 else v) for k, v in p.items()}

    def _ik(self, poses: np.ndarray, p: dict) -> np.ndarray:
        return self._check_rows(poses, p, strict=True)[0]

    def _run(self, kernel: str, poses, model, params: dict) -> dict:
        poses = self._poses(poses)
        n = len(poses)
        p = self._params(n, params, model)
        results: dict = {}
        for sl in self._chunks(n):
            pc = self._take(p, sl)
            q, jac, _ = self._check_rows(poses[sl], pc, strict=True)
            # the checks already evaluated the jacobians kernel: every result carries it
            out = {"q": q, **jac} if kernel == "jacobians" else {"q": q, **jac, **getattr(self._kernels, kernel)(q, pc)}
            for key, val in out.items():
                results.setdefault(key, []).append(val)
        return {k: np.concatenate(v, axis=0) for k, v in results.items()}

    # ----------------------------------------------------------------- public
    def valid(self, poses, model="paper", **params) -> np.ndarray:
        """(N,) bool: which poses are reachable and not singular for these parameters.

        The per-row form of the checks that make :meth:`modes` raise; use it to filter
        a batch (e.g. a sweep over a workspace box) instead of catching errors.
        """
        poses = self._poses(poses)
        p = self._params(len(poses), params, model)
        return np.concatenate([self._check_rows(poses[sl], self._take(p, sl), strict=False)[2]
                               for sl in self._chunks(len(poses))])

    def joint_angles(self, poses, **params) -> np.ndarray:
        """Joint angles (rad), shape (N, legs, 3): (q1, q2, q3) per leg (closed-form IK)."""
        poses = self._poses(poses)
        p = self._params(len(poses), params, "paper")
        return np.concatenate([self._ik(poses[sl], self._take(p, sl)) for sl in self._chunks(len(poses))])

    def jacobians(self, poses, **params) -> dict:
        """Inverse-Jacobian rows ``J_rows`` (N, legs, 4, 6) and levers ``lever`` (N, legs), m."""
        return self._run("jacobians", poses, "paper", params)

    def parameter_values(self, n: int, model="paper", **params) -> dict:
        """The generated kernels' parameter input for ``n`` poses, validated.

        Every parameter of the robot (``params`` overriding the defaults, SI units) as an
        array that broadcasts with the poses, plus the 0/1 switch of every effect.
        """
        return self._params(n, params, model)

    def run_kernel(self, kernel: str, poses, model="paper", **params) -> dict:
        """Outputs of the generated kernel ``kernel`` (e.g. ``"gravity"``) for ``poses``.

        Poses are checked (reachable, not singular) as in :meth:`matrices`; the result
        also holds the joint angles ``q`` and the ``jacobians`` kernel's outputs.
        """
        return self._run(kernel, poses, model, params)

    def matrices(self, poses, model="paper", **params) -> dict:
        """``M``, ``K_R``, ``K_F`` at the EE origin, each (N, 6, 6) (Eqs. 12, 14, 13).

        ``model`` switches effects on or off (K_R uses only the actuator-side effects).
        """
        out = self._run("matrices", poses, model, params)
        return {k: out[k] for k in ("M", "K_R", "K_F")}

    def stiffness(self, poses, model="paper", **params):
        """The (M, K) pair the model's eigenproblem uses, with the gravity preload if on.

        Rigid models use the 3x3 translational subsets of M and K_R (as the paper does);
        flexible models the full 6x6 M and K_F.
        """
        poses_arr = self._poses(poses)
        effects = resolve_model(model, self.robot)
        mats = self.matrices(poses_arr, model, **params)
        rigid = self.kind(effects) == "rigid"
        M = mats["M"][:, 3:, 3:] if rigid else mats["M"]
        K = mats["K_R"][:, 3:, 3:] if rigid else mats["K_F"]
        if self._preloaded(effects):
            from .gravity import gravity_stiffness

            K = K + gravity_stiffness(self, poses_arr, effects, params, mats, rigid)
        return M, K

    def _preloaded(self, effects) -> bool:
        return any(self.robot.effect(base_name(e)).kind == "preload" for e in effects)

    def modes(self, poses, model="paper", *, invalid: str = "raise", **params) -> Modes:
        """Natural frequencies (Hz) and eigentwists of ``det(omega^2 M - K) = 0`` (Eq. 7).

        ``invalid="raise"`` (the default) raises on the first unreachable or singular
        pose; ``invalid="nan"`` evaluates the valid poses only, fills the others with NaN
        and reports them in ``Modes.valid`` (for sweeps over a workspace box).
        """
        if invalid not in ("raise", "nan"):
            raise InputError(f"invalid={invalid!r}: expected 'raise' or 'nan'")
        poses = self._poses(poses)
        effects = resolve_model(model, self.robot)
        fused = getattr(self._kernels, "fused_frequencies", None)
        if fused is not None and not self._preloaded(effects):
            return self._fused_modes(fused, poses, effects, params, check=invalid == "raise")
        if invalid == "raise":
            return self._solve(*self.stiffness(poses, effects, **params))
        ok = self.valid(poses, effects, **params)
        n = len(poses)
        rows = {k: (np.asarray(v)[ok] if np.ndim(v) == 1 and np.shape(v)[0] == n and n > 1 else v)
                for k, v in params.items()}
        kind = self.kind(effects)
        size = 3 if kind == "rigid" else 6
        freq, vec = np.full((n, size), np.nan), np.full((n, size, size), np.nan)
        if ok.any():
            m = self._solve(*self.stiffness(poses[ok], effects, **rows))
            freq[ok], vec[ok] = m.freq_hz, m.eigentwists
        return Modes(freq, vec, AXES[3:] if kind == "rigid" else AXES, kind, ok)

    @staticmethod
    def _solve(M, K) -> Modes:
        lam, V = generalized_eigh(K, M)
        rigid = M.shape[-1] == 3
        return Modes(frequencies_hz(lam), normalize_eigentwists(V),
                     AXES[3:] if rigid else AXES, "rigid" if rigid else "flexible")

    def _fused_modes(self, fused, poses, effects, params, check: bool = True) -> Modes:
        """The C backend's single pass from poses to frequencies and eigentwists."""
        n = len(poses)
        p = self._params(n, params, effects)
        kind = self.kind(effects)
        freq, vec, ok = [], [], []
        for start in range(0, n, 16 * CHUNK):
            sl = slice(start, min(n, start + 16 * CHUNK))
            pc = self._take(p, sl)
            out = fused(poses[sl, 0], poses[sl, 1], poses[sl, 2], pc, model=kind, vectors=True, check=check)
            freq.append(out["freq_hz"])
            vec.append(out["eigentwists"])
            ok.append(out["valid"])
        return Modes(np.concatenate(freq), np.concatenate(vec), AXES[3:] if kind == "rigid" else AXES, kind,
                     None if check else np.concatenate(ok))

    def frequencies(self, poses, model="paper", **params) -> np.ndarray:
        """Natural frequencies in Hz, shape (N, 6) for flexible models (the default,
        ``"paper"``) or (N, 3) for ``"rigid"``, ascending."""
        return self.modes(poses, model, **params).freq_hz
