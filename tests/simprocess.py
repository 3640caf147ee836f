"""Test helper: ``harlsync sim`` as a subprocess, controlled through its standard input."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def harlsync_sim(
    *args: str,
    lines: int = 3,
) -> Iterator[tuple[subprocess.Popen[str], dict[str, str]]]:
    """Run ``harlsync sim ARGS`` serving a pty and TCP; yield the process and the
    ``lines`` lines it prints first, by name (``pty``, ``tcp``, ``stations``; an
    Epson simulator has no pty line).

    Leaving the block ends its input, and it must then exit 0.
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "harlsync", "sim", *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdin is not None and proc.stdout is not None
    try:
        yield proc, dict(proc.stdout.readline().strip().split(": ", 1) for _ in range(lines))
        proc.stdin.close()
        assert proc.wait(timeout=10) == 0
    finally:
        proc.kill()
