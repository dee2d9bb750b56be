"""The allowed-twist bases in C (:mod:`eigentwist.runtime.c_allowed`) against NumPy's
(:func:`eigentwist.runtime.allowed.allowed_twists`), and against the rule itself: every
column orthonormal and annihilated by every constraint row."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.errors import InputError
from eigentwist.runtime import c_allowed
from eigentwist.runtime.allowed import VANISHING, allowed_twists, coordinate_twists
from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

from .conftest import skip_tier

pytestmark = pytest.mark.compiled


@pytest.fixture(scope="module", autouse=True)
def _driver():
    if c_allowed.driver() is None:
        skip_tier("compiled", "the C allowed-twist driver cannot be built here (no C compiler)")


def _rows(rng, n, c, dependent=()):
    """(n, c, 6) random constraint rows; row k of ``dependent`` (k, (i, j)) is row i + 2 row j."""
    A = rng.standard_normal((n, c, 6))
    for k, (i, j) in dependent:
        A[:, k] = A[:, i] + 2.0 * A[:, j]
    return A


def _both(A, E, **kw):
    return allowed_twists(A, E, compiled=True, **kw), allowed_twists(A, E, compiled=False, **kw)


@pytest.mark.parametrize("n", [1, 63, 64, 65, 150])
def test_c_basis_equals_numpy_and_the_rule(n):
    rng = np.random.default_rng(n)
    A = _rows(rng, n, 4, dependent=[(3, (0, 1))])  # three independent constraints
    E = coordinate_twists(["x", "y", "z", "rot_z"])[:, :3]
    c, py = _both(A, E)
    # round-off grows as the projected candidates near dependence: 1 / their least singular
    # value (the null space's basis from an SVD written here)
    _, _, Vt = np.linalg.svd(A)
    least = np.linalg.svd(Vt[:, 3:] @ E, compute_uv=False)[:, -1]
    assert (np.abs(c - py).max(axis=(1, 2)) <= 1e-14 / least).all()
    # the rule: orthonormal columns that every constraint row annihilates
    # (Gram-Schmidt loses orthogonality in proportion to that conditioning)
    assert (np.abs(np.swapaxes(c, 1, 2) @ c - np.eye(3)).max(axis=(1, 2)) <= 1e-14 / least).all()
    assert np.abs(A @ c).max() < 1e-12 * np.abs(A).max()


def test_no_rows_per_pose_candidates_and_picks():
    rng = np.random.default_rng(7)
    n = 70
    E = rng.standard_normal((n, 6, 2))
    c, py = _both(np.zeros((n, 0, 6)), E)
    assert np.allclose(c, py, atol=1e-14)
    assert np.allclose(c[:, :, 0] * np.linalg.norm(E[:, :, 0], axis=1)[:, None], E[:, :, 0], atol=1e-13)
    # rows picked in place from a leg-shaped array (n, legs, rows, 6): the same as stacking them
    J = rng.standard_normal((n, 3, 4, 6))
    picks = [1, 5, 11]
    stacked = J.reshape(n, 12, 6)[:, picks]
    got = allowed_twists(J, E, compiled=True, picks=picks)
    assert np.allclose(got, allowed_twists(stacked, E), atol=1e-13)
    assert np.allclose(allowed_twists(J, E, picks=picks), allowed_twists(stacked, E), atol=0)


def test_a_row_dependent_at_some_poses_only_and_at_every_pose():
    rng = np.random.default_rng(3)
    n = 100
    A = _rows(rng, n, 3)
    A[::3, 2] = A[::3, 0] - A[::3, 1]  # dependent at every third pose only
    E = coordinate_twists(["x", "y", "z"])
    c, py = _both(A, E)
    assert np.allclose(c, py, atol=1e-13)
    # a row dependent at every pose adds nothing: the same bases without it
    A[:, 2] = 3.0 * A[:, 0]
    assert np.allclose(allowed_twists(A, E, compiled=True), allowed_twists(A[:, :2], E, compiled=True), atol=1e-14)


def test_a_vanishing_projection_is_nan_from_that_column_on():
    """A coordinate the rows fix (its unit twist in their span) gives a NaN column, and so do
    the later columns at that pose; just above the threshold the column is kept."""
    n = 64
    E = coordinate_twists(["x", "y", "z"])
    A = np.zeros((n, 1, 6))
    A[:, 0, 3] = 1.0  # v_x fixed: x cannot move
    A[1, 0, 3:5] = [1.0, 0.5 * VANISHING]  # projection of x: ~0.5 VANISHING, below
    A[2, 0, 3:5] = [1.0, 2.0 * VANISHING]  # ~2 VANISHING: above
    c, py = _both(A, E)
    assert np.array_equal(np.isnan(c), np.isnan(py))
    assert np.isnan(c[0]).all() and np.isnan(c[1]).all()
    assert not np.isnan(c[2][:, 0]).any()  # x kept (nearly v_y: y's projection then vanishes)
    A[3, 0] = np.nan  # a pose whose rows are not finite: NaN, as NumPy
    c, py = _both(A, E)
    assert np.array_equal(np.isnan(c), np.isnan(py))


def test_threads_split_on_blocks_give_the_same_bits():
    rng = np.random.default_rng(5)
    n = 2 * MIN_BLOCKS_PER_THREAD * c_allowed.BLOCK + 17
    A = _rows(rng, n, 3)
    E = coordinate_twists(["x", "y", "rot_z"])
    one = allowed_twists(A, E, compiled=True, threads=1)
    assert np.array_equal(allowed_twists(A, E, compiled=True, threads=2), one)


@pytest.mark.parametrize("m", (3, 6))
def test_the_reduction_on_threads_gives_the_same_bits(m, monkeypatch):
    """B^T X B split over threads on block boundaries (a short last block) equals one
    thread bit for bit, and the poses' results stay in their rows."""
    from eigentwist.runtime import allowed, threads

    rng = np.random.default_rng(m)
    n = 2 * MIN_BLOCKS_PER_THREAD * c_allowed.BLOCK + 17
    X, B = rng.standard_normal((n, 6, 6)), rng.standard_normal((n, 6, m))
    one = c_allowed.reduce(X, B, threads=1)
    counts = []
    run = threads.run_ranges
    monkeypatch.setattr(threads, "run_ranges", lambda call, n, block, t: counts.append(t) or run(call, n, block, t))
    assert np.array_equal(c_allowed.reduce(X, B, threads=2), one)
    assert counts == [2]  # split over both threads
    assert np.array_equal(allowed.reduce(X, B, compiled=True, threads=2), one)
    np.testing.assert_allclose(one[-1], B[-1].T @ X[-1] @ B[-1], rtol=1e-13, atol=1e-13 * np.abs(one).max())


def test_declared_argument_types_are_the_c_declaration():
    from .c_signatures import check

    fn = c_allowed.driver()
    check(c_allowed.SOURCE, "et_allowed_twists", fn.argtypes, fn.restype)


@pytest.mark.parametrize("m", range(1, 7))
def test_c_reduction_is_b_transpose_x_b(m):
    """B^T X B per pose for every basis width, NaN columns (a vanishing twist) spreading as
    in NumPy; the compiled route of ``allowed.reduce`` is this one; bad shapes refused."""
    from eigentwist.runtime import allowed

    rng = np.random.default_rng(m)
    X, B = rng.standard_normal((70, 6, 6)), rng.standard_normal((70, 6, m))
    B[5, :, -1] = np.nan
    want = np.einsum("nia,nij,njb->nab", B, X, B)
    got = c_allowed.reduce(X, B)
    assert got.shape == (70, m, m) and np.array_equal(np.isnan(got), np.isnan(want))
    assert np.isnan(got[5, -1]).all() and np.isnan(got[5, :, -1]).all()
    assert np.allclose(got, want, rtol=1e-13, atol=1e-13 * np.abs(want[np.isfinite(want)]).max(), equal_nan=True)
    assert np.array_equal(allowed.reduce(X, B, compiled=True), got, equal_nan=True)
    assert allowed.reduce(X[:0], B[:0], compiled=True).shape == (0, m, m)
    with pytest.raises(InputError, match=r"reduce takes X \(N, 6, 6\) and B \(N, 6, m <= 6\): got \(70, 6, 6\)"):
        c_allowed.reduce(X, np.zeros((70, 5, m)))
    with pytest.raises(InputError, match=r"got \(70, 6, 6\) and \(70, 6, 7\)"):
        c_allowed.reduce(X, np.zeros((70, 6, 7)))


def test_the_reduction_into_given_rows():
    """``out=``: B^T X B written into the given (N, m, m) rows (a slice of a larger array
    here), bit for bit what it returns otherwise, in C and in NumPy; an array of another shape,
    type or layout refused, naming the expected shape."""
    from eigentwist.runtime import allowed

    rng = np.random.default_rng(9)
    X, B = rng.standard_normal((70, 6, 6)), rng.standard_normal((70, 6, 3))
    whole = np.full((100, 3, 3), -1.0)
    got = c_allowed.reduce(X, B, out=whole[20:90])
    assert got.base is whole and np.array_equal(whole[20:90], c_allowed.reduce(X, B))
    assert (whole[:20] == -1).all() and (whole[90:] == -1).all()
    mine = np.empty((70, 3, 3))
    assert allowed.reduce(X, B, compiled=False, out=mine) is mine
    assert np.array_equal(mine, np.swapaxes(B, 1, 2) @ X @ B)
    ints = (rng.integers(-4, 5, (70, 6, 6)), rng.integers(-4, 5, (70, 6, 3)))  # read as numbers, not as bits
    assert np.array_equal(c_allowed.reduce(*ints), c_allowed.reduce(*(a.astype(float) for a in ints)))
    for bad in (np.empty((70, 3, 4)), np.empty((70, 3, 3), dtype=np.float32), np.empty((70, 3, 3, 2))[..., 0]):
        with pytest.raises(InputError, match=r"out: expected a C-contiguous float64 array of shape \(70, 3, 3\)"):
            c_allowed.reduce(X, B, out=bad)


def test_without_the_driver_the_reduction_is_numpys_and_the_c_one_says_why(monkeypatch):
    """Where the driver cannot be built (no compiler: ``driver()`` None), ``allowed.reduce``
    with ``compiled`` gives NumPy's B^T X B (into ``out`` too) and ``c_allowed.reduce`` refuses,
    naming the missing compiler."""
    from eigentwist.runtime import allowed

    rng = np.random.default_rng(4)
    X, B = rng.standard_normal((5, 6, 6)), rng.standard_normal((5, 6, 2))
    monkeypatch.setattr(c_allowed, "driver", lambda: None)
    want = np.swapaxes(B, 1, 2) @ X @ B
    assert np.array_equal(allowed.reduce(X, B, compiled=True), want)
    into = np.empty((5, 2, 2))
    assert allowed.reduce(X, B, compiled=True, out=into) is into and np.array_equal(into, want)
    with pytest.raises(RuntimeError, match=r"^the C allowed-twist driver could not be built \(no compiler\)$"):
        c_allowed.reduce(X, B)
