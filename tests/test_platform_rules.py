"""The followers' rates: the SO(3) left Jacobian against differences of rotations, and the
rates along the followers against the full twist Jacobian written out here."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from eigentwist.runtime.platform import along_followers, commanded, left_jacobian


def _omega_by_differences(phi, d, h=1e-6):
    """Angular velocity (base axes) of R(phi + s d) at s = 0: the axial vector of
    dR/ds R^T by central differences (SciPy's rotation vectors, not eigentwist's)."""
    Rp = Rotation.from_rotvec(phi + h * d).as_matrix()
    Rm = Rotation.from_rotvec(phi - h * d).as_matrix()
    W = (Rp - Rm) / (2 * h) @ Rotation.from_rotvec(phi).as_matrix().T
    return np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2


@pytest.mark.parametrize("scale", [1.0, 0.3, 2e-5, 0.5e-5, 1e-9])  # t^2 around the series' 1e-10
def test_left_jacobian_maps_rotation_vector_rates_to_angular_velocity(scale):
    rng = np.random.default_rng(2)
    for _ in range(5):
        phi = scale * rng.standard_normal(3)
        d = rng.standard_normal(3)
        assert np.allclose(left_jacobian(phi) @ d, _omega_by_differences(phi, d), rtol=0, atol=1e-8)


@pytest.mark.parametrize("t2", [0.0, 1e-12, 9e-11])
def test_left_jacobian_series_below_its_threshold(t2):
    """Below t^2 = 1e-10 the left Jacobian's factors are their series: a = (1 - cos t)/t^2 (here
    2 sin^2(t/2)/t^2, free of cancellation) and b = (t - sin t)/t^3 (here its series to t^4)."""
    from eigentwist.runtime.platform import _left_jacobian_factors

    phi = np.sqrt(t2 / 3) * np.ones((1, 3))
    a, b, t2_got = _left_jacobian_factors(phi)
    t = np.sqrt(t2)
    a_ref = 0.5 if t2 == 0 else 2 * np.sin(t / 2) ** 2 / t2
    assert t2_got[0] == pytest.approx(t2, rel=1e-15, abs=1e-300)
    assert a[0] == pytest.approx(a_ref, rel=1e-15, abs=0)
    assert b[0] == pytest.approx(1 / 6 - t2 / 120 + t2**2 / 5040, rel=1e-15, abs=0)


@pytest.mark.parametrize("followers", [[0, 1, 5], [3, 4, 5], [2], [4, 0], [3], [0, 3]])
def test_rates_along_followers_are_the_rates_along_their_twists(followers):
    rng = np.random.default_rng(len(followers))
    n = 40
    full = rng.standard_normal((n, 6))
    full[::4, 3:] *= 1e-6  # small rotations: the series
    full[1::4, 3:] = 0.0
    rate = rng.standard_normal((n, 2, 3, 6))  # (poses, legs, rows, twist)
    T = np.zeros((n, 6, len(followers)))  # the twist [omega; v] per unit rate of each follower
    for c, k in enumerate(followers):
        if k < 3:
            T[:, 3 + k, c] = 1.0
        else:
            T[:, :3, c] = left_jacobian(full[:, 3:])[:, :, k - 3]
    want = rate @ T[:, None]
    assert np.allclose(along_followers(rate, full, followers), want, rtol=0, atol=1e-14)
    assert np.allclose(along_followers(rate[:, 0], full, followers), want[:, 0], rtol=0, atol=1e-14)


def test_c_follow_takes_only_a_closed_form_followers_kernel_with_its_two_outputs():
    from eigentwist.runtime.c_kernels import CKernels

    kernels = CKernels.__new__(CKernels)  # the spec alone: no library is called
    kernels.ROBOT = "stand_in"
    kernels._spec = {
        "followers": {"inputs": [["pose", "x", None]], "outputs": [["closure_rate", [3, 6]], ["closure", [3]]]}
    }
    with pytest.raises(RuntimeError, match="expected closure and closure_rate"):
        kernels.follow(np.zeros((1, 1, 3)), {}, [0, 1, 5], 1, 1e-12)
    kernels._spec["followers"]["inputs"].append(["q", "q_1", [0, 0]])  # legs solved numerically: NumPy's
    assert kernels.follow(np.zeros((1, 1, 3)), {}, [0, 1, 5], 1, 1e-12) is None
    kernels._spec = {}  # no followers kernel
    assert kernels.follow(np.zeros((1, 1, 3)), {}, [0, 1, 5], 1, 1e-12) is None


def test_commanded_poses_are_the_given_coordinates_and_zeros_into_any_array():
    """The user's coordinates (z, rot_x, rot_y of a 3-PRS-like space) at their places of the
    full pose [x, y, z, rot_x, rot_y, rot_z], every other entry 0 (the followers' reference),
    whatever an ``out`` array held before."""

    class Space:
        coordinates = ("z", "rot_x", "rot_y")

    given = np.array([[0.6, 0.1, -0.2], [0.55, -0.05, 0.0]])
    want = np.array([[0.0, 0.0, 0.6, 0.1, -0.2, 0.0], [0.0, 0.0, 0.55, -0.05, 0.0, 0.0]])
    assert np.array_equal(commanded(Space, given), want)
    held = np.full((2, 6), 7.0)
    assert commanded(Space, given, out=held) is held and np.array_equal(held, want)
