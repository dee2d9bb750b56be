"""The rotation matrix entries in C (eigentwist.runtime.c_poses) against NumPy's (runtime.poses)."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime import c_poses
from eigentwist.runtime.poses import rotation_entries


pytestmark = pytest.mark.compiled


@pytest.fixture(autouse=True)
def library():
    """The compiled tier (skips without a compiler, fails where CI requires it); where a
    compiler exists the library must build (a None here would make every test below compare
    NumPy with itself)."""
    from .conftest import compiled_tier

    mp = compiled_tier()
    assert c_poses._function() is not None
    yield
    mp.undo()


def _poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = rng.uniform(-1.0, 1.0, (n, 6))
    poses[:, 3:] *= rng.uniform(0.0, 3.0, (n, 1))  # angles up to ~pi
    return poses


def test_the_entries_are_numpys_to_round_off_and_an_orthonormal_matrix():
    poses = _poses(5000, 1)
    c = np.array(c_poses.rotation_entries(poses))
    numpy = np.array(rotation_entries(poses[:, 3:]))
    assert np.abs(c - numpy).max() <= 4 * np.finfo(float).eps  # the same arithmetic; the C library's sin, cos
    R = c.T.reshape(-1, 3, 3)
    np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)


@pytest.mark.parametrize("t2", [0.99e-12, 1.01e-12])
def test_either_side_of_the_series_threshold(t2):
    """Below t^2 = 1e-12 the series of sin(t)/t and (1 - cos t)/t^2, above them the functions:
    the entries follow NumPy's on each side (the series' error there is ~1e-25)."""
    axis = np.array([0.6, 0.0, 0.8])
    poses = np.zeros((3, 6))
    poses[:, 3:] = np.sqrt(t2) * axis
    c = np.array(c_poses.rotation_entries(poses))
    numpy = np.array(rotation_entries(poses[:, 3:]))
    assert np.abs(c - numpy).max() <= 4 * np.finfo(float).eps
    x, y, z = np.sqrt(t2) * axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    # to O(t^3); above the threshold 1 - cos(t) keeps ~4 digits of (1 - cos t)/t^2 (hence the series below)
    np.testing.assert_allclose(c[:, 0], (np.eye(3) + K + K @ K / 2).ravel(), rtol=1e-3, atol=1e-20)


def test_any_thread_count_and_a_strided_batch_give_the_same_bits():
    poses = _poses(20000 + 37, 2)
    one = np.array(c_poses.rotation_entries(poses, 1))
    for threads in (2, 3):
        assert np.array(c_poses.rotation_entries(poses, threads)).tobytes() == one.tobytes()
    wide = np.zeros((len(poses), 8))
    wide[:, 1:7] = poses
    assert np.array(c_poses.rotation_entries(wide[:, 1:7], 2)).tobytes() == one.tobytes()
    assert np.array(c_poses.rotation_entries(np.asfortranarray(poses))).tobytes() == one.tobytes()
    assert [e.shape for e in c_poses.rotation_entries(np.zeros((0, 6)))] == [(0,)] * 9


def test_the_c_backend_reads_them_where_numpy_reads_its_own(monkeypatch):
    """A 6-DoF robot's pose inputs on the C backend come from C; without the library, from NumPy."""
    from tests.descriptions import hexapod_urdf

    import eigentwist

    ev = eigentwist.load(hexapod_urdf.describe(), backend="c", threads=2, progress=lambda m: None)
    poses = _poses(6000, 3)
    got = ev.completion.kernel_pose_inputs(poses)
    want = dict(zip([f"R_{i}{j}" for i in range(3) for j in range(3)], c_poses.rotation_entries(poses)))
    assert all(got[k].tobytes() == v.tobytes() for k, v in want.items())
    monkeypatch.setattr(c_poses, "_function", lambda: None)
    numpy = ev.completion.kernel_pose_inputs(poses)
    ref = rotation_entries(poses[:, 3:])
    assert all(numpy[k].tobytes() == v.tobytes() for k, v in zip(want, ref))


@pytest.mark.parametrize("t2, series", [(0.99e-12, True), (1.01e-12, False)])
def test_the_series_is_taken_below_the_threshold_and_the_functions_above(t2, series):
    """R_02 of a rotation about (0.6, 0, 0.8) is b x z alone (y = 0): below t^2 = 1e-12 exactly
    the series' b = 1/2 - t^2/24 times x z; above it (1 - cos t)/t^2, whose cancellation leaves
    it off that value by far more than its rounding (~1e-4 relative at t ~ 1e-6)."""
    axis = np.array([0.6, 0.0, 0.8])
    poses = np.zeros((1, 6))
    poses[0, 3:] = np.sqrt(t2) * axis
    x, _, z = poses[0, 3:]
    tt = x * x + 0.0 * 0.0 + z * z
    r02 = c_poses.rotation_entries(poses)[2][0]
    assert bool(r02 == (0.5 - tt / 24) * (x * z)) == series
