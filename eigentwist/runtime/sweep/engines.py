"""Run every chunk of a sweep in process or on a Dask cluster, streamed into a writer."""

from __future__ import annotations

import math
import os
import time
from collections import deque
from contextlib import ExitStack
from dataclasses import dataclass

from ..errors import InputError
from .evaluate import evaluate_chunk
from .lowest import LowestTracker
from .spec import SweepSpec, sweep_evaluator

__all__ = ["ENGINES", "SweepSummary", "run_sweep"]

ENGINES = ("inprocess", "dask")


def _inprocess(spec: SweepSpec):
    for chunk in range(spec.n_chunks):
        yield chunk, evaluate_chunk(spec, chunk)


def _dask(spec: SweepSpec, scheduler: str | None = None, workers: int | None = None):
    """Submit the chunks to a Dask cluster; yield results in chunk order.

    A sliding window of ``2 x workers`` chunks in flight keeps memory bounded. The
    workers of a remote cluster need eigentwist installed (and a C compiler for
    ``backend="c"``); the spec travels with each task, each worker loads its evaluator once.
    The workers of a local cluster drop the heartbeat failure of their own shutdown
    (:class:`~eigentwist.runtime.sweep.dask_quiet.QuietShutdown`).
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise InputError(
            f'engine "dask" needs the optional dask extra: pip install "eigentwist[dask]" ({exc})'
        ) from None
    with ExitStack() as stack:
        if scheduler:
            client = stack.enter_context(Client(scheduler))
        else:
            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                )
            )
            client = stack.enter_context(Client(cluster))
            from .dask_quiet import QuietShutdown

            client.register_plugin(QuietShutdown())
        window = 2 * max(1, len(client.scheduler_info().get("workers", {})))
        pending: deque = deque()
        submitted = 0
        while submitted < spec.n_chunks or pending:
            while submitted < spec.n_chunks and len(pending) < window:
                pending.append(client.submit(evaluate_chunk, spec, submitted, pure=False))
                submitted += 1
            index = submitted - len(pending)
            future = pending.popleft()
            result = future.result()
            future.release()
            yield index, result


@dataclass
class SweepSummary:
    """What :func:`run_sweep` reports: rows, reachable rows, wall time (s), the
    :func:`lowest` arrays and the backend actually used."""

    spec: SweepSpec
    n_rows: int
    n_reachable: int
    seconds: float
    lowest: dict
    backend: str = ""

    @property
    def rows_per_second(self) -> float:
        return self.n_rows / self.seconds if self.seconds > 0 else math.inf


def run_sweep(
    spec: SweepSpec,
    writer=None,
    engine: str = "inprocess",
    scheduler: str | None = None,
    workers: int | None = None,
    on_chunk=None,
) -> SweepSummary:
    """Evaluate every chunk of ``spec`` and stream it to ``writer`` (or nowhere).

    engine : ``"inprocess"`` or ``"dask"`` (``scheduler``: a Dask scheduler address;
        without one a ``LocalCluster`` of ``workers`` processes). Both give the same
        bits: chunks are deterministic and consumed in chunk order.
    on_chunk : called with ``(chunk_index, result)`` after each chunk (progress bars).
    """
    if engine not in ENGINES:
        raise InputError(f"engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if engine == "inprocess" and (scheduler or workers):
        raise InputError("scheduler and workers apply to the dask engine only")
    if scheduler and workers:
        raise InputError("workers sets the size of a local cluster: it cannot be combined with a scheduler address")
    start = time.perf_counter()
    tracker = LowestTracker(spec)
    reachable = 0
    results = _dask(spec, scheduler, workers) if engine == "dask" else _inprocess(spec)
    for index, result in results:
        if writer is not None:
            writer.write(index, result)
        tracker.update(result)
        reachable += int(result["reachable"].sum())
        if on_chunk is not None:
            on_chunk(index, result)
    summary = SweepSummary(
        spec,
        spec.n_rows,
        reachable,
        time.perf_counter() - start,
        tracker.result(),
        sweep_evaluator(spec.robot, spec.backend).backend,
    )
    if writer is not None:
        writer.close(summary)
    return summary
