"""The damped Newton iterations of :mod:`.levenberg_marquardt` in C, around a robot's compiled closure.

:func:`iterate` (through :meth:`~eigentwist.runtime.c_kernels.CKernels.newton`) runs the
algorithm of :func:`eigentwist.runtime.levenberg_marquardt._iterate` (the same Levenberg-Marquardt
steps, acceptance rule, damping updates, bounded steps and final undamped polish, per
(pose, leg)) in one C call per batch: blocks of 64 poses, each iterated to convergence
with its joint coordinates kept in a structure-of-arrays buffer that the generated
``loop_closure`` kernel of the robot's C library reads in place (the driver calls it
through its address). The small normal equations are solved by Cholesky, vectorised
across the block. No Python runs between iterations; the results equal the NumPy
iterations' to round-off (``tests/test_numeric_ik.py``).

The driver is plain C99, compiled once into the cache (:mod:`.ccompile`); where it cannot
be built, :func:`driver` is None and the NumPy iterations run.
"""

from __future__ import annotations

import ctypes

import numpy as np

from .levenberg_marquardt import LAMBDA0, MAX_STEP

__all__ = ["driver", "iterate", "SOURCE"]

SOURCE = r"""
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef int (*et_kernel)(int64_t, const double *const *, const int64_t *, double *const *);

#define B 64
#define FOR_I for (int i = 0; i < B; ++i)

/* Per leg, for all B poses of a block at once (the pose index innermost: vector code):
   x = -(A^T A + diag(scale * (diag(A^T A) + shift)))^-1 A^T r by Cholesky (no scale:
   diag(shift)), where A
   (rows x nq) and r are the leg's rows of the structure-of-arrays buffers As, rs; a pose
   whose matrix is not finite takes x = -A^T r (numpy's H = I); one that is not positive
   definite gets NaN. w: workspace of (nq * nq + 3 * nq) * B doubles. */
static void et_steps(int rows, int nq, const double *As, const double *rs, const double *scale, double shift,
                     double *x, double *w)
{
    double *H = w, *g = H + nq * nq * B, *y = g + nq * B, *inv = y + nq * B;
    int fin[B];
    FOR_I fin[i] = 1;
    for (int a = 0; a < nq; ++a) {
        for (int b = 0; b <= a; ++b) {
            double *h = H + (a * nq + b) * B;
            const double *pa = As + a * B, *pb = As + b * B;
            FOR_I h[i] = pa[i] * pb[i];
            for (int k = 1; k < rows; ++k) {
                pa = As + (k * nq + a) * B;
                pb = As + (k * nq + b) * B;
                FOR_I h[i] += pa[i] * pb[i];
            }
        }
        double *gg = g + a * B;
        const double *pa = As + a * B;
        FOR_I gg[i] = pa[i] * rs[i];
        for (int k = 1; k < rows; ++k) {
            pa = As + (k * nq + a) * B;
            const double *pr = rs + k * B;
            FOR_I gg[i] += pa[i] * pr[i];
        }
    }
    for (int a = 0; a < nq; ++a) {
        double *h = H + (a * nq + a) * B;
        if (scale)
            FOR_I h[i] = h[i] + (scale[i] * h[i] + shift * scale[i]);
        else
            FOR_I h[i] = h[i] + shift;
        for (int b = 0; b <= a; ++b) {
            const double *hb = H + (a * nq + b) * B;
            FOR_I fin[i] &= isfinite(hb[i]) ? 1 : 0;
        }
    }
    /* Cholesky in place: H's lower triangle becomes L */
    for (int j = 0; j < nq; ++j) {
        double *d = H + (j * nq + j) * B, *iv = inv + j * B;
        for (int k = 0; k < j; ++k) {
            const double *l = H + (j * nq + k) * B;
            FOR_I d[i] = d[i] - l[i] * l[i];
        }
        FOR_I d[i] = sqrt(d[i]);
        FOR_I iv[i] = 1.0 / d[i];
        for (int a = j + 1; a < nq; ++a) {
            double *t = H + (a * nq + j) * B;
            for (int k = 0; k < j; ++k) {
                const double *la = H + (a * nq + k) * B, *lj = H + (j * nq + k) * B;
                FOR_I t[i] = t[i] - la[i] * lj[i];
            }
            FOR_I t[i] = t[i] * iv[i];
        }
    }
    for (int a = 0; a < nq; ++a) {
        double *ya = y + a * B;
        const double *ga = g + a * B, *iv = inv + a * B;
        FOR_I ya[i] = ga[i];
        for (int k = 0; k < a; ++k) {
            const double *l = H + (a * nq + k) * B, *yk = y + k * B;
            FOR_I ya[i] = ya[i] - l[i] * yk[i];
        }
        FOR_I ya[i] = ya[i] * iv[i];
    }
    for (int a = nq - 1; a >= 0; --a) {
        double *xa = x + a * B;
        const double *iv = inv + a * B;
        FOR_I xa[i] = y[a * B + i];
        for (int k = a + 1; k < nq; ++k) {
            const double *l = H + (k * nq + a) * B, *xk = x + k * B;
            FOR_I xa[i] = xa[i] - l[i] * xk[i];
        }
        FOR_I xa[i] = xa[i] * iv[i];
    }
    for (int a = 0; a < nq; ++a) {
        double *xa = x + a * B;
        const double *ga = g + a * B;
        FOR_I xa[i] = fin[i] ? -xa[i] : -ga[i];
    }
}

/* AoS kernel outputs (pose, leg, rows[, nq]) of m poses -> SoA (leg, rows[, nq], B) */
static void et_soa(int m, int legs, int rows, int nq, const double *r, const double *A, double *rs, double *As)
{
    const int lr = legs * rows;
    for (int e = 0; e < lr; ++e)
        for (int i = 0; i < m; ++i)
            rs[e * B + i] = r[(int64_t)i * lr + e];
    for (int e = 0; e < lr * nq; ++e)
        for (int i = 0; i < m; ++i)
            As[e * B + i] = A[(int64_t)i * lr * nq + e];
    for (int i = m; i < B; ++i) {             /* padding lanes: copies of the last pose */
        for (int e = 0; e < lr; ++e)
            rs[e * B + i] = rs[e * B + m - 1];
        for (int e = 0; e < lr * nq; ++e)
            As[e * B + i] = As[e * B + m - 1];
    }
}

static void et_norms(int legs, int rows, const double *rs, double *nrm)
{
    for (int l = 0; l < legs; ++l) {
        double *o = nrm + l * B;
        const double *r0 = rs + (l * rows) * B;
        FOR_I o[i] = r0[i] * r0[i];
        for (int k = 1; k < rows; ++k) {
            const double *rk = rs + (l * rows + k) * B;
            FOR_I o[i] += rk[i] * rk[i];
        }
        FOR_I o[i] = sqrt(o[i]);
    }
}

/* Point the closure's inputs at block b0: joint coordinates from the SoA buffer qs
   ((legs * nq) rows of B), the others from the caller's arrays. */
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
    if (nq < 1 || nq > 8 || rows < 1)
        return -1;
    const int lq = legs * nq, lr = legs * rows;
    const size_t soa = (size_t)B * (size_t)(lr * (1 + nq));
    double *buf = malloc(sizeof(double) * (2 * (size_t)lq * B + 4 * soa + 3 * (size_t)legs * B
                                           + (size_t)(nq * nq + 4 * nq) * B));
    const double **ptr = malloc(sizeof(double *) * (size_t)(n_in > 0 ? n_in : 1));
    int64_t *st = malloc(sizeof(int64_t) * (size_t)(n_in > 0 ? n_in : 1));
    int *act = malloc(sizeof(int) * (size_t)legs * B);
    if (!buf || !ptr || !st || !act) {
        free(buf); free(ptr); free(st); free(act);
        return -2;
    }
    double *qs = buf, *qt = qs + lq * B;          /* coordinates and trial coordinates (SoA) */
    double *r = qt + lq * B, *A = r + B * lr;     /* kernel outputs (AoS) */
    double *rs = r + soa, *As = rs + B * lr;      /* current residual and Jacobian (SoA) */
    double *rts = rs + soa, *Ats = rts + B * lr;  /* at the trial (SoA) */
    double *lam = rts + soa, *nrm = lam + legs * B, *nn = nrm + legs * B;
    double *x = nn + legs * B, *w = x + nq * B;
    double *outs[2] = {r, A};
    int rc = 0;
    for (int64_t b0 = 0; b0 < n && rc == 0; b0 += B) {
        const int m = n - b0 < B ? (int)(n - b0) : B;
        for (int c = 0; c < lq; ++c)
            for (int i = 0; i < B; ++i)
                qs[c * B + i] = q[(b0 + (i < m ? i : m - 1)) * lq + c];
        et_point(n_in, q_of, in, stride, b0, qs, ptr, st);
        if ((rc = closure(m, ptr, st, outs)) != 0)
            break;
        et_soa(m, legs, rows, nq, r, A, rs, As);
        et_norms(legs, rows, rs, nrm);
        for (int e = 0; e < legs * B; ++e)
            lam[e] = lambda0;
        for (int pass = 0; pass <= iterations; ++pass) {
            const int polish = pass == iterations;     /* the last pass: one undamped step */
            int any = 0;
            for (int l = 0; l < legs; ++l) {
                int *a = act + l * B;
                const double *nl = nrm + l * B;
                if (polish)
                    FOR_I a[i] = nl[i] < tol;
                else
                    FOR_I a[i] = !(nl[i] < tol) && isfinite(nl[i]);
                for (int i = 0; i < m; ++i)
                    any |= a[i];
            }
            if (!any) {
                if (!polish) {                           /* converged: go straight to the polish */
                    pass = iterations - 1;
                    continue;
                }
                break;
            }
            for (int l = 0; l < legs; ++l) {
                const int *a = act + l * B;
                et_steps(rows, nq, As + (l * rows * nq) * B, rs + (l * rows) * B, polish ? 0 : lam + l * B,
                         polish ? 1e-300 : 1e-12, x, w);
                if (!polish) {
                    double *big = w;
                    FOR_I big[i] = 0.0;
                    for (int j = 0; j < nq; ++j) {
                        const double *xj = x + j * B;
                        FOR_I big[i] = fabs(xj[i]) > big[i] ? fabs(xj[i]) : big[i];
                    }
                    for (int j = 0; j < nq; ++j) {
                        double *xj = x + j * B;
                        FOR_I xj[i] = big[i] > max_step ? xj[i] * (max_step / big[i]) : xj[i];
                    }
                }
                for (int j = 0; j < nq; ++j) {
                    const double *xj = x + j * B, *qj = qs + (l * nq + j) * B;
                    double *tj = qt + (l * nq + j) * B;
                    FOR_I tj[i] = qj[i] + (a[i] ? xj[i] : 0.0);
                }
            }
            et_point(n_in, q_of, in, stride, b0, qt, ptr, st);
            if ((rc = closure(m, ptr, st, outs)) != 0)
                break;
            et_soa(m, legs, rows, nq, r, A, rts, Ats);
            et_norms(legs, rows, rts, nn);
            for (int l = 0; l < legs; ++l) {
                const int *a = act + l * B;
                double *nl = nrm + l * B, *ll = lam + l * B;
                const double *nnl = nn + l * B;
                int better[B];
                if (polish)
                    FOR_I better[i] = a[i] && nnl[i] <= nl[i];
                else
                    FOR_I better[i] = a[i] && nnl[i] < nl[i];
                for (int j = 0; j < nq; ++j) {
                    double *qj = qs + (l * nq + j) * B;
                    const double *tj = qt + (l * nq + j) * B;
                    FOR_I qj[i] = better[i] ? tj[i] : qj[i];
                }
                if (!polish) {
                    for (int k = 0; k < rows; ++k) {
                        double *rk = rs + (l * rows + k) * B;
                        const double *tk = rts + (l * rows + k) * B;
                        FOR_I rk[i] = better[i] ? tk[i] : rk[i];
                    }
                    for (int k = 0; k < rows * nq; ++k) {
                        double *ak = As + (l * rows * nq + k) * B;
                        const double *tk = Ats + (l * rows * nq + k) * B;
                        FOR_I ak[i] = better[i] ? tk[i] : ak[i];
                    }
                    FOR_I ll[i] = better[i] ? (ll[i] / 4 > 1e-12 ? ll[i] / 4 : 1e-12)
                                            : (a[i] ? (ll[i] * 4 < 1e12 ? ll[i] * 4 : 1e12) : ll[i]);
                }
                FOR_I nl[i] = better[i] ? nnl[i] : nl[i];
            }
        }
        if (rc != 0)
            break;
        for (int i = 0; i < m; ++i) {
            for (int c = 0; c < lq; ++c)
                q[(b0 + i) * lq + c] = qs[c * B + i];
            for (int l = 0; l < legs; ++l)
                norm[(b0 + i) * legs + l] = nrm[l * B + i];
        }
    }
    free(buf); free(ptr); free(st); free(act);
    return rc;
}
"""

BLOCK = 64  # poses per block (B in the source)
_DRIVER: list = []  # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []  # the loaded driver library, kept for the process


def driver():
    """The compiled driver ``et_newton_lm`` (built on first use into the cache), or None
    where it cannot be built (no compiler)."""
    if not _DRIVER:
        from .ccompile import load_library

        lib = load_library(SOURCE, "newton")
        fn = None
        if lib is not None:
            _LIBRARIES.append(lib)
            fn = lib.et_newton_lm
            P = ctypes.POINTER
            fn.argtypes = [
                ctypes.c_int64,
                ctypes.c_void_p,
                ctypes.c_int,
                P(ctypes.c_void_p),
                P(ctypes.c_int64),
                P(ctypes.c_int),
                ctypes.c_int,
                ctypes.c_int,
                ctypes.c_int,
                ctypes.c_void_p,
                ctypes.c_void_p,
                ctypes.c_int,
                ctypes.c_double,
                ctypes.c_double,
                ctypes.c_double,
            ]
            fn.restype = ctypes.c_int
        _DRIVER.append(fn)
    return _DRIVER[0]


def iterate(
    closure_address: int,
    n_q_inputs: list,
    addresses: list,
    strides: list,
    q: np.ndarray,
    rows: int,
    iterations: int,
    tol: float,
    threads: int = 1,
):
    """Run the driver: ``(q, |r|)`` from ``q`` (n, legs, n_q) for the closure kernel at
    ``closure_address``; ``n_q_inputs[k]`` is ``leg * n_q + coordinate`` for the kernel's
    joint-coordinate inputs and -1 for the others, read at ``addresses[k]`` with
    ``strides[k]`` (doubles). ``threads`` > 1 runs ranges of whole blocks on that many
    threads (each pose's iterations are its own: the results do not depend on it).
    Raises RuntimeError when the driver fails."""
    from .threads import run_ranges, threads_for

    n, legs, nq = q.shape
    qq = np.array(q, dtype=np.float64, order="C")
    norm = np.empty((n, legs))
    size = max(len(addresses), 1)
    q_of = (ctypes.c_int * max(len(n_q_inputs), 1))(*n_q_inputs)
    fn = driver()

    def call(a: int, b: int) -> int:
        moved = [x + 8 * a * st for x, st in zip(addresses, strides)]
        return fn(
            b - a,
            closure_address,
            len(addresses),
            (ctypes.c_void_p * size)(*moved),
            (ctypes.c_int64 * size)(*strides),
            q_of,
            legs,
            rows,
            nq,
            qq.ctypes.data + 8 * a * legs * nq,
            norm.ctypes.data + 8 * a * legs,
            int(iterations),
            float(tol),
            LAMBDA0,
            MAX_STEP,
        )

    for rc in run_ranges(call, n, BLOCK, threads_for(n, BLOCK, threads)):
        if rc != 0:
            raise RuntimeError(f"C Newton iterations returned {rc}")
    return qq, norm
