"""One process's part of a fleet: a thread a line, its robots backed up in turn,
every line's first robot starting at once.

The same here (:mod:`harlsync.sync.fleet`) and in a worker process
(:mod:`harlsync.sync.fleetworker`).  (Issue 24 let at most four robots of a process
start at once; issue 33 measured it again once the link no longer timed replies by
the first ones it saw, found its gain within noise, and removed it:
docs/BENCHMARKS.md, "Issue 33".)
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

from .robotbackup import BackupWatch, backup_one

__all__ = ["Task"]


class Task:
    """What every robot's backup of one run needs, here or in a worker."""

    def __init__(self, attempts: int, lock_timeout: float, clock: Callable[[], datetime]) -> None:
        self.attempts = attempts
        self.lock_timeout = lock_timeout
        self.clock = clock

    def line(self, paths: list[Path], watch: BackupWatch, stop: threading.Event) -> None:
        """Back up the robots of one line in turn (each tells ``watch`` its outcome);
        none once ``stop`` is set."""
        for path in paths:
            if stop.is_set():  # stopped before this robot started
                return
            backup_one(path, self.attempts, self.lock_timeout, self.clock, watch, stop)
