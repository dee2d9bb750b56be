"""How many threads a C pass uses, and running its block ranges on them.

The generated C library works on ranges of whole blocks (``ET_BLOCK`` poses), each block
computed on its own (the Jacobi solver iterates a block until all its poses converge), so
splitting a batch on block boundaries gives results bit-identical to one thread. The
threads are Python threads: ctypes releases the GIL for the duration of each C call.

The count, in order of precedence: the ``threads`` argument of :func:`eigentwist.load`;
the ``EIGENTWIST_THREADS`` environment variable; 1 inside a Dask worker (the cluster runs
one task per core already); otherwise every core this process may run on. A batch gets at
most one thread per :data:`MIN_BLOCKS_PER_THREAD` blocks, so small batches (a diagnosis
fit's few dozen rows) stay on the calling thread.
"""

from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

from .errors import InputError

__all__ = [
    "MIN_BLOCKS_PER_THREAD",
    "TASKS_PER_THREAD",
    "resolve_threads",
    "threads_for",
    "block_ranges",
    "run_ranges",
    "map_tasks",
    "run_workers",
    "available_cores",
]

MIN_BLOCKS_PER_THREAD = 16  # 1024 poses at 64 per block: below this, one thread
TASKS_PER_THREAD = 4  # ranges per thread, so a thread slowed by other load is not the tail


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS reports it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _in_dask_worker() -> bool:
    if "distributed" not in sys.modules:
        return False
    try:
        from distributed import get_worker

        get_worker()
        return True
    except (ImportError, ValueError):
        return False


def _parse(value: str, what: str) -> int:
    if not value.isdigit() or int(value) < 1:
        raise InputError(f"{what} = {value!r}: expected a whole number of threads >= 1")
    return int(value)


def resolve_threads(threads=None) -> int:
    """The thread count for ``threads`` (None: ``EIGENTWIST_THREADS``, Dask worker, cores)."""
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise InputError(f"threads = {threads!r}: expected a whole number of threads >= 1")
        return threads
    env = os.environ.get("EIGENTWIST_THREADS", "").strip()
    if env:
        return _parse(env, "EIGENTWIST_THREADS")
    if _in_dask_worker():
        return 1
    return available_cores()


def threads_for(n: int, block: int, threads: int) -> int:
    """Threads for a batch of ``n`` poses: at most one per MIN_BLOCKS_PER_THREAD blocks."""
    blocks = -(-n // block)
    return max(1, min(threads, blocks // MIN_BLOCKS_PER_THREAD))


def block_ranges(n: int, block: int, parts: int) -> list[tuple[int, int]]:
    """``parts`` (or fewer) contiguous ``(begin, end)`` ranges covering [0, n), every
    boundary a multiple of ``block`` (except the final end, n)."""
    blocks = -(-n // block)
    if blocks == 0:
        return []
    parts = max(1, min(parts, blocks))
    cuts = [min(n, (blocks * k // parts) * block) for k in range(parts + 1)]
    return list(zip(cuts[:-1], cuts[1:]))  # parts <= blocks: every range holds a block or more


_POOLS: dict = {}
_POOL_LOCK = threading.Lock()


def _pool(threads: int) -> ThreadPoolExecutor:
    """An executor of exactly ``threads`` workers, one per process and size (a forked child
    makes its own: the parent's worker threads do not exist there)."""
    key = (os.getpid(), threads)
    with _POOL_LOCK:
        pool = _POOLS.get(key)
        if pool is None:
            pool = _POOLS[key] = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="eigentwist")
        return pool


def run_ranges(call, n: int, block: int, threads: int) -> list:
    """``call(begin, end)`` over block-aligned ranges of [0, n) on ``threads`` threads.

    Returns the results in range order. One thread: a single call on the calling thread.
    """
    if n == 0:
        return []
    if threads <= 1:
        return [call(0, n)]
    ranges = block_ranges(n, block, threads * TASKS_PER_THREAD)
    pool = _pool(threads)
    futures = [pool.submit(call, a, b) for a, b in ranges]
    return [f.result() for f in futures]


def map_tasks(task, items: list, threads: int) -> list:
    """``[task(item) for item in items]``, the items run on ``threads`` threads (the same
    pool as :func:`run_ranges`; a task must not itself wait on that pool). One thread or one
    item: on the calling thread."""
    if threads <= 1 or len(items) <= 1:
        return [task(item) for item in items]
    return list(_pool(threads).map(task, items))


def run_workers(work, threads: int) -> None:
    """``work()`` on ``threads`` threads at once: ``threads - 1`` of the pool's and the calling
    thread, returning when every one has returned (the first exception raised is raised
    here). For workers that share out their own work (:mod:`.c_schedule`)."""
    if threads <= 1:
        work()
        return
    futures = [_pool(threads).submit(work) for _ in range(threads - 1)]
    try:
        work()
    finally:
        for f in futures:
            f.result()
