"""Recorded serial traffic played back as the controller: spy:// captures as fixtures.

pyserial's ``spy://`` port (``spy:///dev/ttyUSB0?file=capture.txt``) writes what
the client sends (TX) and reads (RX) as a hex dump, one line per 16 bytes::

    000000.000 Q-RX reset_input_buffer                     control line: ignored
    000000.012 TX   0000  02 31 20 52 45 41 44 03                           .1 READ.
    000000.041 RX   0000  02 31 20 35 2E 30 30 03  09                       .1 5.00..
    ^seconds   ^dir ^offset in the chunk                                    ^ASCII, checked
                          <------ 16 hex bytes, 49 columns ------------->

Each ``write()`` or ``read()`` of the client is one chunk; a chunk longer than 16
bytes goes on over lines with offsets 0010, 0020 ...  :func:`parse_spy_log` turns
the text back into :class:`Chunk` s.  Blank lines and lines that start with ``#``
(notes a site adds by hand) are skipped; anything else that is not pyserial's
format is an error naming the line.

:class:`Replay` plays the controller's side of a capture, sans I/O like
:meth:`Simulator.receive <harlsync.sim.Simulator.receive>`: ``receive(bytes the
client wrote)`` checks them against the next recorded TX bytes and returns the
RX chunks recorded after that request as ``(delay, bytes)``, each delayed by its
recorded time after the request (or at once, ``timing=False``).  The client
sees the same replies, fragments, noise, late replies and silences as the
recorded client did.  Anything else it sends is a :class:`ReplayMismatch`.
The ``replay://`` port (:mod:`harlsync.sim.protocol_replay`) serves it to any
harlsync command.  The bytes are any family's: the family's decoder (the
default family's unless given) only names requests in messages and finds the
next one for :meth:`Replay.next_request`.

Replay follows the capture, not the protocol: a client that sends its requests
in another order, or retries differently, does not match the capture.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from ..errors import ProtocolError
from .device import Decoder, RequestFrame
from .family import line_family

__all__ = ["Chunk", "Replay", "ReplayMismatch", "load_spy_log", "parse_spy_log"]

Direction = Literal["TX", "RX"]

_LINE_RE = re.compile(r"(?P<at>\d+\.\d+) (?P<label>\S+) *(?P<rest>.*)")
_DATA_RE = re.compile(r"(?P<offset>[0-9A-F]{4,})  (?P<row>.*)")
_ANSI_RE = re.compile(r"\x1b\[[0-9;]*m")
_HEX_COLUMNS = 16 * 3 + 1  # "XX " per byte and one more space after the eighth
_BYTES_PER_LINE = 16


@dataclass(frozen=True)
class Chunk:
    """What one ``write()`` (TX) or ``read()`` (RX) of the recorded client moved."""

    direction: Direction
    data: bytes
    #: seconds since the capture started
    at: float


def _ascii(data: bytes) -> str:
    return "".join(chr(b) if 0x20 <= b < 0x7F else "." for b in data)


def parse_spy_log(text: str | Iterable[str]) -> list[Chunk]:
    """The TX and RX chunks of a pyserial ``spy://`` hex dump, in order.

    Raises ValueError naming the line for text that is not a spy:// hex dump.
    """
    lines = text.splitlines() if isinstance(text, str) else text
    chunks: list[Chunk] = []
    current: tuple[Direction, bytearray, float] | None = None  # the chunk being read

    def close() -> None:
        nonlocal current
        if current is not None:
            chunks.append(Chunk(current[0], bytes(current[1]), current[2]))
            current = None

    for number, raw in enumerate(lines, 1):
        line = _ANSI_RE.sub("", raw).rstrip("\r\n")
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        match = _LINE_RE.fullmatch(line)
        if match is None:
            raise ValueError(f"line {number}: not a spy:// hex dump line: {raw!r}")
        label, rest = match["label"], match["rest"]
        if label not in ("TX", "RX"):
            continue  # control lines: flush, reset_input_buffer, RTS ...
        direction: Direction = "TX" if label == "TX" else "RX"
        if rest.strip() == "<empty>":  # a read that returned nothing (spy's "all" option)
            continue
        data_match = _DATA_RE.fullmatch(rest)
        if data_match is None:
            raise ValueError(f"line {number}: no offset and hex bytes after {label}: {raw!r}")
        data = _row_bytes(data_match["row"], number)
        offset = int(data_match["offset"], 16)
        if offset == 0:
            close()
            current = (direction, bytearray(), float(match["at"]))
        elif current is None or current[0] != direction or len(current[1]) != offset:
            raise ValueError(f"line {number}: offset {offset:04X} does not continue a chunk")
        assert current is not None
        current[1].extend(data)
        if len(data) < _BYTES_PER_LINE:
            close()  # a short line ends its chunk
    close()
    return chunks


def _row_bytes(row: str, number: int) -> bytes:
    """The bytes of one dump line's hex column, checked against its ASCII column."""
    tokens = row[:_HEX_COLUMNS].split()
    if not 1 <= len(tokens) <= _BYTES_PER_LINE or not all(
        re.fullmatch(r"[0-9A-F]{2}", t) for t in tokens
    ):
        raise ValueError(f"line {number}: bad hex bytes {row[:_HEX_COLUMNS].strip()!r}")
    data = bytes.fromhex("".join(tokens))
    shown = row[_HEX_COLUMNS + 1 :]
    # An editor may strip trailing blanks, which are also what a space byte shows as.
    if shown.rstrip() != _ascii(data).rstrip():
        raise ValueError(
            f"line {number}: the ASCII column {shown.rstrip()!r} does not match the hex bytes"
        )
    return data


def load_spy_log(path: str | os.PathLike[str]) -> list[Chunk]:
    """:func:`parse_spy_log` of a file.  Raises OSError or ValueError."""
    with open(path, encoding="ascii", errors="replace") as file:
        try:
            return parse_spy_log(file)
        except ValueError as exc:
            raise ValueError(f"{os.fspath(path)}: {exc}") from None


class ReplayMismatch(Exception):
    """The client sent something other than what the capture holds next."""


class Replay:
    """The controller's side of a capture, played back.

    ``timing`` delays each recorded reply chunk by the time it came after its
    request in the capture, so timeouts, retries and late replies happen as they
    did; without it every reply is due at once.  ``decoder`` makes a decoder for
    the capture's family (default: the default family's).
    """

    def __init__(
        self,
        chunks: Sequence[Chunk],
        *,
        timing: bool = True,
        decoder: Callable[[], Decoder[RequestFrame]] | None = None,
    ) -> None:
        self.chunks = list(chunks)
        self.timing = timing
        self.new_decoder = decoder or line_family(None).decoder
        #: the first error; once set, every further write fails
        self.mismatch: ReplayMismatch | None = None
        self._next = 0  # the next chunk to play
        self._matched = 0  # bytes of chunks[_next] (a TX) the client has already sent
        self._requests = 0  # TX chunks the client has sent in full

    @property
    def done(self) -> bool:
        """Whether the client has sent every recorded request (and got every reply)."""
        return self._next >= len(self.chunks)

    def start(self) -> list[tuple[float, bytes]]:
        """The RX chunks recorded before the first request (line noise), as (delay, bytes)."""
        return self._replies(0.0)

    def receive(
        self, data: bytes, decoder: Decoder[Any] | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        """Take bytes from the client; return the recorded reply chunks as (delay, bytes).

        ``decoder`` is ignored: it is there so that a replay can stand where a
        :class:`~harlsync.sim.Simulator` does.  Raises :class:`ReplayMismatch`
        when ``data`` is not what the capture holds next.
        """
        if self.mismatch is not None:
            raise self.mismatch
        out = self.start()  # nothing, unless start() was not called
        data = bytes(data)
        while data:
            if self.done:
                self._fail(f"the capture ends here, but the client sent {self._show(data)}")
            chunk = self.chunks[self._next]  # a TX: the RX after each one are played
            want = chunk.data[self._matched :]
            take = min(len(data), len(want))
            if data[:take] != want[:take]:
                self._fail(
                    f"request {self._requests + 1} of the capture (at {chunk.at:.3f} s) is "
                    f"{self._show(chunk.data)}, but the client sent "
                    f"{self._show(chunk.data[: self._matched] + data)}"
                )
            data = data[take:]
            self._matched += take
            if self._matched == len(chunk.data):
                self._next += 1
                self._matched = 0
                self._requests += 1
                out += self._replies(chunk.at)
        return out

    def _replies(self, sent_at: float) -> list[tuple[float, bytes]]:
        out = []
        while not self.done and self.chunks[self._next].direction == "RX":
            chunk = self.chunks[self._next]
            delay = max(0.0, chunk.at - sent_at) if self.timing else 0.0
            out.append((delay, chunk.data))
            self._next += 1
        return out

    def _fail(self, message: str) -> None:
        self.mismatch = ReplayMismatch(f"replay: {message}")
        raise self.mismatch

    def next_request(self) -> RequestFrame | None:
        """The next request frame of the capture that the client has not sent, or None.

        Raises :class:`~harlsync.errors.ProtocolError` when the capture's next TX
        bytes are not a valid frame.
        """
        decoder = self.new_decoder()
        skip = self._matched
        for chunk in self.chunks[self._next :]:
            if chunk.direction != "TX":
                continue
            decoder.feed(chunk.data[skip:])
            skip = 0
            frame = decoder.next_frame()
            if frame is not None:
                return frame
        if decoder.pending:
            raise ProtocolError("the capture ends inside a request")
        return None

    def _show(self, data: bytes) -> str:
        """A request as its frame's text (station and payload) when it is one valid
        frame, else as hex."""
        decoder = self.new_decoder()
        decoder.feed(data)
        try:
            frame = decoder.next_frame()
        except ProtocolError:
            frame = None
        if frame is not None and not decoder.pending and not decoder.dropped:
            return repr(f"{frame.station} {frame.payload}")
        return data.hex(" ").upper() or "nothing"
