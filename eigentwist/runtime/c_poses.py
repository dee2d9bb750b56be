"""The rotation matrix entries of a batch of 6-DoF poses in C.

:func:`rotation_entries` computes what :func:`eigentwist.runtime.poses.rotation_entries` computes
(Rodrigues' formula ``R = I + a [r]x + b [r]x^2``, ``a = sin(t)/t``, ``b = (1 - cos t)/t^2``,
their series below ``t^2 = 1e-12``), with the same operations in the same order and no fused
multiply-adds, one pose after another in C: a few C calls for a batch on the threads instead
of some forty NumPy operations a range, each taking the GIL. The sine and cosine are the C
library's; where NumPy's are its own (SIMD builds on some CPUs) the two may differ in the last
bit. Where the library cannot be built, :func:`rotation_entries` returns None and the NumPy
function runs.
"""

from __future__ import annotations

import ctypes

import numpy as np

from .addresses import address
from .ccompile import library_once

__all__ = ["rotation_entries", "RODRIGUES", "SOURCE"]

#: Rodrigues' formula on one rotation vector, the C shared by this module's library and the
#: followers' Newton driver (:mod:`.c_levenberg_marquardt`)
RODRIGUES = r"""
/* e[3 i + j] = R_ij of the rotation vector (x, y, z) (rad), R = I + a [r]x + b [r]x^2, given
   a = sin(t)/t and b = (1 - cos t)/t^2 */
static inline void et_rotation_ab(double x, double y, double z, double a, double b, double *e)
{
    const double xx = x * x, yy = y * y, zz = z * z;
    e[0] = 1 + b * (-zz - yy);
    e[1] = -(a * z) + b * (x * y);
    e[2] = a * y + b * (x * z);
    e[3] = a * z + b * (x * y);
    e[4] = 1 + b * (-zz - xx);
    e[5] = -(a * x) + b * (y * z);
    e[6] = -(a * y) + b * (x * z);
    e[7] = a * x + b * (y * z);
    e[8] = 1 + b * (-yy - xx);
}

/* Rodrigues' a = sin(t)/t and b = (1 - cos t)/t^2 from t^2, t, sin t and cos t (their series
   below t^2 = 1e-12) */
static inline void et_rodrigues_ab(double t2, double t, double sn, double cs, double *a, double *b)
{
    *a = t2 < 1e-12 ? 1 - t2 / 6 : sn / t;
    *b = t2 < 1e-12 ? 0.5 - t2 / 24 : (1 - cs) / (t * t);
}

/* e[3 i + j] = R_ij of the rotation vector (x, y, z) (rad): et_rotation_ab with
   et_rodrigues_ab's a and b */
static inline void et_rodrigues(double x, double y, double z, double *e)
{
    const double t2 = x * x + y * y + z * z, t = sqrt(t2);
    double a, b;
    et_rodrigues_ab(t2, t, sin(t), cos(t), &a, &b);
    et_rotation_ab(x, y, z, a, b, e);
}
"""

SOURCE = (
    r"""
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
#include <math.h>
#include <stdint.h>
"""
    + RODRIGUES
    + r"""
/* R_ij (9 arrays of n, R[3 i + j][k] for pose k) of rotation vectors r (pose k at r + k * stride,
   3 contiguous values, rad). */
void et_rotation_entries(int64_t n, const double *r, int64_t stride, double *const *R)
{
    for (int64_t k = 0; k < n; ++k) {
        double e[9];
        et_rodrigues(r[k * stride], r[k * stride + 1], r[k * stride + 2], e);
        for (int j = 0; j < 9; ++j)
            R[j][k] = e[j];
    }
}
"""
)

_FN: list = []  # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []


def _bind(lib):
    """et_rotation_entries of the loaded library, its argument and return types declared."""
    fn = lib.et_rotation_entries
    fn.argtypes = [ctypes.c_int64, ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p]
    fn.restype = None
    return fn


def _function():
    """The compiled ``et_rotation_entries`` (built on first use into the cache), or None where
    it cannot be built."""
    return library_once(_FN, _LIBRARIES, SOURCE, "poses", _bind)


def rotation_entries(poses: np.ndarray, threads: int = 1, block: int = 256) -> list | None:
    """The nine entries ``[R_00, ..., R_22]`` ((n,) arrays) of the rotation vectors in
    columns 3 to 5 of ``poses`` (n, 6) (rad), in C, ranges of whole ``block`` poses on
    ``threads`` threads (:func:`~.threads.run_ranges`, :func:`~.threads.threads_for`; every
    pose on its own: the same values on any count); None where the C library cannot be built."""
    from .threads import run_ranges, threads_for

    fn = _function()
    if fn is None:
        return None
    arr = np.asarray(poses, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 6 or arr.strides[1] != 8 or arr.strides[0] % 8:
        arr = np.ascontiguousarray(arr, dtype=np.float64)
    n, stride = len(arr), arr.strides[0] // 8
    entries = [np.empty(n) for _ in range(9)]
    table = (ctypes.c_void_p * 9)(*(address(e) for e in entries))
    base = address(arr) + 8 * 3 if n else 0

    def call(begin: int, end: int) -> None:
        moved = (ctypes.c_void_p * 9)(*(table[k] + 8 * begin for k in range(9)))
        fn(end - begin, base + 8 * stride * begin, stride, moved)

    if n:
        run_ranges(call, n, block, threads_for(n, block, threads))
    return entries
