"""Batched symmetric-definite eigen-solver for det(omega^2 M - K) = 0 (Eq. 7)."""
from __future__ import annotations

import numpy as np

__all__ = ["generalized_eigh", "frequencies_hz", "normalize_eigentwists"]


def generalized_eigh(K: np.ndarray, M: np.ndarray):
    """Solve ``K v = lambda M v`` for a batch of symmetric K and SPD M.

    Parameters
    ----------
    K, M : arrays of shape (N, n, n)
        Stiffness (N/m, N, N m/rad) and inertia (kg, kg m, kg m^2) at the same point.

    Returns
    -------
    lam : (N, n) eigenvalues omega^2 in (rad/s)^2, ascending.
    V : (N, n, n) eigenvectors (columns), M-orthonormal.

    Cholesky reduction M = L L^T, A = L^-1 K L^-T, ``numpy.linalg.eigh`` on the batch,
    V = L^-T W: no Python loop over poses.
    """
    L = np.linalg.cholesky(M)
    Linv = np.linalg.inv(L)
    A = Linv @ K @ np.swapaxes(Linv, -1, -2)
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    lam, W = np.linalg.eigh(A)
    V = np.swapaxes(Linv, -1, -2) @ W
    return lam, V


def frequencies_hz(lam: np.ndarray) -> np.ndarray:
    """Natural frequencies (Hz) from eigenvalues omega^2; negative roundoff clips to 0."""
    return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)


def normalize_eigentwists(V: np.ndarray) -> np.ndarray:
    """Scale each eigentwist (column) so that its entry of largest magnitude is +1 (Eqs. 57, 65)."""
    idx = np.argmax(np.abs(V), axis=-2)
    big = np.take_along_axis(V, idx[..., None, :], axis=-2)
    return V / big
