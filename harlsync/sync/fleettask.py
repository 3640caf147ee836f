"""One process's part of a fleet: a thread a line, its robots backed up in turn,
at most :data:`STARTING` robots of the process starting at once.

The same here (:mod:`harlsync.sync.fleet`) and in a worker process
(:mod:`harlsync.sync.fleetworker`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

from .robotbackup import BackupWatch, RobotOutcome, backup_one

__all__ = ["STARTING", "START_HOLD", "Starts", "Task"]


#: How many robots of one process start at once: from its line's thread beginning
#: (project lock, robot.yaml, git, the line's lock, the port) to its first progress
#: (its identity read).  All of a share's robots starting together (64 in a 128-line
#: night) made their lines' first exchanges wait for each other's start-up, and a line
#: whose first replies of a kind were read late kept sleeping that long for the rest
#: of its read (the link times each kind's replies by the quickest of them it has
#: seen: docs/BENCHMARKS.md, issue 24); four at a time start one after the other as
#: quickly, and read as if alone.
STARTING = 4
#: A robot starting for longer than this no longer keeps another from starting: one
#: that does not answer (its retries take seconds) or waits for a line another
#: harlsync holds (up to --lock-timeout) holds up no one for long.
START_HOLD = 0.5


class Starts:
    """The starting places of one process (see :data:`STARTING`)."""

    def __init__(self, places: int = STARTING, hold: float = START_HOLD) -> None:
        self.places = places
        self.hold = hold
        self._since: dict[object, float] = {}  # each robot starting: since when
        self._changed = threading.Condition()

    def enter(self, stop: threading.Event) -> object | None:
        """A place (a token for :meth:`leave`), once one is free; None once ``stop``
        is set."""
        token = object()
        with self._changed:
            while not stop.is_set():
                now = time.monotonic()
                held = sorted(t for t in self._since.values() if now - t < self.hold)
                if len(held) < self.places:
                    self._since[token] = now
                    return token
                self._changed.wait(held[0] + self.hold - now)  # the oldest's time is up
        return None

    def leave(self, token: object) -> None:
        with self._changed:
            if self._since.pop(token, None) is not None:
                self._changed.notify()

    def held(self) -> int:
        """How many places are taken (their holders' time up or not)."""
        with self._changed:
            return len(self._since)


class Task:
    """What every robot's backup of one run needs, here or in a worker."""

    def __init__(self, attempts: int, lock_timeout: float, clock: Callable[[], datetime]) -> None:
        self.attempts = attempts
        self.lock_timeout = lock_timeout
        self.clock = clock
        self.starts = Starts()

    def line(self, paths: list[Path], watch: BackupWatch, stop: threading.Event) -> None:
        """Back up the robots of one line in turn (each tells ``watch`` its outcome),
        each starting when a starting place of this process is free (:data:`STARTING`)."""
        for path in paths:
            token = self.starts.enter(stop)
            if token is None:  # stopped (before it started, or while it waited)
                return
            start = _Start(watch, self.starts, token)
            try:
                backup_one(path, self.attempts, self.lock_timeout, self.clock, start, stop)
            finally:
                start.done()


class _Start:
    """A robot's watch that gives its starting place back at the robot's first
    progress (or its end, whichever comes first)."""

    def __init__(self, watch: BackupWatch, starts: Starts, token: object) -> None:
        self.watch = watch
        self.starts = starts
        self.token = token

    def done(self) -> None:
        self.starts.leave(self.token)

    def started(self, path: Path, name: str) -> None:
        self.watch.started(path, name)

    def progress(self, path: Path, done: int, total: int) -> None:
        try:  # the watch hears of it before the next robot starts
            self.watch.progress(path, done, total)
        finally:
            self.done()

    def finished(self, outcome: RobotOutcome) -> None:
        try:
            self.watch.finished(outcome)
        finally:
            self.done()
