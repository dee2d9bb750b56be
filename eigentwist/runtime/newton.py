"""Inverse kinematics without algebra: a damped Newton method on the loop closure (issue 21).

A leg written in URDF form (:mod:`eigentwist.description.serial`) has no closed-form IK.
Its generated ``loop_closure`` kernel (NumPy or C) gives, at joint coordinates ``q`` and a
pose, the residual ``r(q)`` (chain end minus platform attachment: orientation error in rad
when the chain does not end in a spherical joint, then position in m) and its exact
Jacobian ``A = dr/dq``. :func:`solve` finds ``r(q) = 0`` for every pose and leg at once by
Levenberg-Marquardt steps

    (A^T A + lambda diag(A^T A)) dq = -A^T r,

accepting a step when ``|r|`` decreases (lambda / 4) and otherwise retrying with a
larger damping (lambda x 4), each coordinate moving at most ``MAX_STEP`` per iteration, started from the description's reference configuration (its
assembly branch); poses that do not converge from there are retried from the solution of
the previous pose of the batch (a sweep moves in small steps). A pose converges when
``|r| < tol``; one that does not has NaN coordinates, which the IK program's closure check
reports as unreachable (:mod:`.validity`), never a silently wrong configuration. The
assembly branch is kept: a solution whose leg determinant (the jacobians kernel's
``lever``: the six unit twists' determinant) has the opposite sign of the reference
configuration's lies past a singularity and is rejected too.
"""
from __future__ import annotations

import numpy as np

__all__ = ["solve", "MAX_ITERATIONS", "TOL"]

MAX_ITERATIONS = 80
TOL = 1e-12            # |r| (m and rad) of a converged configuration
LAMBDA0 = 1e-3
MAX_STEP = 0.25        # largest change of one coordinate per iteration (rad; m for P)


def _iterate(closure, q: np.ndarray, p: dict, iterations: int, tol: float):
    """Damped Newton steps on every (pose, leg) at once; returns (q, |r|)."""
    out = closure(q, p)
    r, A = out["residual"], out["dresidual"]
    norm = np.sqrt((r * r).sum(-1))
    lam = np.full(norm.shape, LAMBDA0)
    nq = q.shape[-1]
    eye = np.eye(nq)
    for _ in range(iterations):
        active = ~(norm < tol) & np.isfinite(norm)
        if not active.any():
            break
        AtA = np.einsum("...ki,...kj->...ij", A, A)
        Atr = np.einsum("...ki,...k->...i", A, r)
        diag = np.einsum("...ii->...i", AtA)
        H = AtA + lam[..., None, None] * (diag[..., None, :] * eye + 1e-12 * eye)
        H = np.where(np.isfinite(H), H, 0.0) + np.where(np.isfinite(H).all((-1, -2)), 0.0, 1.0)[..., None, None] * eye
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            try:
                step = -np.linalg.solve(H, Atr[..., None])[..., 0]
            except np.linalg.LinAlgError:               # a singular H (a zero row): least squares
                step = -(np.linalg.pinv(H) @ Atr[..., None])[..., 0]
        # a bounded step (MAX_STEP rad or m per coordinate) keeps Newton near the branch it
        # starts on: an undamped first step from far away may jump past a singularity
        big = np.abs(step).max(-1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            step = np.where(big > MAX_STEP, step * (MAX_STEP / big), step)
        step = np.where(active[..., None], step, 0.0)
        trial = q + step
        new = closure(trial, p)
        new_norm = np.sqrt((new["residual"] ** 2).sum(-1))
        better = active & (new_norm < norm)
        q = np.where(better[..., None], trial, q)
        r = np.where(better[..., None], new["residual"], r)
        A = np.where(better[..., None, None], new["dresidual"], A)
        norm = np.where(better, new_norm, norm)
        lam = np.where(better, np.maximum(lam / 4, 1e-12), np.minimum(lam * 4, 1e12))
    # one undamped Gauss-Newton step polishes a converged configuration to round-off
    # (quadratic convergence), kept where it does not raise the residual
    AtA = np.einsum("...ki,...kj->...ij", A, A) + 1e-300 * eye
    Atr = np.einsum("...ki,...k->...i", A, r)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        try:
            trial = q - np.linalg.solve(AtA, Atr[..., None])[..., 0]
        except np.linalg.LinAlgError:
            return q, norm
        new_norm = np.sqrt((closure(trial, p)["residual"] ** 2).sum(-1))
    keep = (norm < tol) & (new_norm <= norm)
    return np.where(keep[..., None], trial, q), np.where(keep, new_norm, norm)


def solve(closure, reference: np.ndarray, p: dict, n: int, branch=None,
          iterations: int = MAX_ITERATIONS, tol: float = TOL) -> np.ndarray:
    """Joint coordinates (n, legs, n_q) closing every leg's loop at n poses; NaN where
    Newton does not converge (or lands on another assembly branch).

    closure : ``closure(q, p) -> {"residual", "dresidual"}`` (the generated kernel).
    reference : (legs, n_q) the description's reference configuration (rad; m for P).
    p : the kernel's inputs (parameters and the pose, (n,) arrays or scalars).
    branch : optional ``branch(q) -> (n, legs)`` signs of each leg's determinant; a
        solution whose sign differs from the reference configuration's is rejected.
    """
    q0 = np.broadcast_to(reference, (n,) + reference.shape).copy()
    q, norm = _iterate(closure, q0, p, iterations, tol)
    ok = norm < tol
    # warm start: a pose that fails from the reference starts from the previous pose's solution
    for _ in range(3):
        retry = ~ok.all(-1)
        retry[0] = False
        prev = np.flatnonzero(retry)
        prev = prev[ok[prev - 1].all(-1)] if prev.size else prev
        if prev.size == 0:
            break
        sub = {k: (v[prev] if np.ndim(v) == 1 and np.shape(v)[0] == n and n > 1 else v) for k, v in p.items()}
        qs, ns = _iterate(closure, q[prev - 1].copy(), sub, iterations, tol)
        q[prev], norm[prev] = qs, ns
        ok = norm < tol
    if branch is not None and ok.any():
        ref_sign = np.sign(branch(np.broadcast_to(reference, q.shape)))
        ok &= np.sign(branch(np.where(ok[..., None], q, q0))) == ref_sign
    return np.where(ok[..., None], q, np.nan)
