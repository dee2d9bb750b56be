"""Rigid constraints condensed exactly, and the eigenproblem in compliance form (issue 20).

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

import numpy as np

__all__ = ["leg_condensation", "condensed_compliance", "compliance_eigh", "finite_modes", "leg_joints",
           "platform_compliance",
           "RIGID_RTOL", "PROBE_C_RIGID"]

# A joint-compliance eigenvalue below RIGID_RTOL times the leg's largest (or a singular
# value of the stacked rigid rows below RIGID_RTOL times the largest) is a rigid direction
# (a dependent constraint): the compliances of a model are either exact zeros (rigid) or
# physical values many orders above round-off.
RIGID_RTOL = 1e-10
# The generated ``gravity`` kernel's joint stiffness ``Kqe = Cq^-1`` includes the
# description's ``c_rigid`` on each virtual joint; :func:`platform_compliance` evaluates it
# with this value (rad/(N m), within the parameter's bounds: Kqe well conditioned) and
# subtracts it again, which recovers ``Cq`` with exact-zero rigid directions to round-off.
PROBE_C_RIGID = 1e-7


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
    s, U = np.linalg.eigh(0.5 * (Cq + np.swapaxes(Cq, -1, -2)))
    rigid = s <= rtol * np.abs(s).max(axis=-1, keepdims=True)
    inv = np.where(rigid, 0.0, 1.0 / np.where(rigid, 1.0, s))
    UJ = np.swapaxes(U, -1, -2) @ Je                                  # (N, e, 6): combinations' rows
    K = np.swapaxes(UJ, -1, -2) @ (inv[..., None] * UJ)
    R = np.where(rigid[..., None], UJ, 0.0)
    return 0.5 * (K + np.swapaxes(K, -1, -2)), R


def condensed_compliance(Je: np.ndarray, Cq: np.ndarray, K_parallel: np.ndarray | None = None,
                         rtol: float = RIGID_RTOL):
    """Exact platform compliance of legs in parallel with rigid constraints.

    Je : (N, legs, e, 6) and Cq : (N, legs, e, e) as in :func:`leg_condensation`;
    K_parallel : optional (N, 6, 6) stiffness in parallel (ground springs).

    Returns ``(C_F, B)``: C_F (N, 6, 6) = ``B (B^T K_s B)^-1 B^T`` in rad/(N m), m/N
    (K_s: the legs' finite springs plus ``K_parallel``), and B (N, 6, n) an orthonormal
    basis of the admissible twists (the null space of the rigid rows; n = 6 without
    rigid constraints). Raises ``numpy.linalg.LinAlgError`` when ``B^T K_s B`` is
    singular (a mechanism: an admissible twist without stiffness).
    """
    Je = np.asarray(Je, dtype=float)
    N = Je.shape[0]
    K_s = np.zeros((N, 6, 6)) if K_parallel is None else np.array(K_parallel, dtype=float)
    rows = []
    for i in range(Je.shape[1]):
        K, R = leg_condensation(Je[:, i], np.asarray(Cq)[:, i], rtol)
        K_s += K
        rows.append(R)
    A = np.concatenate(rows, axis=1)                                  # (N, legs*e, 6)
    _, sv, Vt = np.linalg.svd(A, full_matrices=True)
    rank = (sv > rtol * sv.max(axis=-1, keepdims=True, initial=0.0)).sum(axis=-1)
    if np.any(rank != rank[0]):
        raise ValueError(f"rigid constraints of rank {sorted(set(rank.tolist()))} across the poses: "
                         "expected one rank (a constraint singularity)")
    B = np.swapaxes(Vt[:, int(rank[0]):, :], -1, -2)                 # (N, 6, n)
    Kr = np.swapaxes(B, -1, -2) @ K_s @ B
    C = B @ np.linalg.solve(0.5 * (Kr + np.swapaxes(Kr, -1, -2)), np.swapaxes(B, -1, -2))
    return 0.5 * (C + np.swapaxes(C, -1, -2)), B


def compliance_eigh(C: np.ndarray, M: np.ndarray, rtol: float = RIGID_RTOL):
    """Solve ``C M v = (1/omega^2) v`` (Eq. 6 in compliance form) for a batch.

    C : (N, n, n) symmetric PSD compliance; M : (N, n, n) SPD inertia.

    Returns ``(freq_hz, V)``: freq_hz (N, n) ascending, ``+inf`` for each direction of
    zero compliance (an eigenvalue 1/omega^2 below ``rtol`` times the pose's largest);
    V (N, n, n) the eigentwists (columns), M-orthonormal. With ``M = L L^T`` the solved
    matrix is the symmetric PSD ``L^T C L`` (eigenvalues 1/omega^2 in (s/rad)^2).
    """
    L = np.linalg.cholesky(np.asarray(M, dtype=float))
    A = np.swapaxes(L, -1, -2) @ np.asarray(C, dtype=float) @ L
    mu, W = np.linalg.eigh(0.5 * (A + np.swapaxes(A, -1, -2)))
    mu, W = mu[..., ::-1], W[..., ::-1]                               # largest 1/omega^2 first
    zero = mu <= rtol * np.abs(mu).max(axis=-1, keepdims=True)
    freq = np.where(zero, np.inf, 1.0 / np.sqrt(np.where(zero, 1.0, mu)) / (2 * np.pi))
    V = np.swapaxes(np.linalg.inv(L), -1, -2) @ W
    return freq, V


def finite_modes(freq_hz: np.ndarray) -> np.ndarray:
    """The finite frequencies of :func:`compliance_eigh` (N, n_finite): drops the ``inf``
    columns (the same number at every pose, else ValueError)."""
    finite = np.isfinite(freq_hz)
    n = finite.sum(axis=-1)
    if np.any(n != n.flat[0]):
        raise ValueError(f"{sorted(set(n.ravel().tolist()))} finite modes across the poses: expected one number")
    return freq_hz[..., : int(n.flat[0])]


def leg_joints(ev, poses, model="paper", **params):
    """Each leg's elastic joints of ``model`` at ``poses`` from an evaluator ``ev``.

    Returns ``(Je, Cq, K_parallel, M)``: Je (N, legs, e, 6) the actuated then virtual
    joints' inverse-Jacobian rows (``J_rows``); Cq (N, legs, e, e) their compliance
    (Eqs. 41-43) **without** ``c_rigid``: ``Kqe^-1 - c diag(0, 1, ..., 1)`` from the
    generated ``gravity`` kernel evaluated with ``c_rigid = c =`` :data:`PROBE_C_RIGID`;
    K_parallel (N, 6, 6) the springs in parallel with the legs (ground springs: ``K_R``
    minus the actuators' ``k_act j_a^T j_a``, Eq. 14); M (N, 6, 6) the inertia (Eq. 12).
    Robots whose model couples platform bodies (legs on traveling plates,
    ``ee_coupling``) are not covered: ValueError.
    """
    from .allowed import constraint_positions

    robot = ev.robot
    coupled = sorted(c.effect for c in robot.couplings if c.effect in _names(ev, model))
    if coupled:
        raise ValueError(f"model {model!r} of {robot.name} couples platform bodies ({', '.join(coupled)}): "
                         "expected legs on the tool body for the exact condensation")
    extra = {"c_rigid": PROBE_C_RIGID} if ev.accepts("c_rigid") else {}
    out = ev.run_kernel("gravity", poses, model, **params, **extra)
    mats = ev.matrices(poses, model, **params, **extra)
    pick = [[0] + constraint_positions(leg) for leg in robot.legs]
    Je = np.stack([out["J_rows"][:, i, r, :] for i, r in enumerate(pick)], axis=1)
    Cq = np.linalg.inv(np.asarray(out["Kqe"], dtype=float))
    if extra:
        Cq = Cq - PROBE_C_RIGID * np.diag([0.0] + [1.0] * (Cq.shape[-1] - 1))
    ja = Je[:, :, 0, :]
    K_act = np.einsum("nl,nli,nlj->nij", np.asarray(out["k_act"], dtype=float), ja, ja)
    return Je, Cq, mats["K_R"] - K_act, mats["M"]


def platform_compliance(ev, poses, model="paper", **params):
    """Exact ``(C_F, M)`` of ``model`` at ``poses`` (:func:`leg_joints`, then
    :func:`condensed_compliance`): the 6 x 6 route without a rigid-constraint penalty,
    to solve with :func:`compliance_eigh`. The gravity preload is not included."""
    Je, Cq, K_parallel, M = leg_joints(ev, poses, model, **params)
    C, _ = condensed_compliance(Je, Cq, K_parallel)
    return C, M


def _names(ev, model) -> tuple:
    from ..description.effects import base_name, resolve_model

    return tuple(base_name(e) for e in resolve_model(model, ev.robot))
