"""Reverse-mode (adjoint) sensitivities: one backward sweep per mode, every parameter at once.

dλ/dp = φᵀ(∂K − λ∂M)φ for M-orthonormal φ: the adjoint kernel's gradient of the seeded
contraction against the forward kernel's matrices dM, dK contracted in NumPy, and the
frequency derivatives of the public path against central differences of the frequencies
(tests/test_sensitivity.py covers more robots, models and the Heli4's cluster).
"""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist
from eigentwist.runtime.adjoint import adjoint_frequency_derivatives, adjoint_kernel, parameter_columns, seed_matrices
from eigentwist.runtime.eigen import generalized_eigh
from eigentwist.runtime.sensitivity import sensitivity_kernels

from .conftest import random_poses

pytestmark = pytest.mark.derives
WRT = ("k_a", "E_rod")  # the forward kernel of tests/test_sensitivity_split.py


@pytest.fixture(scope="module")
def delta():
    ev = eigentwist.load("delta", backend="numpy")
    poses = random_poses(ev.robot, 4, seed=21)
    p = ev._with_pose(poses, ev._params(len(poses), {}, ev._resolve("paper")))
    return ev, poses, p


def test_adjoint_gradient_equals_the_forward_kernels_contraction(delta):
    ev, x, p = delta
    fwd = sensitivity_kernels(ev, WRT)(x[:, 0], x[:, 1], x[:, 2], p)
    kern = adjoint_kernel(ev)
    mats = kern.matrices(x[:, 0], x[:, 1], x[:, 2], p)
    for k in ("M", "K_R", "K_F"):
        np.testing.assert_allclose(mats[k], fwd[k], rtol=1e-13, atol=1e-13 * np.abs(fwd[k]).max())
    lam, V = generalized_eigh(fwd["K_F"], fwd["M"])
    u = np.swapaxes(V, 1, 2)  # (N, modes, 6)
    got = kern.gradient(x[:, 0], x[:, 1], x[:, 2], p, seed_matrices(u, u, lam, kern.outputs, "K_F"))
    got = got @ parameter_columns(kern.targets, WRT)  # d/dP: P and each leg's copy P__N
    # φᵀ(dK − λ dM)φ from the forward kernel's (N, P, 6, 6) derivatives
    want = np.einsum("nim,npij,njm->nmp", V, fwd["dK_F"], V) - lam[..., None] * np.einsum(
        "nim,npij,njm->nmp", V, fwd["dM"], V
    )
    scale = np.abs(want).max(axis=(0, 1))
    assert np.all(np.abs(got - want) <= 1e-12 * scale), np.max(np.abs(got - want) / scale)


def test_public_path_equals_central_differences(delta):
    """``Evaluator.sensitivities`` (the adjoint route) against 4th-order central differences
    of the frequencies: df/dp = dλ/dp / (4π ω)."""
    ev, x, _ = delta
    got = ev.sensitivities(x, WRT)
    for j, name in enumerate(WRT):
        v = ev.defaults[name]
        h = 1e-3 * v
        f = {s: ev.frequencies(x, **{name: v + s * h}) for s in (-2, -1, 1, 2)}
        want = (f[-2] - 8 * f[-1] + 8 * f[1] - f[2]) / (12 * h)
        np.testing.assert_allclose(got[..., j], want, rtol=1e-6, atol=1e-8 * np.abs(want).max())


def test_a_cluster_takes_the_seeds_of_its_pairs():
    """Two equal eigenvalues: their derivatives are the eigenvalues of the 2x2 projected
    derivative (from the pair's seed sym(φ_1 φ_2ᵀ)), not the diagonal of an arbitrary basis.
    A stand-in kernel with M = I, K = diag(1, 1, 2, 3, 4, 5) + p A."""
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 6))
    A = A + A.T
    K0 = np.diag([1.0, 1.0, 2.0, 3.0, 4.0, 5.0])

    class Kern:
        outputs, targets = ("M", "K_R", "K_F"), ("p",)

        def matrices(self, x, y, z, p):
            return {"M": np.eye(6)[None], "K_R": K0[None], "K_F": K0[None]}

        def gradient(self, x, y, z, p, seed):
            s = seed[..., 42:]  # S_K_F: upper triangle; the kernel counts off-diagonals twice
            a, b = np.triu_indices(6)
            return (np.where(a == b, 1.0, 2.0) * s * A[a, b]).sum(-1)[..., None]

    _, _, d = adjoint_frequency_derivatives(Kern(), 0, 0, 0, {}, ("p",), False, 1e-6)
    t = 1e-7
    want = (np.linalg.eigvalsh(K0 + t * A) - np.diag(K0)) / t / (2 * np.sqrt(np.diag(K0))) / (2 * np.pi)
    np.testing.assert_allclose(d[0, :, 0], want, rtol=1e-5, atol=1e-6)
    assert not np.isclose(d[0, 0, 0], d[0, 1, 0])


def test_an_unknown_adjoint_backend_is_refused(delta):
    from eigentwist.runtime import InputError

    assert adjoint_kernel(delta[0], backend="numpy") is adjoint_kernel(delta[0])
    with pytest.raises(InputError, match="backend='fortran'"):
        adjoint_kernel(delta[0], backend="fortran")


@pytest.mark.compiled
def test_c_adjoint_equals_numpy(delta, monkeypatch):
    """The C kernel (forward parts once per block, backward parts once per seed; a partial
    last block) against the NumPy module, compiled at -O0 (seconds; -O2 takes minutes)."""
    from eigentwist.runtime import adjoint

    ev, _, _ = delta
    monkeypatch.setattr(adjoint, "C_OPT", "-O0")
    x = random_poses(ev.robot, 70, seed=3)
    p = ev._with_pose(x, ev._params(len(x), {}, ev._resolve("paper")))
    seed = np.random.default_rng(1).normal(size=(len(x), 5, 63))
    kn, kc = adjoint_kernel(ev), adjoint_kernel(ev, backend="c")
    a, b = kn.gradient(x[:, 0], x[:, 1], x[:, 2], p, seed), kc.gradient(x[:, 0], x[:, 1], x[:, 2], p, seed)
    assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
    ma, mc = kn.matrices(x[:, 0], x[:, 1], x[:, 2], p), kc.matrices(x[:, 0], x[:, 1], x[:, 2], p)
    for k in ma:
        assert np.abs(ma[k] - mc[k]).max() <= 1e-12 * np.abs(ma[k]).max(), k
