"""6-DoF poses: rotation vectors, Rodrigues' formula and the exponential map."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime.poses import exp_twist, rotation_entries, rotation_matrix, rotation_vector


def test_rotation_matrix_is_a_rotation_about_its_vector():
    rng = np.random.default_rng(7)
    r = rng.normal(size=(5, 3))
    r *= 3.0 * rng.random((5, 1)) / np.linalg.norm(r, axis=1, keepdims=True)  # angles below pi
    R = rotation_matrix(r)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, rtol=1e-14)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, r), r, atol=1e-14)  # the axis stays put
    for k in range(5):
        np.testing.assert_allclose(rotation_vector(R[k]), r[k], atol=1e-10)


def test_small_angles_use_the_series():
    r = np.array([1e-9, -2e-9, 3e-9])
    K = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    np.testing.assert_allclose(rotation_matrix(r), np.eye(3) + K, atol=1e-17)
    np.testing.assert_array_equal(rotation_matrix(np.zeros(3)), np.eye(3))


def test_rotation_entries_written_in_place_are_the_matrix_entries():
    r = np.random.default_rng(2).normal(size=(7, 3))
    r[0] = 0.0  # the series
    out = [np.full(7, np.nan) for _ in range(9)]
    got = rotation_entries(r, out)
    assert all(g is o for g, o in zip(got, out))
    np.testing.assert_array_equal(np.stack(out, -1).reshape(7, 3, 3), rotation_matrix(r))
    np.testing.assert_array_equal(np.stack(rotation_entries(r), -1).reshape(7, 3, 3), rotation_matrix(r))


def test_exp_twist_moves_the_origin_by_v_and_turns_by_omega():
    pose = np.array([0.1, -0.2, 0.8, 0.05, 0.1, -0.2])
    twist = np.array([0.3, -0.1, 0.2, 0.01, 0.02, -0.03])
    eps = 1e-6
    a, b = exp_twist(pose, twist, -eps), exp_twist(pose, twist, eps)
    np.testing.assert_allclose((b[:3] - a[:3]) / (2 * eps), twist[3:], atol=1e-9)
    Rdot = (rotation_matrix(b[3:]) - rotation_matrix(a[3:])) / (2 * eps)
    W = Rdot @ rotation_matrix(pose[3:]).T  # [omega]x in base axes
    np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], twist[:3], rtol=1e-7)
    assert exp_twist(pose, twist, 0.0) == pytest.approx(pose, abs=1e-15)


@pytest.mark.parametrize("extra", [0, 5])
def test_a_batchs_rotation_entries_either_side_of_one_chunk(extra):
    """The kernels' pose inputs of a 6-DoF robot: one batch of one chunk, or chunks side by
    side on the threads past it; the entries of Rodrigues' matrix either way."""
    import eigentwist
    from eigentwist.runtime.completion import CHUNK

    ev = eigentwist.load("hexapod", backend="numpy", threads=2)
    poses = np.zeros((CHUNK + extra, 6))
    poses[:, 3:] = np.random.default_rng(extra).uniform(-0.3, 0.3, (len(poses), 3))
    got = ev.kernel_pose_inputs(poses)
    R = rotation_matrix(poses[:, 3:])
    for i in range(3):
        for j in range(3):
            np.testing.assert_array_equal(got[f"R_{i}{j}"], R[:, i, j])
    np.testing.assert_array_equal(got["rot_y"], poses[:, 4])
