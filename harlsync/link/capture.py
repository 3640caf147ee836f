"""A line's traffic recorded as pyserial's ``spy://`` hex dump, for ``replay://``.

pyserial's own ``spy://`` port wraps a device path only; :func:`recording` records
any port the link opens (a device, ``socket://``, ``sim://``) in the same format
(:class:`serial.urlhandler.protocol_spy.FormatHexdump`), which
:mod:`harlsync.sim.replay` reads back: each ``write()`` of the link a TX chunk,
each ``read()`` that returned bytes an RX chunk::

    with recording(Path("probe.txt")):
        ...   # every port opened meanwhile is recorded, one session after another
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from serial.urlhandler.protocol_spy import FormatHexdump

__all__ = ["Spied", "recording", "spied"]

_lock = threading.Lock()
_dump: list[FormatHexdump] = []


@contextmanager
def recording(path: Path) -> Iterator[None]:
    """Record every port the link opens until the block ends into ``path`` (created
    or emptied).  Raises OSError when the file cannot be written."""
    with path.open("w", encoding="ascii") as output:
        output.write("# harlsync capture (pyserial spy:// hex dump); replays through replay://\n")
        dump = FormatHexdump(output, False)
        with _lock:
            _dump.append(dump)
        try:
            yield
        finally:
            with _lock:
                _dump.remove(dump)


class Spied:
    """An open port whose reads and writes go to a hex dump as well."""

    def __init__(self, port: Any, dump: FormatHexdump) -> None:
        self._port = port
        self._dump = dump

    @property
    def in_waiting(self) -> int:
        waiting: int = self._port.in_waiting
        return waiting

    def read(self, size: int = 1) -> bytes:
        data: bytes = self._port.read(size)
        if data:
            self._dump.rx(data)
        return data

    def write(self, data: bytes, /) -> int | None:
        self._dump.tx(data)
        written: int | None = self._port.write(data)
        return written

    def reset_input_buffer(self) -> None:
        self._dump.control("Q-RX", "reset_input_buffer")
        self._port.reset_input_buffer()

    def close(self) -> None:
        self._port.close()


def spied(port: Any) -> Any:
    """``port`` recorded when :func:`recording` is in force, else ``port`` itself."""
    with _lock:
        dump = _dump[-1] if _dump else None
    return port if dump is None else Spied(port, dump)
