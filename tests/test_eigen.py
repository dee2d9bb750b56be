"""Batched eigen-solver against scipy.linalg.eigh pose by pose; mode tracking through a crossing."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from eigentwist.runtime.eigen import (
    ROUNDOFF_EPS,
    frequencies_and_stability,
    frequencies_hz,
    generalized_eigh,
    generalized_eigvalsh,
    largest_magnitude,
    normalize_eigentwists,
    unstable_modes,
)
from eigentwist.runtime.tracking import mac, track_modes

from .conftest import workspace_grid


def random_spd_pairs(n_pairs: int, n: int, seed: int):
    """(K, M) with M SPD (condition up to ~1e3) and K symmetric positive definite."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n_pairs, n, n))
    B = rng.normal(size=(n_pairs, n, n))
    M = A @ np.swapaxes(A, 1, 2) + 1e-2 * np.eye(n)
    K = 1e4 * (B @ np.swapaxes(B, 1, 2) + 1e-1 * np.eye(n))
    return K, M


def assert_matches_scipy(K, M, lam, V, rtol=1e-10):
    """Eigenvalues to rtol; eigenvectors (up to sign) to rtol where the spectrum is separated."""
    for k in range(len(K)):
        w, U = scipy.linalg.eigh(K[k], M[k])
        np.testing.assert_allclose(lam[k], w, rtol=rtol, atol=rtol * np.abs(w).max())
        gap = np.diff(w) / np.abs(w).max()
        for c in range(len(w)):
            near = [g for g in (gap[c - 1] if c else np.inf, gap[c] if c < len(gap) else np.inf)]
            if min(near) < 1e-4:
                continue  # (nearly) repeated eigenvalue: vectors not unique
            v, u = V[k][:, c], U[:, c]
            v = v * np.sign(v @ M[k] @ u)
            np.testing.assert_allclose(v, u, rtol=0, atol=rtol / min(near) * np.abs(u).max())


@pytest.mark.parametrize("n", [6, 3])
def test_batched_solver_equals_scipy_on_random_pairs(n):
    K, M = random_spd_pairs(200, n, seed=n)
    lam, V = generalized_eigh(K, M)
    assert_matches_scipy(K, M, lam, V)
    # M-orthonormal eigentwists and the eigen-equation K V = M V diag(lam) (Eq. 6)
    np.testing.assert_allclose(np.swapaxes(V, 1, 2) @ M @ V, np.broadcast_to(np.eye(n), M.shape), atol=1e-10)
    np.testing.assert_allclose(K @ V, M @ V * lam[:, None, :], rtol=0, atol=1e-9 * np.abs(K).max())
    np.testing.assert_allclose(generalized_eigvalsh(K, M), lam, rtol=0, atol=1e-12 * np.abs(lam).max())


@pytest.mark.parametrize("model", ["paper", "rigid"])
def test_batched_solver_equals_scipy_on_model_matrices(ev, model):
    M, K = ev.stiffness(workspace_grid(ev.robot, 3), model)
    lam, V = generalized_eigh(K, M)
    assert_matches_scipy(K, M, lam, V)


def test_frequencies_and_normalisation():
    lam = np.array([[-1e-9, (2 * np.pi * 3.0) ** 2]])
    np.testing.assert_allclose(frequencies_hz(lam), [[0.0, 3.0]])
    V = np.array([[[0.2, -4.0], [-0.5, 1.0]]])
    N = normalize_eigentwists(V)
    np.testing.assert_allclose(N, [[[-0.4, 1.0], [1.0, -0.25]]])


def test_largest_magnitude_is_the_rows_max_abs():
    lam = np.random.default_rng(3).normal(size=(50, 4)) * 10.0 ** np.arange(4)
    lam[7, 2] = np.nan  # a pose that failed: its scale is NaN, as NumPy's max gives it
    want = np.abs(lam).max(axis=-1, keepdims=True)
    got = largest_magnitude(lam)
    assert got.shape == (50, 1) and np.array_equal(got, want, equal_nan=True)
    assert largest_magnitude(np.zeros((3, 0))).tolist() == [[0.0]] * 3
    assert largest_magnitude(np.array([-2.0, 1.0])).tolist() == [2.0]


def test_a_negative_eigenvalue_is_round_off_up_to_eps_of_the_largest():
    big = 4.0e6
    edge = -ROUNDOFF_EPS * big
    lam = np.array([[edge * 0.99, 1.0, big], [edge * 1.01, 1.0, big], [np.nan, 1.0, big]])
    assert unstable_modes(lam).tolist() == [[False, False, False], [True, False, False], [False, False, False]]
    f = frequencies_hz(lam)
    assert f[0, 0] == 0.0 and np.isnan(f[1, 0]) and f[0, 2] == np.sqrt(big) / (2 * np.pi)
    # a bound given is the one applied: twice it takes the second pose's in, half the first's out
    assert frequencies_hz(lam, 2 * ROUNDOFF_EPS)[1, 0] == 0.0
    f, stable = frequencies_and_stability(lam, 0.5 * ROUNDOFF_EPS)
    assert np.isnan(f[0, 0]) and stable.tolist() == [False, False, True]


def test_stability_is_false_where_any_mode_is_unstable():
    big = 4.0e6
    edge = -ROUNDOFF_EPS * big
    lam = np.array(
        [[edge * 0.99, 1.0, big], [1.0, edge * 1.01, big], [1.0, 2.0, big], [np.nan, 1.0, big], [-5.0, -1.0, big]]
    )
    f, stable = frequencies_and_stability(lam)
    assert stable.tolist() == [True, False, True, True, False]  # a NaN eigenvalue is not unstable
    assert np.isnan(f[1, 1]) and np.isnan(f[4, :2]).all() and f[0, 0] == 0.0
    assert f[2, 1] == np.sqrt(2.0) / (2 * np.pi) and np.array_equal(f, frequencies_hz(lam), equal_nan=True)
    f, stable = frequencies_and_stability(lam[0])  # one pose: a scalar flag
    assert stable.shape == () and bool(stable) and f[0] == 0.0


def test_mac_is_one_for_parallel_and_zero_for_m_orthogonal():
    K, M = random_spd_pairs(1, 6, seed=3)
    _, V = generalized_eigh(K, M)
    m = mac(V[0], -2.5 * V[0], M[0])
    np.testing.assert_allclose(m, np.eye(6), atol=1e-12)


def _crossing_sweep(steps: int = 41):
    """Two modes whose frequencies cross (k1 rises, k2 falls) while all eigentwists rotate slowly.

    Built as a generalised problem with known answer: M fixed SPD, V(s) = L^-T Q(s) with
    Q a slow rotation, K(s) = M V diag(lam(s)) V^T M, so that K V = M V diag(lam).
    """
    rng = np.random.default_rng(11)
    A = rng.normal(size=(6, 6))
    M = A @ A.T + 6 * np.eye(6)
    L = np.linalg.cholesky(M)
    G = rng.normal(size=(6, 6))
    G = 0.5 * (G - G.T)  # generator of the slow rotation
    s = np.linspace(0.0, 1.0, steps)
    lam = np.empty((steps, 6))
    lam[:, 0] = 100 + 200 * s  # label 0 rises ...
    lam[:, 1] = 260 - 200 * s  # ... label 1 falls: they cross at s = 0.6
    lam[:, 2:] = [500, 800, 1200, 2000]
    Ks, Ms = [], []
    for k in range(steps):
        Q = scipy.linalg.expm(0.4 * s[k] * G)
        V = np.linalg.solve(L.T, Q)
        Ks.append(M @ V @ np.diag(lam[k]) @ V.T @ M)
        Ms.append(M)
    return np.array(Ks), np.array(Ms), lam


def test_tracking_keeps_labels_through_a_crossing():
    K, M, lam_true = _crossing_sweep()
    lam, V = generalized_eigh(K, M)
    f = frequencies_hz(lam)
    f_true = frequencies_hz(lam_true)
    # sorting alone swaps the two crossing modes after the crossing
    assert not np.allclose(f[:, :2], f_true[:, :2])
    tracked = track_modes(f, V, M)
    np.testing.assert_allclose(tracked.freq_hz, f_true, rtol=1e-10)
    assert tracked.mac.min() > 0.9
    # the tracked eigentwists are continuous: each is parallel to its predecessor
    step = mac(tracked.eigentwists[:-1], tracked.eigentwists[1:], M[1:])
    assert np.diagonal(step, axis1=1, axis2=2).min() > 0.9
    # the same without mass weighting, and through the reordering bookkeeping
    plain = track_modes(f, V)
    np.testing.assert_array_equal(plain.order, tracked.order)
    np.testing.assert_array_equal(tracked.freq_hz, np.take_along_axis(f, tracked.order, axis=1))


def test_tracking_rejects_mismatched_shapes():
    with pytest.raises(ValueError, match="eigentwists has shape"):
        track_modes(np.zeros((3, 6)), np.zeros((3, 6, 5)))
