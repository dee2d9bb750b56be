"""The prepared fused pass's blocks handed out to its threads in C, with its checks.

A prepared pass (:class:`~.fused_call.FusedCall`) over a batch of poses runs on a few
threads, each in one C call, :c:func:`et_schedule_work`, that takes the next *grain* of
:data:`GRAIN_BLOCKS` blocks from a shared counter until none is left: a thread slowed by other
load takes fewer grains, none waits at a split fixed beforehand, and the GIL is taken once per
thread and call, not once per range and check. Per grain, before the pass, the poses' values
are checked finite (a non-finite one stops every thread: the caller then hands the batch to
the path that names it); after it, the poses that are not clean are counted: a nonzero
status, or a lowest frequency that does not lie above ``screen`` times the highest (NaN
included) — :data:`~.c_route.PARALLEL_SCREEN`'s test. A block's poses are the same whatever
grain or thread computes it, so the results are those of one call over the batch, bit for bit.

The scheduler is plain C with gcc's ``__atomic`` builtins (gcc, clang), compiled once into the
cache (:mod:`.ccompile`); where it cannot be built, :func:`scheduler` is None and the pass runs
on ranges from Python (:func:`~.threads.run_ranges`) with the checks in NumPy.
"""

from __future__ import annotations

import ctypes

from .ccompile import library_once

__all__ = ["GRAIN_BLOCKS", "Schedule", "scheduler", "run_pass", "SOURCE"]

#: blocks a thread takes at a time: 256 poses at 64 a block, a few hundred microseconds of
#: work, so the last grains even out the threads' ends while the counter is seldom touched
GRAIN_BLOCKS = 4

SOURCE = r"""
#include <math.h>
#include <stdint.h>

#if !defined(__GNUC__)
#error "the scheduler needs gcc's __atomic builtins (gcc, clang)"
#endif

typedef int (*et_fused_fn)(int64_t, int64_t, const double *const *, const int64_t *, int, double *const *,
                           double *const *, double *const *, double *, double *, int8_t *, const double *);

/* One batch's pass: the fused function and its arguments (see a generated library's
   <robot>_fused), the poses checked finite (dof values a pose, contiguous; NULL: not
   checked), the clean test's frequency columns (dim; 0: no test) and screen, and what the
   threads share: the next grain, a non-finite pose seen, the not-clean count, the first
   nonzero return code of the pass. */
typedef struct {
    void *fn;
    int64_t n, block, grain;
    const double *const *in;
    const int64_t *stride;
    int64_t model;
    double *const *ik_out, *const *mat_out, *const *jac_out;
    double *freq, *vec;
    int8_t *status;
    const double *opts;
    const double *poses;
    int64_t dof, dim;
    double screen;
    int64_t next, not_finite, unclean, rc;
} et_schedule;

/* Grains of s->grain blocks until none is left, a non-finite pose is seen or the pass
   returns nonzero. Returns 0. */
int et_schedule_work(et_schedule *s)
{
    const et_fused_fn fn = (et_fused_fn)s->fn;
    const int64_t span = s->block * s->grain, dim = s->dim;
    int64_t unclean = 0;
    while (!__atomic_load_n(&s->rc, __ATOMIC_RELAXED) && !__atomic_load_n(&s->not_finite, __ATOMIC_RELAXED)) {
        const int64_t b0 = __atomic_fetch_add(&s->next, 1, __ATOMIC_RELAXED) * span;
        if (b0 >= s->n)
            break;
        const int64_t b1 = s->n - b0 > span ? b0 + span : s->n;
        if (s->poses) {
            int finite = 1;
            for (int64_t k = b0 * s->dof; k < b1 * s->dof; ++k)
                finite &= isfinite(s->poses[k]) != 0;
            if (!finite) {
                __atomic_store_n(&s->not_finite, 1, __ATOMIC_RELAXED);
                break;
            }
        }
        const int rc = fn(b0, b1, s->in, s->stride, (int)s->model, s->ik_out, s->mat_out, s->jac_out, s->freq, s->vec,
                          s->status, s->opts);
        if (rc) {
            int64_t none = 0;
            __atomic_compare_exchange_n(&s->rc, &none, (int64_t)rc, 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED);
            break;
        }
        if (dim > 0)
            for (int64_t i = b0; i < b1; ++i) {
                const double *f = s->freq + i * dim;
                unclean += s->status[i] != 0 || !(f[0] > s->screen * f[dim - 1]);
            }
    }
    __atomic_fetch_add(&s->unclean, unclean, __ATOMIC_RELAXED);
    return 0;
}
"""


class Schedule(ctypes.Structure):
    """The C ``et_schedule`` of one batch (see :data:`SOURCE`)."""

    _fields_ = [
        ("fn", ctypes.c_void_p),
        ("n", ctypes.c_int64),
        ("block", ctypes.c_int64),
        ("grain", ctypes.c_int64),
        ("ins", ctypes.c_void_p),
        ("strides", ctypes.c_void_p),
        ("model", ctypes.c_int64),
        ("ik_out", ctypes.c_void_p),
        ("mat_out", ctypes.c_void_p),
        ("jac_out", ctypes.c_void_p),
        ("freq", ctypes.c_void_p),
        ("vec", ctypes.c_void_p),
        ("status", ctypes.c_void_p),
        ("opts", ctypes.c_void_p),
        ("poses", ctypes.c_void_p),
        ("dof", ctypes.c_int64),
        ("dim", ctypes.c_int64),
        ("screen", ctypes.c_double),
        ("next", ctypes.c_int64),
        ("not_finite", ctypes.c_int64),
        ("unclean", ctypes.c_int64),
        ("rc", ctypes.c_int64),
    ]


_SCHEDULER: list = []  # [ctypes function] once built, [None] when it cannot be
_LIBRARIES: list = []  # the loaded library, kept for the process


def _bind(lib):
    """et_schedule_work of the loaded library, its argument and return types declared."""
    fn = lib.et_schedule_work
    fn.argtypes = [ctypes.c_void_p]
    fn.restype = ctypes.c_int
    return fn


def scheduler():
    """The compiled ``et_schedule_work`` (built on first use into the cache), or None where
    it cannot be built."""
    return library_once(_SCHEDULER, _LIBRARIES, SOURCE, "schedule", _bind)


def _at(arg):
    """A pass argument as a number: a ctypes array's address, an address or a model index as
    it is, None as NULL."""
    if arg is None:
        return None
    return ctypes.addressof(arg) if isinstance(arg, ctypes.Array) else int(arg)


def run_pass(
    fn, n: int, block: int, threads: int, args: tuple, poses=None, dof: int = 0, dim: int = 0, screen: float = 0.0
):
    """A generated library's fused pass ``fn`` (its ctypes function) over ``n`` poses with
    ``args``, its arguments after the range (inputs, strides, model, the ik, matrices and
    jacobians output tables, frequencies, eigentwists, status, options: ctypes arrays,
    addresses or None), its blocks handed out to ``threads`` threads in C. With ``poses``
    (the address of n rows of ``dof`` contiguous doubles) each grain's poses are checked
    finite first; with ``dim`` > 0 (the frequencies' columns) its poses that are not clean
    against ``screen`` are counted (status and frequencies must be among the outputs).
    Returns the finished :class:`Schedule` (``not_finite``, ``unclean``, ``rc``: the first
    nonzero return code, for the caller's check), or None where the scheduler cannot be
    built."""
    from .threads import run_workers, threads_for

    work = scheduler()
    if work is None:
        return None
    ins, strides, model, ik, mats, jacs, freq, vec, status, opts = map(_at, args)
    sched = Schedule(
        ctypes.cast(fn, ctypes.c_void_p).value, n, block, GRAIN_BLOCKS, ins, strides, model, ik, mats, jacs, freq,
        vec, status, opts, poses, dof, dim, screen,
    )  # fmt: skip
    state = ctypes.addressof(sched)
    run_workers(lambda: work(state), threads_for(n, block, threads))
    return sched
