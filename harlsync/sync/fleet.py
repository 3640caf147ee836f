"""The fleet: a backup's lines spread over worker processes, one per core.

A line spends nearly all its time waiting for the wire, so one process reads many
lines, a thread each; but threads share one interpreter, and at a hundred lines
and more one process needs its whole core (docs/BENCHMARKS.md, issue 15).  So
:func:`read_lines` gives each of ``workers`` shares of the lines to a process: this
one reads the first share in its own threads (so one worker costs no process at
all), and each other share is read by a worker process started for the run
(``python -c 'from harlsync.sync.fleet import worker; worker()'``), a thread a line
there too.  Every robot of a line is in one share, read one after the other; the
line lock (:mod:`harlsync.link.lock`) holds across processes all the same.

A worker is told its share as one JSON line on its standard input and tells what
happens (a robot started, its progress, its outcome, its log lines) as JSON lines
on a pipe of its own; this process hands them to the run's watch and log.  A line
whose port only this process can open (a simulator registered in it, ``sim://@name``;
``loop://``) is read here.

Signals.  A worker runs in a session of its own, so a Ctrl-C typed on the terminal
reaches this process only: on KeyboardInterrupt it tells every worker to stop (or
a worker sees its standard input end, as when this process is killed), and each
robot's read stops at its next exchange, leaving its previous backup as it was,
as with one process; this process waits for the workers to end (their locks
released) before the interruption goes on.  A worker that ends without finishing
its share (killed, out of memory) fails the robots it had not finished, naming
that; the others and the report go on.
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
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import asdict
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import IO, Any

from ..errors import HarlsyncError, SyncError
from ..link import lock_key
from ..project import load_robot
from ..robotlog import about, current
from .backup import BackupWatch, RobotOutcome, Stopped, backup_one, not_backed_up

__all__ = ["default_workers", "in_process", "plan", "read_lines", "worker"]

log = logging.getLogger(__name__)

#: What a worker process runs.
_WORKER = "from harlsync.sync.fleet import worker; worker()"
#: Whether a run can have worker processes (see :func:`default_workers`).
_SPREADS = os.name == "posix"
#: A worker tells a robot's progress at most this often (a live display redraws
#: about as often; a night's 100,000 exchanges need not cross the pipe).
_PROGRESS_EVERY = 0.1


def default_workers() -> int:
    """One per core this process may run on (on Windows 1: a worker is handed its
    events pipe by descriptor, which only POSIX passes)."""
    if not _SPREADS:
        return 1
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def in_process(port: str) -> bool:
    """Whether only this process can open ``port``: a peer registered in it
    (``sim://@name``, :class:`harlsync.sim.protocol_sim.Registry`) or ``loop://``."""
    return "://@" in port or lock_key(port) is None


def plan(lines: dict[str, list[Path]], workers: int, here: Iterable[str] = ()) -> list[list[str]]:
    """The lines (keys of ``lines``) of each of at most ``workers`` shares, the first
    read in this process: the lines ``here`` in the first, then each line, the most
    robots first, to the share with the fewest robots so far (ties: the first)."""
    here = set(here)
    count = max(1, min(workers, len(lines)))
    shares: list[list[str]] = [[] for _ in range(count)]
    robots = [0] * count
    for line, paths in lines.items():
        if line in here:
            shares[0].append(line)
            robots[0] += len(paths)
    for line in sorted((k for k in lines if k not in here), key=lambda k: -len(lines[k])):
        least = robots.index(min(robots))
        shares[least].append(line)
        robots[least] += len(lines[line])
    return [share for n, share in enumerate(shares) if share or n == 0]


class Task:
    """What every robot's backup of one run needs, here or in a worker."""

    def __init__(self, attempts: int, lock_timeout: float, clock: Callable[[], datetime]) -> None:
        self.attempts = attempts
        self.lock_timeout = lock_timeout
        self.clock = clock

    def line(self, paths: list[Path], watch: BackupWatch, stop: threading.Event) -> None:
        """Back up the robots of one line in turn (each tells ``watch`` its outcome)."""
        for path in paths:
            if stop.is_set():
                return
            backup_one(path, self.attempts, self.lock_timeout, self.clock, watch, stop)


def _threads(jobs: int | None, shares: list[list[str]]) -> list[int]:
    """Threads per share: a line each, at most ``jobs`` lines at once in all."""
    if jobs is None:
        return [max(1, len(share)) for share in shares]
    base, extra = divmod(max(1, jobs), len(shares))
    return [max(1, min(len(share), base + (n < extra))) for n, share in enumerate(shares)]


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
    lines: dict[str, list[Path]],
    task: Task,
    *,
    workers: int,
    jobs: int | None,
    watch: BackupWatch,
    watched: bool,
) -> list[RobotOutcome]:
    """Back up every robot of ``lines`` (line -> its projects, in order) in at most
    ``workers`` processes, at most ``jobs`` lines at once (default: all); the
    outcomes, in no order.  ``watched``: whether ``watch`` shows progress (a worker
    sends it only then).  Raises KeyboardInterrupt when interrupted, once every
    read has stopped."""
    here = [line for line, paths in lines.items() if any(_local(p) for p in paths)]
    workers = workers if _SPREADS else 1
    shares = plan(lines, workers if jobs is None else min(workers, jobs), here)
    threads = _threads(jobs, shares)
    collect = _Collect(watch)
    stop = threading.Event()
    offset = (task.clock() - datetime.now(timezone.utc)).total_seconds()
    children = [
        _Child([lines[k] for k in share], task, offset, count, collect, watched)
        for share, count in zip(shares[1:], threads[1:])
    ]
    with ThreadPoolExecutor(max_workers=threads[0]) as pool:
        try:
            for done in [pool.submit(task.line, lines[k], collect, stop) for k in shares[0]]:
                done.result()
            for child in children:
                child.wait()
        except BaseException:  # Ctrl-C: every read stops at its next exchange, none starts
            stop.set()
            for child in children:
                child.stop()
            pool.shutdown(wait=True, cancel_futures=True)
            for child in children:
                child.wait(stopped=True)
            raise
    return collect.outcomes


def _local(path: Path) -> bool:
    """Whether the project's robot can only be read here (or not at all: its
    robot.yaml is unreadable, which this process says as well as any)."""
    try:
        return in_process(load_robot(path).port)
    except HarlsyncError:
        return True


class _Child:
    """A worker process reading ``share`` (lines, each its projects); its events go to
    ``watch`` from a thread of this process."""

    def __init__(
        self,
        share: list[list[Path]],
        task: Task,
        offset: float,
        threads: int,
        watch: _Collect,
        watched: bool,
    ) -> None:
        self.share = share
        self.watch = watch
        read_fd, write_fd = os.pipe()
        job = {
            "lines": [[str(p) for p in paths] for paths in share],
            "attempts": task.attempts,
            "lock_timeout": task.lock_timeout,
            "offset": offset,
            "threads": threads,
            "watched": watched,
            "events": write_fd,
            "levels": _levels(),
        }
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-c", _WORKER],
                stdin=subprocess.PIPE,
                pass_fds=(write_fd,),
                start_new_session=True,  # a Ctrl-C on the terminal is this process's to pass on
            )
        finally:
            os.close(write_fd)
        self._events = os.fdopen(read_fd, "rb")
        assert self.process.stdin is not None
        self.process.stdin.write(json.dumps(job).encode() + b"\n")
        self.process.stdin.flush()
        self.finished: set[str] = set()
        self.fatal: str | None = None
        self._reader = threading.Thread(target=self._read, name="fleet-worker", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        with self._events:
            for raw in self._events:
                try:
                    event = json.loads(raw)
                except ValueError:
                    continue
                self._event(event)

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

    def stop(self) -> None:
        """Tell the worker to stop: every read at its next exchange."""
        try:
            assert self.process.stdin is not None
            self.process.stdin.close()
        except OSError:  # it has ended already
            pass

    def wait(self, *, stopped: bool = False) -> None:
        """Wait for the worker to end; fail each robot it did not finish, unless it
        was ``stopped`` (a robot stopped is told of no more than in this process)."""
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
                    not_backed_up(
                        path,
                        SyncError(
                            f"the backup's worker process ended before this robot was "
                            f"backed up ({why}); its previous backup is kept"
                        ),
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


# --- in the worker process ----------------------------------------------------------


class _Sender:
    """A worker's watch and log handler: each event one JSON line on the pipe."""

    def __init__(self, stream: IO[bytes], watched: bool) -> None:
        self.stream = stream
        self.watched = watched
        self._lock = threading.Lock()
        self._told: dict[Path, tuple[float, int]] = {}

    def send(self, **event: Any) -> None:
        data = json.dumps(event, default=str).encode() + b"\n"
        with self._lock:
            self.stream.write(data)
            self.stream.flush()

    def started(self, path: Path, name: str) -> None:
        self.send(event="started", path=str(path), name=name)

    def progress(self, path: Path, done: int, total: int) -> None:
        if not self.watched:
            return
        now = time.monotonic()
        when, last = self._told.get(path, (0.0, -1))
        if done == total or done < last or now - when >= _PROGRESS_EVERY:
            self._told[path] = (now, done)
            self.send(event="progress", path=str(path), done=done, total=total)

    def finished(self, outcome: RobotOutcome) -> None:
        self.send(event="finished", outcome=asdict(outcome))


class _Forward(logging.Handler):
    def __init__(self, sender: _Sender) -> None:
        super().__init__()
        self.sender = sender

    def emit(self, record: logging.LogRecord) -> None:
        try:
            exc_text = record.exc_text
            if record.exc_info and not exc_text:
                exc_text = logging.Formatter().formatException(record.exc_info)
            self.sender.send(
                event="log",
                name=record.name,
                levelno=record.levelno,
                levelname=record.levelname,
                msg=record.getMessage(),
                exc_text=exc_text,
                robot=current(),
            )
        except Exception:  # noqa: BLE001  a log line must never cost a robot
            self.handleError(record)


def worker() -> None:
    """A worker process's main: read the share its standard input names, tell what
    happens on its events pipe, stop when its standard input ends."""
    job = json.loads(sys.stdin.buffer.readline())
    sender = _Sender(os.fdopen(job["events"], "wb"), job["watched"])
    root = logging.getLogger()
    for name, level in job["levels"].items():
        logging.getLogger(name or None).setLevel(level)
    root.addHandler(_Forward(sender))
    stop = threading.Event()

    def watch_input() -> None:
        # Nothing more is sent: the end is the word to stop.  Unbuffered: a daemon
        # thread must hold no lock of sys.stdin's when the interpreter exits.
        while os.read(0, 4096):
            pass
        stop.set()

    threading.Thread(target=watch_input, name="stop", daemon=True).start()
    offset = timedelta(seconds=job["offset"])
    task = Task(job["attempts"], job["lock_timeout"], lambda: datetime.now(timezone.utc) + offset)
    try:
        with ThreadPoolExecutor(max_workers=job["threads"]) as pool:
            for done in [
                pool.submit(task.line, [Path(p) for p in paths], sender, stop)
                for paths in job["lines"]
            ]:
                done.result()
    except Stopped:
        sys.exit(0)
    except Exception as exc:  # a bug: the robots not finished fail, naming it
        log.debug("worker failed", exc_info=True)
        sender.send(event="fatal", error=f"unexpected {type(exc).__name__}: {exc}")
        sys.exit(1)
