"""Test helper: run harlsync on a real terminal and read what a person would see.

The command runs on a pseudo-terminal that is its controlling terminal (so a ^C
typed on it is a real SIGINT, sent by the kernel), and everything it writes is
played through pyte, a VT100 emulator: the screen at the end is what the person
sees, after every carriage return, cursor move and erase.
"""

from __future__ import annotations

import fcntl
import os
import select
import struct
import subprocess
import sys
import termios
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pyte

COLUMNS, LINES = 200, 30
DEADLINE = 60.0
HARLSYNC = [sys.executable, "-m", "harlsync"]
#: Exec ARGV[1:] with standard input (the pty) as its controlling terminal.
_ON_THIS_TERMINAL = (
    "import fcntl, os, sys, termios; fcntl.ioctl(0, termios.TIOCSCTTY, 0); "
    "os.execvp(sys.argv[1], sys.argv[1:])"
)


@dataclass
class Seen:
    code: int
    #: the screen's non-blank lines at the end, as shown
    screen: list[str]
    #: every byte written, for messages
    raw: bytes

    @property
    def text(self) -> str:
        return "\n".join(self.screen)


def run(
    *args: str,
    cwd: Path | None = None,
    interrupt_when: str | Callable[[list[str]], bool] | None = None,
) -> Seen:
    """``harlsync ARGS`` on a terminal; with ``interrupt_when``, ^C is typed as soon as
    that text is on the screen (or as soon as it holds for the screen's lines)."""
    controller, terminal = os.openpty()
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", LINES, COLUMNS, 0, 0))
    process = subprocess.Popen(
        [sys.executable, "-c", _ON_THIS_TERMINAL, *HARLSYNC, *args],
        stdin=terminal,
        stdout=terminal,
        stderr=terminal,
        cwd=cwd,
        start_new_session=True,
    )
    os.close(terminal)
    screen = pyte.Screen(COLUMNS, LINES)
    stream = pyte.ByteStream(screen)
    raw = bytearray()
    end = time.monotonic() + DEADLINE
    try:
        while time.monotonic() < end:
            ready, _, _ = select.select([controller], [], [], 0.05)
            if not ready:
                if process.poll() is not None:
                    break
                continue
            try:
                data = os.read(controller, 65536)
            except OSError:  # the other side closed: it has exited
                break
            if not data:
                break
            raw += data
            stream.feed(data)
            if interrupt_when and _holds(interrupt_when, screen.display):
                os.write(controller, b"\x03")
                interrupt_when = None
        else:
            raise AssertionError(f"harlsync {' '.join(args)} did not end: {bytes(raw)[-500:]!r}")
        code = process.wait(timeout=DEADLINE)
    finally:
        process.kill()
        os.close(controller)
    return Seen(code, [line.rstrip() for line in screen.display if line.strip()], bytes(raw))


def _holds(when: str | Callable[[list[str]], bool], lines: list[str]) -> bool:
    if isinstance(when, str):
        return any(when in line for line in lines)
    return when(lines)
