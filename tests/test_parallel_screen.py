"""The parallel screen of the C pass's results (eigentwist.runtime.evaluator.above_screen)."""

from __future__ import annotations

import numpy as np

from eigentwist.runtime.evaluator import PARALLEL_SCREEN, above_screen


def test_the_screen_is_the_rows_lowest_against_their_highest():
    rng = np.random.default_rng(3)
    freq = rng.uniform(1.0, 100.0, (500, 6))
    freq[::7, rng.integers(0, 6)] = 1e-4  # some rows with a mode far below the others
    want = np.array([row.min() > PARALLEL_SCREEN * row.max() for row in freq])
    assert 0 < want.sum() < len(freq)
    np.testing.assert_array_equal(above_screen(freq), want)


def test_either_side_of_the_screen_and_nan_in_any_column():
    row = np.array([1.0, 5.0, 20.0, 50.0, 70.0, 100.0])
    inside, outside = row.copy(), row.copy()
    inside[0], outside[0] = PARALLEL_SCREEN * 100.0 * 1.001, PARALLEL_SCREEN * 100.0 * 0.999
    freq = np.array([row, inside, outside] + [np.where(np.arange(6) == j, np.nan, row) for j in range(6)])
    assert above_screen(freq).tolist() == [True, True, False] + [False] * 6
    assert above_screen(np.array([[3.0]])).tolist() == [True]  # one mode: its own highest
    assert above_screen(np.empty((0, 6))).shape == (0,)
