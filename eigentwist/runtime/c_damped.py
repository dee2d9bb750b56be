"""The damped modes of :func:`eigentwist.runtime.damped.damped_modes` in C, for a batch of poses.

:func:`solve` runs, pose by pose in one C call (ranges of whole blocks of poses on the
evaluator's threads), what the NumPy function does for real stiffness without couplings
between the legs' internal coordinates:

1. the undamped modes ``K Phi = M Phi Omega^2`` (Cholesky reduction, cyclic Jacobi);
2. the first-order state matrix on ``[Omega q; dq/dt; y]`` with the same elimination rule
   (:data:`~eigentwist.runtime.damped.ELIMINATE`: a leg whose internal pole lies beyond
   1/ELIMINATE times the highest undamped omega becomes a damping matrix);
3. its eigenvalues: balancing by powers of two, Householder reduction to Hessenberg form
   and Francis double-shift QR in real arithmetic (Golub and Van Loan, Algorithms 7.4.2,
   7.5.1 and 7.5.2);
4. each undamped mode's pole: by order of ``|s|`` where every pole lies closer to its own
   mode's omega than ``AMBIGUOUS`` times the distance to a neighbour's, else by modal-energy
   share, with the eigenvectors from inverse iteration in complex arithmetic (the
   one-to-one assignment of largest total share, then the overdamped modes' real pole
   pairs), as :func:`~eigentwist.runtime.damped._assign` does.

Four entry points run these steps: :func:`solve` on given M, K and actuator wrenches;
:func:`solve_legs` from the legs kernel's outputs (the actuator wrenches, the stiffness and
the projection on the model's coordinates in C too); :func:`one_pass` inside the robot's
fused pass: per block of poses the generated fused pass (inverse kinematics, M and the
model's stiffness, the undamped modes), the generated ``legs`` kernel on the block's joint
coordinates, then the damped modes, with no Python between them (the robot's library and
this one each loaded only after their SHA-256 check; the driver calls the robot's functions
by address); :func:`exact_pass` the same for legs with rigid directions, condensed exactly
between the kernels and the solve as :func:`.condense.condensed_modes` does (each leg's
rigid rows, the admissible twists B from their Gram matrix, the undamped modes on B), the
damped solve optional.

With a structural loss factor (stiffness ``K + i K_loss``, complex actuator wrenches:
:func:`wrenches` with ``loss``), :func:`solve_complex` runs the same steps on the complex state
matrix: balancing, complex Householder reduction to Hessenberg form and single-shift QR with
Wilkinson shifts (Golub and Van Loan, Algorithm 7.5.1's complex form), the poles of positive
frequency assigned by the same rules.

A pose the C code cannot decide (the QR iteration without convergence, an inertia that is
not positive definite, more than ``MAX_ASSIGN`` (10) poles of positive frequency to assign
by share) is marked, and
:func:`~eigentwist.runtime.damped.damped_modes` solves it in NumPy. The driver is plain
C99 compiled once into the cache (:mod:`.ccompile`: loaded only after its recorded
SHA-256 matches); where it cannot be built, :func:`driver` is None and NumPy runs.
"""

from __future__ import annotations

import ctypes

import numpy as np

from .addresses import address
from .ccompile import library_once

__all__ = [
    "driver",
    "solve",
    "solve_complex",
    "wrenches",
    "one_pass",
    "exact_pass",
    "solve_legs",
    "SOURCE",
    "MAX_MODES",
    "MAX_LEGS",
    "BLOCK",
]

#: the largest problem the C driver takes (modes, legs); a larger one is solved in NumPy
MAX_MODES = 12
MAX_LEGS = 16
#: poses per block of the thread ranges
BLOCK = 16

#: real poles whose modal-energy shares in a mode differ by less than SHARE_TIE share it
#: equally (a decoupled subsystem's poles have share 1 each, to round-off ~1e-15): the slower
#: is taken, so the choice does not follow the order in which LAPACK returns them (the C
#: driver's rule and :func:`eigentwist.runtime.damped._assign`'s)
SHARE_TIE = 1e-9
SOURCE = r"""
#include <complex.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define MAXN 12
#define MAXL 16
#define MAXM (2 * MAXN + MAXL)
#define MAX_ASSIGN 10
#define NO_POLE 1e300
#define SHARE_TIE @SHARE_TIE@ /* SHARE_TIE of this module: shares this close tie; the slower pole wins */

/* Of the nc poles cand[] (indices into wr), the one of largest share in a mode (share: that
   mode's share of every pole), the slowest (largest wr) of those within SHARE_TIE of it, the
   first in cand[] among equals: its position in cand[], -1 when nc is 0 (the rule of
   damped._largest_share) */
static int et_largest_share(int nc, const int *cand, const double *share, const double *wr)
{
    double top = -INFINITY;
    for (int r = 0; r < nc; ++r)
        top = fmax(top, share[cand[r]]);
    int b = -1;
    for (int r = 0; r < nc; ++r)
        if (share[cand[r]] >= top - SHARE_TIE && (b < 0 || wr[cand[r]] > wr[cand[b]]))
            b = r;
    return b;
}

/* M = C C^T (C lower, n x n row-major); 0 where M is not positive definite */
static int et_cholesky(int n, const double *M, double *C)
{
    memset(C, 0, sizeof(double) * n * n);
    for (int j = 0; j < n; ++j) {
        double d = M[j * n + j];
        for (int k = 0; k < j; ++k)
            d -= C[j * n + k] * C[j * n + k];
        if (!(d > 0.0))
            return 0;
        C[j * n + j] = sqrt(d);
        for (int i = j + 1; i < n; ++i) {
            double v = M[i * n + j];
            for (int k = 0; k < j; ++k)
                v -= C[i * n + k] * C[j * n + k];
            C[i * n + j] = v / C[j * n + j];
        }
    }
    return 1;
}

/* X := C^-1 X for the n x n matrix X (forward substitution, column by column) */
static void et_lower_solve(int n, const double *C, double *X)
{
    for (int c = 0; c < n; ++c)
        for (int i = 0; i < n; ++i) {
            double v = X[i * n + c];
            for (int k = 0; k < i; ++k)
                v -= C[i * n + k] * X[k * n + c];
            X[i * n + c] = v / C[i * n + i];
        }
}

/* symmetric S (n x n) = V diag(lam) V^T by cyclic Jacobi rotations; lam ascending */
static void et_jacobi(int n, double *S, double *lam, double *V)
{
    for (int i = 0; i < n * n; ++i)
        V[i] = 0.0;
    for (int i = 0; i < n; ++i)
        V[i * n + i] = 1.0;
    for (int sweep = 0; sweep < 100; ++sweep) {
        int rotated = 0;
        for (int p = 0; p < n - 1; ++p)
            for (int q = p + 1; q < n; ++q) {
                double apq = S[p * n + q], app = S[p * n + p], aqq = S[q * n + q];
                if (fabs(apq) <= 1e-18 * sqrt(fabs(app * aqq)) || apq == 0.0)
                    continue;
                rotated = 1;
                double theta = (aqq - app) / (2.0 * apq);
                double t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < n; ++k) {
                    double a = S[k * n + p], b = S[k * n + q];
                    S[k * n + p] = c * a - s * b;
                    S[k * n + q] = s * a + c * b;
                }
                for (int k = 0; k < n; ++k) {
                    double a = S[p * n + k], b = S[q * n + k];
                    S[p * n + k] = c * a - s * b;
                    S[q * n + k] = s * a + c * b;
                }
                for (int k = 0; k < n; ++k) {
                    double a = V[k * n + p], b = V[k * n + q];
                    V[k * n + p] = c * a - s * b;
                    V[k * n + q] = s * a + c * b;
                }
            }
        if (!rotated)
            break;
    }
    for (int i = 0; i < n; ++i)
        lam[i] = S[i * n + i];
    for (int i = 1; i < n; ++i) /* insertion sort of the pairs */
        for (int j = i; j > 0 && lam[j] < lam[j - 1]; --j) {
            double t = lam[j];
            lam[j] = lam[j - 1];
            lam[j - 1] = t;
            for (int k = 0; k < n; ++k) {
                t = V[k * n + j];
                V[k * n + j] = V[k * n + j - 1];
                V[k * n + j - 1] = t;
            }
        }
}

/* diagonal similarity by powers of two that evens each row's and column's 1-norms */
static void et_balance(int m, double *A)
{
    int done = 0;
    while (!done) {
        done = 1;
        for (int i = 0; i < m; ++i) {
            double c = 0.0, r = 0.0;
            for (int j = 0; j < m; ++j)
                if (j != i) {
                    c += fabs(A[j * m + i]);
                    r += fabs(A[i * m + j]);
                }
            if (c == 0.0 || r == 0.0 || !isfinite(c + r))
                continue;
            double total = c + r, f = 1.0, g = r / 2.0;
            while (c < g) {
                f *= 2.0;
                c *= 4.0;
            }
            g = r * 2.0;
            while (c > g) {
                f /= 2.0;
                c /= 4.0;
            }
            if ((c + r) / f < 0.95 * total) {
                done = 0;
                for (int j = 0; j < m; ++j) {
                    A[i * m + j] /= f;
                    A[j * m + i] *= f;
                }
            }
        }
    }
}

/* apply the reflector I - 2 v v^T / (v^T v) of length len at rows/columns k.. */
static void et_reflect_rows(int m, double *A, int k, int len, const double *v, double vv, int c0, int c1)
{
    double f = 2.0 / vv;
    for (int j = c0; j <= c1; ++j) {
        double s = 0.0;
        for (int i = 0; i < len; ++i)
            s += v[i] * A[(k + i) * m + j];
        s *= f;
        for (int i = 0; i < len; ++i)
            A[(k + i) * m + j] -= s * v[i];
    }
}

static void et_reflect_cols(int m, double *A, int k, int len, const double *v, double vv, int r0, int r1)
{
    double f = 2.0 / vv;
    for (int i = r0; i <= r1; ++i) {
        double s = 0.0;
        for (int j = 0; j < len; ++j)
            s += A[i * m + k + j] * v[j];
        s *= f;
        for (int j = 0; j < len; ++j)
            A[i * m + k + j] -= s * v[j];
    }
}

/* v with (I - 2 v v^T / v^T v) u = (beta, 0, ...); returns v^T v (0: nothing to do) */
static double et_householder(int len, const double *u, double *v)
{
    double nrm = 0.0;
    for (int i = 0; i < len; ++i)
        nrm += u[i] * u[i];
    nrm = sqrt(nrm);
    if (nrm == 0.0)
        return 0.0;
    for (int i = 0; i < len; ++i)
        v[i] = u[i];
    v[0] += u[0] >= 0.0 ? nrm : -nrm;
    double vv = 0.0;
    for (int i = 0; i < len; ++i)
        vv += v[i] * v[i];
    return vv;
}

static void et_hessenberg(int m, double *A)
{
    double u[MAXM], v[MAXM];
    for (int k = 0; k < m - 2; ++k) {
        int len = m - k - 1;
        for (int i = 0; i < len; ++i)
            u[i] = A[(k + 1 + i) * m + k];
        double vv = et_householder(len, u, v);
        if (vv == 0.0)
            continue;
        et_reflect_rows(m, A, k + 1, len, v, vv, k, m - 1);
        et_reflect_cols(m, A, k + 1, len, v, vv, 0, m - 1);
        for (int i = k + 2; i < m; ++i)
            A[i * m + k] = 0.0;
    }
}

/* the eigenvalues of [a b; c d] */
static void et_two(double a, double b, double c, double d, double *re, double *im)
{
    double p = 0.5 * (a - d), q = p * p + b * c;
    if (q >= 0.0) {
        double z = p + (p >= 0.0 ? sqrt(q) : -sqrt(q));
        re[0] = d + z;
        re[1] = z != 0.0 ? d - b * c / z : d;
        im[0] = im[1] = 0.0;
    } else {
        re[0] = re[1] = d + p;
        im[0] = sqrt(-q);
        im[1] = -im[0];
    }
}

/* eigenvalues of the upper Hessenberg H (m x m, overwritten) by Francis double-shift QR;
   0 where it does not converge */
static int et_francis(int m, double *H, double *wr, double *wi)
{
    int hi = m - 1, its = 0, total = 0;
    while (hi >= 0) {
        int l;
        for (l = hi; l > 0; --l) {
            double s = fabs(H[(l - 1) * m + l - 1]) + fabs(H[l * m + l]);
            if (s == 0.0)
                for (int i = l - 1; i <= hi; ++i)
                    for (int j = l - 1; j <= hi; ++j)
                        s += fabs(H[i * m + j]);
            if (fabs(H[l * m + l - 1]) <= DBL_EPSILON * s) {
                H[l * m + l - 1] = 0.0;
                break;
            }
        }
        if (l == hi) {
            wr[hi] = H[hi * m + hi];
            wi[hi] = 0.0;
            hi -= 1;
            its = 0;
            continue;
        }
        if (l == hi - 1) {
            et_two(H[(hi - 1) * m + hi - 1], H[(hi - 1) * m + hi], H[hi * m + hi - 1], H[hi * m + hi], wr + hi - 1,
                   wi + hi - 1);
            hi -= 2;
            its = 0;
            continue;
        }
        if (++total > 60 * m)
            return 0;
        ++its;
        /* the shifts: the roots of (x - a)(x - d) - bc, the trailing 2 x 2 block's eigenvalues */
        double a = H[(hi - 1) * m + hi - 1], d = H[hi * m + hi], bc = H[(hi - 1) * m + hi] * H[hi * m + hi - 1];
        if (its % 11 == 0) { /* an exceptional shift pair, off the stalled one */
            a = d = d + 0.75 * (fabs(H[hi * m + hi - 1]) + fabs(H[(hi - 1) * m + hi - 2]));
            bc = 0.0;
        }
        /* first column of (H - s1)(H - s2), from differences to the shifts (no cancellation
           of the diagonal's size where the eigenvalues cluster) */
        double u[3], v[3];
        double h00 = H[l * m + l], h10 = H[(l + 1) * m + l];
        u[0] = (h00 - a) * (h00 - d) - bc + H[l * m + l + 1] * h10;
        u[1] = h10 * ((h00 - a) + (H[(l + 1) * m + l + 1] - d));
        u[2] = h10 * H[(l + 2) * m + l + 1];
        for (int k = l; k < hi; ++k) {
            int len = k + 2 <= hi ? 3 : 2;
            if (k > l) {
                u[0] = H[k * m + k - 1];
                u[1] = H[(k + 1) * m + k - 1];
                u[2] = len == 3 ? H[(k + 2) * m + k - 1] : 0.0;
            }
            double vv = et_householder(len, u, v);
            if (vv == 0.0)
                continue;
            /* the reflector I - tau w w^T with w = v / v0 (w0 = 1), applied in place */
            double tau = 2.0 * v[0] * v[0] / vv, w1 = v[1] / v[0], w2 = len == 3 ? v[2] / v[0] : 0.0;
            int c0 = k > l ? k - 1 : l, r1 = k + 3 < hi ? k + 3 : hi;
            double *r0p = H + k * m, *r1p = r0p + m, *r2p = r1p + m;
            if (len == 3) {
                for (int j = c0; j <= hi; ++j) {
                    double t = tau * (r0p[j] + w1 * r1p[j] + w2 * r2p[j]);
                    r0p[j] -= t;
                    r1p[j] -= t * w1;
                    r2p[j] -= t * w2;
                }
                for (int i = l; i <= r1; ++i) {
                    double *row = H + i * m + k;
                    double t = tau * (row[0] + w1 * row[1] + w2 * row[2]);
                    row[0] -= t;
                    row[1] -= t * w1;
                    row[2] -= t * w2;
                }
            } else {
                for (int j = c0; j <= hi; ++j) {
                    double t = tau * (r0p[j] + w1 * r1p[j]);
                    r0p[j] -= t;
                    r1p[j] -= t * w1;
                }
                for (int i = l; i <= r1; ++i) {
                    double *row = H + i * m + k;
                    double t = tau * (row[0] + w1 * row[1]);
                    row[0] -= t;
                    row[1] -= t * w1;
                }
            }
            if (k > l) {
                H[(k + 1) * m + k - 1] = 0.0;
                if (len == 3)
                    H[(k + 2) * m + k - 1] = 0.0;
            }
        }
    }
    return 1;
}

/* an eigenvector x of a complex A (m x m) for the eigenvalue s: inverse iteration on A - s I
   (LU with partial pivoting, a zero pivot replaced by eps times the norm) */
static __attribute__((noinline)) void et_zvector(int m, const double complex *A, double complex s, double complex *x)
{
    double complex L[MAXM * MAXM];
    int piv[MAXM];
    double norm = 0.0;
    for (int i = 0; i < m * m; ++i) {
        L[i] = A[i];
        norm = fmax(norm, cabs(A[i]));
    }
    for (int i = 0; i < m; ++i)
        L[i * m + i] -= s;
    double tiny = DBL_EPSILON * (norm > 0.0 ? norm : 1.0);
    for (int k = 0; k < m; ++k) {
        int p = k;
        double best = fabs(creal(L[k * m + k])) + fabs(cimag(L[k * m + k]));
        for (int i = k + 1; i < m; ++i) {
            double a = fabs(creal(L[i * m + k])) + fabs(cimag(L[i * m + k]));
            if (a > best) {
                best = a;
                p = i;
            }
        }
        piv[k] = p;
        if (p != k)
            for (int j = 0; j < m; ++j) {
                double complex t = L[k * m + j];
                L[k * m + j] = L[p * m + j];
                L[p * m + j] = t;
            }
        if (best < tiny)
            L[k * m + k] = tiny;
        for (int i = k + 1; i < m; ++i) {
            double complex f = L[i * m + k] / L[k * m + k];
            L[i * m + k] = f;
            for (int j = k + 1; j < m; ++j)
                L[i * m + j] -= f * L[k * m + j];
        }
    }
    for (int i = 0; i < m; ++i)
        x[i] = 1.0 + 0.1 * i;
    for (int it = 0; it < 2; ++it) {
        for (int k = 0; k < m; ++k) {
            double complex t = x[k];
            x[k] = x[piv[k]];
            x[piv[k]] = t;
            for (int i = k + 1; i < m; ++i)
                x[i] -= L[i * m + k] * x[k];
        }
        for (int i = m - 1; i >= 0; --i) {
            double complex v = x[i];
            for (int j = i + 1; j < m; ++j)
                v -= L[i * m + j] * x[j];
            x[i] = v / L[i * m + i];
        }
        double big = 0.0;
        for (int i = 0; i < m; ++i)
            big = fmax(big, fabs(creal(x[i])) + fabs(cimag(x[i])));
        if (!(big > 0.0) || !isfinite(big))
            return;
        for (int i = 0; i < m; ++i)
            x[i] /= big;
    }
}

/* et_zvector for a real A (m x m): the same arithmetic (|a| = cabs(a + 0i) exactly) */
static __attribute__((noinline)) void et_vector(int m, const double *A, double complex s, double complex *x)
{
    double complex Z[MAXM * MAXM];
    for (int i = 0; i < m * m; ++i)
        Z[i] = A[i];
    et_zvector(m, Z, s, x);
}

static double et_cabs1(double complex z)
{
    return fabs(creal(z)) + fabs(cimag(z));
}

/* et_balance for a complex A (the 1-norms of |re| + |im|) */
static void et_zbalance(int m, double complex *A)
{
    int done = 0;
    while (!done) {
        done = 1;
        for (int i = 0; i < m; ++i) {
            double c = 0.0, r = 0.0;
            for (int j = 0; j < m; ++j)
                if (j != i) {
                    c += et_cabs1(A[j * m + i]);
                    r += et_cabs1(A[i * m + j]);
                }
            if (c == 0.0 || r == 0.0 || !isfinite(c + r))
                continue;
            double total = c + r, f = 1.0, g = r / 2.0;
            while (c < g) {
                f *= 2.0;
                c *= 4.0;
            }
            g = r * 2.0;
            while (c > g) {
                f /= 2.0;
                c /= 4.0;
            }
            if ((c + r) / f < 0.95 * total) {
                done = 0;
                for (int j = 0; j < m; ++j) {
                    A[i * m + j] /= f;
                    A[j * m + i] *= f;
                }
            }
        }
    }
}

/* complex A (m x m) to upper Hessenberg form by Householder reflectors I - 2 v v^H / v^H v */
static void et_zhessenberg(int m, double complex *A)
{
    double complex v[MAXM];
    for (int k = 0; k < m - 2; ++k) {
        int len = m - k - 1;
        double nrm = 0.0;
        for (int i = 0; i < len; ++i) {
            v[i] = A[(k + 1 + i) * m + k];
            nrm += creal(v[i] * conj(v[i]));
        }
        nrm = sqrt(nrm);
        if (nrm == 0.0)
            continue;
        double a0 = cabs(v[0]);
        double complex phase = a0 > 0.0 ? v[0] / a0 : 1.0;
        v[0] += phase * nrm;
        double vv = 0.0;
        for (int i = 0; i < len; ++i)
            vv += creal(v[i] * conj(v[i]));
        double f = 2.0 / vv;
        for (int j = k; j < m; ++j) { /* rows k+1..: A = (I - f v v^H) A */
            double complex t = 0.0;
            for (int i = 0; i < len; ++i)
                t += conj(v[i]) * A[(k + 1 + i) * m + j];
            t *= f;
            for (int i = 0; i < len; ++i)
                A[(k + 1 + i) * m + j] -= t * v[i];
        }
        for (int i = 0; i < m; ++i) { /* columns k+1..: A = A (I - f v v^H) */
            double complex t = 0.0;
            for (int j = 0; j < len; ++j)
                t += A[i * m + k + 1 + j] * v[j];
            t *= f;
            for (int j = 0; j < len; ++j)
                A[i * m + k + 1 + j] -= t * conj(v[j]);
        }
        for (int i = k + 2; i < m; ++i)
            A[i * m + k] = 0.0;
    }
}

/* eigenvalues of the complex upper Hessenberg H (m x m, overwritten) by single-shift QR with
   Wilkinson shifts (Givens rotations on the active window); 0 where it does not converge */
static int et_zqr(int m, double complex *H, double *wr, double *wi)
{
    int hi = m - 1, its = 0, total = 0;
    double cs[MAXM];
    double complex sn[MAXM];
    while (hi >= 0) {
        int l;
        for (l = hi; l > 0; --l) {
            double s = et_cabs1(H[(l - 1) * m + l - 1]) + et_cabs1(H[l * m + l]);
            if (s == 0.0)
                for (int i = l - 1; i <= hi; ++i)
                    for (int j = l - 1; j <= hi; ++j)
                        s += et_cabs1(H[i * m + j]);
            if (et_cabs1(H[l * m + l - 1]) <= DBL_EPSILON * s) {
                H[l * m + l - 1] = 0.0;
                break;
            }
        }
        if (l == hi) {
            wr[hi] = creal(H[hi * m + hi]);
            wi[hi] = cimag(H[hi * m + hi]);
            hi -= 1;
            its = 0;
            continue;
        }
        if (++total > 60 * m)
            return 0;
        ++its;
        double complex a = H[(hi - 1) * m + hi - 1], b = H[(hi - 1) * m + hi], c = H[hi * m + hi - 1],
                       d = H[hi * m + hi], mu;
        if (its % 11 == 0) /* an exceptional shift */
            mu = d + 0.75 * (cabs(H[hi * m + hi - 1]) + (hi >= 2 ? cabs(H[(hi - 1) * m + hi - 2]) : 0.0));
        else { /* the trailing 2 x 2 block's eigenvalue closer to d: d + p -/+ q */
            double complex p = 0.5 * (a - d), q = csqrt(p * p + b * c);
            mu = cabs(p + q) < cabs(p - q) ? d + p + q : d + p - q;
        }
        for (int i = l; i <= hi; ++i)
            H[i * m + i] -= mu;
        for (int k = l; k < hi; ++k) { /* H - mu = Q R, rotations from the left */
            double complex x = H[k * m + k], y = H[(k + 1) * m + k];
            double ax = cabs(x), r = hypot(ax, cabs(y));
            double cc;
            double complex ss;
            if (r == 0.0) {
                cc = 1.0;
                ss = 0.0;
            } else if (ax == 0.0) {
                cc = 0.0;
                ss = 1.0;
            } else {
                cc = ax / r;
                ss = (x / ax) * conj(y) / r;
            }
            cs[k] = cc;
            sn[k] = ss;
            for (int j = k; j <= hi; ++j) {
                double complex u = H[k * m + j], w = H[(k + 1) * m + j];
                H[k * m + j] = cc * u + ss * w;
                H[(k + 1) * m + j] = -conj(ss) * u + cc * w;
            }
        }
        for (int k = l; k < hi; ++k) /* R Q + mu, rotations from the right */
            for (int i = l; i <= (k + 1 < hi ? k + 1 : hi); ++i) {
                double complex u = H[i * m + k], w = H[i * m + k + 1];
                H[i * m + k] = u * cs[k] + w * conj(sn[k]);
                H[i * m + k + 1] = -u * sn[k] + w * cs[k];
            }
        for (int i = l; i <= hi; ++i)
            H[i * m + i] += mu;
    }
    return 1;
}

/* the one-to-one assignment of rows (modes) to columns (poles of positive frequency) of
   largest total weight w (n x u): min(n, u) pairs (every row assigned where u >= n, every
   column where u < n), by dynamic programming over the subsets of used columns; best[j]
   the column of row j, -1 for none */
static __attribute__((noinline)) void et_assign(int n, int u, const double *w, int *best)
{
    static const double NONE = -1e300;
    int size = 1 << u;
    double value[(MAXN + 1) << MAX_ASSIGN];
    signed char choice[(MAXN + 1) << MAX_ASSIGN];
    for (int mask = 0; mask < size; ++mask)
        value[mask] = mask ? NONE : 0.0;
    for (int j = 0; j < n; ++j) {
        double *prev = value + j * size, *next = value + (j + 1) * size;
        signed char *ch = choice + (j + 1) * size;
        for (int mask = 0; mask < size; ++mask) {
            next[mask] = NONE;
            ch[mask] = -2;
        }
        for (int mask = 0; mask < size; ++mask) {
            if (prev[mask] == NONE)
                continue;
            int used = __builtin_popcount(mask), skipped = j - used;
            if (skipped + 1 <= (n > u ? n - u : 0) && prev[mask] > next[mask]) {
                next[mask] = prev[mask];
                ch[mask] = -1;
            }
            for (int c = 0; c < u; ++c)
                if (!(mask >> c & 1)) {
                    double v = prev[mask] + w[j * u + c];
                    int to = mask | 1 << c;
                    if (v > next[to]) {
                        next[to] = v;
                        ch[to] = (signed char)c;
                    }
                }
        }
    }
    int mask = 0;
    double top = NONE;
    for (int k = 0; k < size; ++k)
        if (__builtin_popcount(k) == (u < n ? u : n) && value[n * size + k] > top) {
            top = value[n * size + k];
            mask = k;
        }
    for (int j = n; j > 0; --j) {
        int c = choice[j * size + mask];
        best[j - 1] = c;
        if (c >= 0)
            mask &= ~(1 << c);
    }
}

/* the undamped modes K Phi = M Phi diag(lam) of the n x n pair: lam ascending (omega^2, any
   sign), Phi (V, n x n, columns) M-orthonormal, by the Cholesky reduction C^-1 sym(K) C^-T and
   cyclic Jacobi; 0 where M is not positive definite */
static int et_modal(int n, const double *M, const double *K, double *lam, double *V)
{
    double C[MAXN * MAXN], S[MAXN * MAXN];
    if (!et_cholesky(n, M, C))
        return 0;
    for (int i = 0; i < n; ++i) /* S = C^-1 sym(K) C^-T */
        for (int j = 0; j < n; ++j)
            S[i * n + j] = 0.5 * (K[i * n + j] + K[j * n + i]);
    et_lower_solve(n, C, S);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < i; ++j) {
            double t = S[i * n + j];
            S[i * n + j] = S[j * n + i];
            S[j * n + i] = t;
        }
    et_lower_solve(n, C, S);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < i; ++j)
            S[i * n + j] = S[j * n + i] = 0.5 * (S[i * n + j] + S[j * n + i]);
    et_jacobi(n, S, lam, V);
    for (int c = 0; c < n; ++c) /* Phi = C^-T V, in place in V */
        for (int i = n - 1; i >= 0; --i) {
            double v = V[i * n + c];
            for (int k = i + 1; k < n; ++k)
                v -= C[k * n + i] * V[k * n + c];
            V[i * n + c] = v / C[i * n + i];
        }
    return 1;
}

static int et_poles(int n, int m, const double *Ar, const double complex *Ac, const double *wr, const double *wi,
                    const double *om, double unstable, double ambiguous, double *wn, double *zeta, double *wd,
                    double *poles, int8_t *stable);

/* one pose; returns 0 when solved, 1 where NumPy must solve it (2: M not positive definite, the
   undamped modes not solved either); lam_out (n) and phi_out (n x n),
   where not NULL, receive the undamped modes (et_modal); kd NULL: those alone */
static int et_pose(int n, int L, const double *M, const double *K, const double *W, const double *h,
                   const double *kd, const double *cd, const double *td, double eliminate, double unstable,
                   double ambiguous, double *wn, double *zeta, double *wd, double *poles, int8_t *stable,
                   double *lam_out, double *phi_out)
{
    double V[MAXN * MAXN], lam[MAXN], om[MAXN], Bw[MAXL * MAXN];
    double A[MAXM * MAXM], H[MAXM * MAXM], wr[MAXM], wi[MAXM];
    if (!et_modal(n, M, K, lam, V))
        return 2;
    if (lam_out)
        memcpy(lam_out, lam, sizeof(double) * n);
    if (phi_out)
        memcpy(phi_out, V, sizeof(double) * n * n);
    if (!kd)
        return 0;
    int ok = 1;
    for (int i = 0; i < n; ++i)
        ok &= lam[i] > 0.0;
    if (!ok) {
        for (int j = 0; j < n; ++j) {
            wn[j] = zeta[j] = wd[j] = NAN;
            poles[2 * j] = NAN;
            poles[2 * j + 1] = 0.0;
        }
        *stable = 0;
        return 0;
    }
    double big = 0.0;
    for (int i = 0; i < n; ++i) {
        om[i] = sqrt(lam[i]);
        big = fmax(big, om[i]);
    }
    for (int l = 0; l < L; ++l)
        for (int j = 0; j < n; ++j) {
            double v = 0.0;
            for (int i = 0; i < n; ++i)
                v += V[i * n + j] * W[l * n + i];
            Bw[l * n + j] = v;
        }
    double alpha[MAXL], D[MAXL], beta[MAXL];
    int elim[MAXL], live = 0;
    for (int l = 0; l < L; ++l) {
        alpha[l] = kd[l] * kd[l];
        D[l] = kd[l] * td[l] - cd[l];
        beta[l] = cd[l] * (kd[l] - h[l]) + h[l] * kd[l] * td[l];
        elim[l] = fabs(beta[l]) * big <= eliminate * fabs(alpha[l]);
        live += !elim[l];
    }
    int m = live ? 2 * n + L : 2 * n;
    memset(A, 0, sizeof(double) * m * m);
    for (int i = 0; i < n; ++i) {
        A[i * m + n + i] = om[i];
        A[(n + i) * m + i] = -om[i];
    }
    for (int l = 0; l < L; ++l) {
        const double *b = Bw + l * n;
        if (elim[l]) {
            double r = D[l] / alpha[l];
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j)
                    A[(n + i) * m + n + j] += r * b[i] * b[j];
        } else {
            double safe = beta[l] != 0.0 ? beta[l] : 1.0;
            for (int i = 0; i < n; ++i) {
                A[(n + i) * m + 2 * n + l] = b[i];
                A[(2 * n + l) * m + n + i] = D[l] / safe * b[i];
            }
            A[(2 * n + l) * m + 2 * n + l] = -alpha[l] / safe;
        }
        if (live && elim[l])
            A[(2 * n + l) * m + 2 * n + l] = -1.0;
    }
    memcpy(H, A, sizeof(double) * m * m);
    et_balance(m, H);
    et_hessenberg(m, H);
    if (!et_francis(m, H, wr, wi))
        return 1;
    return et_poles(n, m, A, NULL, wr, wi, om, unstable, ambiguous, wn, zeta, wd, poles, stable);
}

/* each undamped mode's pole from the m eigenvalues wr + i wi of the state matrix (Ar, real, or
   Ac, complex: a loss factor, whose poles are those of positive frequency) and the undamped
   omega om (n): by order of |s| where unambiguous, else by modal-energy share (inverse
   iteration on the state matrix); 0 when decided, 1 where NumPy must decide */
static int et_poles(int n, int m, const double *Ar, const double complex *Ac, const double *wr, const double *wi,
                    const double *om, double unstable, double ambiguous, double *wn, double *zeta, double *wd,
                    double *poles, int8_t *stable)
{
    int grows = 0, u = 0, up[MAXM];
    for (int k = 0; k < m; ++k) {
        grows |= wr[k] > unstable * hypot(wr[k], wi[k]) && (Ar || wi[k] > 0.0);
        if (wi[k] > 0.0)
            up[u++] = k;
    }
    *stable = !grows;
    int col[MAXN];
    int by_order = u == n;
    if (by_order) { /* the poles of positive frequency by |s|, each beside its own mode */
        for (int i = 1; i < u; ++i)
            for (int j = i; j > 0 && hypot(wr[up[j]], wi[up[j]]) < hypot(wr[up[j - 1]], wi[up[j - 1]]); --j) {
                int t = up[j];
                up[j] = up[j - 1];
                up[j - 1] = t;
            }
        for (int j = 0; j < n && by_order; ++j) {
            double left = j > 0 ? om[j] - om[j - 1] : INFINITY, right = j < n - 1 ? om[j + 1] - om[j] : INFINITY;
            by_order = fabs(hypot(wr[up[j]], wi[up[j]]) - om[j]) < ambiguous * fmin(left, right);
        }
        for (int j = 0; j < n; ++j)
            col[j] = up[j];
    }
    double share[MAXN * MAXM];
    if (!by_order) { /* modal-energy shares of every pole */
        double complex x[MAXM];
        for (int k = 0; k < m; ++k) {
            if (Ar && wi[k] < 0.0 && k > 0 && wr[k - 1] == wr[k] && wi[k - 1] == -wi[k]) {
                for (int j = 0; j < n; ++j)
                    share[j * m + k] = share[j * m + k - 1];
                continue;
            }
            if (Ar)
                et_vector(m, Ar, wr[k] + wi[k] * I, x);
            else
                et_zvector(m, Ac, wr[k] + wi[k] * I, x);
            double total = 0.0;
            for (int j = 0; j < n; ++j) {
                double e = creal(x[j] * conj(x[j])) + creal(x[n + j] * conj(x[n + j]));
                share[j * m + k] = e;
                total += e;
            }
            for (int j = 0; j < n; ++j)
                share[j * m + k] = total > 0.0 ? share[j * m + k] / total : 0.0;
        }
        int unique = u >= n;
        for (int j = 0; j < n; ++j) {
            int pick = 0;
            double best = -2.0;
            for (int k = 0; k < m; ++k) {
                double score = wi[k] > 0.0 ? share[j * m + k] : -1.0;
                if (score > best) {
                    best = score;
                    pick = k;
                }
            }
            col[j] = pick;
            for (int i = 0; i < j; ++i)
                unique &= col[i] != pick;
        }
        if (!unique) {
            int done[MAXN] = {0};
            for (int j = 0; j < n; ++j)
                col[j] = -1;
            if (u > 0) {
                if (u > MAX_ASSIGN)
                    return 1;
                double w[MAXN * MAXM];
                int best[MAXN];
                for (int j = 0; j < n; ++j)
                    for (int c = 0; c < u; ++c)
                        w[j * u + c] = share[j * m + up[c]];
                et_assign(n, u, w, best);
                for (int j = 0; j < n; ++j)
                    if (best[j] >= 0 && w[j * u + best[j]] > 0.0) {
                        col[j] = up[best[j]];
                        done[j] = 1;
                    }
            }
            int real[MAXM], nr = 0;
            for (int k = 0; k < m; ++k)
                if (wi[k] == 0.0 && fabs(wr[k]) < NO_POLE)
                    real[nr++] = k;
            for (int j = 0; j < n; ++j) {
                if (done[j])
                    continue;
                if (!nr)
                    break;
                int b = et_largest_share(nr, real, share + j * m, wr);
                col[j] = real[b];
                for (int r = b; r < nr - 1; ++r) /* the remaining poles keep their order */
                    real[r] = real[r + 1];
                --nr;
            }
        }
    }
    for (int j = 0; j < n; ++j) {
        if (col[j] < 0) { /* no pole left for this mode */
            wn[j] = zeta[j] = NAN;
            wd[j] = 0.0;
            poles[2 * j] = NAN;
            poles[2 * j + 1] = 0.0;
            continue;
        }
        double re = wr[col[j]], im = wi[col[j]], r = hypot(re, im);
        poles[2 * j] = re;
        poles[2 * j + 1] = im;
        wn[j] = r;
        zeta[j] = -re / (r > 0.0 ? r : 1.0);
        wd[j] = fabs(im);
        if (im == 0.0) { /* overdamped: this real pole and the real one of next largest share */
            int cand[MAXM], nc = 0;
            for (int k = 0; k < m; ++k)
                if (k != col[j] && wi[k] == 0.0 && fabs(wr[k]) < NO_POLE)
                    cand[nc++] = k;
            int b = et_largest_share(nc, cand, share + j * m, wr);
            int other = b < 0 ? col[j] : cand[b];
            double s1 = re, s2 = wr[other];
            poles[2 * j] = fmax(s1, s2); /* the slower of the pair */
            wn[j] = sqrt(fabs(s1 * s2));
            zeta[j] = wn[j] > 0.0 ? -(s1 + s2) / (2.0 * wn[j]) : 1.0;
            wd[j] = 0.0;
        }
    }
    return 0;
}

/* et_pose with a structural loss factor: the stiffness K + i Kl (Kl: n x n, real, NULL: none),
   the actuator wrenches W (L x n) and h (L) complex; the complex state matrix's eigenvalues by
   et_zqr and the poles of positive frequency assigned as et_poles does. Returns 0 when solved,
   1 where NumPy must solve it, 2 where M is not positive definite. */
static int et_pose_complex(int n, int L, const double *M, const double *K, const double *Kl,
                           const double complex *W, const double complex *h, const double *kd, const double *cd,
                           const double *td, double eliminate, double unstable, double ambiguous, double *wn,
                           double *zeta, double *wd, double *poles, int8_t *stable)
{
    double V[MAXN * MAXN], lam[MAXN], om[MAXN], wr[MAXM], wi[MAXM];
    double complex Bw[MAXL * MAXN], A[MAXM * MAXM], H[MAXM * MAXM];
    if (!et_modal(n, M, K, lam, V))
        return 2;
    int ok = 1;
    for (int i = 0; i < n; ++i)
        ok &= lam[i] > 0.0;
    if (!ok) {
        for (int j = 0; j < n; ++j) {
            wn[j] = zeta[j] = wd[j] = NAN;
            poles[2 * j] = NAN;
            poles[2 * j + 1] = 0.0;
        }
        *stable = 0;
        return 0;
    }
    double big = 0.0;
    for (int i = 0; i < n; ++i) {
        om[i] = sqrt(lam[i]);
        big = fmax(big, om[i]);
    }
    for (int l = 0; l < L; ++l)
        for (int j = 0; j < n; ++j) {
            double complex v = 0.0;
            for (int i = 0; i < n; ++i)
                v += V[i * n + j] * W[l * n + i];
            Bw[l * n + j] = v;
        }
    double alpha[MAXL], D[MAXL];
    double complex beta[MAXL];
    int elim[MAXL], live = 0;
    for (int l = 0; l < L; ++l) {
        alpha[l] = kd[l] * kd[l];
        D[l] = kd[l] * td[l] - cd[l];
        beta[l] = cd[l] * (kd[l] - h[l]) + h[l] * kd[l] * td[l];
        elim[l] = cabs(beta[l]) * big <= eliminate * fabs(alpha[l]);
        live += !elim[l];
    }
    int m = live ? 2 * n + L : 2 * n;
    for (int i = 0; i < m * m; ++i)
        A[i] = 0.0;
    for (int i = 0; i < n; ++i) {
        A[i * m + n + i] = om[i];
        A[(n + i) * m + i] = -om[i];
    }
    if (Kl) { /* -i Phi^T Kl Phi, column j over omega_j */
        double T[MAXN * MAXN];
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                double v = 0.0;
                for (int k = 0; k < n; ++k)
                    v += Kl[i * n + k] * V[k * n + j];
                T[i * n + j] = v;
            }
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                double v = 0.0;
                for (int k = 0; k < n; ++k)
                    v += V[k * n + i] * T[k * n + j];
                A[(n + i) * m + j] -= I * (v / om[j]);
            }
    }
    for (int l = 0; l < L; ++l) {
        const double complex *b = Bw + l * n;
        if (elim[l]) {
            double r = D[l] / alpha[l];
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j)
                    A[(n + i) * m + n + j] += r * b[i] * b[j];
        } else {
            double complex safe = beta[l] != 0.0 ? beta[l] : 1.0;
            for (int i = 0; i < n; ++i) {
                A[(n + i) * m + 2 * n + l] = b[i];
                A[(2 * n + l) * m + n + i] = D[l] / safe * b[i];
            }
            A[(2 * n + l) * m + 2 * n + l] = -alpha[l] / safe;
        }
        if (live && elim[l])
            A[(2 * n + l) * m + 2 * n + l] = -1.0;
    }
    memcpy(H, A, sizeof(double complex) * m * m);
    et_zbalance(m, H);
    et_zhessenberg(m, H);
    if (!et_zqr(m, H, wr, wi))
        return 1;
    return et_poles(n, m, NULL, A, wr, wi, om, unstable, ambiguous, wn, zeta, wd, poles, stable);
}

/* et_pose_complex for count poses: M, K, Kl (n x n; Kl NULL: none), W (L x n complex), h (L
   complex), kd, cd, td (L) per pose; status 1 where NumPy must solve the pose */
int et_damped_complex(int64_t count, int n, int L, const double *M, const double *K, const double *Kl,
                      const double complex *W, const double complex *h, const double *kd, const double *cd,
                      const double *td, double eliminate, double unstable, double ambiguous, double *wn,
                      double *zeta, double *wd, double *poles, int8_t *stable, int8_t *status)
{
    if (n < 1 || n > MAXN || L < 0 || L > MAXL)
        return -1;
    for (int64_t p = 0; p < count; ++p)
        status[p] = (int8_t)et_pose_complex(n, L, M + p * n * n, K + p * n * n, Kl ? Kl + p * n * n : NULL,
                                            W + p * L * n, h + p * L, kd + p * L, cd + p * L, td + p * L, eliminate,
                                            unstable, ambiguous, wn + p * n, zeta + p * n, wd + p * n,
                                            poles + 2 * p * n, stable + p);
    return 0;
}

/* one leg: Kq = pinv(C) on the compliant eigen-directions of its joint compliance C (e x e; an
   eigenvalue within rtol of the largest magnitude: rigid, left out), g = Kq e_0: the
   actuator wrench W (c) = g^T J (J: e x c), h = g[0], where K is not NULL
   K (c x c) += J^T Kq J, and where R is not NULL its rigid rows u^T J (e x c: a rigid
   eigen-direction u's row, zeros for a compliant one) */
static void et_wrench_leg(int e, int c, const double *J, const double *C, double rtol, double *K, double *W,
                          double *h, double *R)
{
    double S[MAXN * MAXN], U[MAXN * MAXN], lam[MAXN], Kq[MAXN * MAXN], KJ[MAXN * 64];
    memcpy(S, C, sizeof(double) * e * e);
    et_jacobi(e, S, lam, U);
    double scale = 0.0;
    for (int i = 0; i < e; ++i)
        scale = fmax(scale, fabs(lam[i]));
    for (int i = 0; i < e; ++i)
        lam[i] = fabs(lam[i]) <= rtol * scale ? 0.0 : 1.0 / lam[i];
    if (R)
        for (int k = 0; k < e; ++k)
            for (int j = 0; j < c; ++j) {
                double v = 0.0;
                if (lam[k] == 0.0)
                    for (int a = 0; a < e; ++a)
                        v += U[a * e + k] * J[a * c + j];
                R[k * c + j] = v;
            }
    for (int a = 0; a < e; ++a)
        for (int b = 0; b < e; ++b) {
            double v = 0.0;
            for (int k = 0; k < e; ++k)
                v += U[a * e + k] * lam[k] * U[b * e + k];
            Kq[a * e + b] = v;
        }
    *h = Kq[0];
    for (int j = 0; j < c; ++j) {
        double v = 0.0;
        for (int a = 0; a < e; ++a)
            v += Kq[a * e] * J[a * c + j];
        W[j] = v;
    }
    if (!K)
        return;
    for (int a = 0; a < e; ++a) /* KJ = Kq Je (e x c) */
        for (int j = 0; j < c; ++j) {
            double v = 0.0;
            for (int b = 0; b < e; ++b)
                v += Kq[a * e + b] * J[b * c + j];
            KJ[a * c + j] = v;
        }
    for (int i = 0; i < c; ++i)
        for (int j = 0; j < c; ++j) {
            double v = 0.0;
            for (int a = 0; a < e; ++a)
                v += J[a * c + i] * KJ[a * c + j];
            K[i * c + j] += v;
        }
}

/* per pose: K (c x c) = sum_i Je_i^T Kq_i Je_i, W (L x c) rows g_i^T Je_i, h_i = g_i[0]
   (et_wrench_leg); Je (L x e x c), Cq (L x e x e) */
int et_wrenches(int64_t count, int L, int e, int c, const double *Je, const double *Cq, double rtol, double *K,
                double *W, double *h)
{
    if (e < 1 || e > MAXN || L < 1 || c > 64)
        return -1;
    for (int64_t p = 0; p < count; ++p) {
        double *Kp = K + p * c * c;
        memset(Kp, 0, sizeof(double) * c * c);
        for (int l = 0; l < L; ++l)
            et_wrench_leg(e, c, Je + (p * L + l) * e * c, Cq + (p * L + l) * e * e, rtol, Kp, W + (p * L + l) * c,
                          h + p * L + l, NULL);
    }
    return 0;
}

/* et_wrench_leg with a structural loss factor eta: the joint compliance C_q = (C - a0 e0 e0^T) /
   (1 + i eta) + a0 e0 e0^T (a0: the actuator's own compliance, C[0][0]'s share), complex
   symmetric; its rigid directions are C's (real: the passive compliance's null space, never
   along e0), so its pseudo-inverse on the compliant ones is P (P^T C_q P)^-1 P^T with P the
   compliant eigenvectors of C (an eigenvalue within rtol of the largest magnitude: rigid).
   K (c x c) += J^T Kq J, W (c) = g^T J, h = g[0], g = Kq e0; all complex. */
static void et_wrench_leg_complex(int e, int c, const double *J, const double *C, double a0, double eta, double rtol,
                                  double complex *K, double complex *W, double complex *h)
{
    double S[MAXN * MAXN], U[MAXN * MAXN], lam[MAXN];
    double complex Cc[MAXN * MAXN], Ac[MAXN * MAXN], Ai[MAXN * MAXN], Kq[MAXN * MAXN], KJ[MAXN * 64];
    int keep[MAXN], np_ = 0;
    memcpy(S, C, sizeof(double) * e * e);
    et_jacobi(e, S, lam, U);
    double scale = 0.0;
    for (int i = 0; i < e; ++i)
        scale = fmax(scale, fabs(lam[i]));
    for (int i = 0; i < e; ++i)
        if (!(fabs(lam[i]) <= rtol * scale))
            keep[np_++] = i;
    for (int a = 0; a < e; ++a)
        for (int b = 0; b < e; ++b) {
            double act = a == 0 && b == 0 ? a0 : 0.0;
            Cc[a * e + b] = (C[a * e + b] - act) / (1.0 + I * eta) + act;
        }
    for (int i = 0; i < np_; ++i) /* Ac = P^T C_q P */
        for (int j = 0; j < np_; ++j) {
            double complex v = 0.0;
            for (int a = 0; a < e; ++a)
                for (int b = 0; b < e; ++b)
                    v += U[a * e + keep[i]] * Cc[a * e + b] * U[b * e + keep[j]];
            Ac[i * np_ + j] = v;
        }
    for (int i = 0; i < np_; ++i) /* Ai = Ac^-1 (Gauss-Jordan, partial pivoting) */
        for (int j = 0; j < np_; ++j)
            Ai[i * np_ + j] = i == j ? 1.0 : 0.0;
    for (int k = 0; k < np_; ++k) {
        int piv = k;
        for (int i = k + 1; i < np_; ++i)
            if (cabs(Ac[i * np_ + k]) > cabs(Ac[piv * np_ + k]))
                piv = i;
        if (piv != k)
            for (int j = 0; j < np_; ++j) {
                double complex t = Ac[k * np_ + j];
                Ac[k * np_ + j] = Ac[piv * np_ + j];
                Ac[piv * np_ + j] = t;
                t = Ai[k * np_ + j];
                Ai[k * np_ + j] = Ai[piv * np_ + j];
                Ai[piv * np_ + j] = t;
            }
        double complex d = Ac[k * np_ + k];
        for (int j = 0; j < np_; ++j) {
            Ac[k * np_ + j] /= d;
            Ai[k * np_ + j] /= d;
        }
        for (int i = 0; i < np_; ++i)
            if (i != k) {
                double complex f = Ac[i * np_ + k];
                for (int j = 0; j < np_; ++j) {
                    Ac[i * np_ + j] -= f * Ac[k * np_ + j];
                    Ai[i * np_ + j] -= f * Ai[k * np_ + j];
                }
            }
    }
    for (int a = 0; a < e; ++a) /* Kq = P Ai P^T */
        for (int b = 0; b < e; ++b) {
            double complex v = 0.0;
            for (int i = 0; i < np_; ++i)
                for (int j = 0; j < np_; ++j)
                    v += U[a * e + keep[i]] * Ai[i * np_ + j] * U[b * e + keep[j]];
            Kq[a * e + b] = v;
        }
    *h = Kq[0];
    for (int j = 0; j < c; ++j) {
        double complex v = 0.0;
        for (int a = 0; a < e; ++a)
            v += Kq[a * e] * J[a * c + j];
        W[j] = v;
    }
    for (int a = 0; a < e; ++a)
        for (int j = 0; j < c; ++j) {
            double complex v = 0.0;
            for (int b = 0; b < e; ++b)
                v += Kq[a * e + b] * J[b * c + j];
            KJ[a * c + j] = v;
        }
    for (int i = 0; i < c; ++i)
        for (int j = 0; j < c; ++j) {
            double complex v = 0.0;
            for (int a = 0; a < e; ++a)
                v += J[a * c + i] * KJ[a * c + j];
            K[i * c + j] += v;
        }
}

/* et_wrenches with a structural loss factor (et_wrench_leg_complex): a0 (L) the actuators'
   compliance and eta (1) per pose; K, W, h complex */
int et_wrenches_complex(int64_t count, int L, int e, int c, const double *Je, const double *Cq, const double *a0,
                        const double *eta, double rtol, double complex *K, double complex *W, double complex *h)
{
    if (e < 1 || e > MAXN || L < 1 || c > 64)
        return -1;
    for (int64_t p = 0; p < count; ++p) {
        double complex *Kp = K + p * c * c;
        for (int i = 0; i < c * c; ++i)
            Kp[i] = 0.0;
        for (int l = 0; l < L; ++l)
            et_wrench_leg_complex(e, c, Je + (p * L + l) * e * c, Cq + (p * L + l) * e * e, a0[p * L + l], eta[p],
                                  rtol, Kp, W + (p * L + l) * c, h + p * L + l);
    }
    return 0;
}

int et_damped(int64_t count, int n, int L, const double *M, const double *K, const double *W, const double *h,
              const double *kd, const double *cd, const double *td, double eliminate, double unstable,
              double ambiguous, double *wn, double *zeta, double *wd, double *poles, int8_t *stable,
              int8_t *status)
{
    if (n < 1 || n > MAXN || L < 0 || L > MAXL)
        return -1;
    for (int64_t p = 0; p < count; ++p) {
        status[p] = (int8_t)et_pose(n, L, M + p * n * n, K + p * n * n, W + p * L * n, h + p * L, kd + p * L,
                                    cd + p * L, td + p * L, eliminate, unstable, ambiguous, wn + p * n,
                                    zeta + p * n, wd + p * n, poles + 2 * p * n, stable + p, NULL, NULL);
    }
    return 0;
}

/* B^T M B, B^T K B (r x r) and W6 B (L x r) on the coordinates B (6 x r, row-major; NULL: the six
   twists, copies) */
static void et_project(int L, int r, const double *M, const double *K, const double *W6, const double *B, double *Mr,
                       double *Kr, double *W)
{
    if (B) { /* B^T M B, B^T K B, W B */
        double BM[36], BK[36];
        for (int i = 0; i < r; ++i)
            for (int j = 0; j < 6; ++j) {
                double vm = 0.0, vk = 0.0;
                for (int k = 0; k < 6; ++k) {
                    vm += B[k * r + i] * M[k * 6 + j];
                    vk += B[k * r + i] * K[k * 6 + j];
                }
                BM[i * 6 + j] = vm;
                BK[i * 6 + j] = vk;
            }
        for (int i = 0; i < r; ++i)
            for (int j = 0; j < r; ++j) {
                double vm = 0.0, vk = 0.0;
                for (int k = 0; k < 6; ++k) {
                    vm += BM[i * 6 + k] * B[k * r + j];
                    vk += BK[i * 6 + k] * B[k * r + j];
                }
                Mr[i * r + j] = vm;
                Kr[i * r + j] = vk;
            }
        for (int l = 0; l < L; ++l)
            for (int j = 0; j < r; ++j) {
                double v = 0.0;
                for (int k = 0; k < 6; ++k)
                    v += W6[l * 6 + k] * B[k * r + j];
                W[l * r + j] = v;
            }
    } else {
        memcpy(Mr, M, sizeof(double) * 36);
        memcpy(Kr, K, sizeof(double) * 36);
        memcpy(W, W6, sizeof(double) * L * 6);
    }
}

/* one pose from its legs' kernel outputs: each leg's actuator wrench from the first e_used rows
   of its Je (L x e x 6) and Cq (L x e x e) (et_wrench_leg), the stiffness K (6 x 6), or where K
   is NULL the legs' J_e^T C_q^+ J_e plus Kg (6 x 6, NULL: none), then B^T M B, B^T K B and
   W B on the model's coordinates B (6 x r, row-major; NULL: the six twists) into et_pose */
static int et_pose_legs(int L, int e, int e_used, int r, const double *M, const double *K, const double *Kg,
                        const double *Je, const double *Cq, const double *B, const double *kd, const double *cd,
                        const double *td, double rtol, double eliminate, double unstable, double ambiguous,
                        double *wn, double *zeta, double *wd, double *poles, int8_t *stable)
{
    double W6[MAXL * 6], W[MAXL * 6], h[MAXL], Mr[36], Kr[36], J[MAXN * 6], C[MAXN * MAXN], Ks[36];
    if (!K)
        memset(Ks, 0, sizeof(Ks));
    for (int l = 0; l < L; ++l) {
        const double *Jl = Je + l * e * 6, *Cl = Cq + l * e * e;
        for (int a = 0; a < e_used; ++a) {
            for (int j = 0; j < 6; ++j)
                J[a * 6 + j] = Jl[a * 6 + j];
            for (int c = 0; c < e_used; ++c)
                C[a * e_used + c] = Cl[a * e + c];
        }
        et_wrench_leg(e_used, 6, J, C, rtol, K ? NULL : Ks, W6 + l * 6, h + l, NULL);
    }
    if (!K) {
        if (Kg)
            for (int i = 0; i < 36; ++i)
                Ks[i] += Kg[i];
        K = Ks;
    }
    et_project(L, r, M, K, W6, B, Mr, Kr, W);
    return et_pose(r, L, Mr, Kr, W, h, kd, cd, td, eliminate, unstable, ambiguous, wn, zeta, wd, poles, stable, NULL,
                   NULL);
}

/* et_pose_legs for count poses: M (6 x 6), K (6 x 6, or NULL), Kg (6 x 6, or NULL), Je, Cq,
   B (6 x r, or NULL) and kd, cd, td (L) per pose, a NULL-free input of stride 0 shared (its
   *_shared flag 1); status 1 where NumPy must solve the pose */
int et_damped_legs(int64_t count, int L, int e, int e_used, int r, const double *M, const double *K, int K_shared,
                   const double *Kg, int Kg_shared, const double *Je, const double *Cq, const double *B, int B_shared,
                   const double *kd, const double *cd, const double *td, double rtol, double eliminate,
                   double unstable, double ambiguous, double *wn, double *zeta, double *wd, double *poles,
                   int8_t *stable, int8_t *status)
{
    if (r < 1 || r > 6 || L < 1 || L > MAXL || e_used < 1 || e_used > e || e > MAXN)
        return -1;
    for (int64_t p = 0; p < count; ++p)
        status[p] = (int8_t)et_pose_legs(L, e, e_used, r, M + p * 36, K ? K + (K_shared ? 0 : p * 36) : NULL,
                                         Kg ? Kg + (Kg_shared ? 0 : p * 36) : NULL, Je + p * L * e * 6,
                                         Cq + p * L * e * e, B ? B + (B_shared ? 0 : p * 6 * r) : NULL,
                                         kd + p * L, cd + p * L, td + p * L, rtol, eliminate, unstable, ambiguous,
                                         wn + p * r, zeta + p * r, wd + p * r, poles + 2 * p * r, stable + p);
    return 0;
}

/* the robot's generated fused pass and one of its kernels (eigentwist/generated/<robot>_c.c) */
typedef int (*et_fused_fn)(int64_t, int64_t, const double *const *, const int64_t *, int, double *const *,
                           double *const *, double *const *, double *, double *, int8_t *, const double *);
typedef int (*et_kernel_fn)(int64_t, const double *const *, const int64_t *, double *const *);

/* The damped modes of poses [begin, end) in one pass, `block` poses at a time (begin a multiple
   of it): the robot's fused pass (its f_* arguments: inverse kinematics, the 6 x 6 M and the
   model's stiffness, the undamped modes and the status), its legs kernel on the block's joint
   coordinates (input k read at l_in[k] with stride l_stride[k], or, where q_of[k] >= 0, entry
   q_of[k] of the pose's row of q (q_row doubles); output k of l_size[k] doubles per pose to
   l_out[k]), then per pose of status 0 or 4 (undamped unstable) each leg's actuator wrench from
   the first e_used rows of its Je (L x e x 6) and Cq (L x e x e) (et_wrench_leg), the problem
   on the model's coordinates B (6 x r; NULL: the six twists) and et_pose. Other poses: NaN,
   redo 0. Returns the kernels' nonzero code, -1 for bad sizes. */
int et_damped_pass(int64_t begin, int64_t end, int64_t block, et_fused_fn fused, const double *const *f_in,
                   const int64_t *f_stride, int f_model, double *const *f_ik, double *const *f_mat,
                   double *const *f_jac, double *f_freq, double *f_vec, int8_t *f_status, const double *f_opts,
                   et_kernel_fn legs, int n_in, const double *const *l_in, const int64_t *l_stride, const int *q_of,
                   int n_out, double *const *l_out, const int64_t *l_size, const double *q, int q_row,
                   const double *Mall, const double *Kall, const double *Je, const double *Cq, int L, int e,
                   int e_used, const double *B, int r, const double *kd, const double *cd, const double *td,
                   double rtol, double eliminate, double unstable, double ambiguous, double *wn, double *zeta,
                   double *wd, double *poles, int8_t *stable, int8_t *redo)
{
    if (r < 1 || r > 6 || r > MAXN || L < 1 || L > MAXL || e_used < 1 || e_used > e || e > MAXN || n_in > 256 ||
        n_out > 64 || block < 1 || begin % block != 0)
        return -1;
    const double *ins[256];
    int64_t strides[256];
    double *outs[64];
    for (int64_t b = begin; b < end; b += block) {
        const int64_t b2 = end - b < block ? end : b + block;
        int rc = fused(b, b2, f_in, f_stride, f_model, f_ik, f_mat, f_jac, f_freq, f_vec, f_status, f_opts);
        if (rc != 0)
            return rc;
        for (int k = 0; k < n_in; ++k) {
            ins[k] = q_of[k] >= 0 ? q + b * q_row + q_of[k] : l_in[k] + b * l_stride[k];
            strides[k] = q_of[k] >= 0 ? q_row : l_stride[k];
        }
        for (int k = 0; k < n_out; ++k)
            outs[k] = l_out[k] + b * l_size[k];
        rc = legs(b2 - b, ins, strides, outs);
        if (rc != 0)
            return rc;
        for (int64_t p = b; p < b2; ++p) {
            if (f_status[p] != 0 && f_status[p] != 4) {
                for (int j = 0; j < r; ++j)
                    wn[p * r + j] = zeta[p * r + j] = wd[p * r + j] = poles[2 * (p * r + j)] =
                        poles[2 * (p * r + j) + 1] = NAN;
                stable[p] = 1;
                redo[p] = 0;
                continue;
            }
            redo[p] = (int8_t)et_pose_legs(L, e, e_used, r, Mall + p * 36, Kall + p * 36, NULL,
                                           Je + p * L * e * 6, Cq + p * L * e * e, B, kd + p * L, cd + p * L,
                                           td + p * L, rtol, eliminate, unstable, ambiguous, wn + p * r,
                                           zeta + p * r, wd + p * r, poles + 2 * p * r, stable + p);
        }
    }
    return 0;
}
/* one pose of the exact condensation from its legs' kernel outputs Je (L x e x 6), Cq (L x e x e)
   and Kg (6 x 6): each leg's springs J^T C_q^+ J, actuator wrench and rigid rows
   (et_wrench_leg); the admissible twists B, the eigenvectors of G = sum of the rigid rows' r r^T
   whose eigenvalue is at most null_rtol times the largest (cyclic Jacobi, ascending: the null
   ones first), *nb of them; on B the undamped modes (lam: omega^2 of the nb finite modes, and
   where V is not NULL their eigentwists B Phi, 6 x 6 row-major, columns nb.. NaN) and, where kd is
   not NULL, the damped modes (et_pose). Returns 0 when solved, 1 where the damped modes are left
   undecided, 2 where the undamped ones are not solved (no admissible twist, B^T M B not positive
   definite). */
static int et_exact_pose(int L, int e, const double *M, const double *Kg, const double *Je, const double *Cq,
                         const double *kd, const double *cd, const double *td, double rtol, double null_rtol,
                         double eliminate, double unstable, double ambiguous, int8_t *nb, double *lam, double *V,
                         double *wn, double *zeta, double *wd, double *poles, int8_t *stable)
{
    double W6[MAXL * 6], W[MAXL * 6], h[MAXL], K[36], G[36], g[6], Q[36], R[MAXN * 6], B[36], Mr[36], Kr[36],
        Phi[36];
    memcpy(K, Kg, sizeof(K));
    memset(G, 0, sizeof(G));
    for (int l = 0; l < L; ++l) {
        et_wrench_leg(e, 6, Je + l * e * 6, Cq + l * e * e, rtol, K, W6 + l * 6, h + l, R);
        for (int k = 0; k < e; ++k)
            for (int i = 0; i < 6; ++i)
                for (int j = 0; j < 6; ++j)
                    G[i * 6 + j] += R[k * 6 + i] * R[k * 6 + j];
    }
    et_jacobi(6, G, g, Q);
    double top = 0.0;
    for (int i = 0; i < 6; ++i)
        top = fmax(top, fabs(g[i]));
    int r = 0;
    while (r < 6 && g[r] <= null_rtol * top)
        ++r;
    *nb = (int8_t)r;
    for (int j = r; j < 6; ++j) {
        lam[j] = NAN;
        if (kd) {
            wn[j] = zeta[j] = wd[j] = poles[2 * j] = poles[2 * j + 1] = NAN;
        }
    }
    if (V)
        for (int i = 0; i < 36; ++i)
            V[i] = NAN;
    if (r == 0)
        return 2;
    for (int k = 0; k < 6; ++k)
        for (int i = 0; i < r; ++i)
            B[k * r + i] = Q[k * 6 + i];
    et_project(L, r, M, K, W6, B, Mr, Kr, W);
    int rc = et_pose(r, L, Mr, Kr, W, h, kd, cd, td, eliminate, unstable, ambiguous, wn, zeta, wd, poles, stable,
                     lam, Phi);
    if (rc == 2)
        return 2;
    if (V)
        for (int k = 0; k < 6; ++k)
            for (int j = 0; j < r; ++j) {
                double v = 0.0;
                for (int i = 0; i < r; ++i)
                    v += B[k * r + i] * Phi[i * r + j];
                V[k * 6 + j] = v;
            }
    return rc;
}

/* The exact condensation's modes of poses [begin, end) in one pass, `block` poses at a time
   (begin a multiple of it): the robot's fused pass (its f_* arguments, as for et_damped_pass:
   they must fill the status, q and M), its legs kernel on the block's joint coordinates (as
   for et_damped_pass; Je, Cq and Kg its outputs), then per pose of status 0 or 4
   et_exact_pose, writing 6 entries per pose of lam, wn, zeta, wd, poles (complex), 36 of V
   (NULL: none) and nb, stable, redo (kd NULL: the undamped modes alone; wn .. stable unused).
   Other poses: nb 0, redo 0. Returns the kernels' nonzero code, -1 for bad sizes. */
int et_exact_pass(int64_t begin, int64_t end, int64_t block, et_fused_fn fused, const double *const *f_in,
                  const int64_t *f_stride, int f_model, double *const *f_ik, double *const *f_mat,
                  double *const *f_jac, double *f_freq, double *f_vec, int8_t *f_status, const double *f_opts,
                  et_kernel_fn legs, int n_in, const double *const *l_in, const int64_t *l_stride, const int *q_of,
                  int n_out, double *const *l_out, const int64_t *l_size, const double *q, int q_row,
                  const double *Mall, const double *Je, const double *Cq, const double *Kg, int L, int e,
                  const double *kd, const double *cd, const double *td, double rtol, double null_rtol,
                  double eliminate, double unstable, double ambiguous, int8_t *nb, double *lam, double *V,
                  double *wn, double *zeta, double *wd, double *poles, int8_t *stable, int8_t *redo)
{
    if (L < 1 || L > MAXL || e < 1 || e > MAXN || n_in > 256 || n_out > 64 || block < 1 || begin % block != 0)
        return -1;
    const double *ins[256];
    int64_t strides[256];
    double *outs[64];
    for (int64_t b = begin; b < end; b += block) {
        const int64_t b2 = end - b < block ? end : b + block;
        int rc = fused(b, b2, f_in, f_stride, f_model, f_ik, f_mat, f_jac, f_freq, f_vec, f_status, f_opts);
        if (rc != 0)
            return rc;
        for (int k = 0; k < n_in; ++k) {
            ins[k] = q_of[k] >= 0 ? q + b * q_row + q_of[k] : l_in[k] + b * l_stride[k];
            strides[k] = q_of[k] >= 0 ? q_row : l_stride[k];
        }
        for (int k = 0; k < n_out; ++k)
            outs[k] = l_out[k] + b * l_size[k];
        rc = legs(b2 - b, ins, strides, outs);
        if (rc != 0)
            return rc;
        for (int64_t p = b; p < b2; ++p) {
            redo[p] = 0;
            nb[p] = 0;
            if (f_status[p] != 0 && f_status[p] != 4)
                continue;
            redo[p] = (int8_t)et_exact_pose(
                L, e, Mall + p * 36, Kg + p * 36, Je + p * L * e * 6, Cq + p * L * e * e, kd ? kd + p * L : NULL,
                kd ? cd + p * L : NULL, kd ? td + p * L : NULL, rtol, null_rtol, eliminate, unstable, ambiguous,
                nb + p, lam + p * 6, V ? V + p * 36 : NULL, kd ? wn + p * 6 : NULL, kd ? zeta + p * 6 : NULL,
                kd ? wd + p * 6 : NULL, kd ? poles + 12 * p : NULL, kd ? stable + p : NULL);
        }
    }
    return 0;
}
""".replace("@SHARE_TIE@", repr(SHARE_TIE))

_DRIVER: list = []  # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []  # the loaded driver library, kept for the process
_WRENCHES: list = []  # its et_wrenches
_PASS: list = []  # its et_damped_pass
_LEGS: list = []  # its et_damped_legs
_EXACT: list = []  # its et_exact_pass
_COMPLEX: list = []  # its et_damped_complex


def _bind(lib):
    """et_damped of the loaded library, its argument and return types declared; the functions
    beside it (the wrenches, the damped pass, the legs', the exact pass, the complex solver)
    declared too and kept in their lists."""
    fn = lib.et_damped
    d, i = ctypes.c_double, ctypes.c_int
    fn.argtypes = [ctypes.c_int64, i, i] + [ctypes.c_void_p] * 7 + [d, d, d] + [ctypes.c_void_p] * 6
    fn.restype = ctypes.c_int
    lib.et_wrenches.argtypes = [ctypes.c_int64, i, i, i, ctypes.c_void_p, ctypes.c_void_p, d] + [ctypes.c_void_p] * 3
    lib.et_wrenches.restype = ctypes.c_int
    _WRENCHES.append(lib.et_wrenches)
    lib.et_wrenches_complex.argtypes = [ctypes.c_int64, i, i, i] + [ctypes.c_void_p] * 4 + [d] + [ctypes.c_void_p] * 3
    lib.et_wrenches_complex.restype = ctypes.c_int
    _WRENCHES.append(lib.et_wrenches_complex)
    v, i64 = ctypes.c_void_p, ctypes.c_int64
    lib.et_damped_pass.argtypes = (
        [i64, i64, i64, v, v, v, i, v, v, v, v, v, v, v]
        + [v, i, v, v, v, i, v, v, v, i]
        + [v, v, v, v, i, i, i, v, i, v, v, v, d, d, d, d]
        + [v] * 6
    )
    lib.et_damped_pass.restype = ctypes.c_int
    _PASS.append(lib.et_damped_pass)
    lib.et_damped_legs.argtypes = [i64, i, i, i, i, v, v, i, v, i, v, v, v, i, v, v, v, d, d, d, d] + [v] * 6
    lib.et_damped_legs.restype = ctypes.c_int
    _LEGS.append(lib.et_damped_legs)
    lib.et_exact_pass.argtypes = (
        [i64, i64, i64, v, v, v, i, v, v, v, v, v, v, v]
        + [v, i, v, v, v, i, v, v, v, i]
        + [v, v, v, v, i, i, v, v, v, d, d, d, d, d]
        + [v] * 9
    )
    lib.et_exact_pass.restype = ctypes.c_int
    _EXACT.append(lib.et_exact_pass)
    lib.et_damped_complex.argtypes = [i64, i, i] + [v] * 8 + [d, d, d] + [v] * 6
    lib.et_damped_complex.restype = ctypes.c_int
    _COMPLEX.append(lib.et_damped_complex)
    return fn


def driver():
    """The compiled driver ``et_damped`` (built on first use into the cache, loaded after its
    SHA-256 is checked), or None where it cannot be built (no compiler)."""
    return library_once(_DRIVER, _LIBRARIES, SOURCE, "damped", _bind)


def solve(M, K, W, h, k_d, c_d, t_d, eliminate: float, unstable: float, ambiguous: float, threads: int = 1):
    """Run the driver on N poses: ``(wn, zeta, wd, poles, stable, redo)``, each (N, n) (stable,
    redo (N,)): omega_n (rad/s), zeta, omega_d (rad/s), the complex poles (rad/s), whether no
    pole grows, and the poses the driver left to NumPy (their other values are undefined).
    M, K (N, n, n), W (N, legs, n), h, k_d, c_d, t_d (N, legs), real; the rules' constants as
    in :mod:`.damped`. ``threads`` > 1 runs ranges of whole blocks of poses on threads."""
    fn = driver()
    N, n = np.shape(K)[:2]
    L = np.shape(W)[1]
    arrays = [np.ascontiguousarray(v, dtype=np.float64) for v in (M, K, W, h, k_d, c_d, t_d)]
    sizes = (n * n, n * n, L * n, L, L, L, L)
    inputs = [(v, 8 * size) for v, size in zip(arrays, sizes)]
    return _run_poles(fn, N, n, L, inputs, (eliminate, unstable, ambiguous), threads, "C damped modes")


def _run_poles(fn, N: int, n: int, L: int, inputs, rules, threads: int, what: str):
    """Call the damped-modes entry ``fn`` on ranges of whole blocks of the N poses (threads):
    its arguments are the range's count, n, L, each input's address at the range's first pose
    (``inputs``: (array or None, bytes per pose) in the entry's order), ``rules`` and the
    outputs' addresses; ``(wn, zeta, wd, poles, stable, redo)`` as :func:`solve` returns them.
    A non-zero return code raises, naming ``what``."""
    from .threads import run_ranges, threads_for

    wn, zeta, wd = (np.empty((N, n)) for _ in range(3))
    poles = np.empty((N, n), dtype=complex)
    stable = np.empty(N, dtype=np.int8)
    status = np.empty(N, dtype=np.int8)

    def call(a: int, b: int) -> int:
        return fn(
            b - a,
            n,
            L,
            *(None if v is None else address(v) + a * size for v, size in inputs),
            *rules,
            *(address(x) + 8 * a * n for x in (wn, zeta, wd)),
            address(poles) + 16 * a * n,
            address(stable) + a,
            address(status) + a,
        )

    for rc in run_ranges(call, N, BLOCK, threads_for(N, BLOCK, threads)):
        if rc != 0:
            raise RuntimeError(f"{what} returned {rc}")
    return wn, zeta, wd, poles, stable.astype(bool), status != 0


def wrenches(Je, Cq, rigid: float, a0=None, loss=None):
    """``(K, W, h)`` of :func:`eigentwist.runtime.damped.actuator_wrenches` by the driver's
    ``et_wrenches`` (one call for the batch): Je (N, legs, e, c), Cq (N, legs, e, e); an
    eigenvalue of Cq within ``rigid`` times the largest magnitude is a rigid direction. With
    a structural loss factor ``loss`` (N,) and the actuators' compliance ``a0`` (N, legs),
    ``et_wrenches_complex``: K, W, h complex (the passive compliance over 1 + i loss). None
    where the driver is not built or e > MAX_MODES."""
    N, L, e, c = np.shape(Je)
    if driver() is None or e > MAX_MODES or c > 64:
        return None
    Je = np.ascontiguousarray(Je, dtype=np.float64)
    Cq = np.ascontiguousarray(Cq, dtype=np.float64)
    dtype = float if loss is None else complex
    K, W, h = np.empty((N, c, c), dtype), np.empty((N, L, c), dtype), np.empty((N, L), dtype)
    if loss is None:
        args = (address(Je), address(Cq), rigid)
        rc = _WRENCHES[0](N, L, e, c, *args, address(K), address(W), address(h))
    else:
        a0 = np.ascontiguousarray(np.broadcast_to(a0, (N, L)), dtype=np.float64)
        eta = np.ascontiguousarray(np.broadcast_to(loss, (N,)), dtype=np.float64)
        args = (address(Je), address(Cq), address(a0), address(eta), rigid)
        rc = _WRENCHES[1](N, L, e, c, *args, address(K), address(W), address(h))
    if rc != 0:
        raise RuntimeError(f"C actuator wrenches returned {rc}")
    return K, W, h


def _legs_arguments(legs, n: int):
    """The legs kernel's part of a pass's C arguments: its address, the number of inputs
    read from the joint coordinates, the input and stride tables, which inputs are the
    joint coordinates, the number of outputs and their addresses and sizes per pose; and the
    arrays those addresses point into (keep them alive for the call). ``legs``: the kernel's
    :meth:`~.c_kernels.CKernels.kernel_arguments`; n poses."""
    kernel_at, inputs, strides, q_of, outs, _ = legs
    out_ptrs = np.array([address(a) for a in outs.values()], dtype=np.uint64)
    sizes = np.array([a[0].size if n else 0 for a in outs.values()], dtype=np.int64)
    args = (
        kernel_at,
        len(q_of),
        address(inputs),
        address(strides),
        address(q_of),
        len(out_ptrs),
        address(out_ptrs),
        address(sizes),
    )
    return args, (out_ptrs, sizes)


def one_pass(fused, legs, block: int, n: int, q, M, K, Je, Cq, e_used: int, B, k_d, c_d, t_d, rules, threads: int = 1):
    """The robot's fused pass, its legs kernel and the damped modes of n poses in one C call
    per range of whole blocks (``et_damped_pass``: no Python between the kernels and the
    solve): ``(wn, zeta, wd, poles, stable, redo)`` as :func:`solve` gives them, on the model's
    r coordinates (the poses the pass marks invalid: NaN).

    ``fused``: ``(address, args)`` of the fused pass (:meth:`.c_kernels.CKernels.address`,
    :meth:`~.c_kernels.CKernels.fused_arguments`'s C arguments, which must ask for the
    status, ``q``, ``M`` and the model's stiffness); ``legs``: the legs kernel's
    :meth:`~.c_kernels.CKernels.kernel_arguments`; ``block``: the kernels' block of poses;
    q (n, legs, n_q), M, K (n, 6, 6), Je (n, legs, e, 6), Cq (n, legs, e, e): the arrays those
    calls fill (the actuated joint's first ``e_used`` rows are the leg's compliance), B (6, r)
    the model's coordinates or None (the six twists), k_d, c_d, t_d (n, legs); ``rules``: the
    constants ``(RIGID, ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS)`` of :mod:`.damped`. Raises
    RuntimeError when a kernel or the driver fails."""
    from .threads import run_ranges, threads_for

    driver()
    fn = _PASS[0]
    pass_at, args = fused
    L, e = np.shape(Je)[1:3]
    r = 6 if B is None else np.shape(B)[1]
    Bc = None if B is None else np.ascontiguousarray(B, dtype=np.float64)
    kd, cd, td = (np.ascontiguousarray(np.broadcast_to(v, (n, L)), dtype=np.float64) for v in (k_d, c_d, t_d))
    legs_args, _keep = _legs_arguments(legs, n)
    wn, zeta, wd = (np.empty((n, r)) for _ in range(3))
    poles = np.empty((n, r), dtype=complex)
    stable = np.empty(n, dtype=np.int8)
    redo = np.empty(n, dtype=np.int8)
    q_row = int(np.prod(np.shape(q)[1:]))

    def call(a: int, b: int) -> int:
        return fn(
            a,
            b,
            block,
            pass_at,
            *args,
            *legs_args,
            address(q),
            q_row,
            address(M),
            address(K),
            address(Je),
            address(Cq),
            L,
            e,
            e_used,
            None if Bc is None else address(Bc),
            r,
            address(kd),
            address(cd),
            address(td),
            *rules,
            address(wn),
            address(zeta),
            address(wd),
            address(poles),
            address(stable),
            address(redo),
        )

    for rc in run_ranges(call, n, block, threads_for(n, block, threads)):
        if rc != 0:
            raise RuntimeError(f"C damped pass returned {rc}")
    return wn, zeta, wd, poles, stable.astype(bool), redo != 0


def solve_legs(M, K, K_ground, Je, Cq, e_used: int, B, k_d, c_d, t_d, rules, threads: int = 1):
    """The damped modes of N poses from their legs' kernel outputs in one C call
    (``et_damped_legs``: the actuator wrenches, the stiffness, the projection on the model's
    coordinates and :func:`solve`'s solve, pose by pose): ``(wn, zeta, wd, poles, stable,
    redo)`` as :func:`solve` gives them, on the r coordinates of B.

    M (N, 6, 6); K (N, 6, 6) the model's stiffness, or None for the legs' own
    ``J_e^T C_q^+ J_e`` plus K_ground ((6, 6) or (N, 6, 6), or None); Je (N, legs, e, 6),
    Cq (N, legs, e, e) (the first ``e_used`` rows: the legs' compliance the model keeps);
    B (6, r) or (N, 6, r) the model's coordinates, or None (the six twists); k_d, c_d, t_d
    (N, legs); ``rules``: ``(RIGID, ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS)`` of :mod:`.damped`.
    ``threads`` > 1 runs ranges of whole blocks of poses on threads."""
    from .threads import run_ranges, threads_for

    driver()
    fn = _LEGS[0]
    f64 = lambda v: None if v is None else np.ascontiguousarray(v, dtype=np.float64)  # noqa: E731
    M, K, Kg, Je, Cq, Bc = (f64(v) for v in (M, K, K_ground, Je, Cq, B))
    N, L, e = Je.shape[:3]
    r = 6 if Bc is None else Bc.shape[-1]
    kd, cd, td = (np.ascontiguousarray(np.broadcast_to(v, (N, L)), dtype=np.float64) for v in (k_d, c_d, t_d))
    wn, zeta, wd = (np.empty((N, r)) for _ in range(3))
    poles = np.empty((N, r), dtype=complex)
    stable = np.empty(N, dtype=np.int8)
    status = np.empty(N, dtype=np.int8)

    def at(v, a: int, size: int):
        return None if v is None else address(v) + (0 if v.ndim == 2 else 8 * a * size)

    def call(a: int, b: int) -> int:
        return fn(
            b - a,
            L,
            e,
            e_used,
            r,
            address(M) + 8 * a * 36,
            at(K, a, 36),
            int(K is not None and K.ndim == 2),
            at(Kg, a, 36),
            int(Kg is not None and Kg.ndim == 2),
            address(Je) + 8 * a * L * e * 6,
            address(Cq) + 8 * a * L * e * e,
            at(Bc, a, 6 * r),
            int(Bc is not None and Bc.ndim == 2),
            *(address(x) + 8 * a * L for x in (kd, cd, td)),
            *rules,
            *(address(x) + 8 * a * r for x in (wn, zeta, wd)),
            address(poles) + 16 * a * r,
            address(stable) + a,
            address(status) + a,
        )

    for rc in run_ranges(call, N, BLOCK, threads_for(N, BLOCK, threads)):
        if rc != 0:
            raise RuntimeError(f"C damped modes from the legs returned {rc}")
    return wn, zeta, wd, poles, stable.astype(bool), status != 0


def exact_pass(fused, legs, block: int, n: int, q, M, k_d, c_d, t_d, rules, null_rtol: float, vectors: bool, threads=1):
    """The robot's fused pass, its legs kernel and the exact condensation's modes of n poses in
    one C call per range of whole blocks (``et_exact_pass``: no Python between the kernels, the
    condensation and the damped solve). Returns a dict: ``nb`` (n,) the number of admissible
    twists (0 where the pass marks the pose invalid), ``lam`` (n, 6) the undamped omega^2
    ((rad/s)^2) of the nb finite modes ascending, ``V`` (n, 6, 6) their eigentwists as
    M-orthonormal columns (with ``vectors``), ``code`` (n,) 0 solved, 1 the damped modes
    undecided, 2 the undamped ones not solved, and, with ``k_d`` not None, ``damped``:
    ``(wn, zeta, wd, poles, stable)`` as :func:`solve` gives them, (n, 6) on the first nb
    columns.

    ``fused``, ``legs``, ``block``, q and M as for :func:`one_pass` (the fused pass must fill
    the status, q and M; the legs kernel's outputs ``Je``, ``Cq``, ``K_ground`` are read);
    k_d, c_d, t_d (n, legs) or None (the undamped modes alone); ``rules``: ``(RIGID,
    ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS)`` of :mod:`.damped`; ``null_rtol``: a rigid rows'
    Gram eigenvalue at most this times the largest is an admissible twist. Raises
    RuntimeError when a kernel or the driver fails."""
    from .threads import run_ranges, threads_for

    driver()
    fn = _EXACT[0]
    pass_at, args = fused
    l_outs = legs[4]
    Je, Cq, Kg = l_outs["Je"], l_outs["Cq"], l_outs["K_ground"]
    L, e = np.shape(Je)[1:3]
    damped = k_d is not None
    kd, cd, td = (
        (np.ascontiguousarray(np.broadcast_to(v, (n, L)), dtype=np.float64) for v in (k_d, c_d, t_d))
        if damped
        else (None, None, None)
    )
    legs_args, _keep = _legs_arguments(legs, n)
    nb, code = np.empty(n, dtype=np.int8), np.empty(n, dtype=np.int8)
    lam = np.empty((n, 6))
    V = np.empty((n, 6, 6)) if vectors else None
    wn, zeta, wd = (np.empty((n, 6)) for _ in range(3))
    poles = np.empty((n, 6), dtype=complex)
    stable = np.empty(n, dtype=np.int8)
    ptr = lambda a: None if a is None else address(a)  # noqa: E731
    q_row = int(np.prod(np.shape(q)[1:]))

    def call(a: int, b: int) -> int:
        return fn(
            a,
            b,
            block,
            pass_at,
            *args,
            *legs_args,
            address(q),
            q_row,
            address(M),
            address(Je),
            address(Cq),
            address(Kg),
            L,
            e,
            ptr(kd),
            ptr(cd),
            ptr(td),
            *rules[:1],
            null_rtol,
            *rules[1:],
            address(nb),
            address(lam),
            ptr(V),
            *(address(x) for x in (wn, zeta, wd, poles, stable, code)),
        )

    for rc in run_ranges(call, n, block, threads_for(n, block, threads)):
        if rc != 0:
            raise RuntimeError(f"C exact pass returned {rc}")
    out = {"nb": nb.astype(int), "lam": lam, "V": V, "code": code}
    if damped:
        out["damped"] = (wn, zeta, wd, poles, stable.astype(bool))
    return out


def solve_complex(M, K, K_loss, W, h, k_d, c_d, t_d, eliminate: float, unstable: float, ambiguous: float, threads=1):
    """:func:`solve` with a structural loss factor: the stiffness ``K + i K_loss`` (K_loss
    (N, n, n) real, or None), the actuator wrenches W (N, legs, n) and h (N, legs) complex;
    the state matrix complex (``et_damped_complex``: complex Householder-Hessenberg and
    single-shift QR), its poles of positive frequency assigned as :func:`solve` does. Returns
    ``(wn, zeta, wd, poles, stable, redo)`` as :func:`solve`."""
    driver()
    fn = _COMPLEX[0]
    N, n = np.shape(K)[:2]
    L = np.shape(W)[1]
    M, K, kd, cd, td = (np.ascontiguousarray(v, dtype=np.float64) for v in (M, K, k_d, c_d, t_d))
    Kl = None if K_loss is None else np.ascontiguousarray(K_loss, dtype=np.float64)
    W, h = (np.ascontiguousarray(v, dtype=np.complex128) for v in (W, h))
    inputs = [(M, 8 * n * n), (K, 8 * n * n), (Kl, 8 * n * n), (W, 16 * L * n), (h, 16 * L)]
    inputs += [(x, 8 * L) for x in (kd, cd, td)]
    return _run_poles(fn, N, n, L, inputs, (eliminate, unstable, ambiguous), threads, "C complex damped modes")
