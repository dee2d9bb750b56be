"""Rigid constraints condensed exactly, and the eigenproblem in compliance form.

The paper gives a leg's ideally rigid constrained directions a small compliance so that
K_F (Eq. 13) is full rank (Sec. 2.2); with 1e-12 rad/(N m) K_F spans 1e12 to 1e4 and
its finite modes carry a relative error of ~1e-6 (the penalty) plus round-off. Here the
constraint is exact instead:

* each leg ``i`` has elastic-joint rows ``Je_i`` (e x 6: its inverse-Jacobian rows of
  the actuated joint and the virtual joints, twists ``[omega; v]``) and the joints'
  compliance ``Cq_i`` (e x e, Eqs. 41-43) with **zero** compliance in its rigid
  directions (no ``c_rigid``);
* a combination ``u`` of joints with ``Cq_i u = 0`` is rigid: it constrains the platform,
  ``(u^T Je_i) t = 0``; the rest is a finite spring, ``Je_i^T Cq_i^+ Je_i`` (Eq. 40 on
  the compliant combinations);
* the platform's admissible twists ``B`` (orthonormal, 6 x n) are the null space of all
  legs' rigid rows, and the platform compliance is ``C_F = B (B^T K_s B)^-1 B^T`` with
  ``K_s`` the legs' finite springs plus any spring in parallel (6 x 6, PSD, rank n).

:func:`compliance_eigh` solves ``C_F M v = (1/omega^2) v`` (``M = L L^T``: the symmetric
PSD ``L^T C_F L``), whose conditioning is that of the physics. Convention: a direction
with zero compliance is a mode of **infinite** frequency, reported as ``+inf`` after the
finite modes (frequencies ascending), so a 3-DoF robot's 6 x 6 route gives its 3 finite
modes then 3 ``inf``; :func:`finite_modes` drops them.
"""

from __future__ import annotations

from ..errors import DescriptionError, InputError
import numpy as np

__all__ = [
    "leg_condensation",
    "condensed_compliance",
    "condensed_modes",
    "compliance_eigh",
    "finite_modes",
    "leg_joints",
    "platform_compliance",
    "has_rigid_direction",
    "compliance_from_legs",
    "merge_modes",
    "RIGID_RTOL",
    "NULL_FACTOR",
    "EXACT",
]

# A joint-compliance eigenvalue below RIGID_RTOL times the leg's largest (or a singular
# value of the stacked rigid rows below RIGID_RTOL times the largest) is a rigid direction
# (a dependent constraint): the compliances of a model are either exact zeros (rigid) or
# physical values many orders above round-off.
RIGID_RTOL = 1e-10
#: an eigenvalue of the stacked rigid rows' Gram matrix A^T A at most NULL_FACTOR * rtol times the
#: largest is an admissible twist (a squared singular value: rtol on the rows, with margin)
NULL_FACTOR = 1e-2
#: ``c_rigid`` as ``ModeSolver.route`` (:mod:`.mode_solver`) passes it when no leg direction of the model is rigid: zero
#: (K_F exact), the one value the parameter's bounds refuse from a user (the evaluator
#: knows this object and does not check it)
EXACT = np.float64(0.0)


def leg_condensation(Je: np.ndarray, Cq: np.ndarray, rtol: float = RIGID_RTOL):
    """Split one leg's elastic joints into springs and rigid constraints.

    Je : (N, e, 6) elastic-joint inverse-Jacobian rows (rad or m per unit twist).
    Cq : (N, e, e) symmetric PSD joint compliance (rad/(N m), m/N), zeros where rigid.

    Returns ``(K, R)``: K (N, 6, 6) the leg's finite stiffness at the platform
    ``Je^T Cq^+ Je`` on its compliant combinations (N m/rad, N/m), and R (N, e, 6) the
    rigid rows ``u^T Je`` (rows of zeros where a combination is compliant).
    """
    Je = np.asarray(Je, dtype=float)
    Cq = np.asarray(Cq, dtype=float)
    s, U = _eigh_small(0.5 * (Cq + np.swapaxes(Cq, -1, -2)))
    rigid = s <= rtol * np.abs(s).max(axis=-1, keepdims=True)
    inv = np.where(rigid, 0.0, 1.0 / np.where(rigid, 1.0, s))
    UJ = np.swapaxes(U, -1, -2) @ Je  # (N, e, 6): combinations' rows
    K = np.swapaxes(UJ, -1, -2) @ (inv[..., None] * UJ)
    R = np.where(rigid[..., None], UJ, 0.0)
    return 0.5 * (K + np.swapaxes(K, -1, -2)), R


def _eigh_small(S: np.ndarray):
    """``numpy.linalg.eigh`` of a batch of symmetric e x e matrices, in closed form for
    e <= 2 (a leg's actuated and one virtual joint: no LAPACK call per matrix)."""
    if S.shape[-1] == 1:
        return S[..., 0], np.ones_like(S)
    if S.shape[-1] != 2:
        return np.linalg.eigh(S)
    a, b, c = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    h = 0.5 * (a - c)
    r = np.hypot(h, b)
    m = 0.5 * (a + c)
    s = np.stack([m - r, m + r], axis=-1)
    # the larger eigenvalue's vector (h + r, b) or (b, r - h), whichever is the longer
    big = h >= 0
    x = np.where(big, h + r, b)
    y = np.where(big, b, r - h)
    norm = np.hypot(x, y)
    zero = norm == 0
    x = np.where(zero, 1.0, x / np.where(zero, 1.0, norm))
    y = np.where(zero, 0.0, y / np.where(zero, 1.0, norm))
    U = np.stack([np.stack([-y, x], axis=-1), np.stack([x, y], axis=-1)], axis=-1)  # columns: small, large
    return s, U


def condensed_modes(
    Je: np.ndarray,
    Cq: np.ndarray,
    K_parallel: np.ndarray,
    M: np.ndarray,
    eigh=None,
    rtol: float = RIGID_RTOL,
    basis: dict | None = None,
):
    """The exact modes of legs on the tool body (no couplings) in stiffness form on the
    admissible twists: ``(B^T K B) y = omega^2 (B^T M B) y``, ``v = B y``.

    Je, Cq : as in :func:`condensed_compliance`; K_parallel, M : (N, 6, 6). ``eigh`` solves
    ``K v = lambda M v`` for (N, n, n) batches (default
    :func:`eigentwist.runtime.eigen.generalized_eigh`; the C backend's Jacobi solver for
    the sizes it has). Returns ``(freq_hz, V)`` as :func:`compliance_eigh` does: NaN for an
    unstable mode, the finite modes ascending, ``inf`` for each rigid direction (its
    column of V is NaN). ``basis`` (a dict) receives the admissible twists ``"B"`` (N, 6, n)
    where every pose has the same number n of them.
    """
    from .eigen import frequencies_hz, generalized_eigh

    eigh = eigh or generalized_eigh
    Je = np.asarray(Je, dtype=float)
    N = Je.shape[0]
    K_x = np.array(np.broadcast_to(K_parallel, (N, 6, 6)), dtype=float)
    A = _assemble(Je, Cq, K_x, [None] * Je.shape[1], rtol)
    G = np.swapaxes(A, -1, -2) @ A  # (N, 6, 6): null space = admissible twists
    g, Q = eigh(G, np.broadcast_to(np.eye(6), G.shape))
    null = g <= (rtol * NULL_FACTOR) * np.abs(g).max(axis=-1, keepdims=True, initial=0.0)
    freq = np.full((N, 6), np.inf)
    V = np.full((N, 6, 6), np.nan)
    for n in np.unique(null.sum(axis=-1)):
        at = null.sum(axis=-1) == n
        if n == 0:
            continue
        B = Q[at][:, :, :n]  # ascending: the null vectors first
        if basis is not None and at.all():
            basis["B"] = B
        Bt = np.swapaxes(B, -1, -2)
        Kr, Mr = Bt @ K_x[at] @ B, Bt @ np.asarray(M, dtype=float)[at] @ B
        lam, Y = eigh(0.5 * (Kr + np.swapaxes(Kr, -1, -2)), 0.5 * (Mr + np.swapaxes(Mr, -1, -2)))
        fa, Va = freq[at], V[at]
        fa[:, :n] = frequencies_hz(lam)
        Va[:, :, :n] = B @ Y
        freq[at], V[at] = fa, Va
    return freq, V


def _assemble(Je: np.ndarray, Cq, K_x: np.ndarray, T: list, rtol: float) -> np.ndarray:
    """Add each leg's finite springs (:func:`leg_condensation`) to ``K_x`` (N, d, d, in
    place), moved by its map ``T[i]`` (N, 6, d) from the coordinates x to its body's twist
    (None: x is the twist), and return the legs' rigid rows in x, stacked (N, legs*e, d)."""
    rows = []
    Cq = np.asarray(Cq)
    if all(Ti is None for Ti in T):  # every leg on the tool: one batched condensation
        N, legs, e = Je.shape[:3]
        K, R = leg_condensation(Je.reshape(N * legs, e, 6), Cq.reshape(N * legs, e, e), rtol)
        K = K.reshape(N, legs, 6, 6)
        for i in range(legs):
            K_x += K[:, i]
        return R.reshape(N, legs * e, 6)
    for i, Ti in enumerate(T):
        K, R = leg_condensation(Je[:, i], Cq[:, i], rtol)
        K_x += K if Ti is None else np.swapaxes(Ti, -1, -2) @ K @ Ti
        rows.append(R if Ti is None else R @ Ti)
    return np.concatenate(rows, axis=1)


def condensed_compliance(
    Je: np.ndarray,
    Cq: np.ndarray,
    K_parallel: np.ndarray | None = None,
    rtol: float = RIGID_RTOL,
    *,
    bodies=None,
    G_c: np.ndarray | None = None,
    K_c: np.ndarray | None = None,
):
    """Exact platform compliance of legs in parallel with rigid constraints.

    Je : (N, legs, e, 6) and Cq : (N, legs, e, e) as in :func:`leg_condensation`;
    K_parallel : optional (N, 6, 6) stiffness in parallel (ground springs, a preload).
    Legs on a platform body coupled to the tool: ``bodies`` (legs,) gives each
    leg's coupling index (-1: the tool body), ``G_c`` (N, couplings, 6, m) the couplings'
    unit twists at the EE origin and ``K_c`` (N, couplings, m) their stiffnesses; the body
    moves with ``t - G_c theta`` (``theta``: the coupling's m coordinates, condensed
    statically like :func:`eigentwist.symbolic.stiffness.condense_coupling` does).

    With x = [t; theta] the assembled stiffness K_x (legs' finite springs on their body's
    twist, couplings on theta, K_parallel on t) and B an orthonormal basis of the x that
    violate no rigid row, the tool compliance is the t-block of ``B (B^T K_x B)^-1 B^T``:
    every solve is on the admissible motions, so its conditioning is that of the physics.

    Returns ``(C_F, B)``: C_F (N, 6, 6) in rad/(N m), m/N and B (N, d, n) (d = 6 without
    couplings; n = 6 without rigid constraints). A pose where ``B^T K_x B`` is singular (a
    mechanism) gets NaN; poses may differ in the rank of their constraints (each rank is
    solved on its own).
    """
    Je = np.asarray(Je, dtype=float)
    N, n_legs = Je.shape[:2]
    nc = 0 if G_c is None or bodies is None else np.shape(G_c)[1]
    m = 0 if nc == 0 else np.shape(G_c)[3]
    d = 6 + nc * m
    K_x = np.zeros((N, d, d))
    if K_parallel is not None:
        K_x[:, :6, :6] = K_parallel
    T = {-1: np.broadcast_to(np.eye(6, d), (N, 6, d))}  # x -> a body's twist
    for k in range(nc):
        Tk = np.zeros((N, 6, d))
        Tk[:, :, :6] = np.eye(6)
        Tk[:, :, 6 + k * m : 6 + (k + 1) * m] = -np.asarray(G_c, dtype=float)[:, k]
        T[k] = Tk
        idx = np.arange(6 + k * m, 6 + (k + 1) * m)
        K_x[:, idx, idx] = np.asarray(K_c, dtype=float)[:, k]
    A = _assemble(
        Je, Cq, K_x, [T[-1 if bodies is None or nc == 0 else int(bodies[i])] for i in range(n_legs)], rtol
    )  # (N, legs*e, d)
    _, sv, Vt = np.linalg.svd(A, full_matrices=True)
    rank = (sv > rtol * sv.max(axis=-1, keepdims=True, initial=0.0)).sum(axis=-1)
    C = np.full((N, 6, 6), np.nan)
    B_out = None
    for r in np.unique(rank):
        at = rank == r
        B = np.swapaxes(Vt[at][:, int(r) :, :], -1, -2)  # (n_at, d, d - r)
        Kr = np.swapaxes(B, -1, -2) @ K_x[at] @ B
        Kr = 0.5 * (Kr + np.swapaxes(Kr, -1, -2))
        Bt = np.swapaxes(B[:, :6, :], -1, -2)
        C[at] = _solve_each(B[:, :6, :], Kr, Bt)
        if at.all():
            B_out = B
    return C, B_out


def _solve_each(B6: np.ndarray, Kr: np.ndarray, Bt: np.ndarray) -> np.ndarray:
    """``B6 Kr^-1 Bt`` per pose (symmetrised); NaN where Kr is singular (a mechanism)."""
    try:
        Ct = B6 @ np.linalg.solve(Kr, Bt)
    except np.linalg.LinAlgError:
        Ct = np.full(B6.shape[:1] + (6, 6), np.nan)
        for k in range(len(Kr)):
            try:
                Ct[k] = B6[k] @ np.linalg.solve(Kr[k], Bt[k])
            except np.linalg.LinAlgError:
                pass
    return 0.5 * (Ct + np.swapaxes(Ct, -1, -2))


def compliance_eigh(C: np.ndarray, M: np.ndarray, rtol: float = RIGID_RTOL):
    """Solve ``C M v = (1/omega^2) v`` (Eq. 6 in compliance form) for a batch.

    C : (N, n, n) symmetric compliance; M : (N, n, n) SPD inertia.

    Returns ``(freq_hz, V)``: freq_hz (N, n) in the order of omega^2 ascending, like
    :func:`eigentwist.runtime.eigen.generalized_eigh`: an unstable mode (negative
    compliance, omega^2 < 0) first as NaN, then the finite modes ascending, then ``+inf``
    for each direction of zero compliance (an eigenvalue 1/omega^2 within ``rtol`` of zero
    relative to the pose's largest); V (N, n, n) the eigentwists (columns), M-orthonormal.
    With ``M = L L^T`` the solved matrix is the symmetric ``L^T C L`` (eigenvalues
    1/omega^2 in (s/rad)^2). A pose with a NaN compliance gets NaN throughout.
    """
    C = np.asarray(C, dtype=float)
    L = np.linalg.cholesky(np.asarray(M, dtype=float))
    A = np.swapaxes(L, -1, -2) @ np.nan_to_num(C) @ L
    mu, W = np.linalg.eigh(0.5 * (A + np.swapaxes(A, -1, -2)))
    zero = np.abs(mu) <= rtol * np.abs(mu).max(axis=-1, keepdims=True)
    lam = np.where(zero, np.inf, 1.0 / np.where(zero, 1.0, mu))  # omega^2, (rad/s)^2
    order = np.argsort(lam, axis=-1, kind="stable")
    lam = np.take_along_axis(lam, order, axis=-1)
    W = np.take_along_axis(W, order[..., None, :], axis=-1)
    with np.errstate(invalid="ignore"):
        freq = np.where(lam < 0, np.nan, np.sqrt(np.abs(lam)) / (2 * np.pi))
    V = np.swapaxes(np.linalg.inv(L), -1, -2) @ W
    bad = np.isnan(C).any(axis=(-1, -2))
    freq[bad], V[bad] = np.nan, np.nan
    return freq, V


def finite_modes(freq_hz: np.ndarray) -> np.ndarray:
    """The finite frequencies of :func:`compliance_eigh` (N, n_finite): drops the ``inf``
    columns (the same number at every pose, else ValueError)."""
    finite = np.isfinite(freq_hz)
    n = finite.sum(axis=-1)
    if np.any(n != n.flat[0]):
        raise InputError(f"{sorted(set(n.ravel().tolist()))} finite modes across the poses: expected one number")
    return freq_hz[..., : int(n.flat[0])]


def has_rigid_direction(Cq: np.ndarray, rtol: float = RIGID_RTOL) -> bool:
    """Whether any leg's joint compliance Cq (..., legs, e, e) has a zero eigenvalue (a
    rigid constraint direction), relative to the leg's largest."""
    Cq = np.asarray(Cq, dtype=float)
    s = np.linalg.eigvalsh(0.5 * (Cq + np.swapaxes(Cq, -1, -2)))
    return bool((s <= rtol * np.abs(s).max(axis=-1, keepdims=True)).any())


def compliance_from_legs(robot, effects, out: dict, K_extra=None) -> np.ndarray:
    """Exact C_F (N, 6, 6) from the generated ``legs`` kernel's outputs ``out`` (``Je``,
    ``Cq``, ``K_ground``, and ``G_c``, ``K_c`` of the couplings) for ``effects``: the
    couplings whose effect is on condense their bodies' legs (:func:`condensed_compliance`),
    ``K_extra`` (N, 6, 6; e.g. the gravity preload's stiffness) is in parallel."""
    K_par = np.asarray(out["K_ground"], dtype=float)
    if K_extra is not None:
        K_par = K_par + K_extra
    names = set(effects)
    couplings = sorted(robot.couplings, key=lambda c: c.body)
    active = [k for k, c in enumerate(couplings) if c.effect in names]
    if active and "G_c" not in out:
        raise DescriptionError(
            f"{robot.name}: couplings with different numbers of compliant directions: "
            "expected one number for the exact condensation"
        )
    bodies = G_c = K_c = None
    if active:
        index = {couplings[k].body: j for j, k in enumerate(active)}
        bodies = [index.get(leg.platform_body, -1) for leg in robot.legs]
        G_c, K_c = out["G_c"][:, active], out["K_c"][:, active]
    N = len(out["Je"])
    bc = lambda a: np.broadcast_to(np.asarray(a, dtype=float), (N,) + np.shape(a)[-(np.ndim(a) - 1) :])  # noqa: E731
    C, _ = condensed_compliance(
        out["Je"],
        out["Cq"],
        np.broadcast_to(K_par, (N, 6, 6)),
        bodies=bodies,
        G_c=None if G_c is None else bc(G_c),
        K_c=None if K_c is None else bc(K_c),
    )
    return C


def merge_modes(modes, rows: np.ndarray, freq_hz: np.ndarray, V: np.ndarray, vectors: bool):
    """``modes`` (6 columns, K_F's) with the finite modes of :func:`compliance_eigh`
    (``freq_hz``, ``V`` of the rows ``rows``: a boolean mask or index array, or a slice):
    frequencies, eigentwists (normalised like the rest) and stability replaced; a rigid
    direction's column (``inf``) keeps K_F's stand-in frequency and eigentwist and is marked
    in ``modes.constrained``."""
    from .eigen import normalize_eigentwists

    modes.shares = None  # the eigentwists change: the shares with them
    finite = ~np.isinf(freq_hz)
    if isinstance(rows, np.ndarray) and rows.dtype == bool and rows.all():
        rows = slice(None)  # every row: views, no row copies
    freq = np.array(modes.freq_hz, dtype=float)
    fr = freq[rows]
    fr[finite] = freq_hz[finite]
    freq[rows] = fr
    modes.freq_hz = freq
    if not finite.all():
        constrained = np.zeros(freq.shape, dtype=bool)
        constrained[rows] = ~finite
        modes.constrained = constrained
    if modes.stable is not None:
        stable = np.array(modes.stable, dtype=bool)
        stable[rows] = ~np.isnan(freq_hz).any(axis=-1)
        modes.stable = stable
    if vectors and modes.eigentwists is not None:
        vec = np.array(modes.eigentwists, dtype=float)
        vr = vec[rows]
        mask = np.broadcast_to(finite[:, None, :], vr.shape)
        vr[mask] = normalize_eigentwists(V)[mask]
        vec[rows] = vr
        modes.eigentwists = vec
    return modes


def leg_joints(ev, poses, model="paper", **params):
    """Each leg's elastic joints of ``model`` at ``poses`` from an evaluator ``ev`` (the
    generated ``legs`` kernel; the poses are checked as in :meth:`Evaluator.matrices`).

    Returns ``(Je, Cq, K_parallel, M)``: Je (N, legs, e, 6) the actuated then virtual
    joints' inverse-Jacobian rows; Cq (N, legs, e, e) their compliance (Eqs. 41-43)
    without ``c_rigid`` (rigid directions exact zeros); K_parallel (N, 6, 6) the springs
    in parallel with the legs (ground springs); M (N, 6, 6) the inertia (Eq. 12).
    """
    out = ev.run_kernel("legs", poses, model, **params)
    M = ev.matrices(poses, model, **params)["M"]
    return out["Je"], out["Cq"], out["K_ground"], M


def platform_compliance(ev, poses, model="paper", **params):
    """Exact ``(C_F, M)`` of ``model`` at ``poses`` from an evaluator ``ev``: the legs'
    rigid constraints without a penalty, couplings of platform bodies (``ee_coupling``)
    and the gravity preload included; solve it with :func:`compliance_eigh`."""
    from ..description.effects import base_name, resolve_model

    effects = resolve_model(model, ev.robot)
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    out = ev.run_kernel("legs", poses, effects, **params)
    mats = ev.matrices(poses, effects, **params)
    K_G = None
    if any("preload" in ev.robot.effect(base_name(e)).primitives for e in effects):
        from .gravity import gravity_stiffness

        K_G = gravity_stiffness(ev, poses, effects, params, mats, False)
    return compliance_from_legs(ev.robot, effects, out, K_G), mats["M"]
