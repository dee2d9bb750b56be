"""A sweep's poses by index (``runtime/sweep/poseset.py``): the grid's order and ends, and random
poses drawn from seeded blocks, checked against NumPy's generator called here as documented."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime.sweep.poseset import POSE_BLOCK, PoseSet

BOX = ((-0.1, 0.1), (0.0, 0.3), (-0.7, -0.5))


def test_a_grid_includes_its_ends_and_runs_the_last_axis_fastest():
    s = PoseSet("grid", BOX, shape=(2, 1, 3))
    assert s.count == 6
    assert s.axis(0).tolist() == [-0.1, 0.1] and s.axis(1).tolist() == [0.15]  # one point: the middle
    assert s.axis(2) == pytest.approx([-0.7, -0.6, -0.5])
    x, y, z = np.meshgrid(s.axis(0), s.axis(1), s.axis(2), indexing="ij")
    expected = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    assert np.array_equal(s.take(np.arange(6)), expected)
    assert np.array_equal(s.take([5, 0]), expected[[5, 0]])


def test_a_six_coordinate_grid():
    box = BOX + ((0.0, 0.2), (-0.1, 0.1), (0.5, 0.5))
    s = PoseSet("grid", box, shape=(1, 1, 1, 2, 1, 1))
    assert s.count == 2
    assert s.take([1]).tolist() == [[0.0, 0.15, -0.6, 0.2, 0.0, 0.5]]


def test_random_poses_come_from_seeded_blocks():
    s = PoseSet("random", BOX, n=POSE_BLOCK + 10, seed=7)
    assert s.count == POSE_BLOCK + 10
    index = np.array([3, POSE_BLOCK - 1, POSE_BLOCK, POSE_BLOCK + 9])
    first = np.random.default_rng([7, 0]).random((POSE_BLOCK, 3))
    second = np.random.default_rng([7, 1]).random((POSE_BLOCK, 3))
    unit = np.vstack([first[[3, POSE_BLOCK - 1]], second[[0, 9]]])
    lo, hi = np.array(BOX).T
    assert np.array_equal(s.take(index), lo + (hi - lo) * unit)
    # any chunking gives the same rows; another seed other rows
    assert np.array_equal(np.vstack([s.take(index[:1]), s.take(index[1:])]), s.take(index))
    assert not np.array_equal(PoseSet("random", BOX, n=5, seed=8).take([3]), s.take([3]))


def test_random_poses_in_six_coordinates():
    box = BOX + ((0.0, 0.2), (-0.1, 0.1), (0.5, 0.6))
    s = PoseSet("random", box, n=4, seed=1)
    unit = np.random.default_rng([1, 0]).random((POSE_BLOCK, 6))[:4]
    lo, hi = np.array(box).T
    assert np.array_equal(s.take(np.arange(4)), lo + (hi - lo) * unit)


def test_the_cached_block_cannot_be_written():
    from eigentwist.runtime.sweep.poseset import _random_block

    with pytest.raises(ValueError):
        _random_block(0, 0)[0, 0] = 1.0
    assert _random_block(0, 0).shape == (POSE_BLOCK, 3)


@pytest.mark.parametrize("kind", ["grid", "random"])
def test_indices_as_floats_or_none_at_all(kind):
    s = PoseSet(kind, BOX, shape=(2, 1, 3), n=6, seed=2)
    assert np.array_equal(s.take(np.array([5.0, 0.0])), s.take([5, 0]))
    assert s.take([]).shape == (0, 3)
