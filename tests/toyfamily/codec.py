"""The toy family's wire format, sans-I/O: one ASCII line per frame.

::

    @ SS SP payload SP * CC LF        SS: station, 2 decimal digits
    |  |     |          |             CC: sum of the bytes from '@' to SP before '*',
    '@' '07' 'R 3'      '*' '5A'          mod 256, 2 hex digits

Requests: ``R n`` (read slot n), ``W n v`` (write slot n), ``S`` (status),
``V`` (version).  Replies: ``= n v``, ``OK``, ``IDLE`` / ``RUN``, ``TOY x.y``,
or ``ERR code``.  Bytes before an ``@`` are noise; a line with a bad checksum
is a ProtocolError, after it is consumed.
"""

from __future__ import annotations

from dataclasses import dataclass

from harlsync.errors import FrameError, ProtocolError, ReplyError
from harlsync.settings import SerialSettings

SLOTS = 16
MAX_VALUE = 9999


@dataclass(frozen=True)
class Frame:
    station: int
    payload: str


def _sum(body: bytes) -> int:
    return sum(body) % 256


def encode(station: int, payload: str) -> bytes:
    if not 0 <= station <= 99:
        raise ValueError(f"station {station} is out of range (0-99)")
    body = f"@{station:02d} {payload} ".encode("ascii")
    return body + f"*{_sum(body):02X}\n".encode("ascii")


def corrupt(frame: bytes) -> bytes:
    """``frame`` with a wrong checksum."""
    head, _, tail = frame.rpartition(b"*")
    wrong = (int(tail[:2], 16) + 1) % 256
    return head + b"*" + f"{wrong:02X}".encode() + tail[2:]


class Decoder:
    def __init__(self) -> None:
        self._buf = bytearray()
        self._dropped = 0

    def feed(self, data: bytes) -> None:
        self._buf += data

    @property
    def pending(self) -> int:
        return len(self._buf)

    @property
    def dropped(self) -> int:
        return self._dropped

    def clear(self) -> None:
        self._dropped += len(self._buf)
        self._buf.clear()

    def next_frame(self) -> Frame | None:
        start = self._buf.find(b"@")
        if start < 0:
            self._dropped += len(self._buf)
            self._buf.clear()
            return None
        if start:
            self._dropped += start
            del self._buf[:start]
        end = self._buf.find(b"\n")
        if end < 0:
            return None
        line = bytes(self._buf[: end + 1])
        del self._buf[: end + 1]
        body, star, tail = line.rpartition(b"*")
        if not star or len(tail) != 3 or len(body) < 5:
            raise FrameError(f"not a toy frame: {line!r}")
        try:
            check = int(tail[:2], 16)
            station = int(body[1:3])
            text = body[4:-1].decode("ascii")
        except ValueError:
            raise FrameError(f"not a toy frame: {line!r}") from None
        if check != _sum(body):
            raise ProtocolError(f"bad checksum in {line!r}")
        return Frame(station, text)


@dataclass(frozen=True)
class Request:
    """One command and how its reply reads: ``decode`` gives the value, or raises
    ReplyError for a frame that does not answer it."""

    payload: str
    is_write: bool = False
    volatile: bool = False

    def encode(self, station: int) -> bytes:
        return encode(station, self.payload)

    def decode(self, frame: Frame) -> str:
        reply = frame.payload
        verb = self.payload.split()[0]
        if reply.startswith("ERR "):
            return reply
        starts: dict[str, str | tuple[str, ...]] = {
            "R": "= ",
            "W": "OK",
            "S": ("IDLE", "RUN"),
            "V": "TOY ",
        }
        expected = starts[verb]
        if not reply.startswith(expected):
            raise ReplyError(f"{reply!r} does not answer {self.payload!r}")
        if verb == "R" and reply.split()[1] != self.payload.split()[1]:
            raise ReplyError(f"{reply!r} is another slot's")
        return reply


def read_slot(n: int) -> Request:
    return Request(f"R {n}")


def write_slot(n: int, value: int) -> Request:
    """The only write the toy has: a slot in range, a value in range."""
    if not 0 <= n < SLOTS or not 0 <= value <= MAX_VALUE:
        raise ValueError(f"slot {n} = {value}: out of range")
    return Request(f"W {n} {value}", is_write=True)


STATUS = Request("S", volatile=True)
VERSION = Request("V")


class Codec:
    settings = SerialSettings(timeout=0.5, retries=1)
    reply_gap = 0.0

    def decoder(self) -> Decoder:
        return Decoder()

    def no_reply_hint(self, station: int) -> str:
        return "check the toy's cable and station"

    def station_text(self, station: int) -> str:
        return f"{station:02d}"

    def reply_timeout(self, request: object, settings: SerialSettings) -> float:
        return settings.timeout


CODEC = Codec()
