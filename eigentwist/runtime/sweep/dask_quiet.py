"""Keep a closing Dask worker's heartbeat race out of the user's terminal.

When a local cluster shuts down, a worker can be closing its connection pool while a
heartbeat it sent before is still waiting for the scheduler; distributed then logs
"Failed to communicate with scheduler during heartbeat" with a traceback, although
every chunk has arrived. :class:`QuietShutdown` drops exactly that record, and only
from a worker that is already closing: a heartbeat failure of a running worker still
reaches the log.
"""

from __future__ import annotations

import logging

from distributed.core import Status
from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["HEARTBEAT_FAILURE", "ClosingHeartbeatFilter", "QuietShutdown"]

HEARTBEAT_FAILURE = "Failed to communicate with scheduler during heartbeat"
CLOSING = (Status.closing, Status.closing_gracefully, Status.closed)


class ClosingHeartbeatFilter(logging.Filter):
    """Drop the heartbeat-failure record of ``worker`` while it is closing."""

    def __init__(self, worker):
        super().__init__()
        self.worker = worker

    def filter(self, record: logging.LogRecord) -> bool:
        closing = self.worker.status in CLOSING
        return not (closing and record.getMessage().startswith(HEARTBEAT_FAILURE))


class QuietShutdown(WorkerPlugin):
    """Worker plugin installing :class:`ClosingHeartbeatFilter` on ``distributed.worker``."""

    name = "eigentwist-quiet-shutdown"

    def setup(self, worker) -> None:
        logging.getLogger("distributed.worker").addFilter(ClosingHeartbeatFilter(worker))
