"""Mode tracking along a sweep: a mode keeps its label when frequencies cross.

Sorting natural frequencies at every step of a sweep (poses, k_a values, design
parameters) relabels two modes whenever their frequencies cross. Tracking follows each
mode by the similarity of its eigentwist (Eq. 6) from one step to the next, measured by
the modal assurance criterion (MAC), and solves the assignment between the previous
step's modes and the current ones for the largest total MAC (Hungarian method,
``scipy.optimize.linear_sum_assignment``).

Units: frequencies in Hz (or any unit: they are only reordered); eigentwists are
``[rotation (rad); translation (m)]`` columns; the optional mass matrix M (kg, kg m,
kg m^2) makes the MAC an inner product of kinetic energy, independent of the choice of
length unit. The MAC is dimensionless, in [0, 1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from ..errors import InputError

__all__ = ["mac", "track_modes", "TrackedModes"]


def mac(A: np.ndarray, B: np.ndarray, M: np.ndarray | None = None) -> np.ndarray:
    """Modal assurance criterion between the columns of ``A`` and ``B``.

    ``MAC[i, j] = (a_i^T M b_j)^2 / ((a_i^T M a_i) (b_j^T M b_j))``, with ``M`` the
    identity when None. ``A`` (..., n, k) and ``B`` (..., n, l) give (..., k, l). It is 1
    for parallel eigentwists (any scale or sign) and 0 for M-orthogonal ones.
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    MB = B if M is None else np.asarray(M, dtype=float) @ B
    MA = A if M is None else np.asarray(M, dtype=float) @ A
    cross = np.swapaxes(A, -1, -2) @ MB
    na = np.einsum("...ik,...ik->...k", A, MA)
    nb = np.einsum("...il,...il->...l", B, MB)
    return cross**2 / (na[..., :, None] * nb[..., None, :])


@dataclass
class TrackedModes:
    """Modes of a sweep, one column per label.

    freq_hz : (S, n) frequency of each labelled mode at each step (input unit, Hz).
    eigentwists : (S, n, n) eigentwist of each labelled mode (column l = label l).
    order : (S, n) column of the input at step s that carries label l: ``freq_hz[s, l] =
        freqs[s, order[s, l]]``.
    mac : (S, n) MAC between a label's eigentwist at step s and at step s - 1 (1 at s = 0):
        a value far below 1 flags a step too coarse to follow that mode.
    """

    freq_hz: np.ndarray
    eigentwists: np.ndarray
    order: np.ndarray
    mac: np.ndarray


def track_modes(freqs, eigentwists, M=None) -> TrackedModes:
    """Order the modes of a sweep so that each keeps its label through frequency crossings.

    Parameters
    ----------
    freqs : (S, n) natural frequencies at the S steps of a sweep (Hz), in any order per
        step (ascending, as the solvers return them).
    eigentwists : (S, n, n) the matching eigentwists as columns (Eq. 6; any scaling,
        e.g. M-orthonormal or largest entry +1).
    M : None, (n, n) or (S, n, n) inertia matrices (kg, kg m, kg m^2) weighting the MAC;
        at step s the MAC uses ``M[s]``.

    Labels are the ascending order at step 0. At each next step the assignment between
    the labels (their eigentwists at the previous step) and the current modes maximises
    the sum of MACs, so a mode keeps its label when its frequency crosses another's,
    provided the steps are fine enough that eigentwists change little between them.
    """
    from scipy.optimize import linear_sum_assignment  # on first use: commands without it start faster

    freqs = np.asarray(freqs, dtype=float)
    V = np.asarray(eigentwists, dtype=float)
    S, n = freqs.shape
    if V.shape != (S, n, n):
        raise InputError(f"eigentwists has shape {V.shape}: expected {(S, n, n)} for freqs of shape {freqs.shape}")
    Ms = None if M is None else np.broadcast_to(np.asarray(M, dtype=float), (S, n, n))
    order = np.empty((S, n), dtype=int)
    similarity = np.ones((S, n))
    order[0] = np.argsort(freqs[0], kind="stable")
    for s in range(1, S):
        prev = V[s - 1][:, order[s - 1]]
        C = mac(prev, V[s], None if Ms is None else Ms[s])  # (labels, current)
        rows, cols = linear_sum_assignment(C, maximize=True)
        order[s, rows] = cols
        similarity[s] = C[rows, cols]
    steps = np.arange(S)[:, None]
    return TrackedModes(
        freq_hz=freqs[steps, order],
        eigentwists=np.take_along_axis(V, order[:, None, :], axis=-1),
        order=order,
        mac=similarity,
    )
