"""What a person at a terminal sees while harlsync works, on stderr; nothing off one.

The command line's side of feedback (the library only reports ``progress(done,
total)`` and outcomes).  Progress is counted in *exchanges with the controller*:
one request and its reply, the unit every family's read advances by.

:class:`Feedback` is one robot's bar (pull, diff, plan, push) and the summary
line a command ends with.  :class:`BackupDisplay` is the live block of
``harlsync backup``, one line per robot being read, redrawn in place, with a
result line printed above it as each robot finishes::

    loader: ok, no change (3.2 s)                       <- printed once, scrolls up
    press: 41%|████▏     | 70/171 exchanges with the controller [00:02<00:03, 31.0/s]
    welder: connecting                                  <- the block, redrawn in place

Whatever stops them (the end, an error, Ctrl-C), :meth:`close` takes every bar
off the screen: nothing is left half drawn under the next line printed.  A line
printed while one is drawn (a warning the log gives, from any thread) goes above
it (:func:`above`, :class:`LogHandler`): the bar or block is taken off, the line
printed, the bar drawn again, so no remnant of it stays on the screen.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, Protocol, TextIO

from .robotlog import RobotFilter

if TYPE_CHECKING:
    from tqdm import tqdm

    from .sync.robotbackup import RobotOutcome

__all__ = [
    "UNIT",
    "BackupDisplay",
    "Feedback",
    "LogHandler",
    "above",
    "in_background",
    "is_terminal",
    "log_to_terminal",
]

#: The progress unit, as every bar and summary says it.
UNIT = "exchanges with the controller"
_BAR = "{l_bar}{bar}| {n_fmt}/{total_fmt} " + UNIT + " [{elapsed}<{remaining}, {rate_fmt}]"
#: Redraw the backup's block at most this often (progress comes per exchange).
_REDRAW = 0.1


def is_terminal(stream: TextIO | None = None) -> bool:
    """Whether ``stream`` (default stderr) is a terminal a person watches."""
    stream = stream if stream is not None else sys.stderr
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # closed or not a real stream
        return False


class _Live(Protocol):
    """What is drawn live at the bottom of stderr: a bar, the backup's block."""

    def hide(self) -> None: ...

    def show(self) -> None: ...


#: Held while stderr is written to around what is drawn live (by any thread).
_screen = threading.RLock()
_live: list[_Live] = []


@contextmanager
def above() -> Iterator[None]:
    """Print to stderr above what is drawn live: it is taken off the screen for the
    ``with`` block and drawn again after (nothing drawn: nothing to do)."""
    with _screen:
        for live in _live:
            live.hide()
        try:
            yield
        finally:
            for live in _live:
                live.show()


class LogHandler(logging.StreamHandler):  # type: ignore[type-arg]
    """The log's lines on stderr, each above what is drawn live (see :func:`above`)."""

    def emit(self, record: logging.LogRecord) -> None:
        with above():
            super().emit(record)


def log_to_terminal(verbose: int, quieted: Iterable[str] = ()) -> None:
    """harlsync's log on stderr, each line above what is drawn live and naming its
    robot (under backup): -v what it does, -vv the raw traffic; without either, only
    warnings on a terminal and errors under cron (nobody is watching).  The
    ``quieted`` loggers (the libraries a family uses, which may log their own ERROR
    lines above the one harlsync says of the same failure) show warnings with -vv,
    else nothing."""
    if verbose >= 2:
        level = logging.DEBUG
    elif verbose == 1:
        level = logging.INFO
    else:
        level = logging.WARNING if sys.stderr.isatty() else logging.ERROR
    logging.basicConfig(
        level=level,
        format="harlsync: %(levelname)s: %(robot)s%(message)s",
        handlers=[LogHandler()],
    )
    for handler in logging.getLogger().handlers:  # %(robot)s: which robot, under backup
        if not any(isinstance(f, RobotFilter) for f in handler.filters):
            handler.addFilter(RobotFilter())
    for name in quieted:
        logging.getLogger(name).setLevel(logging.WARNING if verbose >= 2 else logging.CRITICAL)


def in_background() -> bool:
    """Whether this process was started in the background of a terminal (``&``),
    where a read of standard input would stop it (SIGTTIN)."""
    try:
        return os.isatty(0) and os.tcgetpgrp(0) != os.getpgrp()
    except OSError:  # no controlling terminal: stdin is what it is
        return False


def seconds(elapsed: float) -> str:
    """``0.4 s``, ``12.3 s``, ``3 min 05 s``."""
    if elapsed < 60:
        return f"{elapsed:.1f} s"
    minutes, secs = divmod(round(elapsed), 60)
    return f"{minutes} min {secs:02d} s"


class Feedback:
    """One robot's progress bar on a terminal, and the line a command ends with.

    Call it as ``progress(done, total)``; :meth:`close` clears the bar (also when
    the command failed or was interrupted); :meth:`summary` prints one line, only
    on a terminal, with the time since the start and the exchanges counted.
    """

    def __init__(self, what: str) -> None:
        self.what = what
        self.started = time.monotonic()
        self.exchanges = 0
        self._bar: tqdm[NoReturn] | None = None
        self._drawn = False
        self._finished = False
        self._off_terminal = False  # stderr is no terminal: asked once, not per exchange

    def __call__(self, done: int, total: int) -> None:
        self.exchanges = done
        if self._finished or self._off_terminal:
            return
        with _screen:
            self._draw(done, total)

    def _draw(self, done: int, total: int) -> None:
        if self._bar is None:
            if not is_terminal():
                self._off_terminal = True
                return
            from tqdm import tqdm

            # Narrower than the terminal by the "^C" it echoes: a wrapped line could
            # not be cleared any more.
            width = _width_height(sys.stderr)[0] - len("^C") - 1
            self._drawn = True  # before: a ^C may stop tqdm() after it drew the bar
            self._bar = tqdm(
                total=total,
                desc=self.what,
                unit="",
                bar_format=_BAR,
                file=sys.stderr,
                leave=False,
                ncols=width,
            )
            _live.append(self)
        self._bar.total = total
        self._bar.update(done - self._bar.n)
        if done >= total:  # clear the line before anything else is printed (a plan, a prompt)
            self.close()

    def hide(self) -> None:
        if self._bar is not None:
            self._bar.clear()
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()

    def show(self) -> None:
        if self._bar is not None:
            self._bar.refresh()

    def close(self) -> None:
        with _screen:
            self._finished = True
            if self in _live:
                _live.remove(self)
            if self._bar is not None:
                self._bar.close()
                self._bar = None
            if self._drawn:
                self._drawn = False
                sys.stderr.write("\r\x1b[K")  # whatever is left, and a "^C" echoed after it
                sys.stderr.flush()

    def summary(self, robot: str, contents: str, tail: str = "") -> None:
        """``harlsync: diff cell-1: read CONTENTS in 12.3 s (1160 exchanges with the
        controller); no differences`` on a terminal; nothing off one (cron)."""
        self.close()
        if not is_terminal():
            return
        counted = f" ({self.exchanges} {UNIT})" if self.exchanges else ""
        elapsed = seconds(time.monotonic() - self.started)
        print(
            f"harlsync: {self.what} {robot}: read {contents} in {elapsed}{counted}{tail}",
            file=sys.stderr,
            flush=True,
        )


def _width_height(stream: TextIO) -> tuple[int, int]:
    try:
        size = os.get_terminal_size(stream.fileno())
        return size.columns, size.lines
    except (OSError, ValueError, AttributeError):
        return 80, 24


class _Row:
    def __init__(self, name: str) -> None:
        self.name = name
        self.started = time.monotonic()
        self.done = 0
        self.total = 0


class BackupDisplay:
    """The live block of ``harlsync backup`` on a terminal (see the module's text):
    a :class:`~harlsync.sync.backup.BackupWatch`.

    Its methods are called from the backup's worker threads, one per line; off a
    terminal they do nothing.  The block is never taller than the terminal: the
    robots beyond it are counted on its last line.
    """

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.live = is_terminal(self.stream)
        self._rows: dict[Path, _Row] = {}
        self._drawn = 0
        self._last_draw = 0.0
        self._lock = threading.RLock()
        self._closed = False
        if self.live:
            with _screen:
                _live.append(self)

    # --- what the backup reports -------------------------------------------------------

    def started(self, path: Path, name: str) -> None:
        with self._lock:
            self._rows[path] = _Row(name)
            self._redraw(force=True)

    def progress(self, path: Path, done: int, total: int) -> None:
        with self._lock:
            row = self._rows.get(path)
            if row is None:
                return
            if done < row.done:  # a new attempt starts over
                row.started = time.monotonic()
            row.done, row.total = done, total
            self._redraw()

    def finished(self, outcome: RobotOutcome) -> None:
        """The robot is done: its block line goes, its result line is printed for good."""
        with self._lock:
            self._rows.pop(Path(outcome.path), None)
            if not self.live or self._closed:
                return
            self._clear()
            self.stream.write(outcome.line() + "\n")
            self._redraw(force=True)

    def close(self) -> None:
        """Take the block off the screen; later reports are ignored."""
        with _screen, self._lock:
            if self in _live:
                _live.remove(self)
            if self.live and not self._closed:
                self._clear()
            self._closed = True

    def hide(self) -> None:
        with self._lock:
            if self.live and not self._closed:
                self._clear()

    def show(self) -> None:
        with self._lock:
            self._redraw(force=True)

    # --- drawing -----------------------------------------------------------------------

    def _clear(self) -> None:
        if self._drawn:
            # to the start of the block's first line, then erase to the end of the screen
            self.stream.write(f"\x1b[{self._drawn}F\x1b[J")
            self._drawn = 0
        self.stream.flush()

    def _redraw(self, *, force: bool = False) -> None:
        if not self.live or self._closed:
            return
        now = time.monotonic()
        if not force and now - self._last_draw < _REDRAW:
            return
        self._last_draw = now
        width, height = _width_height(self.stream)
        rows = list(self._rows.values())
        room = max(1, height - 2)
        shown = rows if len(rows) <= room else rows[: room - 1]
        lines = [self._line(row, now, width) for row in shown]
        if len(shown) < len(rows):
            lines.append(f"... and {len(rows) - len(shown)} more robot(s) being read"[: width - 1])
        self._clear()
        self.stream.write("".join(line + "\n" for line in lines))
        self.stream.flush()
        self._drawn = len(lines)

    @staticmethod
    def _line(row: _Row, now: float, width: int) -> str:
        if not row.total:
            return f"{row.name}: connecting"[: width - 1]
        from tqdm import tqdm

        return str(
            tqdm.format_meter(
                row.done,
                row.total,
                now - row.started,
                ncols=width - 1,
                prefix=row.name,
                unit="",
                bar_format=_BAR,
            )
        )
