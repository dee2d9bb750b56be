"""The followers' iterations in C (``et_followers_lm``, :func:`eigentwist.runtime.c_levenberg_marquardt.follow`)
against NumPy's (:func:`eigentwist.runtime.levenberg_marquardt._iterate` around
:func:`eigentwist.runtime.platform._follower_closure`) on a followers kernel written here: three
rotation followers and one position follower, so that every column of the left Jacobian and
Rodrigues' formula in C are exercised (a 3-PRS has only rot_z)."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from eigentwist.runtime import c_levenberg_marquardt as clm
from eigentwist.runtime import ccompile
from eigentwist.runtime.levenberg_marquardt import _iterate
from eigentwist.runtime.platform import MAX_STEPS, TOL_M, _follower_closure

from .conftest import skip_tier

pytestmark = pytest.mark.compiled

#: unit vectors b_k: closure k is (R e_k) . b_k - c_k (k < 3) and x - c_3
B = np.array([[0.6, 0.8, 0.0], [0.0, 0.6, 0.8], [0.8, 0.0, 0.6]])

#: inputs x, y, z, R_00 .. R_22 (roles 0-11), then c_0 .. c_3 read by address
KERNEL = r"""
#include <stdint.h>
static const double b[3][3] = {{0.6, 0.8, 0.0}, {0.0, 0.6, 0.8}, {0.8, 0.0, 0.6}};
int closure(int64_t n, const double *const *in, const int64_t *st, double *const *out)
{
    for (int64_t i = 0; i < n; ++i) {
        double R[3][3];
        for (int e = 0; e < 9; ++e)
            R[e / 3][e % 3] = in[3 + e][i * st[3 + e]];
        double *r = out[0] + 4 * i, *g = out[1] + 24 * i;
        for (int k = 0; k < 3; ++k) {
            const double col[3] = {R[0][k], R[1][k], R[2][k]};
            r[k] = col[0] * b[k][0] + col[1] * b[k][1] + col[2] * b[k][2] - in[12 + k][i * st[12 + k]];
            /* rate along omega: (R e_k) x b_k; along v: 0 */
            g[6 * k + 0] = col[1] * b[k][2] - col[2] * b[k][1];
            g[6 * k + 1] = col[2] * b[k][0] - col[0] * b[k][2];
            g[6 * k + 2] = col[0] * b[k][1] - col[1] * b[k][0];
            g[6 * k + 3] = g[6 * k + 4] = g[6 * k + 5] = 0.0;
        }
        r[3] = in[0][i * st[0]] - in[15][i * st[15]];
        for (int j = 0; j < 6; ++j)
            g[18 + j] = j == 3;
    }
    return 0;
}

/* the same on one block as the generated block functions lay it out: in[k][i] for lane i,
   closure row k in out[k], its rate j in out[4 + 6 k + j] */
int closure_block(int nb, const double *const *in, double *const *out)
{
    const int64_t one[16] = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
    for (int i = 0; i < nb; ++i) {
        const double *at[16];
        for (int k = 0; k < 16; ++k)
            at[k] = in[k] + i;
        double r[4], g[24];
        double *pose_out[2] = {r, g};
        closure(1, at, one, pose_out);
        for (int k = 0; k < 4; ++k)
            out[k][i] = r[k];
        for (int e = 0; e < 24; ++e)
            out[4 + e][i] = g[e];
    }
    return 0;
}
"""


def numpy_closure(x, y, z, p):
    """The same kernel in NumPy, with the generated kernels' signature."""
    R = np.stack([np.stack([p[f"R_{i}{j}"] for j in range(3)], -1) for i in range(3)], -2)  # (n, 3, 3)
    cols = np.swapaxes(R, 1, 2)  # row k: R e_k
    r = np.concatenate([np.einsum("nki,ki->nk", cols, B) - np.stack([p[f"c_{k}"] for k in range(3)], -1)], -1)
    r = np.concatenate([r, (x - p["c_3"])[:, None]], -1)
    g = np.zeros((len(x), 4, 6))
    g[:, :3, :3] = np.cross(cols, B[None])
    g[:, 3, 3] = 1.0
    return {"closure": r, "closure_rate": g}


@pytest.fixture(scope="module")
def kernel():
    if clm.followers_driver() is None:
        skip_tier("compiled", "the C Newton driver cannot be built here (no C compiler)")
    lib = ccompile.load_library(KERNEL, "followers_test")
    if lib is None:
        skip_tier("compiled", "the test kernel cannot be built here")
    return lib


def _problem(n, seed):
    """Commanded (y, z) and targets c_k from known rotations (up to ~0.4 rad) and x."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    phi = 0.4 * (rng.random((n, 3)) - 0.5)
    phi[:3] = [[0.0, 0.0, 0.0], [1e-7, -2e-7, 0.0], [0.0, 0.0, 3e-6]]  # at and near zero rotation
    R = Rotation.from_rotvec(phi).as_matrix()
    c = np.einsum("nik,ki->nk", R, B)  # (R e_k) . b_k
    x = rng.random(n) - 0.5
    full = np.zeros((n, 6))
    full[:, 1:3] = rng.random((n, 2))  # commanded y, z: the kernel does not read them
    return full, {"c_0": c[:, 0], "c_1": c[:, 1], "c_2": c[:, 2], "c_3": x}, phi, x


@pytest.mark.parametrize("n", [5, 64, 130])
def test_c_followers_equal_numpy_and_close_the_loop(kernel, n):
    followers = [3, 0, 4, 5]  # rot_x, x, rot_y, rot_z: the unknowns in this order
    full, p, phi, x = _problem(n, seed=n)
    q0 = np.zeros((n, 1, 4))
    closure = _follower_closure(numpy_closure, followers)
    want_q, want_norm = _iterate(closure, q0, {**p, "_full": full}, MAX_STEPS, TOL_M)
    keep = [np.ascontiguousarray(p[f"c_{k}"]) for k in range(4)]
    roles = [0, 1, 2, *range(3, 12), -1, -1, -1, -1]
    addresses = [0] * 12 + [a.ctypes.data for a in keep]
    strides = [0] * 12 + [1] * 4
    address = ctypes.cast(kernel.closure, ctypes.c_void_p).value
    block = ctypes.cast(kernel.closure_block, ctypes.c_void_p).value
    got_q, got_norm = clm.follow(address, None, roles, addresses, strides, followers, full, q0, 4, MAX_STEPS, TOL_M)
    by_block = clm.follow(address, block, roles, addresses, strides, followers, full, q0, 4, MAX_STEPS, TOL_M)
    assert np.array_equal(by_block[0], got_q) and np.array_equal(by_block[1], got_norm)  # the same steps
    assert (want_norm < TOL_M).all() and (got_norm < TOL_M).all()
    np.testing.assert_allclose(got_q, want_q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got_q[:, 0, 1], x, rtol=0, atol=1e-12)  # the position follower
    np.testing.assert_allclose(got_q[:, 0, [0, 2, 3]], phi, rtol=0, atol=1e-9)  # the rotation it was made from
    # two iterations only: the path, not just the root, is NumPy's (the same residuals and Jacobians)
    want_q, want_norm = _iterate(closure, q0, {**p, "_full": full}, 2, TOL_M)
    got_q, got_norm = clm.follow(address, block, roles, addresses, strides, followers, full, q0, 4, 2, TOL_M)
    assert (want_norm > 1e-9).any()  # not converged: the steps themselves are compared
    np.testing.assert_allclose(got_q, want_q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got_norm, want_norm, rtol=1e-9, atol=1e-15)


def test_c_followers_do_not_depend_on_a_poses_lane(kernel):
    """Each pose's iterations are its own whatever its lane in a block: the batch shifted by
    three poses (every pose in another lane, the blocks cut elsewhere) gives the same bits.
    Every lane of the driver's rotation loop takes the same vector sine and cosine; a path
    computing some lanes otherwise (a scalar remainder) would break it."""
    followers = [3, 0, 4, 5]
    n = 140
    full, p, _, _ = _problem(n, seed=7)
    q0 = np.zeros((n, 1, 4))
    keep = [np.ascontiguousarray(p[f"c_{k}"]) for k in range(4)]
    roles = [0, 1, 2, *range(3, 12), -1, -1, -1, -1]
    strides = [0] * 12 + [1] * 4
    address = ctypes.cast(kernel.closure, ctypes.c_void_p).value
    block = ctypes.cast(kernel.closure_block, ctypes.c_void_p).value

    def run(first):  # the poses from `first` on
        ins = [0] * 12 + [a[first:].ctypes.data for a in keep]
        return clm.follow(address, block, roles, ins, strides, followers, full[first:], q0[first:], 4, MAX_STEPS, TOL_M)

    whole, shifted = run(0), run(3)
    assert np.array_equal(shifted[0], whole[0][3:]) and np.array_equal(shifted[1], whole[1][3:])


CUBIC = r"""
#include <stdint.h>
/* one closure row, r = (x - c)^3 (a triple root: Newton divides the gap by 3/2 a step) */
int closure(int64_t n, const double *const *in, const int64_t *st, double *const *out)
{
    for (int64_t i = 0; i < n; ++i) {
        const double gap = in[0][i * st[0]] - in[12][i * st[12]];
        out[0][i] = gap * gap * gap;
        for (int j = 0; j < 6; ++j)
            out[1][6 * i + j] = j == 3 ? 3 * gap * gap : 0.0;
    }
    return 0;
}
"""


def test_c_followers_hand_a_slow_leg_back_to_the_damped_steps_as_numpy_does():
    """r = (x - c)^3 from |r| below EARLY: the undamped step leaves it above TOL_M, the damped
    steps resume (:func:`~eigentwist.runtime.levenberg_marquardt._iterate`); the C driver takes
    the same steps, and a pose above EARLY beside it its own."""
    from eigentwist.runtime.levenberg_marquardt import EARLY

    if clm.followers_driver() is None:
        skip_tier("compiled", "the C Newton driver cannot be built here (no C compiler)")
    lib = ccompile.load_library(CUBIC, "followers_cubic_test")
    c = np.array([0.1, -0.2, 0.05])
    gap = np.array([(0.5 * EARLY) ** (1 / 3), (5 * EARLY) ** (1 / 3), 0.02])
    full = np.zeros((3, 6))
    q0 = (c + gap)[:, None, None]

    def cubic(x, y, z, p):
        g = np.zeros((len(x), 1, 6))
        g[:, 0, 3] = 3 * (x - p["c"]) ** 2
        return {"closure": ((x - p["c"]) ** 3)[:, None], "closure_rate": g}

    want_q, want_norm = _iterate(_follower_closure(cubic, [0]), q0, {"c": c, "_full": full}, MAX_STEPS, TOL_M)
    keep = np.ascontiguousarray(c)
    address = ctypes.cast(lib.closure, ctypes.c_void_p).value
    roles = [0, 1, 2, *range(3, 12), -1]
    got_q, got_norm = clm.follow(
        address, None, roles, [0] * 12 + [keep.ctypes.data], [0] * 12 + [1], [0], full, q0, 1, MAX_STEPS, TOL_M
    )
    assert (want_norm < TOL_M).all() and (got_norm < TOL_M).all()
    np.testing.assert_allclose(got_q, want_q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(got_norm, want_norm, rtol=1e-9, atol=1e-30)
