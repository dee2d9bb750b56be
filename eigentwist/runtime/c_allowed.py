"""The allowed-twist bases of :mod:`.allowed` in C, for the C backend.

:func:`allowed_twists` computes what :func:`eigentwist.runtime.allowed.allowed_twists`
computes, in one C call over blocks of 64 poses (the pose index innermost: vector code): the
constraint rows orthonormalised by Gram-Schmidt (twice per row; a row within ``rtol`` of
the span so far is a zero vector at that pose), the candidates projected onto their null
space, then orthonormalised in order (a candidate whose projection vanishes gives a NaN
column, and so does every later one at that pose). The arithmetic is NumPy's, in the same
order; the compiler may fuse a multiply and an add, so the two agree to round-off, not bit
for bit (``tests/test_c_allowed.py``).

The driver is plain C99, compiled once into the cache (:mod:`.ccompile`); where it cannot
be built, :func:`driver` is None and the evaluator keeps the NumPy basis.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..errors import InputError
from .addresses import address
from .ccompile import library_once

__all__ = ["driver", "allowed_twists", "reduce", "SOURCE", "BLOCK"]

SOURCE = r"""
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define B 64
#define FOR_L for (int l = 0; l < B; ++l)

/* d[l] = a[l] . b[l] over the six components of twists held as 6 x B arrays */
static void et_dot(const double *a, const double *b, double *d)
{
    FOR_L d[l] = a[l] * b[l];
    for (int i = 1; i < 6; ++i)
        FOR_L d[l] += a[i * B + l] * b[i * B + l];
}

/* For poses [0, n), B at a time (the pose innermost: vector code): the constraint rows of
   pose p are rows[p * stride + 6 * pick[k] + i], k < c; cand (6, m), or (n, 6, m) when
   cand_per_pose; out (n, 6, m) the orthonormal bases of the allowed twists. A row within
   rtol of the span of the rows before it is a zero vector at that pose (a row dependent at
   every pose of the block is left out); a candidate whose projection's norm is not above
   tol_col times its own gives a NaN column, and so does every later one at that pose.
   Returns 0, or 1 when out of memory. */
int et_allowed_twists(int64_t n, const double *rows, int64_t stride, int c, const int *pick, int m,
                      const double *cand, int cand_per_pose, double rtol, double tol_col, double *out)
{
    double *Q = malloc(sizeof(double) * (size_t)(c + m + 2) * 6 * B);
    double *a = malloc(sizeof(double) * (size_t)(c > 0 ? c : 1) * 6 * B);
    if (!Q || !a) {
        free(Q); free(a);
        return 1;
    }
    double *cols = Q + (size_t)c * 6 * B, *v = cols + (size_t)m * 6 * B, *e = v + 6 * B;
    double d[B], norm[B], ref[B];
    for (int64_t b0 = 0; b0 < n; b0 += B) {
        int nb = n - b0 < B ? (int)(n - b0) : B;
        for (int k = 0; k < c; ++k)
            for (int i = 0; i < 6; ++i)
                FOR_L a[(k * 6 + i) * B + l] = l < nb ? rows[(b0 + l) * stride + 6 * pick[k] + i] : 0.0;
        int nq = 0;
        for (int k = 0; k < c; ++k) {
            const double *ak = a + k * 6 * B;
            for (int i = 0; i < 6 * B; ++i)
                v[i] = ak[i];
            for (int pass = 0; pass < 2; ++pass)
                for (int j = 0; j < nq; ++j) {
                    const double *q = Q + j * 6 * B;
                    et_dot(q, v, d);
                    for (int i = 0; i < 6; ++i)
                        FOR_L v[i * B + l] -= d[l] * q[i * B + l];
                }
            et_dot(v, v, norm);
            et_dot(ak, ak, ref);
            int any = 0;
            FOR_L {
                norm[l] = sqrt(norm[l]);
                ref[l] = norm[l] > rtol * sqrt(ref[l]);
                any |= l < nb && ref[l] != 0.0;
            }
            if (!any)
                continue;
            double *q = Q + nq * 6 * B;
            FOR_L d[l] = ref[l] != 0.0 ? 1.0 / norm[l] : 0.0;
            for (int i = 0; i < 6; ++i)
                FOR_L q[i * B + l] = ref[l] != 0.0 ? v[i * B + l] * d[l] : 0.0;
            ++nq;
        }
        for (int k = 0; k < m; ++k) {
            for (int i = 0; i < 6; ++i)
                FOR_L e[i * B + l] = !cand_per_pose ? cand[i * m + k]
                                     : l < nb ? cand[((b0 + l) * 6 + i) * m + k] : 0.0;
            for (int i = 0; i < 6 * B; ++i)
                v[i] = e[i];
            for (int j = 0; j < nq; ++j) {
                const double *q = Q + j * 6 * B;
                et_dot(q, e, d);
                for (int i = 0; i < 6; ++i)
                    FOR_L v[i * B + l] -= q[i * B + l] * d[l];
            }
            for (int j = 0; j < k; ++j) {
                const double *q = cols + j * 6 * B;
                et_dot(q, v, d);
                for (int i = 0; i < 6; ++i)
                    FOR_L v[i * B + l] -= d[l] * q[i * B + l];
            }
            et_dot(v, v, norm);
            et_dot(e, e, ref);
            double *col = cols + k * 6 * B;
            FOR_L {
                norm[l] = sqrt(norm[l]);
                int ok = norm[l] > tol_col * sqrt(ref[l]);
                d[l] = 1.0 / (ok ? norm[l] : 1.0);
                ref[l] = ok;
            }
            for (int i = 0; i < 6; ++i)
                FOR_L col[i * B + l] = ref[l] != 0.0 ? v[i * B + l] * d[l] : NAN;
            for (int i = 0; i < 6; ++i)
                for (int l = 0; l < nb; ++l)
                    out[((b0 + l) * 6 + i) * m + k] = col[i * B + l];
        }
    }
    free(Q); free(a);
    return 0;
}

/* out[p] = B[p]^T (X[p] B[p]) for poses [0, n): X (n, 6, 6), B (n, 6, m), out (n, m, m),
   each row-major and contiguous; m <= 6 (one function per m: fixed loop bounds unroll) */
#define ET_REDUCE(M)                                                                     \
    static void et_reduce_##M(int64_t n, const double *X, const double *Bm, double *out) \
    {                                                                                    \
        for (int64_t p = 0; p < n; ++p) {                                                \
            const double *x = X + 36 * p, *b = Bm + 6 * M * p;                           \
            double *o = out + M * M * p, xb[6][M];                                       \
            for (int i = 0; i < 6; ++i)                                                  \
                for (int k = 0; k < M; ++k) {                                            \
                    double s = 0.0;                                                      \
                    for (int j = 0; j < 6; ++j)                                          \
                        s += x[6 * i + j] * b[M * j + k];                                \
                    xb[i][k] = s;                                                        \
                }                                                                        \
            for (int a = 0; a < M; ++a)                                                  \
                for (int k = 0; k < M; ++k) {                                            \
                    double s = 0.0;                                                      \
                    for (int i = 0; i < 6; ++i)                                          \
                        s += b[M * i + a] * xb[i][k];                                    \
                    o[M * a + k] = s;                                                    \
                }                                                                        \
        }                                                                                \
    }
ET_REDUCE(1)
ET_REDUCE(2)
ET_REDUCE(3)
ET_REDUCE(4)
ET_REDUCE(5)
ET_REDUCE(6)

void et_reduce(int64_t n, int m, const double *X, const double *Bm, double *out)
{
    switch (m) {
    case 1: et_reduce_1(n, X, Bm, out); break;
    case 2: et_reduce_2(n, X, Bm, out); break;
    case 3: et_reduce_3(n, X, Bm, out); break;
    case 4: et_reduce_4(n, X, Bm, out); break;
    case 5: et_reduce_5(n, X, Bm, out); break;
    case 6: et_reduce_6(n, X, Bm, out); break;
    }
}
"""

BLOCK = 64  # poses per block (B in the source): ranges split over threads on its multiples
_DRIVER: list = []  # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []  # the loaded driver library, kept for the process
_REDUCE: list = []  # its et_reduce, bound with the driver


def _bind(lib):
    """et_allowed_twists of the loaded library, its argument and return types declared;
    et_reduce declared too and kept in ``_REDUCE``."""
    fn = lib.et_allowed_twists
    fn.argtypes = [
        ctypes.c_int64,
        ctypes.c_void_p,
        ctypes.c_int64,
        ctypes.c_int,
        ctypes.c_void_p,
        ctypes.c_int,
        ctypes.c_void_p,
        ctypes.c_int,
        ctypes.c_double,
        ctypes.c_double,
        ctypes.c_void_p,
    ]
    fn.restype = ctypes.c_int
    lib.et_reduce.argtypes = [ctypes.c_int64, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    lib.et_reduce.restype = None
    _REDUCE.append(lib.et_reduce)
    return fn


def driver():
    """The compiled driver ``et_allowed_twists`` (built on first use into the cache), or
    None where it cannot be built (no compiler)."""
    return library_once(_DRIVER, _LIBRARIES, SOURCE, "allowed", _bind)


def reduce(X: np.ndarray, B: np.ndarray, threads: int = 1, out: np.ndarray | None = None) -> np.ndarray:
    """``B^T X B`` per pose in C: (N, m, m) from (N, 6, 6) and (N, 6, m), m <= 6; what
    :func:`eigentwist.runtime.allowed.reduce` computes, to round-off; into ``out`` (a
    C-contiguous float64 (N, m, m) array) where given. ``threads`` > 1 splits the poses over
    that many threads (each pose on its own: the same results). Raises RuntimeError where the
    driver cannot be built, InputError for shapes it does not take."""
    from .threads import run_ranges, threads_for

    if driver() is None:
        raise RuntimeError("the C allowed-twist driver could not be built (no compiler)")
    X = np.ascontiguousarray(X, dtype=np.float64)
    B = np.ascontiguousarray(B, dtype=np.float64)
    n, m = len(X), B.shape[-1]
    if X.shape != (n, 6, 6) or B.shape != (n, 6, m) or m > 6:
        raise InputError(f"reduce takes X (N, 6, 6) and B (N, 6, m <= 6): got {X.shape} and {B.shape}")
    if out is None:
        out = np.empty((n, m, m))
    elif out.shape != (n, m, m) or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise InputError(
            f"out: expected a C-contiguous float64 array of shape {(n, m, m)}, got {out.shape} {out.dtype}"
        )
    fn = _REDUCE[-1]

    def call(a: int, b: int) -> None:
        fn(b - a, m, address(X) + 8 * 36 * a, address(B) + 8 * 6 * m * a, address(out) + 8 * m * m * a)

    run_ranges(call, n, BLOCK, threads_for(n, BLOCK, threads))
    return out


def allowed_twists(rows: np.ndarray, candidates: np.ndarray, rtol: float, tol_col: float, picks=None, threads: int = 1):
    """(N, 6, m) orthonormal bases of the allowed twists ``[omega; v]``, computed in C:
    :func:`eigentwist.runtime.allowed.allowed_twists`'s rule (``rows`` (N, c, 6) constraint
    rows, ``candidates`` (6, m) or (N, 6, m), ``rtol`` for dependent rows, ``tol_col`` for a
    vanishing projection). With ``picks`` (indices), the constraint rows are rows ``picks``
    of each pose's ``rows`` (N, ..., 6) read in place (a leg's inverse-Jacobian rows, its
    virtual joints picked). ``threads`` > 1 splits the poses over that many threads, on
    block boundaries (the results do not depend on it). Raises RuntimeError where the driver
    cannot be built or runs out of memory."""
    from .threads import run_ranges, threads_for

    fn = driver()
    if fn is None:
        raise RuntimeError("the C allowed-twist driver could not be built (no compiler)")
    n = len(rows)
    A = np.ascontiguousarray(rows, dtype=np.float64).reshape(n, -1)
    stride = A.shape[1]
    picks = np.arange(stride // 6) if picks is None else np.asarray(picks)
    pick = (ctypes.c_int * max(len(picks), 1))(*(int(k) for k in picks))
    E = np.ascontiguousarray(candidates, dtype=np.float64)
    per_pose = E.ndim == 3
    m = E.shape[-1]
    out = np.empty((n, 6, m))

    def call(a: int, b: int) -> int:
        return fn(
            b - a,
            address(A) + 8 * a * stride,
            stride,
            len(picks),
            pick,
            m,
            address(E) + (8 * a * 6 * m if per_pose else 0),
            int(per_pose),
            float(rtol),
            float(tol_col),
            address(out) + 8 * a * 6 * m,
        )

    for rc in run_ranges(call, n, BLOCK, threads_for(n, BLOCK, threads)):
        if rc != 0:
            raise RuntimeError("the C allowed-twist driver ran out of memory")
    return out
