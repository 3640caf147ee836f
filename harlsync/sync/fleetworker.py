"""A fleet's worker process: it reads the share its standard input names, a
thread a line, and tells what happens as JSON lines on a pipe of its own (see
:mod:`harlsync.sync.fleet`, which starts it as
``python -c 'from harlsync.sync.fleetworker import worker; worker()'``).
"""

from __future__ import annotations

import json
import logging
import os
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import IO

from ..robotlog import current
from .fleettask import Task
from .robotbackup import RobotOutcome, Stopped

__all__ = ["worker"]

log = logging.getLogger(__name__)

#: A worker tells a robot's progress at most this often (a live display redraws
#: about as often; a night's 100,000 exchanges need not cross the pipe).
_PROGRESS_EVERY = 0.1


class _Sender:
    """A worker's watch and log handler: each event one JSON line on the pipe."""

    def __init__(self, stream: IO[bytes], watched: bool) -> None:
        self.stream = stream
        self.watched = watched
        self._lock = threading.Lock()
        self._told: dict[Path, tuple[float, int]] = {}

    def send(self, **event: object) -> None:
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
    happens on its events pipe, stop when its standard input ends (before its
    share comes: this process had none for it, or is gone)."""
    ready = time.monotonic()  # imports done: a worker is started before its share is known
    given = sys.stdin.buffer.readline()
    if not given:
        return
    job = json.loads(given)
    told = time.monotonic()
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
    finally:  # its own figures, for the debug log (bench/fleet.py)
        try:
            sender.send(event="ended", ready=ready, job=told, cpu=time.process_time())
        except OSError:  # this process is gone
            pass
