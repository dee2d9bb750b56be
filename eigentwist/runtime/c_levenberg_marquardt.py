"""The damped Newton iterations of :mod:`.levenberg_marquardt` in C, around a robot's compiled closure.

:func:`iterate` (through :meth:`~eigentwist.runtime.c_kernels.CKernels.newton`) runs the
algorithm of :func:`eigentwist.runtime.levenberg_marquardt._iterate` (the same Levenberg-Marquardt
steps, acceptance rule, damping updates, bounded steps and undamped steps below EARLY, per
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

from .addresses import address
from .ccompile import SIMD_SIN_COS, library_once
from .c_poses import RODRIGUES
from .levenberg_marquardt import EARLY, LAMBDA0, MAX_STEP

__all__ = ["driver", "iterate", "branch_driver", "BranchSolver", "block_steps", "followers_driver", "follow", "SOURCE"]

SOURCE = (
    r"""
#if !defined(_POSIX_C_SOURCE) && !defined(_GNU_SOURCE)
#define _POSIX_C_SOURCE 200112L  /* posix_memalign under -std=c99 */
#endif
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
"""
    + SIMD_SIN_COS
    + RODRIGUES
    + r"""
typedef int (*et_kernel)(int64_t, const double *const *, const int64_t *, double *const *);

#define B 64
#define FOR_I for (int i = 0; i < B; ++i)
"""
    + f"#define ET_EARLY {EARLY!r}  /* levenberg_marquardt.EARLY */\n"
    + r"""
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

/* et_steps for a leg of R rows and Q coordinates known when compiled: the same operations
   in the same order, each lane's system held in registers (the lane loop vectorised). The
   arrays must have these sizes: gcc does not vectorise one lane-loop body for every size (8 x 8
   arrays, loops bounded at run time, inlined with constants), which runs 1.6-1.9x slower than
   this; the other sizes keep et_steps' structure-of-arrays loops. */
#define ET_STEPS_FIXED(R, Q)                                                                                 \
    static inline __attribute__((always_inline)) void et_lanes_##R##_##Q(                                   \
        const double *As, const double *rs, const double *scale, double shift, double *x, const int scaled)  \
    {                                                                                                        \
        _Pragma("omp simd")                                                                                  \
        for (int i = 0; i < B; ++i) {                                                                        \
            double H[Q][Q], g[Q], y[Q], v[Q], inv[Q];                                                        \
            int fin = 1;                                                                                     \
            _Pragma("GCC unroll 8")                                                                          \
            for (int a = 0; a < Q; ++a) {                                                                    \
                _Pragma("GCC unroll 8")                                                                      \
                for (int b = 0; b <= a; ++b) {                                                               \
                    double h = As[a * B + i] * As[b * B + i];                                                \
                    _Pragma("GCC unroll 8")                                                                  \
                    for (int k = 1; k < R; ++k)                                                              \
                        h += As[(k * Q + a) * B + i] * As[(k * Q + b) * B + i];                              \
                    H[a][b] = h;                                                                             \
                }                                                                                            \
                double gg = As[a * B + i] * rs[i];                                                           \
                _Pragma("GCC unroll 8")                                                                      \
                for (int k = 1; k < R; ++k)                                                                  \
                    gg += As[(k * Q + a) * B + i] * rs[k * B + i];                                           \
                g[a] = gg;                                                                                   \
            }                                                                                                \
            _Pragma("GCC unroll 8")                                                                          \
            for (int a = 0; a < Q; ++a) {                                                                    \
                H[a][a] = scaled ? H[a][a] + (scale[i] * H[a][a] + shift * scale[i]) : H[a][a] + shift;      \
                _Pragma("GCC unroll 8")                                                                      \
                for (int b = 0; b <= a; ++b)                                                                 \
                    fin &= isfinite(H[a][b]) ? 1 : 0;                                                        \
            }                                                                                                \
            _Pragma("GCC unroll 8")                                                                          \
            for (int j = 0; j < Q; ++j) {                                                                    \
                double d = H[j][j];                                                                          \
                _Pragma("GCC unroll 8")                                                                      \
                for (int k = 0; k < j; ++k)                                                                  \
                    d = d - H[j][k] * H[j][k];                                                               \
                d = sqrt(d);                                                                                 \
                inv[j] = 1.0 / d;                                                                            \
                _Pragma("GCC unroll 8")                                                                      \
                for (int a = j + 1; a < Q; ++a) {                                                            \
                    double t = H[a][j];                                                                      \
                    _Pragma("GCC unroll 8")                                                                  \
                    for (int k = 0; k < j; ++k)                                                              \
                        t = t - H[a][k] * H[j][k];                                                           \
                    H[a][j] = t * inv[j];                                                                    \
                }                                                                                            \
            }                                                                                                \
            _Pragma("GCC unroll 8")                                                                          \
            for (int a = 0; a < Q; ++a) {                                                                    \
                double ya = g[a];                                                                            \
                _Pragma("GCC unroll 8")                                                                      \
                for (int k = 0; k < a; ++k)                                                                  \
                    ya = ya - H[a][k] * y[k];                                                                \
                y[a] = ya * inv[a];                                                                          \
            }                                                                                                \
            _Pragma("GCC unroll 8")                                                                          \
            for (int a = Q - 1; a >= 0; --a) {                                                               \
                double xa = y[a];                                                                            \
                _Pragma("GCC unroll 8")                                                                      \
                for (int k = a + 1; k < Q; ++k)                                                              \
                    xa = xa - H[k][a] * v[k];                                                                \
                v[a] = xa * inv[a];                                                                          \
            }                                                                                                \
            _Pragma("GCC unroll 8")                                                                          \
            for (int a = 0; a < Q; ++a)                                                                      \
                x[a * B + i] = fin ? -v[a] : -g[a];                                                          \
        }                                                                                                    \
    }                                                                                                        \
    static void et_steps_##R##_##Q(const double *As, const double *rs, const double *scale, double shift,    \
                                   double *x)                                                                \
    {                                                                                                        \
        if (scale)                                                                                           \
            et_lanes_##R##_##Q(As, rs, scale, shift, x, 1);                                                  \
        else                                                                                                 \
            et_lanes_##R##_##Q(As, rs, scale, shift, x, 0);                                                  \
    }

ET_STEPS_FIXED(3, 2)
ET_STEPS_FIXED(3, 3)
ET_STEPS_FIXED(3, 4)
ET_STEPS_FIXED(6, 5)
ET_STEPS_FIXED(6, 6)

/* et_steps, by the fixed-size version where there is one for (rows, nq) */
static void et_solve_steps(int rows, int nq, const double *As, const double *rs, const double *scale, double shift,
                           double *x, double *w)
{
    if (rows == 3 && nq == 2)
        et_steps_3_2(As, rs, scale, shift, x);
    else if (rows == 3 && nq == 3)
        et_steps_3_3(As, rs, scale, shift, x);
    else if (rows == 3 && nq == 4)
        et_steps_3_4(As, rs, scale, shift, x);
    else if (rows == 6 && nq == 5)
        et_steps_6_5(As, rs, scale, shift, x);
    else if (rows == 6 && nq == 6)
        et_steps_6_6(As, rs, scale, shift, x);
    else
        et_steps(rows, nq, As, rs, scale, shift, x, w);
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

/* The residual rs (legs * rows of B) and Jacobian As (legs * rows * nq of B) of the m poses
   of the block at b0 with coordinates qs (SoA); returns the kernel's code. */
typedef int (*et_eval)(void *ctx, int m, int64_t b0, const double *qs, double *rs, double *As);

/* The work buffers of one block's iterations */
typedef struct {
    double *qt, *rts, *Ats, *lam, *nn, *x, *w;
    int *act, *res, *kept;    /* legs rows of B each: stepped, rescued (et_lm_block), step kept */
} et_work;

/* One pass of the block: a damped step (polish = 0: Levenberg-Marquardt, bounded by max_step,
   kept where it lowers |r|, the damping divided by 4 where kept and multiplied by 4 where not)
   or an undamped one (polish = 1: kept where it does not raise |r|) of the lanes marked in act;
   a kept step's coordinates, residual, Jacobian and |r| replace the lane's; kept[l * B + i] = 1
   where lane i of leg l took its step. */
static int et_lm_pass(et_eval eval, void *ctx, int m, int64_t b0, int legs, int rows, int nq, double *qs,
                      double *rs, double *As, double *nrm, const et_work *wk, int polish, double max_step, int *kept)
{
    double *qt = wk->qt, *rts = wk->rts, *Ats = wk->Ats, *lam = wk->lam, *nn = wk->nn, *x = wk->x, *w = wk->w;
    const int *act = wk->act;
    for (int l = 0; l < legs; ++l) {
        const int *a = act + l * B;
        et_solve_steps(rows, nq, As + (l * rows * nq) * B, rs + (l * rows) * B, polish ? 0 : lam + l * B,
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
    int rc;
    if ((rc = eval(ctx, m, b0, qt, rts, Ats)) != 0)
        return rc;
    et_norms(legs, rows, rts, nn);
    for (int l = 0; l < legs; ++l) {
        const int *a = act + l * B;
        double *nl = nrm + l * B, *ll = lam + l * B;
        const double *nnl = nn + l * B;
        int *better = kept + l * B;
        if (polish)
            FOR_I better[i] = a[i] && nnl[i] <= nl[i];
        else
            FOR_I better[i] = a[i] && nnl[i] < nl[i];
        for (int j = 0; j < nq; ++j) {
            double *qj = qs + (l * nq + j) * B;
            const double *tj = qt + (l * nq + j) * B;
            FOR_I qj[i] = better[i] ? tj[i] : qj[i];
        }
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
        if (!polish)
            FOR_I {
                const double down = ll[i] / 4 > 1e-12 ? ll[i] / 4 : 1e-12, up = ll[i] * 4 < 1e12 ? ll[i] * 4 : 1e12;
                ll[i] = better[i] ? down : (a[i] ? up : ll[i]);
            }
        FOR_I nl[i] = better[i] ? nnl[i] : nl[i];
    }
    return 0;
}

/* The iterations of one block: qs (legs * nq rows of B) the starting coordinates, on return
   the iterated ones; nrm (legs rows of B) their |r|; rs, As hold the residual and Jacobian at qs.
   Per lane (pose and leg), as levenberg_marquardt._iterate: damped steps while |r| is not below
   early (ET_EARLY, at least tol) and finite, at most `iterations`; one undamped step of every
   lane below it (quadratic convergence: from ET_EARLY to round-off); then, a lane that step left
   at tol or above (a slow convergence) takes damped steps again while not below tol (at most
   `iterations`) and, below it, a last undamped step. */
static int et_lm_block(et_eval eval, void *ctx, int m, int64_t b0, int legs, int rows, int nq, double *qs,
                       double *rs, double *As, double *nrm, const et_work *wk, int iterations, double tol,
                       double lambda0, double max_step)
{
    double *lam = wk->lam;
    int *act = wk->act, *res = wk->res, *kept = wk->kept;
    const double early = ET_EARLY > tol ? ET_EARLY : tol;
    int rc;
    if ((rc = eval(ctx, m, b0, qs, rs, As)) != 0)
        return rc;
    et_norms(legs, rows, rs, nrm);
    for (int e = 0; e < legs * B; ++e)
        lam[e] = lambda0;
    for (int stage = 0; stage < 2; ++stage) {
        const double below = stage ? tol : early;
        for (int pass = 0; pass <= iterations; ++pass) {
            const int polish = pass == iterations;
            int any = 0;
            for (int l = 0; l < legs; ++l) {
                int *a = act + l * B;
                const int *rl = res + l * B;
                const double *nl = nrm + l * B;
                if (polish)
                    FOR_I a[i] = nl[i] < below && (stage == 0 || rl[i]);
                else
                    FOR_I a[i] = !(nl[i] < below) && isfinite(nl[i]) && (stage == 0 || rl[i]);
                for (int i = 0; i < m; ++i)
                    any |= a[i];
            }
            if (!any) {
                if (!polish) {                       /* none left to step: straight to the polish */
                    pass = iterations - 1;
                    continue;
                }
                break;
            }
            if ((rc = et_lm_pass(eval, ctx, m, b0, legs, rows, nq, qs, rs, As, nrm, wk, polish, max_step, kept)) != 0)
                return rc;
        }
        if (stage == 0) {                            /* the lanes the polish left at tol or above */
            int any = 0;
            for (int l = 0; l < legs; ++l) {
                int *rl = res + l * B;
                const int *a = act + l * B;
                const double *nl = nrm + l * B;
                FOR_I rl[i] = a[i] && !(nl[i] < tol);
                for (int i = 0; i < m; ++i)
                    any |= rl[i];
            }
            if (!any)
                break;
        }
    }
    return 0;
}

typedef int (*et_block_fn)(int, const double *const *, double *const *);

/* A closure of the legs' coordinates: the generated loop_closure kernel, or its block
   function (block: NULL where the library has none) */
typedef struct {
    et_kernel closure;
    et_block_fn block;
    int n_in, legs, rows, nq;
    const double *const *in;
    const int64_t *stride;
    const int *q_of;
    const double **ptr;
    int64_t *st;
    double *outs[2];
    double *held;       /* block: the other inputs of the block at held_b0, n_in rows of B */
    int64_t held_b0;    /* -1: none held */
    double **rows_at;   /* block: the outputs' rows, legs * rows * (1 + nq) */
} et_legs;

static int et_legs_eval(void *ctx, int m, int64_t b0, const double *qs, double *rs, double *As)
{
    et_legs *c = ctx;
    int rc;
    et_point(c->n_in, c->q_of, c->in, c->stride, b0, qs, c->ptr, c->st);
    if ((rc = c->closure(m, c->ptr, c->st, c->outs)) != 0)
        return rc;
    et_soa(m, c->legs, c->rows, c->nq, c->outs[0], c->outs[1], rs, As);
    return 0;
}

/* The lanes a kernel's block function computes for m poses: all B, or m rounded up to 8 */
static int et_lanes8(int m)
{
    return m >= B ? B : (m + 7) / 8 * 8;
}

/* The caller's inputs (those k with own[k] < 0) of the m poses of the block at b0 into
   held (row k of B; the lanes past m repeat the last pose), for a kernel's block function. */
static void et_hold(int n_in, const int *own, const double *const *in, const int64_t *stride, int64_t b0, int m,
                    double *held)
{
    for (int k = 0; k < n_in; ++k) {
        if (own[k] >= 0)
            continue;
        double *row = held + (int64_t)k * B;
        const double *src = in[k];
        const int64_t s = stride[k];
        for (int i = 0; i < B; ++i)
            row[i] = src[(b0 + (i < m ? i : m - 1)) * s];
    }
}

/* et_legs_eval by the kernel's block function, writing rs and As in place: the inputs
   other than the coordinates are copied once per block (padded with the last pose), the
   residual's rows then the Jacobian's are the kernel's output rows, and the lanes past
   the last pose computed (a multiple of 8) get the last pose's values, as et_soa gives. */
static int et_legs_eval_block(void *ctx, int m, int64_t b0, const double *qs, double *rs, double *As)
{
    et_legs *c = ctx;
    const int lr = c->legs * c->rows, lanes = et_lanes8(m);
    if (c->held_b0 != b0) {
        et_hold(c->n_in, c->q_of, c->in, c->stride, b0, m, c->held);
        c->held_b0 = b0;
    }
    for (int k = 0; k < c->n_in; ++k)
        c->ptr[k] = c->q_of[k] >= 0 ? qs + (int64_t)c->q_of[k] * B : c->held + (int64_t)k * B;
    for (int e = 0; e < lr; ++e)
        c->rows_at[e] = rs + (int64_t)e * B;
    for (int e = 0; e < lr * c->nq; ++e)
        c->rows_at[lr + e] = As + (int64_t)e * B;
    int rc = c->block(lanes, c->ptr, c->rows_at);
    if (rc != 0 || lanes == B)
        return rc;
    for (int e = 0; e < lr * (1 + c->nq); ++e) {
        double *row = c->rows_at[e];
        for (int i = lanes; i < B; ++i)
            row[i] = row[m - 1];
    }
    return 0;
}

/* Work buffers for legs * rows residuals of nq coordinates; NULL when out of memory */
static double *et_alloc_work(int legs, int rows, int nq, et_work *wk, double **qs, double **rs, double **As,
                             double **nrm)
{
    const int lq = legs * nq, lr = legs * rows;
    const size_t soa = (size_t)B * (size_t)(lr * (1 + nq));
    double *buf = malloc(sizeof(double) * (2 * (size_t)lq * B + 2 * soa + 3 * (size_t)legs * B
                                           + (size_t)(nq * nq + 4 * nq) * B));
    wk->act = malloc(sizeof(int) * 3 * (size_t)legs * B);
    if (wk->act) {
        wk->res = wk->act + legs * B;
        wk->kept = wk->res + legs * B;
    }
    if (!buf || !wk->act) {
        free(buf); free(wk->act);
        return NULL;
    }
    *qs = buf;
    wk->qt = *qs + lq * B;
    *rs = wk->qt + lq * B;
    *As = *rs + B * lr;
    wk->rts = *rs + soa;
    wk->Ats = wk->rts + B * lr;
    wk->lam = wk->rts + soa;
    *nrm = wk->lam + legs * B;
    wk->nn = *nrm + legs * B;
    wk->x = wk->nn + legs * B;
    wk->w = wk->x + nq * B;
    return buf;
}

/* The steps of one block of B systems laid out as et_steps reads them (As: rows * nq rows of
   B, rs: rows rows of B; scale: B values or NULL): x (nq rows of B). 0, or -1 for sizes the
   driver does not take, -2 out of memory. */
int et_block_steps(int rows, int nq, const double *As, const double *rs, const double *scale, double shift, double *x)
{
    if (nq < 1 || nq > 8 || rows < 1)
        return -1;
    double *w = malloc(sizeof(double) * (size_t)(nq * nq + 4 * nq) * B);
    if (!w)
        return -2;
    et_solve_steps(rows, nq, As, rs, scale, shift, x, w);
    free(w);
    return 0;
}

int et_newton_lm(int64_t n, void *closure_address, void *block_address, int n_in, const double *const *in,
                 const int64_t *stride,
                 const int *q_of, int legs, int rows, int nq, double *q, double *norm, int iterations,
                 double tol, double lambda0, double max_step)
{
    if (nq < 1 || nq > 8 || rows < 1)
        return -1;
    const int lq = legs * nq, lr = legs * rows;
    et_work wk;
    double *qs, *rs, *As, *nrm;
    double *buf = et_alloc_work(legs, rows, nq, &wk, &qs, &rs, &As, &nrm);
    double *out = malloc(sizeof(double) * (size_t)B * (size_t)(lr * (1 + nq)));
    et_legs c = {(et_kernel)closure_address, (et_block_fn)block_address, n_in, legs, rows, nq, in, stride, q_of,
                 malloc(sizeof(double *) * (size_t)(n_in > 0 ? n_in : 1)),
                 malloc(sizeof(int64_t) * (size_t)(n_in > 0 ? n_in : 1)), {out, out + B * lr},
                 block_address ? malloc(sizeof(double) * B * (size_t)(n_in > 0 ? n_in : 1)) : NULL, -1,
                 block_address ? malloc(sizeof(double *) * (size_t)(lr * (1 + nq))) : NULL};
    int rc = 0;
    if (!buf || !out || !c.ptr || !c.st || (block_address && (!c.held || !c.rows_at)))
        rc = -2;
    for (int64_t b0 = 0; b0 < n && rc == 0; b0 += B) {
        const int m = n - b0 < B ? (int)(n - b0) : B;
        for (int k = 0; k < lq; ++k)
            for (int i = 0; i < B; ++i)
                qs[k * B + i] = q[(b0 + (i < m ? i : m - 1)) * lq + k];
        if ((rc = et_lm_block(c.block ? et_legs_eval_block : et_legs_eval, &c, m, b0, legs, rows, nq, qs, rs, As,
                              nrm, &wk, iterations, tol, lambda0, max_step)) != 0)
            break;
        for (int i = 0; i < m; ++i) {
            for (int k = 0; k < lq; ++k)
                q[(b0 + i) * lq + k] = qs[k * B + i];
            for (int l = 0; l < legs; ++l)
                norm[(b0 + i) * legs + l] = nrm[l * B + i];
        }
    }
    free(buf); free(wk.act); free(out); free(c.ptr); free(c.st); free(c.held); free(c.rows_at);
    return rc;
}

/* A platform's followers: the generated followers kernel of closed-form legs, read at the
   full pose (x, y, z; rotation vector) whose follower coordinates are the unknowns. */
typedef struct {
    et_kernel kernel;
    et_block_fn block;        /* the kernel's block function, or NULL */
    int n_in, rows, nf;
    const double *const *in;
    const int64_t *stride;
    const int *role;          /* per input: -1 the caller's array; 0-2 x, y, z; 3 + 3 i + j R_ij */
    const int *followers;     /* indices into (x, y, z, rot_x, rot_y, rot_z) */
    const double *full;       /* (n, 6) the commanded full poses */
    double *pose, *R;         /* 6 and 9 rows of B */
    double *jl;               /* 2 rows of B: a and b of the left Jacobian J_l */
    double *twist;            /* 6 rows of B: a follower's twist (et_follower_twist) */
    const double **ptr;
    int64_t *st;
    double *outs[2];          /* closure (m, rows), closure_rate (m, rows, 6); rows of B with block */
    double *lane;             /* no block: the outputs as rows of B (rows * 7), padded */
    double *held;             /* block: the caller's inputs of the block at held_b0, n_in rows of B */
    int64_t held_b0;          /* -1: none held */
    double **rows_at;         /* block: the output rows, closure's then closure_rate's (rows * 7) */
} et_followers;

/* The rows (x, y, z, rotation vector) of B poses in P: R (9 rows, R_ij at 3 i + j) by
   Rodrigues' formula and the left Jacobian's a = (1 - cos t)/t^2 (Rodrigues' b),
   b = (t - sin t)/t^3 (2 rows of jl; their series below t^2 = 1e-10), from one sine and cosine
   a lane: one vector loop (a series' lane computes the formula too and takes the series). */
static void et_rotation_rows(const double *restrict P, double *restrict R, double *restrict jl)
{
    FOR_I {
        const double x = P[3 * B + i], y = P[4 * B + i], z = P[5 * B + i];
        const double t2 = x * x + y * y + z * z, t = sqrt(t2), sn = sin(t), cs = cos(t);
        double ra, rb, e[9];
        et_rodrigues_ab(t2, t, sn, cs, &ra, &rb);
        et_rotation_ab(x, y, z, ra, rb, e);
        for (int k = 0; k < 9; ++k)
            R[k * B + i] = e[k];
        jl[i] = t2 < 1e-10 ? 0.5 - t2 / 24 : rb;
        jl[B + i] = t2 < 1e-10 ? 1.0 / 6 - t2 / 120 : (t - sn) / (t * t * t);
    }
}

/* T (6 rows of B): the twist of pose entry k (x, y, z, rotation vector; a follower) in each
   lane: e_(3+k) for a position k, J_l's column e = k - 3 for a rotation-vector entry (J_l = I +
   a [phi]x + b [phi]x^2, a and b the rows of jl; its entries e, e + 1, e + 2 mod 3). */
static void et_follower_twist(int k, const double *restrict P, const double *restrict jl, double *restrict T)
{
    for (int j = 0; j < 6; ++j)
        FOR_I T[j * B + i] = j == 3 + k ? 1.0 : 0.0;
    if (k < 3)
        return;
    const int e = k - 3, e1 = (e + 1) % 3, e2 = (e + 2) % 3;
    const double *pe = P + (3 + e) * B, *p1 = P + (3 + e1) * B, *p2 = P + (3 + e2) * B;
    double *te = T + e * B, *t1 = T + e1 * B, *t2 = T + e2 * B;
    FOR_I {
        const double x = P[3 * B + i], y = P[4 * B + i], z = P[5 * B + i];
        const double s2 = x * x + y * y + z * z, a = jl[i], b = jl[B + i];
        te[i] = b * pe[i] * pe[i] + (1.0 - b * s2);
        t1[i] = b * pe[i] * p1[i] + a * p2[i];
        t2[i] = b * pe[i] * p2[i] - a * p1[i];
    }
}

/* out = g . T for B lanes: a closure row's rates along the six pose entries (g, 6 rows of B)
   times a follower's twist (T, :c:func:`et_follower_twist`), summed in order, zeros included. */
static void et_follower_rate(const double *restrict g, const double *restrict T, double *restrict out)
{
    FOR_I {
        double d = g[i] * T[i];
        for (int j = 1; j < 6; ++j)
            d += g[j * B + i] * T[j * B + i];
        out[i] = d;
    }
}

static int et_followers_eval(void *ctx, int m, int64_t b0, const double *qs, double *rs, double *As)
{
    et_followers *c = ctx;
    double *P = c->pose, *R = c->R;
    for (int k = 0; k < 6; ++k)
        FOR_I P[k * B + i] = c->full[(b0 + (i < m ? i : m - 1)) * 6 + k];
    for (int f = 0; f < c->nf; ++f)
        FOR_I P[c->followers[f] * B + i] = qs[f * B + i];
    et_rotation_rows(P, R, c->jl);
    if (c->block && c->held_b0 != b0) {
        et_hold(c->n_in, c->role, c->in, c->stride, b0, m, c->held);
        c->held_b0 = b0;
    }
    for (int k = 0; k < c->n_in; ++k) {
        const int r = c->role[k];
        if (r < 0) {
            c->ptr[k] = c->block ? c->held + (int64_t)k * B : c->in[k] + b0 * c->stride[k];
            c->st[k] = c->block ? 1 : c->stride[k];
        } else {
            c->ptr[k] = r < 3 ? P + r * B : R + (r - 3) * B;
            c->st[k] = 1;
        }
    }
    const int rows = c->rows, nf = c->nf, lanes = et_lanes8(m);
    /* the lanes past m are read by no pose below */
    int rc = c->block ? c->block(lanes, c->ptr, c->rows_at) : c->kernel(m, c->ptr, c->st, c->outs);
    if (rc != 0)
        return rc;
    /* the closure's rows, then its rates' (row k, entry j at rows + 6 k + j), as rows of B whose
       lanes past m hold the last pose's values */
    double *lr = c->block ? c->outs[0] : c->lane;
    if (c->block) {
        for (int e = 0; e < 7 * rows; ++e)
            for (int i = lanes; i < B; ++i)
                lr[e * B + i] = lr[e * B + m - 1];
    } else {
        for (int k = 0; k < rows; ++k) {
            FOR_I lr[k * B + i] = c->outs[0][(i < m ? i : m - 1) * rows + k];
            for (int j = 0; j < 6; ++j)
                FOR_I lr[(rows + 6 * k + j) * B + i] = c->outs[1][((i < m ? i : m - 1) * rows + k) * 6 + j];
        }
    }
    for (int k = 0; k < rows; ++k)
        FOR_I rs[k * B + i] = lr[k * B + i];
    /* As = (d closure / d pose) T, T's column f the follower's twist */
    for (int f = 0; f < nf; ++f) {
        et_follower_twist(c->followers[f], P, c->jl, c->twist);
        for (int row = 0; row < rows; ++row)
            et_follower_rate(lr + (rows + 6 * row) * B, c->twist, As + (row * nf + f) * B);
    }
    return 0;
}

/* et_newton_lm's iterations on a platform's followers: q (n, nf) their starting values,
   on return the iterated ones; norm (n,) their |r|. Returns 0, -1 for sizes it does not
   take, -2 when out of memory, or the kernel's code. */
int et_followers_lm(int64_t n, void *kernel_address, void *block_address, int n_in, const double *const *in,
                    const int64_t *stride,
                    const int *role, int nf, const int *followers, int rows, const double *full, double *q,
                    double *norm, int iterations, double tol, double lambda0, double max_step)
{
    if (nf < 1 || nf > 6 || rows < 1)
        return -1;
    et_work wk;
    double *qs, *rs, *As, *nrm;
    double *buf = et_alloc_work(1, rows, nf, &wk, &qs, &rs, &As, &nrm);
    /* P (6 rows of B), R (9), J_l's a and b (2), a twist (6), the kernel's outputs (7 * rows),
       their rows of B without a block function (7 * rows); aligned, so that every lane takes
       the vector path */
    double *more = NULL;
    if (posix_memalign((void **)&more, 64, sizeof(double) * (size_t)B * (size_t)(23 + 14 * rows)) != 0)
        more = NULL;
    et_followers c = {(et_kernel)kernel_address, (et_block_fn)block_address, n_in, rows, nf, in, stride, role,
                      followers, full, more, more ? more + 6 * B : NULL, more ? more + 15 * B : NULL,
                      more ? more + 17 * B : NULL,
                      malloc(sizeof(double *) * (size_t)(n_in > 0 ? n_in : 1)),
                      malloc(sizeof(int64_t) * (size_t)(n_in > 0 ? n_in : 1)),
                      {more ? more + 23 * B : NULL, more ? more + (23 + rows) * B : NULL},
                      more ? more + (23 + 7 * rows) * B : NULL,
                      block_address ? malloc(sizeof(double) * B * (size_t)(n_in > 0 ? n_in : 1)) : NULL, -1,
                      block_address ? malloc(sizeof(double *) * (size_t)(7 * rows)) : NULL};
    int rc = 0;
    if (!buf || !more || !c.ptr || !c.st || (block_address && (!c.held || !c.rows_at)))
        rc = -2;
    if (rc == 0 && block_address)              /* the kernel's output rows: closure's, then its rates' */
        for (int e = 0; e < 7 * rows; ++e)
            c.rows_at[e] = more + (23 + (int64_t)e) * B;
    for (int64_t b0 = 0; b0 < n && rc == 0; b0 += B) {
        const int m = n - b0 < B ? (int)(n - b0) : B;
        for (int f = 0; f < nf; ++f)
            for (int i = 0; i < B; ++i)
                qs[f * B + i] = q[(b0 + (i < m ? i : m - 1)) * nf + f];
        if ((rc = et_lm_block(et_followers_eval, &c, m, b0, 1, rows, nf, qs, rs, As, nrm, &wk, iterations, tol,
                              lambda0, max_step)) != 0)
            break;
        for (int i = 0; i < m; ++i) {
            for (int f = 0; f < nf; ++f)
                q[(b0 + i) * nf + f] = qs[f * B + i];
            norm[b0 + i] = nrm[i];
        }
    }
    free(buf); free(wk.act); free(more); free(c.ptr); free(c.st); free(c.held); free(c.rows_at);
    return rc;
}

/* A piece of a batch of numeric IK, levenberg_marquardt.solve's first stage without Python
   between its steps: et_newton_lm's iterations on the n poses from pose `at` of the inputs (in[k] moved by
   stride[k] * at; the joint coordinates' entries, NULL, are filled by the driver) from q
   (n, legs, nq), then each leg's lever by the kernel at lever_address (its inputs lin[k]
   (lstride[k]) moved to pose `at`, or where lq_of[k] >= 0 the entry lq_of[k] of the pose's
   row of q) and its sign against ref_sign[leg] (0: either sign). lever_out (n, legs) receives
   the levers; done[i] = 1 where every leg of pose i converged (norm < tol) with its branch's
   sign (a NaN lever has none), else 0: the caller solves those poses' chunks the long way.
   Returns et_newton_lm's code, the lever kernel's, or -2 when out of memory. */
int et_newton_branch(int64_t n, int64_t at, void *closure_address, void *block_address, int n_in,
                     const double *const *in, const int64_t *stride, const int *q_of, int legs, int rows, int nq,
                     double *q, double *norm, int iterations, double tol, double lambda0, double max_step,
                     void *lever_address, int n_lin, const double *const *lin, const int64_t *lstride,
                     const int *lq_of, const double *ref_sign, double *lever_out, int8_t *done)
{
    const int na = n_in > 0 ? n_in : 1, nl = n_lin > 0 ? n_lin : 1;
    const double **moved = malloc(sizeof(double *) * (size_t)(na + nl));
    int64_t *lst = malloc(sizeof(int64_t) * (size_t)nl);
    int rc = -2;
    if (moved && lst) {
        for (int k = 0; k < n_in; ++k)
            moved[k] = in[k] ? in[k] + stride[k] * at : 0;
        rc = et_newton_lm(n, closure_address, block_address, n_in, moved, stride, q_of, legs, rows, nq, q, norm,
                          iterations, tol, lambda0, max_step);
    }
    if (rc == 0) {
        const double **lp = moved + na;
        for (int k = 0; k < n_lin; ++k) {
            if (lq_of[k] >= 0) {
                lp[k] = q + lq_of[k];
                lst[k] = (int64_t)legs * nq;
            } else {
                lp[k] = lin[k] ? lin[k] + lstride[k] * at : 0;
                lst[k] = lstride[k];
            }
        }
        double *outs[1] = {lever_out};
        rc = ((et_kernel)lever_address)(n, lp, lst, outs);
        for (int64_t i = 0; i < n && rc == 0; ++i) {
            int ok = 1;
            for (int l = 0; l < legs; ++l) {
                const double v = lever_out[i * legs + l], sign = (double)((v > 0.0) - (v < 0.0));
                ok &= norm[i * legs + l] < tol && (ref_sign[l] == 0.0 || (v == v && sign == ref_sign[l]));
            }
            done[i] = (int8_t)ok;
        }
    }
    free(moved);
    free(lst);
    return rc;
}

#if defined(__GNUC__)
/* A batch's et_newton_branch handed out to threads: each thread makes one call of
   et_newton_branch_work, which takes grains of `grain` poses from the shared counter `next`
   until none is left or a grain fails (its code kept in `rc`, the first one). The fields are
   et_newton_branch's arguments for the whole batch (q, norm, lever_out, done: n rows). */
typedef struct {
    int64_t n, grain;
    void *closure, *block;
    int64_t n_in;
    const double *const *in;
    const int64_t *stride;
    const int *q_of;
    int64_t legs, rows, nq;
    double *q, *norm;
    int64_t iterations;
    double tol, lambda0, max_step;
    void *lever;
    int64_t n_lin;
    const double *const *lin;
    const int64_t *lstride;
    const int *lq_of;
    const double *ref_sign;
    double *lever_out;
    int8_t *done;
    const double *x;          /* the poses (n, d) q is predicted at, or NULL: q holds the starts */
    int64_t d;
    const double *x_ref, *G, *base;  /* the prediction q = base + (x - x_ref) G, G (d, legs * nq) */
    int64_t next, rc;
} et_branch_batch;

/* q (m rows of k) predicted at poses x (m rows of d): base + (x - x_ref) G, G (d, k) row-major,
   each product rounded and summed in the order of the pose's entries, then base added
   (levenberg_marquardt.Prediction's einsum: the same bits) */
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("fp-contract=off")))
#endif
static void et_predict(int64_t m, const double *x, int64_t d, const double *x_ref, const double *G,
                       const double *base, int64_t k, double *q)
{
#if defined(__clang__)
#pragma clang fp contract(off)
#endif
    for (int64_t i = 0; i < m; ++i) {
        double *qi = q + i * k;
        const double dx0 = x[i * d] - x_ref[0];
        for (int64_t e = 0; e < k; ++e)
            qi[e] = dx0 * G[e];
        for (int64_t j = 1; j < d; ++j) {
            const double dx = x[i * d + j] - x_ref[j];
            for (int64_t e = 0; e < k; ++e)
                qi[e] = qi[e] + dx * G[j * k + e];
        }
        for (int64_t e = 0; e < k; ++e)
            qi[e] = qi[e] + base[e];
    }
}

int et_newton_branch_work(et_branch_batch *s)
{
    const int64_t lq = s->legs * s->nq;
    while (!__atomic_load_n(&s->rc, __ATOMIC_RELAXED)) {
        const int64_t b0 = __atomic_fetch_add(&s->next, 1, __ATOMIC_RELAXED) * s->grain;
        if (b0 >= s->n)
            break;
        const int64_t m = s->n - b0 < s->grain ? s->n - b0 : s->grain;
        if (s->x)
            et_predict(m, s->x + b0 * s->d, s->d, s->x_ref, s->G, s->base, lq, s->q + b0 * lq);
        const int rc = et_newton_branch(m, b0, s->closure, s->block, (int)s->n_in, s->in, s->stride, s->q_of,
                                        (int)s->legs, (int)s->rows, (int)s->nq, s->q + b0 * lq, s->norm + b0 * s->legs,
                                        (int)s->iterations, s->tol, s->lambda0, s->max_step, s->lever, (int)s->n_lin,
                                        s->lin, s->lstride, s->lq_of, s->ref_sign, s->lever_out + b0 * s->legs,
                                        s->done + b0);
        if (rc) {
            int64_t none = 0;
            __atomic_compare_exchange_n(&s->rc, &none, (int64_t)rc, 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED);
            break;
        }
    }
    return 0;
}
#endif
"""
)

BLOCK = 64  # poses per block (B in the source)
_DRIVER: list = []  # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []  # the loaded driver library, kept for the process
_FOLLOWERS: list = []  # [ctypes function et_followers_lm] once bound, [None] when it cannot be


#: the leading arguments of a driver calling a generated kernel: poses, the kernel's and its
#: block function's addresses, its inputs' count, addresses, strides and joint entries (q_of)
_KERNEL_ARGS = [
    ctypes.c_int64,
    ctypes.c_void_p,
    ctypes.c_void_p,
    ctypes.c_int,
    ctypes.POINTER(ctypes.c_void_p),
    ctypes.POINTER(ctypes.c_int64),
    ctypes.POINTER(ctypes.c_int),
]
#: the trailing arguments of the Newton drivers: iterations, tolerance, first damping, largest step
_NEWTON_ARGS = [ctypes.c_int, ctypes.c_double, ctypes.c_double, ctypes.c_double]


def _bind(lib):
    """et_newton_lm of the loaded library, its argument and return types declared."""
    fn = lib.et_newton_lm
    # legs, rows, n_q, q, the residual norms
    fn.argtypes = _KERNEL_ARGS + [ctypes.c_int] * 3 + [ctypes.c_void_p] * 2 + _NEWTON_ARGS
    fn.restype = ctypes.c_int
    return fn


def driver():
    """The compiled driver ``et_newton_lm`` (built on first use into the cache), or None
    where it cannot be built (no compiler)."""
    return library_once(_DRIVER, _LIBRARIES, SOURCE, "newton", _bind)


def block_steps(A: np.ndarray, r: np.ndarray, scale, shift: float):
    """The driver's damped Gauss-Newton steps (:func:`eigentwist.runtime.levenberg_marquardt.normal_solve`'s)
    of one block of ``BLOCK`` systems, A (BLOCK, rows, n_q) and r (BLOCK, rows); ``scale``
    (BLOCK,) or None (undamped: ``diag(shift)``). Returns (BLOCK, n_q), or None where the
    driver cannot be built. Raises InputError for sizes the driver does not take."""
    from .errors import InputError

    if driver() is None:
        return None
    fn = _LIBRARIES[0].et_block_steps
    V = ctypes.c_void_p
    fn.argtypes = [ctypes.c_int, ctypes.c_int, V, V, V, ctypes.c_double, V]
    fn.restype = ctypes.c_int
    A = np.asarray(A, dtype=float)
    n, rows, nq = A.shape
    if n != BLOCK:
        raise InputError(f"block_steps takes {BLOCK} systems, got {n}")
    As = np.ascontiguousarray(np.moveaxis(A, 0, -1))
    rs = np.ascontiguousarray(np.asarray(r, dtype=float).T)
    sc = None if scale is None else np.ascontiguousarray(np.broadcast_to(np.asarray(scale, dtype=float), (BLOCK,)))
    x = np.empty((nq, BLOCK))
    rc = fn(rows, nq, address(As), address(rs), None if sc is None else address(sc), float(shift), address(x))
    if rc == -1:
        raise InputError(f"the driver takes 1 to 8 coordinates and at least one row, got rows={rows}, n_q={nq}")
    if rc != 0:
        raise MemoryError("et_block_steps: out of memory")
    return x.T


def iterate(
    closure_address: int,
    block_address: int | None,
    n_q_inputs: list,
    addresses: list,
    strides: list,
    q: np.ndarray,
    rows: int,
    iterations: int,
    tol: float,
    threads: int = 1,
    lambda0: float = LAMBDA0,
):
    """Run the driver: ``(q, |r|)`` from ``q`` (n, legs, n_q) for the closure kernel at
    ``closure_address``, evaluated by its block function at ``block_address`` where that is
    not None (the kernel's outputs: the residual (legs, rows), then its Jacobian (legs, rows,
    n_q)); ``n_q_inputs[k]`` is ``leg * n_q + coordinate`` for the kernel's
    joint-coordinate inputs and -1 for the others, read at ``addresses[k]`` with
    ``strides[k]`` (doubles). ``threads`` > 1 runs ranges of whole blocks on that many
    threads (each pose's iterations are its own: the results do not depend on it);
    ``lambda0`` the first damping. Raises RuntimeError when the driver fails."""
    n, legs, nq = q.shape
    qq = np.array(q, dtype=np.float64, order="C")
    norm = np.empty((n, legs))
    q_of = (ctypes.c_int * max(len(n_q_inputs), 1))(*n_q_inputs)
    fn = driver()

    def call(a: int, b: int) -> int:
        return fn(
            b - a,
            closure_address,
            block_address,
            len(addresses),
            *_inputs_at(addresses, strides, a),
            q_of,
            legs,
            rows,
            nq,
            address(qq) + 8 * a * legs * nq,
            address(norm) + 8 * a * legs,
            int(iterations),
            float(tol),
            float(lambda0),
            MAX_STEP,
        )

    _run_blocks(call, n, threads, "C Newton iterations")
    return qq, norm


_BRANCH: list = []  # [ctypes function et_newton_branch_work] once bound, [None] when it cannot be
GRAIN = 4 * BLOCK  # poses a thread takes at a time from a batch's shared counter


def branch_driver():
    """The compiled ``et_newton_branch_work`` (:func:`driver`'s library; gcc's and clang's
    ``__atomic`` builtins), or None where that cannot be built."""
    if not _BRANCH:
        fn = None
        if driver() is not None and _LIBRARIES:
            fn = getattr(_LIBRARIES[0], "et_newton_branch_work", None)
            if fn is not None:
                fn.argtypes = [ctypes.c_void_p]
                fn.restype = ctypes.c_int
        _BRANCH.append(fn)
    return _BRANCH[0]


class _BranchBatch(ctypes.Structure):
    """The C ``et_branch_batch`` of one batch (see :data:`SOURCE`)."""

    _fields_ = [
        (name, kind)
        for names, kind in (
            (("n", "grain"), ctypes.c_int64),
            (("closure", "block"), ctypes.c_void_p),
            (("n_in",), ctypes.c_int64),
            (("ins", "strides", "q_of"), ctypes.c_void_p),
            (("legs", "rows", "nq"), ctypes.c_int64),
            (("q", "norm"), ctypes.c_void_p),
            (("iterations",), ctypes.c_int64),
            (("tol", "lambda0", "max_step"), ctypes.c_double),
            (("lever",), ctypes.c_void_p),
            (("n_lin",), ctypes.c_int64),
            (("lin", "lstrides", "lq_of", "ref_sign", "lever_out", "done", "x"), ctypes.c_void_p),
            (("d",), ctypes.c_int64),
            (("x_ref", "G", "base"), ctypes.c_void_p),
            (("next", "rc"), ctypes.c_int64),
        )
        for name in names
    ]


class BranchSolver:
    """The first stage of :func:`eigentwist.runtime.levenberg_marquardt.solve` on a batch in C:
    the Newton iterations from a start, then each leg's lever and its sign against the assembly
    branch's (``et_newton_branch``), on grains of :data:`GRAIN` poses handed out to the threads
    (``et_newton_branch_work``: each thread one C call). The kernels' input tables are made
    once for the batch (``closure`` and ``lever``: ``(address, addresses, strides, q_of)``,
    the inputs of pose 0 and their strides in doubles, a joint coordinate's entry of the
    pose's row of q or -1), each grain moving them to its first pose. A pose's iterations are
    its own, so the grains do not change its result. Made by
    :meth:`~eigentwist.runtime.c_kernels.CKernels.branch_solver`."""

    def __init__(self, closure, block, lever, legs: int, rows: int, nq: int, signs, keep: list):
        kernel, addresses, strides, q_of = closure
        size = max(len(addresses), 1)
        self._tables = [
            (ctypes.c_void_p * size)(*(int(a) or None for a in addresses)),
            (ctypes.c_int64 * size)(*(int(s) for s in strides)),
            (ctypes.c_int * size)(*(int(k) for k in q_of)),
        ]
        self._closure = (kernel, block, len(addresses))
        kernel, addresses, strides, q_of = lever
        size = max(len(addresses), 1)
        self._tables += [
            (ctypes.c_void_p * size)(*(int(a) or None for a in addresses)),
            (ctypes.c_int64 * size)(*(int(s) for s in strides)),
            (ctypes.c_int * size)(*(int(k) for k in q_of)),
        ]
        self._lever = (kernel, len(addresses))
        self._signs = np.ascontiguousarray(np.broadcast_to(np.asarray(signs, dtype=np.float64), (legs,)))
        self._shape, self._rows, self._keep = (legs, nq), rows, keep

    def __call__(
        self, q: np.ndarray, iterations: int, tol: float, lambda0: float, threads: int = 1, predict=None
    ) -> np.ndarray:
        """Iterate the batch's starts ``q`` (n, legs, n_q), C-contiguous float64, in place, with
        first damping ``lambda0`` on ``threads`` threads (:func:`~.threads.threads_for`);
        ``predict``: ``(poses, prediction)``, the starts predicted in C on each grain instead
        (``prediction`` a :class:`~.levenberg_marquardt.Prediction`, ``poses`` (n, d); q then
        only receives the result). Returns done (n,) bool: every leg of the pose converged on
        its branch (where not, the caller solves its chunk the long way). Raises InputError for
        another ``q`` or poses and RuntimeError when the driver or the lever kernel fails."""
        from .threads import run_workers, threads_for

        n, (legs, nq) = len(q), self._shape
        if q.shape != (n, legs, nq) or q.dtype != np.float64 or not q.flags.c_contiguous:
            from .errors import InputError

            raise InputError(f"q: expected a C-contiguous float64 array ({n}, {legs}, {nq}), got {q.shape} {q.dtype}")
        norm, lever = np.empty((n, legs)), np.empty((n, legs))
        done = np.empty(n, dtype=np.int8)
        at = ctypes.addressof
        ins, strides, q_of, lin, lstrides, lq_of = self._tables
        pred = (None, 0, None, None, None)
        if predict is not None:
            poses, prediction = predict
            poses = np.ascontiguousarray(poses, dtype=np.float64)
            d = len(prediction.x_ref)
            if poses.shape != (n, d) or prediction.G.shape != (d, legs * nq):
                from .errors import InputError

                raise InputError(f"poses: expected ({n}, {d}) to predict ({n}, {legs}, {nq}) from, got {poses.shape}")
            arrays = [
                np.ascontiguousarray(a, dtype=np.float64) for a in (prediction.x_ref, prediction.G, prediction.base)
            ]
            pred = (address(poses), d, *(address(a) for a in arrays))
        batch = _BranchBatch(
            n, GRAIN, *self._closure, at(ins), at(strides), at(q_of), legs, self._rows, nq,
            address(q), address(norm), int(iterations), float(tol), float(lambda0), MAX_STEP, *self._lever,
            at(lin), at(lstrides), at(lq_of), address(self._signs), address(lever), address(done), *pred,
        )  # fmt: skip
        state, work = at(batch), branch_driver()
        run_workers(lambda: work(state), threads_for(n, BLOCK, threads))
        if batch.rc != 0:
            raise RuntimeError(f"C Newton iterations on a batch returned {batch.rc}")
        return done.view(bool)


def followers_driver():
    """The compiled ``et_followers_lm`` (:func:`driver`'s library), or None where that
    cannot be built."""
    if not _FOLLOWERS:
        fn = None
        if driver() is not None and _LIBRARIES:
            fn = _LIBRARIES[0].et_followers_lm
            # the followers' count and indices, the closures per pose, the full poses, q, the norms
            P, V = ctypes.POINTER, ctypes.c_void_p
            fn.argtypes = _KERNEL_ARGS + [ctypes.c_int, P(ctypes.c_int), ctypes.c_int, V, V, V] + _NEWTON_ARGS
            fn.restype = ctypes.c_int
        _FOLLOWERS.append(fn)
    return _FOLLOWERS[0]


def follow(
    kernel_address: int,
    block_address: int | None,
    roles: list,
    addresses: list,
    strides: list,
    followers: list,
    full: np.ndarray,
    q: np.ndarray,
    rows: int,
    iterations: int,
    tol: float,
    threads: int = 1,
):
    """The iterations of :func:`iterate` on a platform's followers, in C: ``(q, |r|)``
    ((n, 1, followers) and (n, 1)) from the starting values ``q`` (n, 1, followers) of the
    followers (indices into x, y, z, rot_x, rot_y, rot_z) at the commanded full poses
    ``full`` (n, 6; m, rad), for the followers kernel at ``kernel_address`` (closed-form
    legs: its ``closure`` (rows,) and ``closure_rate`` (rows, 6) at a full pose), evaluated
    by its block function at ``block_address`` where that is not None. The
    kernel's input k is the pose's x, y, z (``roles[k]`` 0-2), its rotation entry R_ij
    (3 + 3 i + j, from the rotation vector by Rodrigues' formula), or else (-1) read at
    ``addresses[k]`` with ``strides[k]`` (doubles). The Jacobian on the followers is the
    closure's rates along their twists (:func:`eigentwist.runtime.platform.along_followers`).
    ``threads`` > 1 runs ranges of whole blocks on threads (the same results). Raises
    RuntimeError when the driver fails."""
    n, _, nf = q.shape
    qq = np.array(q, dtype=np.float64, order="C").reshape(n, 1, nf)
    norm = np.empty((n, 1))
    poses = np.ascontiguousarray(full, dtype=np.float64)
    role = (ctypes.c_int * max(len(roles), 1))(*roles)
    which = (ctypes.c_int * max(nf, 1))(*followers)
    fn = followers_driver()

    def call(a: int, b: int) -> int:
        return fn(
            b - a,
            kernel_address,
            block_address,
            len(addresses),
            *_inputs_at(addresses, strides, a),
            role,
            nf,
            which,
            rows,
            address(poses) + 8 * a * 6,
            address(qq) + 8 * a * nf,
            address(norm) + 8 * a,
            int(iterations),
            float(tol),
            LAMBDA0,
            MAX_STEP,
        )

    _run_blocks(call, n, threads, "C follower iterations")
    return qq, norm


def _inputs_at(addresses: list, strides: list, a: int) -> tuple:
    """The ctypes arrays of the inputs' addresses moved to pose ``a`` (``strides[k]``
    doubles a pose) and of their strides, as the drivers take them."""
    size = max(len(addresses), 1)
    moved = [x + 8 * a * st for x, st in zip(addresses, strides)]
    return (ctypes.c_void_p * size)(*moved), (ctypes.c_int64 * size)(*strides)


def _run_blocks(call, n: int, threads: int, what: str) -> None:
    """``call(begin, end)`` over ranges of whole blocks on the threads
    (:func:`~eigentwist.runtime.threads.run_ranges`); RuntimeError naming ``what`` and the
    code where a range returns one."""
    from .threads import run_ranges, threads_for

    for rc in run_ranges(call, n, BLOCK, threads_for(n, BLOCK, threads)):
        if rc != 0:
            raise RuntimeError(f"{what} returned {rc}")
