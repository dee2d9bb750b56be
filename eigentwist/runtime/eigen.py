"""Batched symmetric-definite eigen-solver for det(omega^2 M - K) = 0 (Eq. 7).

No Python loop over poses: a batched Cholesky reduction of the generalised problem to a
standard one, then LAPACK's symmetric solver on the whole batch (``numpy.linalg.eigh``,
which loops in C). The C backend has its own fused solver (Cholesky + cyclic Jacobi,
``CKernels.generalized_eigh`` and ``fused_frequencies``); both are tested against
``scipy.linalg.eigh`` pose by pose.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "generalized_eigh",
    "generalized_eigvalsh",
    "frequencies_hz",
    "frequencies_and_stability",
    "unstable_modes",
    "largest_magnitude",
    "normalize_eigentwists",
    "ROUNDOFF_EPS",
]

# A negative eigenvalue omega^2 with |lambda| <= ROUNDOFF_EPS * max|lambda| (of the same
# pose) is round-off of a zero mode (a rank-deficient K) and clips to 0 Hz; a more negative
# one is a genuinely unstable mode (negative stiffness, e.g. a preload) and gives NaN.
# The bound is 1e6 units in the last place: backward-stable eigen-solvers err by a few ulp
# of ||A|| and the closed forms of K by cancellation among their terms, far below it.
ROUNDOFF_EPS = 1e-10


def _reduce(K: np.ndarray, M: np.ndarray):
    """``L^-1`` of ``M = L L^T`` and the symmetric ``A = L^-1 K L^-T``, batched."""
    L = np.linalg.cholesky(M)
    Linv = np.linalg.inv(L)
    LinvT = np.swapaxes(Linv, -1, -2)
    A = Linv @ K @ LinvT
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    return LinvT, A


def generalized_eigh(K: np.ndarray, M: np.ndarray):
    """Solve ``K v = lambda M v`` (Eq. 6) for a batch of symmetric K and SPD M.

    Parameters
    ----------
    K, M : arrays of shape (N, n, n)
        Stiffness (N/m, N, N m/rad) and inertia (kg, kg m, kg m^2) at the same point.

    Returns
    -------
    lam : (N, n) eigenvalues omega^2 in (rad/s)^2, ascending.
    V : (N, n, n) eigenvectors (columns, the eigentwists of Eq. 6), M-orthonormal:
        ``V^T M V = I``.

    Cholesky reduction M = L L^T, A = L^-1 K L^-T, ``numpy.linalg.eigh`` on the batch,
    V = L^-T W. Raises ``numpy.linalg.LinAlgError`` when an M is not positive definite.
    """
    LinvT, A = _reduce(K, M)
    lam, W = np.linalg.eigh(A)
    return lam, LinvT @ W


def generalized_eigvalsh(K: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Eigenvalues only of ``K v = lambda M v``: (N, n) omega^2 in (rad/s)^2, ascending.

    About 1.5x faster than :func:`generalized_eigh` when the eigentwists are not needed.
    """
    _, A = _reduce(K, M)
    return np.linalg.eigvalsh(A)


def unstable_modes(lam: np.ndarray, eps: float = ROUNDOFF_EPS) -> np.ndarray:
    """(..., n) bool: eigenvalues below ``-eps * max|lambda|`` of their pose (the last axis).

    Those modes are unstable (the stiffness is not positive semi-definite there);
    negative values closer to zero are round-off and count as 0.
    """
    lam = np.asarray(lam, dtype=float)
    return lam < -eps * largest_magnitude(lam)


def largest_magnitude(lam: np.ndarray) -> np.ndarray:
    """(..., 1): max |lambda| over the last axis (0 for none), one column at a time: a
    reduction along a short last axis runs per row, and a batch has many rows."""
    lam = np.asarray(lam, dtype=float)
    scale = np.zeros(lam.shape[:-1] + (1,))
    for k in range(lam.shape[-1]):
        np.maximum(scale[..., 0], np.abs(lam[..., k]), out=scale[..., 0])
    return scale


def frequencies_hz(lam: np.ndarray, eps: float = ROUNDOFF_EPS) -> np.ndarray:
    """Natural frequencies f = omega / (2 pi) in Hz from eigenvalues omega^2 in (rad/s)^2.

    Negative round-off (|lambda| <= ``eps`` max|lambda| of the pose, a rank-deficient K)
    clips to 0 Hz; an unstable mode (:func:`unstable_modes`) is NaN, never 0 Hz.
    """
    return frequencies_and_stability(lam, eps)[0]


def frequencies_and_stability(lam: np.ndarray, eps: float = ROUNDOFF_EPS) -> tuple:
    """``(freq_hz, stable)``: :func:`frequencies_hz` of ``lam`` (..., n) and whether each pose
    has no unstable mode (..., ) bool (:func:`unstable_modes`, found once for both)."""
    lam = np.asarray(lam, dtype=float)
    unstable = unstable_modes(lam, eps)
    f = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    stable = np.ones(lam.shape[:-1], dtype=bool)
    for k in range(lam.shape[-1]):  # per column: a reduction along a short last axis runs per row
        stable &= ~unstable[..., k]
    return np.where(unstable, np.nan, f), stable


def normalize_eigentwists(V: np.ndarray) -> np.ndarray:
    """Scale each eigentwist (column) so that its entry of largest magnitude is +1 (Eqs. 57, 65)."""
    idx = np.argmax(np.abs(V), axis=-2)
    big = np.take_along_axis(V, idx[..., None, :], axis=-2)
    return V / big
