"""Damped modes: servo damping, a torque lag and a structural loss factor, solved exactly.

Each leg's actuator delivers the impedance ``Z(s) = (k_d + c_d s) / (1 + t_d s)`` (a PD
servo: delivered stiffness ``k_d = eta_a k_a``, delivered damping ``c_d = eta_a c_a``,
the torque lagged by a first-order ``t_d``) in series with the leg's passive compliance
(rods, lower link, the leg's share of the end-effector assembly, a transmission). The
point between the actuator and that compliance is a massless internal coordinate; the
problem is ``det(s^2 M + K(s)) = 0`` with the leg's joint compliance
``C_q(s) = C_s + e_0 e_0^T / Z(s)`` (``e_0``: the actuated joint, Eqs. 41-43).

The actuator's compliance is a rank-one term of C_q, so (Sherman-Morrison, with the
undamped ``K_q0 = C_q(0)^-1``, ``g = K_q0 e_0``, ``h = e_0^T g``, ``w = J_e^T g``: the
platform wrench of a unit actuator torque)::

    K(s) = K - sum_i phi_i(s) w_i w_i^T,   phi_i(s) = D_i s / (alpha_i + beta_i s),
    alpha = k_d^2,  D = k_d t_d - c_d,  beta = c_d (k_d - h) + h k_d t_d  (>= 0).

With ``y_i = phi_i(s) w_i^T x`` per leg this is linear and first order: the state
``[Omega q; dq/dt; y]`` in the undamped modal coordinates ``x = Phi q`` (``K Phi = M Phi
Omega^2``) has 2n + legs entries, and one batched ``numpy.linalg.eig`` gives every pole
``s = -zeta omega_n +/- i omega_d`` at once: no iteration per mode. A leg whose internal
pole ``-alpha/beta`` lies beyond ``1/ELIMINATE`` times the highest undamped frequency
(structure rigid along its actuator: ``beta -> 0``) is eliminated statically: its
``y = (D/alpha) w^T v`` is a damping matrix. A structural loss factor ``eta_s`` makes
the passive compliance hysteretic, ``C_s / (1 + i eta_s)`` (the poles of positive
frequency; the state matrix is complex then).

Each damped mode is matched to the undamped mode it grows from (the largest share of
its modal energy), so column j of the result is mode j of the undamped model.

On the C backend the uncoupled problem (no couplings, no complex shapes) is solved by a
compiled driver, the same state matrix and rules in one C call per batch (:mod:`.c_damped`:
within the fused pass itself, or from the legs kernel's outputs; with a loss factor, the
complex state matrix from the wrenches computed here); the rest, and any pose the driver
leaves undecided, here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .c_damped import SHARE_TIE
from .eigen import generalized_eigh
from .errors import InputError

__all__ = [
    "Damping",
    "damped_modes",
    "actuator_wrenches",
    "coupled_wrenches",
    "distinct_rows",
    "ELIMINATE",
    "UNSTABLE_ZETA",
]

#: a leg's internal pole beyond 1/ELIMINATE times the highest undamped omega is eliminated
#: statically (relative error of that leg's damping term: ~ELIMINATE)
ELIMINATE = 1e-9
#: the legs' coupled internal equations E s y = ... (coupled platform bodies) are solved as a
#: pencil where E's smallest singular value is below SINGULAR times its largest
SINGULAR = 1e-12
#: where the pencil's infinite eigenvalues are put (far left: never a pole of a mode)
NO_POLE = 1e300
#: a pole with damping ratio below -UNSTABLE_ZETA grows: the pose is unstable (round-off
#: of the undamped limit's poles is ~1e-16)
UNSTABLE_ZETA = 1e-9


@dataclass
class Damping:
    """The damped modes of a batch of poses (column j: undamped mode j).

    natural_hz : (N, n) omega_n / 2 pi = |s| / 2 pi, Hz (what a curve fit's poles give).
    damped_hz : (N, n) omega_d / 2 pi = Im(s) / 2 pi, Hz (what a free decay or a step
        response shows: omega_n sqrt(1 - zeta^2)); 0 for an overdamped mode.
    damping_ratio : (N, n) zeta = -Re(s) / |s| (-); negative: the mode grows.
    poles : (N, n) complex s, rad/s (the one of positive frequency; an overdamped mode:
        the slower of its two real poles).
    shapes : (N, n, n) complex eigentwists (columns, largest entry 1 + 0j), or None.
    stable : (N,) bool, False where a pole (of a mode or of an actuator's internal
        coordinate) has zeta < -UNSTABLE_ZETA or the undamped model is unstable.
    """

    natural_hz: np.ndarray
    damped_hz: np.ndarray
    damping_ratio: np.ndarray
    poles: np.ndarray
    shapes: np.ndarray | None
    stable: np.ndarray


#: an eigenvalue of a leg's joint compliance within RIGID times its largest is a rigid direction
RIGID = 1e-10


def actuator_wrenches(Je: np.ndarray, Cq: np.ndarray, a0: np.ndarray, loss=None, solver: str = "numpy"):
    """Each leg's platform stiffness, actuator wrench and actuated-joint stiffness.

    Je : (N, legs, e, 6) elastic-joint rows (the actuated joint first), Cq : (N, legs, e, e)
    their compliance (rad/(N m), m/N; Eqs. 41-43, no c_rigid), a0 : (N, legs) the actuator's
    own compliance 1/k_d in Cq[0, 0] (rad/(N m)), loss : optional (N,) structural loss factor.

    Returns ``(K, W, h)``: K (N, 6, 6) the legs' undamped stiffness sum J_e^T C_q^+ J_e
    (complex with a loss factor), W (N, legs, 6) w_i = J_e^T K_q0 e_0 and h (N, legs)
    e_0^T K_q0 e_0 (N m/rad). Rigid joint combinations (C_q u = 0; never along e_0) stay
    rigid: the pseudo-inverse on the compliant ones (an eigenvalue of C_q within RIGID times
    the largest is rigid). ``solver="c"``: one call of the compiled driver
    (:func:`.c_damped.wrenches`) where it is built.
    """
    Cq = np.asarray(Cq, dtype=float)
    if solver == "c":
        from . import c_damped

        out = c_damped.wrenches(Je, Cq, RIGID, a0, loss)
        if out is not None:
            return out
    if loss is not None:
        E = np.zeros(Cq.shape[-2:])
        E[0, 0] = 1.0
        act = np.asarray(a0, dtype=float)[..., None, None] * E
        eta = np.asarray(loss, dtype=float).reshape(-1, 1, 1, 1)
        Cq = (Cq - act) / (1 + 1j * eta) + act
    s, U = np.linalg.eigh(Cq) if loss is None else _eig_symmetric(Cq)
    scale = np.abs(s).max(axis=-1, keepdims=True)
    rigid = np.abs(s) <= RIGID * scale
    inv = np.where(rigid, 0.0, 1.0 / np.where(rigid, 1.0, s))
    Ut = np.swapaxes(U, -1, -2)
    Kq = U @ (inv[..., None] * (Ut if loss is None else np.linalg.inv(U)))
    g = Kq[..., :, 0]  # (N, legs, e)
    h = g[..., 0]
    W = (g[..., None, :] @ Je)[..., 0, :]
    K = (np.swapaxes(Je, -1, -2) @ Kq @ Je).sum(axis=1)
    return K, W, h


def coupled_wrenches(K_x: np.ndarray, W_x: np.ndarray, k: int = 6):
    """Condense massless coordinates: ``K_x`` (N, d, d) the undamped stiffness and ``W_x``
    (N, legs, d) the actuator wrenches on ``x = [t; theta]``, the first ``k`` coordinates t
    with mass (the tool's twist), theta without (the couplings'). Returns ``(K, W, G)``:
    K (N, k, k) = K_tt - K_tc K_cc^-1 K_ct, the wrenches ``W_t - K_tc K_cc^-1 W_c`` (N, legs, k) and
    ``G = W_c^T K_cc^-1 W_c`` (N, legs, legs), for :func:`damped_modes`."""
    Ktt, Ktc, Kcc = K_x[:, :k, :k], K_x[:, :k, k:], K_x[:, k:, k:]
    Wt, Wc = W_x[:, :, :k], W_x[:, :, k:]
    X = np.linalg.solve(Kcc, np.swapaxes(Ktc, -1, -2))  # Kcc^-1 K_ct
    Y = np.linalg.solve(Kcc, np.swapaxes(Wc, -1, -2))  # Kcc^-1 W_c^T
    K = Ktt - Ktc @ X
    W = Wt - np.swapaxes(Ktc @ Y, -1, -2)
    return 0.5 * (K + np.swapaxes(K, -1, -2)), W, Wc @ Y


def _eig_symmetric(C: np.ndarray):
    """Eigen-decomposition of complex-symmetric matrices (a loss factor): ``C = U diag(s) U^-1``."""
    return np.linalg.eig(C)


def damped_modes(
    M: np.ndarray,
    K: np.ndarray,
    W: np.ndarray,
    h: np.ndarray,
    k_d,
    c_d,
    t_d,
    shapes: bool = False,
    K_loss: np.ndarray | None = None,
    G: np.ndarray | None = None,
    solver: str = "numpy",
    threads: int = 1,
) -> Damping:
    """The damped modes of ``(s^2 M + K(s)) x = 0`` for a batch of poses (module docstring).

    M, K : (N, n, n) inertia and undamped stiffness (SI, in the model's coordinates);
    W : (N, legs, n) the legs' actuator wrenches in the same coordinates; h : (N, legs)
    N m/rad; k_d, c_d, t_d : (N, legs) or broadcastable: delivered stiffness (N m/rad),
    delivered damping (N m s/rad) and torque lag (s) of each actuator; ``shapes``: also the
    complex eigentwists; K_loss : optional (N, n, n) imaginary part of the stiffness (a
    structural loss factor, hysteretic: K + i K_loss for the poles of positive frequency).
    G : optional (N, legs, legs) ``W_c^T K_cc^-1 W_c`` of legs on platform bodies joined by
        compliant couplings (massless coordinates condensed: :func:`coupled_wrenches`); then
        ``(beta_i + ...)`` couples the legs' internal coordinates: ``E s y = -alpha y + D W^T v``
        with ``E = diag(beta) - diag(D) G`` (no leg is eliminated).
    solver : ``"numpy"`` or ``"c"``: the compiled driver (:mod:`.c_damped`, the same state
        matrix and rules, one C call for the batch on ``threads`` threads; complex with a
        loss factor) where the legs are uncoupled (no ``G``) and no ``shapes`` are asked, it
        fits the driver's sizes and a compiler built it; NumPy otherwise and for the poses
        the driver leaves undecided.
    """
    if solver not in ("numpy", "c"):
        raise InputError(f"solver={solver!r}: expected 'numpy' or 'c'")
    M = np.asarray(M, dtype=float)
    K = np.asarray(K, dtype=float)
    N, n = K.shape[:2]
    W = np.asarray(W)
    L = W.shape[1]
    args = [_legs_array(v, N, L) for v in (h, k_d, c_d, t_d)]
    if solver == "c" and _compiled(n, L, args, shapes, G):
        return _damped_c(M, K, W, args, threads, K_loss)
    parts = [M, K, W, *args] + ([] if K_loss is None else [K_loss]) + ([] if G is None else [G])
    key = np.concatenate(
        [
            np.ascontiguousarray(v).reshape(N, -1).view(float)
            if not np.iscomplexobj(v)
            else np.concatenate([v.real.reshape(N, -1), v.imag.reshape(N, -1)], axis=1)
            for v in parts
        ],
        axis=1,
    )
    first, inverse = distinct_rows(key)
    if first is not None:  # rows of one condition (modes of one pose and k_a): solved once
        pick = lambda v: None if v is None else np.asarray(v)[first]  # noqa: E731
        d = damped_modes(
            M[first], K[first], W[first], *(a[first] for a in args), shapes=shapes, K_loss=pick(K_loss), G=pick(G)
        )
        return Damping(
            d.natural_hz[inverse],
            d.damped_hz[inverse],
            d.damping_ratio[inverse],
            d.poles[inverse],
            None if d.shapes is None else d.shapes[inverse],
            d.stable[inverse],
        )
    lam, Phi = generalized_eigh(0.5 * (K + np.swapaxes(K, -1, -2)), M)
    ok = (lam > 0).all(axis=-1)
    om = np.sqrt(np.where(ok[:, None], lam, 1.0))
    Bw = np.einsum("nij,nli->nlj", Phi, W)  # (N, legs, n): b_i = Phi^T w_i
    k_d, c_d, t_d, h = (np.broadcast_to(np.asarray(v), (N, L)) for v in (k_d, c_d, t_d, h))
    alpha = k_d * k_d
    D = k_d * t_d - c_d
    beta = c_d * (k_d - h) + h * k_d * t_d
    big = om.max(axis=-1)[:, None]
    elim = np.abs(beta) * big <= ELIMINATE * np.abs(alpha)
    if G is not None:  # coupled legs: only an undamped one (D = 0: y = 0) drops out
        elim = D == 0
    m = 2 * n + L
    complex_ = K_loss is not None or np.iscomplexobj(Bw) or np.iscomplexobj(h)
    A = np.zeros((N, m, m), dtype=complex if complex_ else float)
    idx = np.arange(n)
    A[:, idx, n + idx] = om
    A[:, n + idx, idx] = -om
    if K_loss is not None:  # -i Phi^T K_loss Phi q
        A[:, n : 2 * n, :n] -= 1j * (np.swapaxes(Phi, -1, -2) @ K_loss @ Phi) / om[:, None, :]
    ratio = np.where(elim, D / alpha, 0.0)
    A[:, n : 2 * n, n : 2 * n] += np.einsum("nl,nli,nlj->nij", ratio, Bw, Bw)
    live = ~elim
    safe = np.where(live & (beta != 0), beta, 1.0)
    A[:, n : 2 * n, 2 * n :] = np.swapaxes(np.where(live[..., None], Bw, 0.0), -1, -2)
    A[:, 2 * n :, n : 2 * n] = np.where(live[..., None], (D / safe)[..., None] * Bw, 0.0)
    A[:, 2 * n + np.arange(L), 2 * n + np.arange(L)] = np.where(live, -alpha / safe, -1.0)
    pencil = None
    if G is not None and live.any():
        E = np.where(live[:, :, None], np.eye(L) * beta[:, :, None] - D[:, :, None] * G, np.eye(L))
        rhs = np.where(live[:, :, None], -np.eye(L) * alpha[:, :, None], -np.eye(L))
        coupling = np.where(live[..., None], D[..., None] * Bw, 0.0)
        sv = np.linalg.svd(E, compute_uv=False)
        if np.all(sv[:, -1] > SINGULAR * sv[:, 0]):
            A[:, 2 * n :, n : 2 * n] = np.linalg.solve(E, coupling)
            A[:, 2 * n :, 2 * n :] = np.linalg.solve(E, rhs)
        else:  # an internal coordinate without series compliance: E s y = ...
            A[:, 2 * n :, n : 2 * n] = coupling
            A[:, 2 * n :, 2 * n :] = rhs
            pencil = np.zeros((N, m, m), dtype=E.dtype)
            pencil[:, : 2 * n, : 2 * n] = np.eye(2 * n)
            pencil[:, 2 * n :, 2 * n :] = E
    A[~ok] = 0.0
    if pencil is not None:
        s, V = _pencil_eig(A, pencil, big[:, 0] / ELIMINATE, ok)
    if elim.all():  # no internal coordinate: the 2n mechanical states alone
        A = A[:, : 2 * n, : 2 * n]
    fast = None if shapes or pencil is not None else _by_order(np.linalg.eigvals(A), om, n)
    if fast is not None:
        s, (wn, zeta, wd, poles, cols) = fast
    else:
        if pencil is None:
            s, V = np.linalg.eig(A)
        mech = np.abs(V[:, :n, :]) ** 2 + np.abs(V[:, n : 2 * n, :]) ** 2  # (N, n modes, m poles)
        total = mech.sum(axis=1, keepdims=True)
        share = mech / np.where(total > 0, total, 1.0)
        wn, zeta, wd, poles, cols = _assign(s, share, n)
    # a hysteretic loss factor holds for positive frequencies: its mirrored roots (Im s < 0) are not poles
    counted = (s.imag > 0) if complex_ else np.ones(s.shape, dtype=bool)
    stable = ok & ~(counted & (s.real > UNSTABLE_ZETA * np.abs(s))).any(axis=-1)
    natural, damped = wn / (2 * np.pi), wd / (2 * np.pi)
    for arr in (natural, damped, zeta, poles):
        arr[~ok] = np.nan
    out_shapes = None
    if shapes:
        Vm = np.take_along_axis(V, cols[:, None, :], axis=-1)  # (N, m, n)
        q = Vm[:, :n, :] / om[:, :, None]
        X = Phi.astype(complex) @ q
        k = np.argmax(np.abs(X), axis=-2)
        X = X / np.take_along_axis(X, k[..., None, :], axis=-2)
        X[~ok] = np.nan
        out_shapes = X
    return Damping(natural, damped, zeta, poles, out_shapes, stable)


def _legs_array(v, N: int, L: int) -> np.ndarray:
    """``v`` as an (N, legs) array (a view where it is broadcast)."""
    v = np.asarray(v)
    return v if v.shape == (N, L) else np.broadcast_to(v, (N, L))


def _compiled(n: int, L: int, args, shapes: bool, G) -> bool:
    """Whether the compiled driver takes this problem (:func:`damped_modes`' ``solver``): no
    shapes, no coupled legs, real k_d, c_d, t_d, sizes within the driver's, a compiler."""
    from . import c_damped

    if shapes or G is not None or n > c_damped.MAX_MODES or L > c_damped.MAX_LEGS:
        return False
    if any(np.iscomplexobj(a) for a in args[1:]):
        return False
    return c_damped.driver() is not None


def _damped_c(M, K, W, args, threads: int, K_loss=None) -> Damping:
    """:func:`damped_modes` by the compiled driver (:func:`.c_damped.solve`; with a loss
    factor, ``K_loss`` or complex wrenches, :func:`.c_damped.solve_complex`), each distinct
    row once (rows of one condition: the modes of one pose and k_a); the poses it leaves
    undecided in NumPy."""
    from . import c_damped

    complex_ = K_loss is not None or np.iscomplexobj(W) or np.iscomplexobj(args[0])
    parts = (M, K, W, *args) + (() if K_loss is None else (K_loss,))
    flat = [np.reshape(v, (len(K), -1)) for v in parts]
    flat = [np.concatenate([v.real, v.imag], axis=1) if np.iscomplexobj(v) else v for v in flat]
    first, inverse = distinct_rows(np.concatenate(flat, axis=1))
    if first is not None:
        M, K, W, args = M[first], K[first], W[first], [a[first] for a in args]
        K_loss = None if K_loss is None else np.asarray(K_loss)[first]
    rules = (ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS)
    if complex_:
        wn, zeta, wd, poles, stable, redo = c_damped.solve_complex(M, K, K_loss, W, *args, *rules, threads=threads)
    else:
        wn, zeta, wd, poles, stable, redo = c_damped.solve(M, K, W, *args, *rules, threads=threads)
    out = [wn / (2 * np.pi), wd / (2 * np.pi), zeta, poles, stable]
    if redo.any():
        kl = None if K_loss is None else np.asarray(K_loss)[redo]
        d = damped_modes(M[redo], K[redo], W[redo], *(a[redo] for a in args), K_loss=kl)
        for arr, name in zip(out, ("natural_hz", "damped_hz", "damping_ratio", "poles", "stable")):
            arr[redo] = getattr(d, name)
    if first is not None:
        out = [arr[inverse] for arr in out]
    return Damping(*out[:4], None, out[4])


def distinct_rows(key: np.ndarray):
    """``(first, inverse)`` of the distinct rows of ``key`` (N, width) (``key[first][inverse]
    == key``), or ``(None, None)`` where every row is distinct (or a row holds a NaN). The
    rows are grouped by one weighted sum each (einsum's own loop: a BLAS call here would wake
    its threads, whose spinning costs more CPU than the sum), then checked equal entry by entry."""
    N = len(key)
    weights = 1.0 + np.arange(key.shape[1]) / key.shape[1]
    _, first, inverse = np.unique(np.einsum("ij,j->i", key, weights), return_index=True, return_inverse=True)
    if len(first) == N or not np.array_equal(key[first][inverse], key):
        return None, None
    return first, inverse


#: the poles of positive frequency, sorted by |s|, belong to the undamped modes in order
#: where each |s| lies closer to its own mode's omega than AMBIGUOUS times the distance to
#: a neighbour's; elsewhere the eigenvectors decide (:func:`_assign`)
AMBIGUOUS = 0.5


def _pencil_eig(A: np.ndarray, B: np.ndarray, limit: np.ndarray, ok: np.ndarray):
    """``A v = s B v`` for the batch, by the standard problem ``A^-1 B v = (1/s) v`` (one
    batched ``numpy.linalg.eig``; A is regular where the undamped model is stable, ``ok``
    (N,): its omega and the legs' alpha are positive). The infinite eigenvalues of a
    singular B (algebraic internal coordinates; round-off leaves them finite but beyond
    ``limit`` (N,) rad/s, 1/ELIMINATE times the highest undamped omega) are no poles: set
    far into the left half-plane. Rows not ``ok`` give undefined values."""
    A = np.where(ok[:, None, None], A, np.eye(A.shape[-1]))
    mu, V = np.linalg.eig(np.linalg.solve(A, B))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = 1.0 / mu
    s[~np.isfinite(s) | (np.abs(s) > limit[:, None])] = -NO_POLE
    return s, V


def _by_order(s: np.ndarray, om: np.ndarray, n: int):
    """``(s, _assign's tuple)`` from eigenvalues alone where the order decides unambiguously
    at every pose (:data:`AMBIGUOUS`), else None (the caller solves with eigenvectors)."""
    upper = s.imag > 0
    if not (upper.sum(axis=-1) == n).all():
        return None
    key = np.where(upper, np.abs(s), np.inf)
    cols = np.argsort(key, axis=-1, kind="stable")[:, :n]
    poles = np.take_along_axis(s, cols, axis=-1)
    wn = np.abs(poles)
    gap = np.diff(om, axis=-1)
    left = np.concatenate([np.full((len(om), 1), np.inf), gap], axis=1)
    right = np.concatenate([gap, np.full((len(om), 1), np.inf)], axis=1)
    if not (np.abs(wn - om) < AMBIGUOUS * np.minimum(left, right)).all():
        return None
    return s, (wn, -poles.real / wn, poles.imag, poles, cols)


def _assign(s: np.ndarray, share: np.ndarray, n: int):
    """Pick, for each undamped mode j, its pole: ``(omega_n, zeta, omega_d, poles, columns)``,
    each (N, n).

    Poles of positive frequency are matched to the modes by their modal-energy share (a
    one-to-one assignment); a mode left without one is overdamped: the two real poles with
    the largest share in it, omega_n^2 = s1 s2, 2 zeta omega_n = -(s1 + s2), omega_d = 0, its
    pole the slower of the two.
    """
    upper = s.imag > 0
    score = np.where(upper[:, None, :], share, -1.0)  # (N, modes, poles)
    cols = np.argmax(score, axis=-1)  # (N, modes)
    poles = np.take_along_axis(s, cols, axis=-1).astype(complex)
    unique = (np.diff(np.sort(cols, axis=-1), axis=-1) != 0).all(axis=-1) & (upper.sum(axis=-1) >= n)
    for k in np.flatnonzero(~unique):
        poles[k], cols[k] = _assign_one(s[k], share[k], n)
    with np.errstate(invalid="ignore", divide="ignore"):
        wn = np.abs(poles)
        zeta = -poles.real / np.where(wn > 0, wn, 1.0)
        wd = np.abs(poles.imag)
        real = (poles.imag == 0) & ~np.isnan(poles.real)
        if real.any():  # overdamped: the pair's values
            k, j = np.nonzero(real)
            for a, b in zip(k, j):
                s1, s2 = _pair(s[a], share[a], b, cols[a, b])
                poles[a, b] = max(s1, s2)  # the slower of the pair
                wn[a, b] = np.sqrt(abs(s1 * s2))
                zeta[a, b] = -(s1 + s2) / (2 * wn[a, b]) if wn[a, b] > 0 else 1.0
                wd[a, b] = 0.0
    return wn, zeta, wd, poles, cols


def _largest_share(s: np.ndarray, shares: np.ndarray, real: np.ndarray) -> int:
    """The real pole (an index of ``s``, one of ``real``) of largest share (``shares``: a
    mode's shares of every pole), the slower among shares within :data:`SHARE_TIE` of it."""
    top = shares[real].max()
    tied = real[shares[real] >= top - SHARE_TIE]
    return int(tied[np.argmax(s[tied].real)])


def _pair(s: np.ndarray, share: np.ndarray, j: int, first: int):
    """The two real poles of overdamped mode j: ``first`` and the real pole with the next
    largest share in it (:func:`_largest_share`)."""
    real = np.flatnonzero((s.imag == 0) & (np.arange(len(s)) != first) & (np.abs(s) < NO_POLE))
    other = _largest_share(s, share[j], real) if len(real) else first
    return s[first].real, s[other].real


def _assign_one(s: np.ndarray, share: np.ndarray, n: int):
    """One pose's assignment (:func:`_assign`): optimal for the oscillatory poles, then the
    slower real pole with the largest share for each mode left (overdamped)."""
    from scipy.optimize import linear_sum_assignment

    poles = np.full(n, np.nan + 0j)
    cols = np.zeros(n, dtype=int)
    upper = np.flatnonzero(s.imag > 0)
    done = np.zeros(n, dtype=bool)
    if len(upper):
        rows, c = linear_sum_assignment(-share[:, upper])
        keep = share[rows, upper[c]] > 0
        poles[rows[keep]], cols[rows[keep]], done[rows[keep]] = s[upper[c][keep]], upper[c][keep], True
    real = np.flatnonzero((s.imag == 0) & (np.abs(s) < NO_POLE))
    for j in np.flatnonzero(~done):
        if not len(real):
            break
        pick = _largest_share(s, share[j], real)
        poles[j], cols[j] = s[pick], pick
        real = real[real != pick]
    return poles, cols
