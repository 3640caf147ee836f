"""The fleet: a backup's lines spread over worker processes, one per core.

A line spends nearly all its time waiting for the wire, so one process reads many
lines, a thread each; but threads share one interpreter, and at a hundred lines
and more one process needs its whole core (docs/BENCHMARKS.md, issue 15).  So
:func:`read_lines` gives the lines to ``workers`` worker processes started for the
run (``python -c 'from harlsync.sync.fleetworker import worker; worker()'``), a thread a
line there too, and this process coordinates: it serves their events, the display
and, at the end, the report and the commit.  One worker is no process at all: this
one reads every line.  Every robot of a line is in one share, read one after the
other; the line lock (:mod:`harlsync.link.lock`) holds across processes all the
same.

The shares are weighed in exchanges with the controllers, as each robot's last
backup counted them (:func:`weights`, ``last_exchanges`` in its
``.harlsync/backup.json``): a robot of 12,000 steps is not one robot among 100
small ones.  The workers are started first thing, before this process reads a
robot.yaml: the interpreter's start-up (0.13 s of CPU) goes on while it finds the
lines and weighs them.  A worker then left with no share ends at once.

A worker is told its share as one JSON line on its standard input and tells what
happens (a robot started, its progress, its outcome, its log lines, and at its end
its own figures) as JSON lines on a pipe of its own; this process hands them to the
run's watch and log.  A line whose port only this process can open (a simulator
registered in it, ``sim://@name``; ``loop://``) is read here.  Where the work went
(lines, expected exchanges, start-up and CPU of each process) is logged at debug
level, the figures in the record's ``fleet`` (bench/fleet.py prints them).

Signals.  A worker runs in a session of its own, so a Ctrl-C typed on the terminal
reaches this process only: on KeyboardInterrupt it tells every worker to stop (or
a worker sees its standard input end, as when this process is killed), and each
robot's read stops at its next exchange, leaving its previous backup as it was,
as with one process; this process waits for the workers to end (their locks
released) before the interruption goes on.  A worker that ends without finishing
its share (killed, out of memory) fails the robots it had not finished, naming
that, and records them failed as a failed pull is (``harlsync status`` then shows
them failed); the others and the report go on.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from ..errors import SyncError
from ..robotlog import about
from . import history
from .fleettask import Task
from .robotbackup import (
    BackupWatch,
    RobotOutcome,
    in_process,
    lines_of,
    record_not_backed_up,
)

__all__ = [
    "Task",
    "default_workers",
    "in_process",
    "plan",
    "read_lines",
    "weights",
]

log = logging.getLogger(__name__)

#: What a worker process runs.
_WORKER = "from harlsync.sync.fleetworker import worker; worker()"
#: Whether a run can have worker processes (see :func:`default_workers`).
_SPREADS = os.name == "posix"


def default_workers() -> int:
    """One per core this process may run on (on Windows 1: a worker is handed its
    events pipe by descriptor, which only POSIX passes)."""
    if not _SPREADS:
        return 1
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def weights(lines: Mapping[str, list[Path]]) -> dict[str, float]:
    """What reading each line costs, in exchanges with its controllers: for each
    robot the count its last good backup recorded (``last_exchanges``,
    :mod:`harlsync.sync.history`), for a robot without one the mean of those the
    others recorded (1 each when none did: every robot alike)."""
    known: dict[Path, int] = {}
    for paths in lines.values():
        for path in paths:
            # quiet: a record that cannot be read is said by the robot's backup itself
            count = history.read(path, []).get("last_exchanges")
            if isinstance(count, int) and count > 0:
                known[path] = count
    guess = sum(known.values()) / len(known) if known else 1.0
    return {k: sum(known.get(p, guess) for p in paths) for k, paths in lines.items()}


def plan(
    lines: Mapping[str, list[Path]],
    workers: int,
    here: Iterable[str] = (),
    weight: Mapping[str, float] | None = None,
) -> list[list[str]]:
    """The lines (keys of ``lines``) of each share: first this process's, then one
    for each of at most ``workers`` worker processes.

    One worker, or one line to spread, is read in this process: every line is the
    first share's.  With more,
    this process reads only the lines ``here`` and the workers read the others:
    each line, the heaviest first (``weight``, default: its robots' count; ties: in
    order), to the share that weighs least so far (ties: the first), so that each
    worker has about as many exchanges to make.  A worker left with no line has no
    share.  (This process serves the workers' events and the display: reading a
    share too, its lines waited for each of those, and on a core another process
    asked for as well; measured in docs/BENCHMARKS.md, issue 24.)
    """
    pinned = set(here)
    if workers <= 1 or len(set(lines) - pinned) <= 1:  # nothing to spread
        return [list(lines)]
    cost = dict(weight) if weight is not None else {k: float(len(p)) for k, p in lines.items()}
    rest = [k for k in lines if k not in pinned]
    shares: list[list[str]] = [[] for _ in range(max(1, min(workers, len(rest))))]
    load = [0.0] * len(shares)
    for line in sorted(rest, key=lambda k: -cost.get(k, 1.0)):  # stable: in order on ties
        least = load.index(min(load))
        shares[least].append(line)
        load[least] += cost.get(line, 1.0)
    return [[k for k in lines if k in pinned], *(share for share in shares if share)]


def _threads(jobs: int | None, shares: list[list[str]]) -> list[int]:
    """Threads per share: a line each, at most ``jobs`` lines at once in all, split
    between the shares that have lines."""
    if jobs is None:
        return [max(1, len(share)) for share in shares]
    busy = [n for n, share in enumerate(shares) if share]
    counts = [1] * len(shares)
    base, extra = divmod(max(1, jobs), max(1, len(busy)))
    for rank, n in enumerate(busy):
        counts[n] = max(1, min(len(shares[n]), base + (rank < extra)))
    return counts


class _Collect:
    """The run's watch, collecting every outcome on the way (from any thread)."""

    def __init__(self, watch: BackupWatch) -> None:
        self.watch = watch
        self.outcomes: list[RobotOutcome] = []
        self._lock = threading.Lock()

    def started(self, path: Path, name: str) -> None:
        self.watch.started(path, name)

    def progress(self, path: Path, done: int, total: int) -> None:
        self.watch.progress(path, done, total)

    def finished(self, outcome: RobotOutcome) -> None:
        with self._lock:
            self.outcomes.append(outcome)
        self.watch.finished(outcome)


def read_lines(
    projects: list[Path],
    task: Task,
    *,
    workers: int,
    jobs: int | None,
    watch: BackupWatch,
    watched: bool,
) -> list[RobotOutcome]:
    """Back up every robot of ``projects``, a line's robots in turn, in at most
    ``workers`` worker processes (see :func:`plan`), at most ``jobs`` lines at once
    (default: all); the outcomes, in no order.  ``watched``: whether ``watch`` shows
    progress (a worker sends it only then).  Raises KeyboardInterrupt when
    interrupted, once every read has stopped."""
    workers = workers if _SPREADS else 1
    if jobs is not None:
        workers = min(workers, max(1, jobs))
    began, used = time.monotonic(), _cpu()
    collect = _Collect(watch)
    offset = (task.clock() - datetime.now(timezone.utc)).total_seconds()
    # The workers first: an interpreter's start-up is what their shares wait for, and
    # it goes on while this process finds each robot's line (robot.yaml) and weight.
    wanted = 0 if workers <= 1 or len(projects) <= 1 else min(workers, len(projects))
    children: list[_Child] = []
    stop = threading.Event()
    try:
        for _ in range(wanted):
            children.append(_Child(task, offset, collect, watched))
        here: set[str] = set()
        lines = lines_of(projects, here)
        cost = weights(lines) if children else {}
        shares = plan(lines, workers if children else 1, here, cost)
        threads = _threads(jobs, shares)
        for n, child in enumerate(children, 1):
            share = shares[n] if n < len(shares) else []  # none left: it ends at once
            child.give(share, [lines[k] for k in share], threads[n] if share else 1)
        with ThreadPoolExecutor(max_workers=threads[0]) as pool:
            try:
                for done in [pool.submit(task.line, lines[k], collect, stop) for k in shares[0]]:
                    done.result()
            except BaseException:  # Ctrl-C: every read stops at its next exchange, none starts
                stop.set()
                for child in children:
                    child.stop()
                pool.shutdown(wait=True, cancel_futures=True)
                raise
        for child in children:
            child.wait()
    except BaseException:
        stop.set()
        for child in children:
            child.stop()
        for child in children:
            child.wait(stopped=True)
        raise
    _tell(shares[0], lines, cost, children, began, _cpu() - used)
    return collect.outcomes


def _cpu() -> float:
    """The CPU this process used so far, in seconds (user and system, every thread)."""
    return time.process_time()


def _tell(
    own: list[str],
    lines: Mapping[str, list[Path]],
    cost: Mapping[str, float],
    children: list[_Child],
    began: float,
    cpu: float,
) -> None:
    """Where the run's work went, a debug line a process, each with its figures in
    the record's ``fleet`` (bench/fleet.py prints them)."""
    relayed = sum(child.relay_cpu for child in children)
    events = sum(child.events for child in children)
    log.debug(
        "fleet: this process started %d worker(s), read %d line(s) and relayed %d worker "
        "event(s) (%.3f s of CPU for them), %.2f s of CPU in all",
        len(children),
        len(own),
        events,
        relayed,
        cpu,
        extra={
            "fleet": {
                "process": "this",
                "workers": len(children),
                "lines": len(own),
                "robots": sum(len(lines[k]) for k in own),
                "cpu": cpu,
                "events": events,
                "relay_cpu": relayed,
            }
        },
    )
    for n, child in enumerate(children, 1):
        if not child.keys:
            continue
        figures = {
            "process": f"worker {n}",
            "pid": child.process.pid,
            "lines": len(child.keys),
            "keys": list(child.keys),
            "robots": sum(len(lines[k]) for k in child.keys),
            "weight": sum(cost.get(k, 0.0) for k in child.keys),
            "ready": child.ended.get("ready", began) - began,
            "job": child.ended.get("job", began) - began,
            "cpu": child.ended.get("cpu", 0.0),
        }
        log.debug(
            "fleet: worker %d (pid %d): %d line(s), %d robot(s), %.0f exchanges expected; "
            "ready %.2f s after the start, its share %.2f s; %.2f s of CPU",
            n,
            figures["pid"],
            figures["lines"],
            figures["robots"],
            figures["weight"],
            figures["ready"],
            figures["job"],
            figures["cpu"],
            extra={"fleet": figures},
        )


class _Child:
    """A worker process, started before it is told its share (:meth:`give`); its
    events go to ``watch`` from a thread of this process."""

    def __init__(self, task: Task, offset: float, watch: _Collect, watched: bool) -> None:
        self.watch = watch
        self.clock = task.clock
        self.keys: list[str] = []
        self.share: list[list[Path]] = []
        self.finished: set[str] = set()
        self.fatal: str | None = None
        self.ended: dict[str, float] = {}  # the worker's own figures, at its end
        self.events = 0
        self.relay_cpu = 0.0
        read_fd, self._write_fd = os.pipe()
        self._job: dict[str, object] = {
            "attempts": task.attempts,
            "lock_timeout": task.lock_timeout,
            "offset": offset,
            "watched": watched,
            "events": self._write_fd,
            "levels": _levels(),
        }
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-c", _WORKER],
                stdin=subprocess.PIPE,
                pass_fds=(self._write_fd,),
                start_new_session=True,  # a Ctrl-C on the terminal is this process's to pass on
            )
        finally:
            os.close(self._write_fd)
        self._events = os.fdopen(read_fd, "rb")
        self._reader = threading.Thread(target=self._read, name="fleet-worker", daemon=True)
        self._reader.start()

    def give(self, keys: list[str], share: list[list[Path]], threads: int) -> None:
        """Tell the worker its ``share`` (lines ``keys``, each its projects), to be read
        in ``threads`` threads; none: it ends at once."""
        self.keys, self.share = keys, share
        if not share:
            self.stop()
            return
        job = self._job | {
            "lines": [[str(p) for p in paths] for paths in share],
            "threads": threads,
        }
        try:
            assert self.process.stdin is not None
            self.process.stdin.write(json.dumps(job).encode() + b"\n")
            self.process.stdin.flush()
        except OSError:  # it has ended already: wait() fails its robots, naming how
            pass

    def _read(self) -> None:
        took = time.thread_time()
        with self._events:
            for raw in self._events:
                try:
                    event = json.loads(raw)
                except ValueError:
                    continue
                self.events += 1
                self._event(event)
        self.relay_cpu = time.thread_time() - took

    def _event(self, event: dict[str, Any]) -> None:
        kind = event.get("event")
        if kind == "started":
            self.watch.started(Path(event["path"]), event["name"])
        elif kind == "progress":
            self.watch.progress(Path(event["path"]), event["done"], event["total"])
        elif kind == "finished":
            outcome = RobotOutcome(**event["outcome"])
            self.finished.add(outcome.path)
            self.watch.finished(outcome)
        elif kind == "log":
            _emit(event)
        elif kind == "fatal":
            self.fatal = event["error"]
        elif kind == "ended":
            self.ended = {k: float(event[k]) for k in ("ready", "job", "cpu")}

    def stop(self) -> None:
        """Tell the worker to stop: every read at its next exchange."""
        try:
            assert self.process.stdin is not None
            self.process.stdin.close()
        except OSError:  # it has ended already
            pass

    def wait(self, *, stopped: bool = False) -> None:
        """Wait for the worker to end; fail each robot it did not finish, in the report
        and in the robot's history, unless it was ``stopped`` (a robot stopped is told
        of no more than in this process)."""
        self._reader.join()
        code = self.process.wait()
        if self.process.stdin and not self.process.stdin.closed:
            self.stop()
        if stopped:
            return
        for paths in self.share:
            for path in paths:
                if str(path) in self.finished:
                    continue
                why = self.fatal or (
                    f"killed by {_signal_name(-code)}" if code < 0 else f"exit status {code}"
                )
                self.watch.finished(
                    record_not_backed_up(
                        path,
                        SyncError(
                            f"the backup's worker process ended before this robot was "
                            f"backed up ({why}); its previous backup is kept"
                        ),
                        self.clock(),
                    )
                )


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def _levels() -> dict[str, int]:
    """The levels this process's loggers are set to ("" the root's), for a worker."""
    levels = {"": logging.getLogger().level}
    for name, logger in logging.Logger.manager.loggerDict.items():
        if isinstance(logger, logging.Logger) and logger.level:
            levels[name] = logger.level
    return levels


def _emit(event: dict[str, Any]) -> None:
    """A worker's log record, through this process's handlers, about its robot."""
    logger = logging.getLogger(event["name"])
    if not logger.isEnabledFor(event["levelno"]):
        return
    record = logging.makeLogRecord(
        {k: event[k] for k in ("name", "levelno", "levelname", "msg", "exc_text")}
    )
    with about(event["robot"]) if event["robot"] else nullcontext():
        logger.handle(record)
