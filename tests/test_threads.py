"""Thread counts of the C passes (no compiler needed): precedence, small batches, ranges."""

from __future__ import annotations

import pytest

from eigentwist.runtime import InputError, threads


def test_explicit_count_wins_over_environment(monkeypatch):
    monkeypatch.setenv("EIGENTWIST_THREADS", "3")
    assert threads.resolve_threads(2) == 2
    assert threads.resolve_threads() == 3


def test_default_is_every_core_but_one_in_a_dask_worker(monkeypatch):
    monkeypatch.delenv("EIGENTWIST_THREADS", raising=False)
    assert threads.resolve_threads() == threads.available_cores()
    monkeypatch.setattr(threads, "_in_dask_worker", lambda: True)
    assert threads.resolve_threads() == 1
    assert threads.resolve_threads(4) == 4  # unless asked
    monkeypatch.setenv("EIGENTWIST_THREADS", "2")
    assert threads.resolve_threads() == 2


@pytest.mark.parametrize("bad", ["0", "-1", "two", "1.5"])
def test_bad_environment_value_is_named(monkeypatch, bad):
    monkeypatch.setenv("EIGENTWIST_THREADS", bad)
    with pytest.raises(InputError, match=r"^EIGENTWIST_THREADS = "):
        threads.resolve_threads()


@pytest.mark.parametrize("count", ["1", "2", " 16 "])
def test_every_whole_count_from_one_is_taken_from_the_environment(monkeypatch, count):
    monkeypatch.setenv("EIGENTWIST_THREADS", count)
    assert threads.resolve_threads() == int(count)


def test_available_cores_are_the_affinity_or_the_cpu_count(monkeypatch):
    import os

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)
    assert threads.available_cores() == 1
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 2, 5}, raising=False)
    assert threads.available_cores() == 3
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)  # not every OS reports it
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    assert threads.available_cores() == 3
    monkeypatch.setattr(os, "cpu_count", lambda: None)  # undeterminable: one
    assert threads.available_cores() == 1


def test_a_dask_worker_is_recognised_only_inside_one(monkeypatch):
    """``distributed`` not imported: not a worker (and nothing imported); imported, the worker
    is ``get_worker()``'s answer (ValueError outside a worker)."""
    import sys
    import types

    monkeypatch.delitem(sys.modules, "distributed", raising=False)
    assert threads._in_dask_worker() is False and "distributed" not in sys.modules
    fake = types.ModuleType("distributed")

    def outside():
        raise ValueError("no worker found")

    fake.get_worker = outside
    monkeypatch.setitem(sys.modules, "distributed", fake)
    assert threads._in_dask_worker() is False
    fake.get_worker = lambda: object()
    assert threads._in_dask_worker() is True


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "2"])
def test_bad_argument_is_named(bad):
    with pytest.raises(InputError, match="threads"):
        threads.resolve_threads(bad)


def test_small_batches_stay_on_one_thread():
    per = threads.MIN_BLOCKS_PER_THREAD * 64
    assert threads.threads_for(30, 64, 8) == 1  # a diagnosis fit's rows
    assert threads.threads_for(2 * per - 64, 64, 8) == 1
    assert threads.threads_for(2 * per, 64, 8) == 2
    assert threads.threads_for(10**6, 64, 8) == 8
    # a partial last block counts as a block; the count is a whole number
    got = threads.threads_for(2 * per - 63, 64, 8)
    assert got == 2 and type(got) is int


def test_a_pool_per_size_of_exactly_that_many_named_threads():
    import threading

    pool = threads._pool(3)
    assert threads._pool(3) is pool and threads._pool(2) is not pool
    assert pool._max_workers == 3
    assert pool.submit(lambda: threading.current_thread().name).result().startswith("eigentwist")


@pytest.mark.parametrize("count", [2, 3])
def test_ranges_and_tasks_run_on_at_most_that_many_threads(count):
    """``run_ranges`` and ``map_tasks`` on ``count`` threads: many slow tasks at once never
    occupy more than ``count`` threads (the pool of that size, not a larger default one)."""
    import threading
    import time

    def where(*_):
        time.sleep(0.01)
        return threading.get_ident()

    used = threads.run_ranges(where, 64 * 64, 64, count)
    assert len(used) == count * threads.TASKS_PER_THREAD and len(set(used)) <= count
    used = threads.map_tasks(where, list(range(6 * count)), count)
    assert len(used) == 6 * count and 1 < len(set(used)) <= count


@pytest.mark.parametrize("n", [1, 63, 64, 65, 1000, 64 * 37 + 5])
@pytest.mark.parametrize("parts", [1, 2, 3, 8, 1000])
def test_ranges_cover_the_batch_on_block_boundaries(n, parts):
    ranges = threads.block_ranges(n, 64, parts)
    assert ranges[0][0] == 0 and ranges[-1][1] == n
    assert all(b == c for (_, b), (c, _) in zip(ranges[:-1], ranges[1:]))
    assert all(a % 64 == 0 and a < b for a, b in ranges)
    assert len(ranges) <= parts


def test_an_empty_batch_has_no_ranges():
    assert threads.block_ranges(0, 64, 3) == []


def test_run_ranges_returns_results_in_order():
    out = threads.run_ranges(lambda a, b: (a, b), 64 * 100 + 3, 64, 3)
    assert out[0][0] == 0 and out[-1][1] == 64 * 100 + 3
    assert [a for a, _ in out] == sorted(a for a, _ in out)


@pytest.mark.parametrize("count", [1, 2])
def test_run_ranges_one_thread_is_one_call_on_the_caller_and_an_empty_batch_none(count):
    """One thread: the whole batch in one call on the calling thread; two: several calls on
    the pool's threads. An empty batch: no call on any count."""
    import threading

    calls = []

    def call(a, b):
        calls.append((a, b, threading.current_thread() is threading.main_thread()))

    threads.run_ranges(call, 64 * 8, 64, count)
    if count == 1:
        assert calls == [(0, 64 * 8, True)]
    else:
        assert len(calls) > 1 and not any(main for *_, main in calls)
    calls.clear()
    assert threads.run_ranges(call, 0, 64, count) == [] and calls == []


def test_map_tasks_keeps_the_items_order_and_runs_small_work_on_the_caller():
    import threading

    where = []

    def task(k):
        where.append(threading.current_thread() is threading.main_thread())
        return k * k

    assert threads.map_tasks(task, [3], 4) == [9] and where == [True]  # one item
    assert threads.map_tasks(task, list(range(5)), 1) == [0, 1, 4, 9, 16] and all(where)  # one thread
    where.clear()
    assert threads.map_tasks(task, list(range(40)), 3) == [k * k for k in range(40)]
    assert not any(where)  # on the pool's threads
    where.clear()
    assert threads.map_tasks(task, [2, 3], 2) == [4, 9] and not any(where)  # two items: on the pool too


def test_map_chunks_runs_chunks_side_by_side_with_one_inner_thread():
    """Several chunks and threads: each chunk on a pool thread with ``inner`` = 1; else the
    chunks one after another on the caller with ``inner`` = the threads; the results in order."""
    import threading

    from eigentwist.runtime.completion import CHUNK, map_chunks

    def task(rows, inner):
        return rows.start, rows.stop, inner, threading.current_thread() is threading.main_thread()

    n = 2 * CHUNK + 1
    got = map_chunks(task, n, 3)
    assert [(a, b) for a, b, _, _ in got] == [(0, CHUNK), (CHUNK, 2 * CHUNK), (2 * CHUNK, n)]
    assert all(inner == 1 and not main for *_, inner, main in got)
    assert [g[2:] for g in map_chunks(task, n, 1)] == [(1, True)] * 3
    assert map_chunks(task, CHUNK, 3) == [(0, CHUNK, 3, True)]  # one chunk: its C calls take the threads
    two = map_chunks(task, CHUNK + 1, 2)  # two chunks: side by side already
    assert [g[:3] for g in two] == [(0, CHUNK, 1), (CHUNK, CHUNK + 1, 1)] and not any(g[3] for g in two)
    assert map_chunks(task, 0, 3) == []


def test_map_ranges_splits_large_batches_into_few_ranges_of_whole_chunks():
    """One call on the caller for one thread or a batch of one chunk; else at most threads ×
    TASKS_PER_THREAD contiguous ranges, each of whole chunks but the last, on the pool's
    threads, covering the batch in order."""
    import threading

    from eigentwist.runtime.completion import CHUNK, map_ranges

    def task(rows):
        return rows.start, rows.stop, threading.current_thread() is threading.main_thread()

    assert map_ranges(task, 5 * CHUNK, 1) == [(0, 5 * CHUNK, True)]
    assert map_ranges(task, CHUNK, 4) == [(0, CHUNK, True)]
    two = map_ranges(task, CHUNK + 1, 4)
    assert [g[:2] for g in two] == [(0, CHUNK), (CHUNK, CHUNK + 1)] and not any(g[2] for g in two)
    n = 100 * CHUNK + 7
    got = map_ranges(task, n, 3)
    assert len(got) == 3 * threads.TASKS_PER_THREAD and not any(g[2] for g in got)
    assert got[0][0] == 0 and got[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(got, got[1:]))
    assert all(a % CHUNK == 0 and b - a >= CHUNK for a, b, _ in got[:-1])


@pytest.mark.parametrize("count", [1, 2, 4])
def test_run_workers_runs_the_work_on_that_many_threads_the_caller_one_of_them(count):
    """``run_workers``: the work once on each of ``count`` threads at once (all of them busy
    together: a barrier of ``count`` passes), the calling thread one of them."""
    import threading

    where, barrier = [], threading.Barrier(count, timeout=30)

    def work():
        barrier.wait()
        where.append(threading.current_thread())

    threads.run_workers(work, count)
    assert len(where) == count and where.count(threading.main_thread()) == 1
    # the others: threads of the pool of that size
    assert all(t in threads._pool(count)._threads for t in where if t is not threading.main_thread())


def test_run_workers_waits_for_every_worker_and_raises_the_first_error():
    import threading
    import time

    done = []

    def work():
        if threading.current_thread() is threading.main_thread():
            raise ValueError("the caller's")
        time.sleep(0.05)
        done.append(1)

    with pytest.raises(ValueError, match="the caller's"):
        threads.run_workers(work, 3)
    assert len(done) == 2  # the pool's two finished before the error left
