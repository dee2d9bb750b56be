"""The damped Newton iterations of :mod:`.newton` in C, around a robot's compiled closure.

:func:`iterate` (through :meth:`~eigentwist.runtime.cbackend.CKernels.newton`) runs :func:`eigentwist.runtime.newton._iterate`'s algorithm (the same
Levenberg-Marquardt steps, acceptance rule, damping updates, bounded steps and final
undamped polish, per (pose, leg)) in one C call per batch: blocks of 64 poses, each
iterated to convergence with its joint coordinates kept in a structure-of-arrays buffer
that the generated ``loop_closure`` kernel of the robot's C library reads in place (the
driver calls it through its address). The small normal equations are solved by
Cholesky. No Python runs between iterations; the results equal the NumPy iterations' to
round-off (``tests/test_numeric_ik.py``).

The driver is plain C99, compiled once into the cache (:mod:`.ccompile`); where it cannot
be built, :func:`driver` is None and the NumPy iterations run.
"""
from __future__ import annotations

import ctypes

import numpy as np

from .newton import LAMBDA0, MAX_STEP

__all__ = ["driver", "iterate", "SOURCE"]

SOURCE = r"""
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef int (*et_kernel)(int64_t, const double *const *, const int64_t *, double *const *);

#define B 64

/* x = -(A^T A + diag(scale * diag(A^T A) + shift))^-1 A^T r for one (rows x nq) A (row
   major) and r; returns 0 when the matrix is not finite (x = -A^T r, as numpy's H = I),
   1 when solved (NaN entries when it is not positive definite). */
static int et_step(int rows, int nq, const double *A, const double *r, double scale, double shift, double *x)
{
    double H[64], L[64], g[8], y[8];
    int finite = 1;
    for (int i = 0; i < nq; ++i) {
        for (int j = 0; j <= i; ++j) {
            double s = A[i] * A[j];
            for (int k = 1; k < rows; ++k)
                s += A[k * nq + i] * A[k * nq + j];
            H[i * nq + j] = s;
        }
        double s = A[i] * r[0];
        for (int k = 1; k < rows; ++k)
            s += A[k * nq + i] * r[k];
        g[i] = s;
    }
    for (int i = 0; i < nq; ++i) {
        H[i * nq + i] = H[i * nq + i] + (scale * H[i * nq + i] + shift);
        for (int j = 0; j <= i; ++j)
            finite &= isfinite(H[i * nq + j]) ? 1 : 0;
    }
    if (!finite) {
        for (int i = 0; i < nq; ++i)
            x[i] = -g[i];
        return 0;
    }
    double inv_d[8];
    for (int j = 0; j < nq; ++j) {
        double s = H[j * nq + j];
        for (int k = 0; k < j; ++k)
            s = s - L[j * nq + k] * L[j * nq + k];
        L[j * nq + j] = sqrt(s);
        const double inv = 1.0 / L[j * nq + j];
        inv_d[j] = inv;
        for (int i = j + 1; i < nq; ++i) {
            double t = H[i * nq + j];
            for (int k = 0; k < j; ++k)
                t = t - L[i * nq + k] * L[j * nq + k];
            L[i * nq + j] = t * inv;
        }
    }
    for (int i = 0; i < nq; ++i) {
        double s = g[i];
        for (int k = 0; k < i; ++k)
            s = s - L[i * nq + k] * y[k];
        y[i] = s * inv_d[i];
    }
    for (int i = nq - 1; i >= 0; --i) {
        double s = y[i];
        for (int k = i + 1; k < nq; ++k)
            s = s - L[k * nq + i] * x[k];
        x[i] = s * inv_d[i];
    }
    for (int i = 0; i < nq; ++i)
        x[i] = -x[i];
    return 1;
}

static double et_norm(int rows, const double *r)
{
    double s = 0.0;
    for (int k = 0; k < rows; ++k)
        s += r[k] * r[k];
    return sqrt(s);
}

/* Point the closure's inputs at block b0 (m poses): joint coordinates from the SoA buffer
   qs ((legs * nq) rows of B), the others from the caller's arrays. */
static void et_point(int n_in, const int *q_of, const double *const *in, const int64_t *stride, int64_t b0,
                     const double *qs, const double **ptr, int64_t *st)
{
    for (int k = 0; k < n_in; ++k) {
        if (q_of[k] >= 0) {
            ptr[k] = qs + (int64_t)q_of[k] * B;
            st[k] = 1;
        } else {
            ptr[k] = in[k] + b0 * stride[k];
            st[k] = stride[k];
        }
    }
}

int et_newton_lm(int64_t n, void *closure_address, int n_in, const double *const *in, const int64_t *stride,
                 const int *q_of, int legs, int rows, int nq, double *q, double *norm, int iterations,
                 double tol, double lambda0, double max_step)
{
    et_kernel closure = (et_kernel)closure_address;
    if (nq > 8 || rows > 64 || nq * rows > 512)
        return -1;
    const int lq = legs * nq, lr = legs * rows;
    double *qs = malloc(sizeof(double) * (size_t)(2 * lq * B));
    double *res = malloc(sizeof(double) * (size_t)(2 * B * lr * (1 + nq)));
    double *lam = malloc(sizeof(double) * (size_t)(2 * B * legs));
    const double **ptr = malloc(sizeof(double *) * (size_t)(n_in > 0 ? n_in : 1));
    int64_t *st = malloc(sizeof(int64_t) * (size_t)(n_in > 0 ? n_in : 1));
    char *act = malloc((size_t)(B * legs));
    if (!qs || !res || !lam || !ptr || !st || !act) {
        free(qs); free(res); free(lam); free(ptr); free(st); free(act);
        return -2;
    }
    double *qt = qs + lq * B;                       /* trial coordinates */
    double *r = res, *A = r + B * lr;               /* current residual and Jacobian (AoS per pose) */
    double *rt = A + B * lr * nq, *At = rt + B * lr; /* at the trial */
    double *nrm = lam + B * legs;
    double *outs[2];
    int rc = 0;
    for (int64_t b0 = 0; b0 < n && rc == 0; b0 += B) {
        const int m = n - b0 < B ? (int)(n - b0) : B;
        for (int i = 0; i < m; ++i)
            for (int c = 0; c < lq; ++c)
                qs[c * B + i] = q[(b0 + i) * lq + c];
        et_point(n_in, q_of, in, stride, b0, qs, ptr, st);
        outs[0] = r; outs[1] = A;
        if ((rc = closure(m, ptr, st, outs)) != 0)
            break;
        for (int i = 0; i < m * legs; ++i) {
            nrm[i] = et_norm(rows, r + (int64_t)i * rows);
            lam[i] = lambda0;
        }
        for (int it = 0; it < iterations; ++it) {
            int any = 0;
            for (int i = 0; i < m; ++i) {
                for (int l = 0; l < legs; ++l) {
                    const int e = i * legs + l;
                    act[e] = !(nrm[e] < tol) && isfinite(nrm[e]);
                    double step[8];
                    if (act[e]) {
                        any = 1;
                        et_step(rows, nq, A + (int64_t)e * rows * nq, r + (int64_t)e * rows, lam[e], 1e-12 * lam[e],
                                step);
                        double big = 0.0;             /* a NaN entry makes the trial NaN: rejected */
                        for (int j = 0; j < nq; ++j)
                            big = fabs(step[j]) > big ? fabs(step[j]) : big;
                        if (big > max_step)
                            for (int j = 0; j < nq; ++j)
                                step[j] = step[j] * (max_step / big);
                    }
                    for (int j = 0; j < nq; ++j)
                        qt[(l * nq + j) * B + i] = qs[(l * nq + j) * B + i] + (act[e] ? step[j] : 0.0);
                }
            }
            if (!any)
                break;
            et_point(n_in, q_of, in, stride, b0, qt, ptr, st);
            outs[0] = rt; outs[1] = At;
            if ((rc = closure(m, ptr, st, outs)) != 0)
                break;
            for (int i = 0; i < m; ++i) {
                for (int l = 0; l < legs; ++l) {
                    const int e = i * legs + l;
                    const double nn = et_norm(rows, rt + (int64_t)e * rows);
                    const int better = act[e] && nn < nrm[e];
                    if (better) {
                        for (int j = 0; j < nq; ++j)
                            qs[(l * nq + j) * B + i] = qt[(l * nq + j) * B + i];
                        memcpy(r + (int64_t)e * rows, rt + (int64_t)e * rows, sizeof(double) * (size_t)rows);
                        memcpy(A + (int64_t)e * rows * nq, At + (int64_t)e * rows * nq,
                               sizeof(double) * (size_t)(rows * nq));
                        nrm[e] = nn;
                        lam[e] = lam[e] / 4 > 1e-12 ? lam[e] / 4 : 1e-12;
                    } else if (act[e]) {
                        lam[e] = lam[e] * 4 < 1e12 ? lam[e] * 4 : 1e12;
                    }
                }
            }
        }
        if (rc != 0)
            break;
        /* one undamped Gauss-Newton step polishes a converged configuration */
        int any = 0;
        for (int i = 0; i < m; ++i) {
            for (int l = 0; l < legs; ++l) {
                const int e = i * legs + l;
                double step[8];
                act[e] = nrm[e] < tol;
                if (act[e]) {
                    any = 1;
                    et_step(rows, nq, A + (int64_t)e * rows * nq, r + (int64_t)e * rows, 0.0, 1e-300, step);
                }
                for (int j = 0; j < nq; ++j)
                    qt[(l * nq + j) * B + i] = qs[(l * nq + j) * B + i] + (act[e] ? step[j] : 0.0);
            }
        }
        if (any) {
            et_point(n_in, q_of, in, stride, b0, qt, ptr, st);
            outs[0] = rt; outs[1] = At;
            if ((rc = closure(m, ptr, st, outs)) != 0)
                break;
            for (int i = 0; i < m; ++i)
                for (int l = 0; l < legs; ++l) {
                    const int e = i * legs + l;
                    const double nn = et_norm(rows, rt + (int64_t)e * rows);
                    if (act[e] && nn <= nrm[e]) {
                        for (int j = 0; j < nq; ++j)
                            qs[(l * nq + j) * B + i] = qt[(l * nq + j) * B + i];
                        nrm[e] = nn;
                    }
                }
        }
        for (int i = 0; i < m; ++i) {
            for (int c = 0; c < lq; ++c)
                q[(b0 + i) * lq + c] = qs[c * B + i];
            for (int l = 0; l < legs; ++l)
                norm[(b0 + i) * legs + l] = nrm[i * legs + l];
        }
    }
    free(qs); free(res); free(lam); free(ptr); free(st); free(act);
    return rc;
}
"""

_DRIVER: list = []          # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []       # the loaded driver library, kept for the process


def driver():
    """The compiled driver ``et_newton_lm`` (built on first use into the cache), or None
    where it cannot be built (no compiler)."""
    if not _DRIVER:
        import subprocess

        from .ccompile import BuildError, build_library, find_compiler, flag_sets

        fn = None
        try:
            cc = find_compiler()
            for _, flags in flag_sets():
                try:
                    lib = ctypes.CDLL(str(build_library(SOURCE, "newton", cc, flags)))
                except (subprocess.CalledProcessError, OSError):
                    continue
                _LIBRARIES.append(lib)
                fn = lib.et_newton_lm
                P = ctypes.POINTER
                fn.argtypes = [ctypes.c_int64, ctypes.c_void_p, ctypes.c_int, P(ctypes.c_void_p), P(ctypes.c_int64),
                               P(ctypes.c_int), ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_void_p,
                               ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_double, ctypes.c_double]
                fn.restype = ctypes.c_int
                break
        except (BuildError, OSError):
            fn = None
        _DRIVER.append(fn)
    return _DRIVER[0]


def iterate(closure_address: int, n_q_inputs: list, addresses: list, strides: list, q: np.ndarray,
            rows: int, iterations: int, tol: float):
    """Run the driver: ``(q, |r|)`` from ``q`` (n, legs, n_q) for the closure kernel at
    ``closure_address``; ``n_q_inputs[k]`` is ``leg * n_q + coordinate`` for the kernel's
    joint-coordinate inputs and -1 for the others, read at ``addresses[k]`` with
    ``strides[k]`` (doubles). Raises RuntimeError when the driver fails."""
    n, legs, nq = q.shape
    qq = np.array(q, dtype=np.float64, order="C")
    norm = np.empty((n, legs))
    size = max(len(addresses), 1)
    rc = driver()(n, closure_address, len(addresses), (ctypes.c_void_p * size)(*addresses),
                  (ctypes.c_int64 * size)(*strides),
                  (ctypes.c_int * max(len(n_q_inputs), 1))(*n_q_inputs), legs, rows, nq, qq.ctypes.data,
                  norm.ctypes.data, int(iterations), float(tol), LAMBDA0, MAX_STEP)
    if rc != 0:
        raise RuntimeError(f"C Newton iterations returned {rc}")
    return qq, norm
