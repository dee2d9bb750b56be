"""The route of the frequencies' derivatives with respect to the parameters.

A stage of an evaluation (:class:`~eigentwist.runtime.evaluator.Evaluator` holds one as
``ev.sensitivity_route``): d f / d p of a model's natural frequencies from the eigenvalue
perturbation d omega^2 / d p = phi^T (dK - omega^2 dM) phi: every parameter at once from the
generated reverse-mode kernel weighted by each mode (:mod:`.sensitivity`), from central
differences of the matrices, or through the solved coordinates of legs solved by Newton and of a
lower-mobility platform's followers (:mod:`.implicit`); a model whose finite modes come from the
exact condensation takes the penalty's derivatives with its first-order error removed.
"""

from __future__ import annotations

import numpy as np

from .completion import chunks, take, user_rows
from .eigen import frequencies_hz, generalized_eigh, normalize_eigentwists
from .errors import InputError
from .mode_solver import MATRICES
from .modes import Modes

__all__ = ["SensitivityRoute"]


class SensitivityRoute:
    """The frequencies' derivatives of one evaluator.

    ev : the :class:`~eigentwist.runtime.evaluator.Evaluator` (its stages, models and
    matrices; ``ev.solver``: the constraints' treatment and the exact condensation).
    """

    def __init__(self, ev):
        self.ev = ev

    def modes_and_sensitivities(self, poses, wrt, model, rtol: float, progress, method: str, params: dict, lowest=None):
        """``(Modes, dfdp)`` of ``Evaluator.modes_and_sensitivities``, the user's parameter values
        as the dict ``params``: the rigid model on allowed twists that turn with the pose by
        :func:`.implicit.reduced_derivatives`, every other model by :meth:`derivatives_at` on the
        constraints' route (``ev.solver.route``). ``lowest``: dfdp of the lowest modes only
        (:func:`.sensitivity.check_lowest`)."""
        from .sensitivity import check_lowest

        if method not in ("exact", "differences"):
            raise InputError(f"method={method!r}: expected 'exact' or 'differences'")
        lowest = check_lowest(lowest)
        given = poses
        poses, effects, wrt = self._checked(poses, wrt, model, params)
        rigid = self.ev.stiffness_model(effects) == "rigid"
        if rigid and getattr(self.ev.space, "basis", 0) is None:
            from .implicit import reduced_derivatives
            from .sensitivity import eigenvalue_derivatives

            out = reduced_derivatives(self.ev, given, wrt, effects, params)
            lam, V = generalized_eigh(out["K"], out["M"])
            omega = np.sqrt(np.clip(lam, 0.0, None))
            with np.errstate(divide="ignore", invalid="ignore"):
                dfdp = eigenvalue_derivatives(lam, V, out["dK"], out["dM"], rtol) / (2 * omega[..., None]) / (2 * np.pi)
            modes = Modes(frequencies_hz(lam), normalize_eigentwists(V), self.ev.axes("rigid"), "rigid")
            return modes, dfdp[:, :lowest]
        solved, exact = self.ev.solver.route(effects, params)
        args = (given, poses, wrt, effects, params, method, rigid, rtol, progress, lowest)
        freq, vec, dfdp = self.derivatives_at(solved, *args)
        if exact and "c_rigid" in self.ev.parameters:
            # the finite modes come from the exact condensation, their derivatives from K_F with
            # the penalty c_rigid: its first-order error removed (Richardson: 2 f'(c/2) - f'(c))
            c = np.asarray(solved.get("c_rigid", self.ev.parameters["c_rigid"].default), dtype=float)
            dfdp = 2 * self.derivatives_at({**solved, "c_rigid": c / 2}, *args)[2] - dfdp
        stiffness = "rigid" if rigid else "flexible"
        modes = Modes(freq, vec, self.ev.axes(stiffness), stiffness)
        if exact:  # K_F's penalty: the finite modes exact
            modes = self.ev.solver.exact_modes(poses, effects, params, modes, True)
            modes.legs = None
        return modes, dfdp

    def derivatives_at(self, solved: dict, given, poses, wrt, effects, params, method, rigid, rtol, progress, lowest):
        """``(freq_hz, eigentwists, dfdp)`` of :meth:`modes_and_sensitivities` with the
        parameters ``solved`` (the route's, or a penalty's other value), other than the
        rigid model on turning allowed twists; dfdp of the ``lowest`` modes (None: all). The
        reverse-mode kernel sweeps those modes only; the other routes slice theirs."""
        from .sensitivity import (
            adjoint_eigen_derivatives,
            frequency_derivatives,
            kernel_wrt,
            own_legs,
            sensitivity_kernels,
            shared_columns,
        )

        basis = None if self.ev.c_route.c_rigid else getattr(self.ev.space, "basis", None)  # a point's translations
        # a flexible model on a lower-mobility platform: the followers move with the parameters
        follow = not rigid and bool(getattr(self.ev.space, "followers", ()))

        def total(out: dict, names, sl=slice(None)) -> dict:
            if follow:
                from .implicit import follower_terms

                terms = follower_terms(self.ev, np.asarray(given, dtype=float)[sl], poses[sl], names, effects, solved)
                for k, d in terms.items():
                    if k in out:
                        out[k] = out[k] + d
            return out

        if method == "exact" and self.ev.numeric_ik:
            from .implicit import numeric_matrix_derivatives

            out = total(numeric_matrix_derivatives(self.ev, poses, wrt, effects, solved), wrt)
            freq, vec, dfdp = frequency_derivatives(
                out, rigid, rtol, translational=not self.ev.completion.six, basis=basis
            )
        elif method == "differences":
            out = total(self.ev.matrix_derivatives(poses, wrt, effects, **solved), wrt)
            freq, vec, dfdp = frequency_derivatives(
                out, rigid, rtol, translational=not self.ev.completion.six, basis=basis
            )
        else:
            own = own_legs(wrt, params)  # legs whose own P@N does not follow a shared P
            full = kernel_wrt(wrt, own)
            stiffness = "rigid" if rigid else "flexible"
            kern = None
            E = self.twists(rigid, basis)
            p = self.ev.resolver.resolve(len(poses), solved, effects)
            parts = []
            for sl in chunks(len(poses)):
                pc = take(p, sl)
                # every pose checked here: the first unreachable or singular one raises
                mats = self.ev.matrices(poses[sl], effects, **user_rows(solved, sl, len(poses)))
                if kern is None:  # after the first chunk's checks: a bad pose costs no generation
                    kern = sensitivity_kernels(self.ev, full, progress, kind=stiffness)
                extra = None
                if follow:
                    d = total({"dM": 0.0, "dK_R": 0.0, "dK_F": 0.0}, full, sl)
                    extra = (d["dM"], d["dK_R" if rigid else "dK_F"])
                x = poses[sl]
                lam, V, dlam = adjoint_eigen_derivatives(
                    kern,
                    x[:, 0],
                    x[:, 1],
                    x[:, 2],
                    self.ev.completion.with_pose(x, pc),
                    mats["M"],
                    mats["K_R" if rigid else "K_F"],
                    E,
                    rtol,
                    extra,
                    lowest,
                    self.ev.solver.eigh,  # the C library's Jacobi where it has the size
                )
                omega = np.sqrt(np.clip(lam, 0.0, None))[:, : dlam.shape[1]]
                with np.errstate(divide="ignore", invalid="ignore"):
                    parts.append(
                        (frequencies_hz(lam), normalize_eigentwists(V), dlam / (2 * omega[..., None]) / (2 * np.pi))
                    )
            freq, vec, dfdp = (np.concatenate(x) for x in zip(*parts))
            if own:
                dfdp = shared_columns(dfdp, wrt, full, own)
        return freq, vec, dfdp[:, :lowest]  # the kernel's route swept only those; the others slice

    def _checked(self, poses, wrt, model, params: dict) -> tuple:
        """``(poses, effects, wrt)``: the completed poses, the model's effects (one that can be
        differentiated) and the checked parameter names."""
        from .sensitivity import check_model, check_wrt

        poses = self.ev.completion.poses(poses, params)
        effects = self.ev.resolver.model_effects(model)
        check_model(effects)
        return poses, effects, check_wrt(self.ev, wrt)

    def weighted_mass(self, poses, wrt, model, params: dict, weights) -> tuple[np.ndarray, np.ndarray]:
        """``(value (N,), gradient (N, len(wrt)))`` of <W, M> = the sum of W_ij M_ij for symmetric
        ``weights`` W (6, 6), M the Cartesian inertia matrix (Eq. 12) at ``poses`` with the
        user's parameter values ``params``, the gradient per SI unit of each parameter: from the
        reverse-mode kernel of the model's stiffness (the one its frequencies' derivatives use)
        with the stiffness weights 0; legs solved by Newton: through their solved coordinates
        (:func:`.implicit.numeric_matrix_derivatives`); a lower-mobility platform's followers:
        their terms added (:func:`.implicit.follower_terms`)."""
        from .sensitivity import kernel_wrt, own_legs, sensitivity_kernels, shared_columns, weighted_derivatives

        W = np.asarray(weights, dtype=float)
        if W.shape != (6, 6) or not np.allclose(W, W.T, rtol=0.0, atol=1e-12 * max(np.abs(W).max(), 1e-300)):
            raise InputError(f"weights of shape {W.shape}: expected a symmetric 6x6 matrix")
        given = poses
        poses, effects, wrt = self._checked(poses, wrt, model, params)
        n = len(poses)
        value = np.einsum("ij,nij->n", W, self.ev.matrices(poses, effects, **params)["M"])
        follow = bool(getattr(self.ev.space, "followers", ()))
        if self.ev.numeric_ik:
            from .implicit import numeric_matrix_derivatives

            dM = numeric_matrix_derivatives(self.ev, poses, wrt, effects, params)["dM"]
            gradient = np.einsum("ij,npij->np", W, dM)
        else:
            own = own_legs(wrt, params)
            full = kernel_wrt(wrt, own)
            kern = sensitivity_kernels(self.ev, full, None, kind=self.ev.stiffness_model(effects))
            p = self.ev.resolver.resolve(n, params, effects)
            self.ev.checks.check_rows(poses, p, strict=True)
            Wn = np.broadcast_to(W, (n, 1, 6, 6))
            g = weighted_derivatives(
                kern,
                poses[:, 0],
                poses[:, 1],
                poses[:, 2],
                self.ev.completion.with_pose(poses, p),
                Wn,
                np.zeros_like(Wn),
            )
            gradient = shared_columns(g, wrt, full, own)[:, 0] if own else g[:, 0]
        if follow:
            from .implicit import follower_terms

            terms = follower_terms(self.ev, np.asarray(given, dtype=float), poses, wrt, effects, params)
            gradient = gradient + np.einsum("ij,npij->np", W, terms["dM"])
        return value, gradient

    def twists(self, rigid: bool, basis) -> np.ndarray:
        """(6, n): the twists a model's eigenproblem is posed on: a constant allowed-twist
        ``basis`` (a point platform's translations), the translations of a rigid model of a
        translational robot (the 3x3 subsets of M and K_R), else all six."""
        if rigid and basis is not None:
            return np.asarray(basis, dtype=float)
        eye = np.eye(6)
        return eye[:, 3:6] if rigid and not self.ev.completion.six else eye

    def matrix_derivatives(self, poses, wrt, model, params: dict) -> dict:
        """``Evaluator.matrix_derivatives``, the user's parameter values as the dict ``params``:
        the matrices and their derivatives by central differences (one-sided, second order, at a
        bound or a constraint between parameters: :meth:`admissible`)."""
        from .sensitivity import difference_step

        poses = self.ev.completion.poses(poses, params)
        out = dict(self.ev.matrices(poses, model, **params))
        d = {k: np.empty((len(poses), len(wrt), 6, 6)) for k in ("dM", "dK_R", "dK_F")}
        for j, name in enumerate(wrt):
            value, h = difference_step(self.ev, name, params)
            step = np.reshape(2 * h, (-1, 1, 1) if np.ndim(h) else ())
            hi, lo = (self.admissible(poses, model, params, name, value + s * h) for s in (1, -1))
            if hi is not None and lo is not None:  # central differences
                for k in MATRICES:
                    d["d" + k][:, j] = (hi[k] - lo[k]) / step
                continue
            sign = 1 if hi is not None else -1  # at a bound: one-sided, second order
            far = self.admissible(poses, model, params, name, value + 2 * sign * h)
            if far is None:
                raise InputError(
                    f"parameter {name!r} = {float(np.max(value)):g}: no difference step of "
                    f"{float(np.max(h)):.3g} either way stays within its bounds and constraints; "
                    "expected a value away from them"
                )
            near = hi if sign == 1 else lo
            for k in MATRICES:
                d["d" + k][:, j] = sign * (4 * near[k] - 3 * out[k] - far[k]) / step
        out.update(d)
        return out

    def admissible(self, poses, model, params: dict, name: str, value):
        """``Evaluator.matrices`` with ``name`` at ``value``; None where that value leaves the
        parameter's bounds or a constraint between parameters (a difference step never
        crosses them)."""
        try:
            return self.ev.matrices(poses, model, **{**params, name: value})
        except InputError:
            return None
