"""Inverse kinematics without algebra: a damped Newton method on the loop closure.

A leg written in URDF form (:mod:`eigentwist.description.serial`) has no closed-form IK.
Its generated ``loop_closure`` kernel (NumPy or C) gives, at joint coordinates ``q`` and a
pose, the residual ``r(q)`` (chain end minus platform attachment: orientation error in rad
when the chain does not end in a spherical joint, then position in m) and its exact
Jacobian ``A = dr/dq``. :func:`solve` finds ``r(q) = 0`` for every pose and leg at once by
Levenberg-Marquardt steps

    (A^T A + lambda diag(A^T A)) dq = -A^T r,

accepting a step when ``|r|`` decreases (lambda / 4) and otherwise retrying with a
larger damping (lambda x 4), each coordinate moving at most ``MAX_STEP`` per iteration,
started from a first-order prediction of the closed configuration
(:func:`predicted_start`: the assembly configuration at x_ref moved along its implicit
derivative dq/dx) where the caller gives one, else from the description's reference
configuration (its assembly branch); poses that do not converge from the prediction, or
converge on another branch, are solved again from the reference, and poses that do not
converge from there are retried from the solution of the previous pose of the batch (a
sweep moves in small steps). A pose converges when
``|r| < tol``; one that does not has NaN coordinates, which the IK program's closure check
reports as unreachable (:mod:`.validity`), never a silently wrong configuration. The
assembly branch is kept: a solution whose leg determinant (the jacobians kernel's
``lever``: the six unit twists' determinant) has the opposite sign of the reference
configuration's lies past a singularity and is rejected too.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "solve",
    "predicted_start",
    "Prediction",
    "tangent",
    "normal_solve",
    "continuation",
    "same_configuration",
    "MAX_ITERATIONS",
    "TOL",
    "HOMOTOPY_STEPS",
    "PATH_TOL",
    "BRANCH_GAP",
]

MAX_ITERATIONS = 80
TOL = 1e-12  # |r| (m and rad) of a converged configuration
LAMBDA0 = 1e-3
#: the first damping from a predicted start (:func:`predicted_start`): near the solution
#: Gauss-Newton converges quadratically, and LAMBDA0's damping would only slow it (a
#: rejected step still raises the damping x 4)
GUESS_LAMBDA0 = 1e-8
#: a (pose, leg) whose |r| falls below this (m and rad; TOL where that is larger) takes no more
#: damped steps but one undamped step: Newton's quadratic convergence takes |r| ~ 1e-8 to
#: round-off in it (one closure evaluation fewer than damped steps down to TOL, then the
#: undamped one); where that step leaves |r| at TOL or above (a slow convergence) the damped
#: steps resume down to TOL (:func:`_iterate`)
EARLY = 1e-8
MAX_STEP = 0.25  # largest change of one coordinate per iteration (rad; m for P)
HOMOTOPY_STEPS = 64  # steps of the Newton homotopy from the reference configuration
HOMOTOPY_ITERATIONS = 12
PATH_TOL = 1e-9  # |r - (1 - t) r_ref| (m and rad) of a point on the homotopy path
#: two closed configurations of a leg are one when no coordinate differs by more (rad; m):
#: both close to 1e-12 and a leg's Jacobian is far better conditioned than 1e-6 off a singularity
BRANCH_GAP = 1e-6


def same_configuration(a, b, angular) -> np.ndarray:
    """(..., ) bool: configurations ``a`` and ``b`` (..., n_q) are one, every coordinate
    within :data:`BRANCH_GAP` (angles, ``angular`` True, compared modulo 2 pi); NaN never."""
    gap = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    gap = np.where(angular, np.angle(np.exp(1j * gap)), gap)
    return (np.abs(gap) <= BRANCH_GAP).all(axis=-1)


def _take(p: dict, rows: np.ndarray, n: int) -> dict:
    """The kernel inputs of poses ``rows`` ((n,) arrays indexed, scalars kept)."""
    return {k: (v[rows] if np.ndim(v) >= 1 and np.shape(v)[0] == n and n > 1 else v) for k, v in p.items()}


SOA_MIN = 64  # systems from which the normal equations are solved entry by entry (_cholesky_solve)


def _lapack_solve(A: np.ndarray, r: np.ndarray, scale, shift) -> np.ndarray:
    """:func:`normal_solve` by LAPACK, one small system at a time (few systems)."""
    At = A.swapaxes(-1, -2)
    AtA, Atr = At @ A, (At @ r[..., None])[..., 0]
    eye = np.eye(A.shape[-1])
    diag = np.einsum("...ii->...i", AtA)
    H = AtA + (np.asarray(scale)[..., None] * diag + np.asarray(shift)[..., None])[..., None, :] * eye
    finite = np.isfinite(H).all((-1, -2))
    H = np.where(finite[..., None, None], H, eye)
    try:
        return -np.linalg.solve(H, Atr[..., None])[..., 0]
    except np.linalg.LinAlgError:  # a singular H (a zero row): least squares
        return -(np.linalg.pinv(H) @ Atr[..., None])[..., 0]


def _cholesky_solve(A: np.ndarray, r: np.ndarray, scale, shift) -> np.ndarray:
    """:func:`normal_solve` with the systems in the last axis: A^T A, A^T r, the Cholesky
    factor and both substitutions entry by entry, each a vector operation over every
    system (n_q <= 6: a few dozen operations in all, against one LAPACK call per system)."""
    R, Q = A.shape[-2:]
    At = np.ascontiguousarray(np.moveaxis(A, (-2, -1), (0, 1)))  # (R, Q, ...)
    rt = np.ascontiguousarray(np.moveaxis(r, -1, 0))  # (R, ...)
    H, g = {}, []
    for i in range(Q):
        for j in range(i + 1):
            s = At[0, i] * At[0, j]
            for k in range(1, R):
                s += At[k, i] * At[k, j]
            H[i, j] = s
        s = At[0, i] * rt[0]
        for k in range(1, R):
            s += At[k, i] * rt[k]
        g.append(s)
    finite = np.ones(rt.shape[1:], dtype=bool)
    for i in range(Q):
        H[i, i] = H[i, i] + (scale * H[i, i] + shift)
        for j in range(i + 1):
            finite &= np.isfinite(H[i, j])
    L = {}
    for j in range(Q):  # H = L L^T
        s = H[j, j]
        for k in range(j):
            s = s - L[j, k] * L[j, k]
        L[j, j] = np.sqrt(s)
        inv = 1.0 / L[j, j]
        for i in range(j + 1, Q):
            s = H[i, j]
            for k in range(j):
                s = s - L[i, k] * L[j, k]
            L[i, j] = s * inv
    y = []
    for i in range(Q):
        s = g[i]
        for k in range(i):
            s = s - L[i, k] * y[k]
        y.append(s / L[i, i])
    x = [None] * Q
    for i in reversed(range(Q)):
        s = y[i]
        for k in range(i + 1, Q):
            s = s - L[k, i] * x[k]
        x[i] = s / L[i, i]
    step = -np.stack(x, axis=-1)
    if not finite.all():  # a non-finite H: the gradient step (as H = I)
        step[~finite] = -np.stack(g, axis=-1)[~finite]
    return step


def normal_solve(A: np.ndarray, r: np.ndarray, scale, shift) -> np.ndarray:
    """The damped Gauss-Newton step ``-(A^T A + diag(scale diag(A^T A) + shift))^-1 A^T r``
    of stacked Jacobians A (..., rows, n_q) and residuals r (..., rows); ``scale`` and
    ``shift`` broadcast against the stack (Levenberg-Marquardt: ``scale = lambda``,
    ``shift = 1e-12 lambda``). A system whose matrix is not finite takes ``-A^T r``; one
    that is not positive definite a non-finite step (rejected by the caller)."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        if int(np.prod(A.shape[:-2])) >= SOA_MIN:
            return _cholesky_solve(A, r, scale, shift)
        return _lapack_solve(A, r, scale, shift)


def _iterate(closure, q: np.ndarray, p: dict, iterations: int, tol: float, lambda0: float = LAMBDA0):
    """Damped Newton steps on every (pose, leg) at once, each iteration on the poses that
    still have a leg to step, the damping starting at ``lambda0``; returns (q, |r|).

    Per (pose, leg): damped steps while |r| is not below :data:`EARLY` (at least ``tol``) and
    finite, at most ``iterations``; one undamped step (kept where it does not raise |r|) where
    it is below; where that step leaves |r| at ``tol`` or above, damped steps again while not
    below ``tol`` (at most ``iterations``) and, below it, a last undamped step."""
    n = len(q)
    out = closure(q, p)
    r, A = out["residual"].copy(), out["dresidual"].copy()
    norm = np.sqrt((r * r).sum(-1))
    lam = np.full(norm.shape, lambda0)
    q = q.copy()
    rescue = None  # the (pose, leg) the first undamped step left at tol or above
    for below in (max(EARLY, tol), tol):
        for _ in range(iterations):
            active = ~(norm < below) & np.isfinite(norm)
            if rescue is not None:
                active &= rescue
            some = active.any(-1)
            every = bool(some.all())
            rows = slice(None) if every else np.flatnonzero(some)
            if not every and rows.size == 0:
                break
            act, A_, r_, lam_, q_ = active[rows], A[rows], r[rows], lam[rows], q[rows]
            step = normal_solve(A_, r_, lam_, 1e-12 * lam_)
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                # a bounded step (MAX_STEP rad or m per coordinate) keeps Newton near the branch
                # it starts on: an undamped first step from far away may jump past a singularity
                big = np.abs(step).max(-1, keepdims=True)
                step = np.where(big > MAX_STEP, step * (MAX_STEP / big), step)
            trial = q_ + np.where(act[..., None], step, 0.0)
            new = closure(trial, p if every else _take(p, rows, n))
            new_norm = np.sqrt((new["residual"] ** 2).sum(-1))
            better = act & (new_norm < norm[rows])
            _keep((q, r, A, norm), rows, better, (trial, new["residual"], new["dresidual"], new_norm))
            lam[rows] = np.where(better, np.maximum(lam_ / 4, 1e-12), np.where(act, np.minimum(lam_ * 4, 1e12), lam_))
        # one undamped Gauss-Newton step takes a (pose, leg) below `below` to round-off
        # (quadratic convergence), kept where it does not raise the residual
        polish = norm < below
        if rescue is not None:
            polish &= rescue
        rows = np.flatnonzero(polish.any(-1))
        if rows.size:
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                trial = q[rows] + normal_solve(A[rows], r[rows], 0.0, 1e-300)
                new = closure(trial, _take(p, rows, n))
                new_norm = np.sqrt((new["residual"] ** 2).sum(-1))
            keep = polish[rows] & (new_norm <= norm[rows])
            _keep((q, r, A, norm), rows, keep, (trial, new["residual"], new["dresidual"], new_norm))
        if rescue is not None:
            break
        rescue = polish & ~(norm < tol)
        if not rescue.any():
            break
    return q, norm


def _keep(state: tuple, rows, keep: np.ndarray, trial: tuple) -> None:
    """The (pose, leg) ``keep`` of rows ``rows`` take the trial point: ``state`` (q, r, A, |r|)
    (N, legs, ...) updated in place from ``trial``, the same four at those rows."""
    for now, new in zip(state, trial):
        now[rows] = np.where(keep.reshape(keep.shape + (1,) * (new.ndim - keep.ndim)), new, now[rows])


def _normal(A: np.ndarray, r: np.ndarray):
    """``(A^T A, A^T r)`` of stacked (..., rows, n_q) Jacobians and (..., rows) residuals."""
    At = A.swapaxes(-1, -2)
    return At @ A, (At @ r[..., None])[..., 0]


def continuation(
    closure, reference: np.ndarray, p: dict, steps: int = HOMOTOPY_STEPS, tol: float = TOL
) -> tuple[np.ndarray, np.ndarray]:
    """The configuration the reference is connected to at one pose: the Newton homotopy
    ``r(q) = (1 - t) r(q_ref)`` followed from t = 0 (where the reference solves it) to
    t = 1 (the loop closed) in ``steps`` steps, Gauss-Newton at each. Where the reference
    already closes, the result is the reference polished; where it does not, the path
    stays on the sheet of solutions through the reference, whichever assembly branch a
    plain Newton solve from it would jump to.

    closure : the generated kernel; reference : (legs, n_q); p : inputs of one pose.
    Returns ``(q (legs, n_q), |r(q)| (legs,))``: NaN coordinates for a leg whose path met
    a singularity (a step that does not converge).
    """
    q = np.array(reference, dtype=float)[None]
    r0 = closure(q, p)["residual"].copy()
    alive = np.isfinite(r0).all(-1)
    for k in range(1, steps + 1):
        target = (1.0 - k / steps) * r0
        for _ in range(HOMOTOPY_ITERATIONS):
            out = closure(q, p)
            r, A = out["residual"] - target, out["dresidual"]
            AtA, Atr = _normal(A, r)
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                try:
                    step = -np.linalg.solve(AtA + 1e-300 * np.eye(q.shape[-1]), Atr[..., None])[..., 0]
                except np.linalg.LinAlgError:
                    step = np.full_like(q, np.nan)
            q = q + np.where(alive[..., None], step, 0.0)
            if (np.sqrt((r * r).sum(-1)) < tol).all():
                break
        with np.errstate(invalid="ignore"):
            res = closure(q, p)["residual"] - target
            alive &= np.sqrt((res * res).sum(-1)) < PATH_TOL
    q = np.where(alive[..., None], q, np.nan)
    r = closure(q, p)["residual"]
    return q[0], np.sqrt((r * r).sum(-1))[0]


def solve(
    closure,
    reference: np.ndarray,
    p: dict,
    n: int,
    branch=None,
    iterations: int = MAX_ITERATIONS,
    tol: float = TOL,
    signs=None,
    report: bool = False,
    iterate=None,
    start=None,
):
    """Joint coordinates (n, legs, n_q) closing every leg's loop at n poses; NaN where
    Newton does not converge (or lands on another assembly branch).

    closure : ``closure(q, p) -> {"residual", "dresidual"}`` (the generated kernel).
    reference : (legs, n_q) the description's reference configuration (rad; m for P).
    p : the kernel's inputs (parameters and the pose, (n,) arrays or scalars).
    branch : optional ``branch(q) -> (n, legs)`` signs of each leg's determinant; a
        solution whose sign differs from the branch's is rejected.
    signs : (legs,) the branch's signs, recorded where the reference closes the loop
        (:func:`continuation`); None: the reference configuration's own.
    report : also return the (n, legs) mask of solutions rejected for their branch.
    iterate : optional ``iterate(q, p, iterations, tol[, lambda0]) -> (q, |r|)`` that runs this
        module's iterations on ``closure`` by other means (the C driver, :mod:`.c_levenberg_marquardt`);
        ``lambda0`` (the first damping) is given for iterations from ``start`` only.
    start : optional (n, legs, n_q) first guesses (e.g. :func:`predicted_start`); a pose
        that does not converge from its guess, or converges on another branch, is solved
        again from ``reference``, so a guess only changes how many iterations it takes.
    """
    if iterate is None:

        def iterate(q, pp, its, tl, lambda0=LAMBDA0):
            return _iterate(closure, q, pp, its, tl, lambda0)

    q0 = np.broadcast_to(reference, (n,) + reference.shape)
    guessed = start is not None
    if guessed:
        q, norm = iterate(np.asarray(start, dtype=float), p, iterations, tol, GUESS_LAMBDA0)
    else:
        q, norm = iterate(q0.copy(), p, iterations, tol)
    ok = norm < tol
    if guessed:
        q, norm, ok = _from_reference(iterate, q, norm, ~ok.all(-1), q0, p, n, iterations, tol)
    q, norm, ok = _warm_start(iterate, q, norm, ok, p, n, iterations, tol)
    off = np.zeros(ok.shape, dtype=bool)
    if branch is not None and ok.any():
        ref_sign = (
            np.sign(branch(np.broadcast_to(reference, q.shape)))
            if signs is None
            else np.broadcast_to(np.asarray(signs, dtype=float), ok.shape)
        )
        # a singular reference (sign 0) names no branch: nothing to compare with
        off = ok & ~((np.sign(branch(_where_ok(ok, q, q0))) == ref_sign) | (ref_sign == 0))
        if guessed and off.any():  # a guess led past a singularity: solve those poses from the reference
            rows = off.any(-1)
            q, norm, ok = _from_reference(iterate, q, norm, rows, q0, p, n, iterations, tol)
            q, norm, ok = _warm_start(iterate, q, norm, ok, p, n, iterations, tol)
            again = ok & ~((np.sign(branch(_where_ok(ok, q, q0))) == ref_sign) | (ref_sign == 0))
            off = np.where(rows[:, None], again, off)
        ok &= ~off
    q = _where_ok(ok, q, np.nan)
    return (q, off) if report else q


def _where_ok(ok: np.ndarray, q: np.ndarray, other) -> np.ndarray:
    """``q`` (n, legs, n_q) where ``ok`` (n, legs), else ``other``; ``q`` itself where every leg is ok."""
    return q if ok.all() else np.where(ok[..., None], q, other)


def _warm_start(iterate, q, norm, ok, p: dict, n: int, iterations: int, tol: float):
    """A pose that has not converged starts again from the previous pose's solution, where
    that converged (three passes: a run of failed poses is reached one by one): (q, |r|, converged)."""
    for _ in range(3):
        retry = ~ok.all(-1)
        retry[0] = False
        prev = np.flatnonzero(retry)
        prev = prev[ok[prev - 1].all(-1)] if prev.size else prev
        if prev.size == 0:
            break
        q, norm = q.copy(), norm.copy()
        q[prev], norm[prev] = iterate(q[prev - 1].copy(), _take(p, prev, n), iterations, tol)
        ok = norm < tol
    return q, norm, ok


def _from_reference(iterate, q, norm, again, q0, p: dict, n: int, iterations: int, tol: float):
    """The poses ``again`` ((n,) bool) iterated anew from the reference ``q0``: (q, |r|, converged)."""
    rows = np.flatnonzero(again)
    if rows.size:
        q, norm = q.copy(), norm.copy()
        q[rows], norm[rows] = iterate(q0[rows], _take(p, rows, n), iterations, tol)
    return q, norm, norm < tol


def tangent(A: np.ndarray, dr: np.ndarray) -> np.ndarray:
    """The implicit function theorem on a closure ``r(q, s) = 0``: ``dq/ds = -A^+ dr/ds``
    (..., n_q, k) from its Jacobian ``A = dr/dq`` (..., rows, n_q) and ``dr/ds`` (..., rows,
    k) at fixed q; A's pseudo-inverse: the least-squares solution of a leg with more closure
    rows than coordinates (a consistent system), and no motion of a coordinate no row reads."""
    return -np.linalg.pinv(A) @ dr


def predicted_start(closure, q_ref: np.ndarray, inputs_at, x_ref: np.ndarray, h: float = 1e-6):
    """``guess(poses) -> (N, legs, n_q)`` (a :class:`Prediction`): the first-order prediction ``q_ref + G (x - x_ref)``
    of the closed configuration at poses x (N, d), from the implicit function theorem on
    ``r(q, x) = 0`` at the closed configuration ``q_ref`` (legs, n_q) of pose ``x_ref``
    (d,): ``G = -A^+ dr/dx`` per leg (A = dr/dq, its pseudo-inverse; dr/dx by central
    differences of step ``h`` in the pose's units). ``inputs_at(x)`` gives the closure's
    inputs at poses x (N, d). None where A or dr/dx is not finite at ``q_ref``: no guess.

    A guess only starts :func:`solve` (which falls back to the reference where it fails),
    so the differences' error (~1e-10) only moves the iteration count, not the solution.
    """
    x_ref = np.asarray(x_ref, dtype=float)
    d = len(x_ref)
    shifted = x_ref + h * np.concatenate([np.eye(d), -np.eye(d)])
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        r = closure(np.broadcast_to(q_ref, (2 * d,) + q_ref.shape), inputs_at(shifted))["residual"]
        A = closure(np.asarray(q_ref, dtype=float)[None], inputs_at(x_ref[None]))["dresidual"][0]
        dr_dx = np.moveaxis((r[:d] - r[d:]) / (2 * h), 0, -1)  # (legs, rows, d)
        if not (np.isfinite(A).all() and np.isfinite(dr_dx).all()):
            return None
        G = tangent(A, dr_dx)  # (legs, n_q, d)

    return Prediction(x_ref, np.ascontiguousarray(G.reshape(-1, d).T), np.asarray(q_ref, dtype=float))


class Prediction:
    """The first-order prediction of :func:`predicted_start`: ``self(poses)`` (N, legs, n_q) is
    ``q_ref + (x - x_ref) G`` at poses x (N, d); ``x_ref`` (d,), ``G`` (d, legs * n_q) and
    ``base`` (legs * n_q,), ``q_ref`` flattened, for a C driver that predicts the same
    (:class:`~eigentwist.runtime.c_levenberg_marquardt.BranchSolver`: each product rounded,
    summed in the order of the pose's entries, then ``base`` added; the same bits)."""

    def __init__(self, x_ref: np.ndarray, G: np.ndarray, q_ref: np.ndarray):
        self.x_ref, self.G, self.shape = x_ref, G, np.shape(q_ref)
        self.base = np.ascontiguousarray(q_ref.ravel())

    def __call__(self, poses) -> np.ndarray:  # q_ref itself at x_ref
        # einsum, not matmul: a (chunk, d) x (d, legs * n_q) product is large enough for a
        # threaded BLAS to wake its threads, which then spin beside the evaluator's own
        # (twice the CPU time of a numeric-IK call, benchmarks/README.md)
        dx = np.asarray(poses, dtype=float) - self.x_ref
        return (np.einsum("nd,dk->nk", dx, self.G) + self.base).reshape((-1,) + self.shape)
