"""HARL-U2 framing: bytes <-> frames, sans I/O.

How this works::

    STX  station  SP  payload  ETX  LRC
    02   '1'      20  'LNM 2 3' 03  xx        LRC = XOR of '1' .. ETX inclusive

A :class:`FrameDecoder` is fed whatever bytes arrive, whole, one at a time or
after line noise, and hands back complete frames.  Bytes before an STX are noise:
they are dropped and counted.  After ETX exactly one LRC byte follows (it may be
any value, even 02 or 03), so the decoder never looks for STX/ETX inside it.  A
bad frame raises a :class:`~harlsync.errors.ProtocolError` subclass after the
frame is consumed, so the next call goes on with the bytes after it.
"""

from __future__ import annotations

import operator
import re
from dataclasses import dataclass
from functools import reduce

from ....errors import ChecksumError, FrameError
from . import profile

__all__ = [
    "MAX_STATION",
    "Frame",
    "FrameDecoder",
    "encode_frame",
    "lrc",
    "off_allow_list",
    "payload_room",
]

#: The widest station number a frame carries (two digits).
MAX_STATION = 99


def lrc(body: bytes) -> int:
    """XOR of every byte of ``body`` (the bytes after STX through ETX inclusive)."""
    return reduce(operator.xor, body, 0)


def _lrc_bytes(value: int) -> bytes:
    if profile.LRC_ENCODING == "hex":
        return f"{value:02X}".encode("ascii")
    return bytes([value])


#: A byte a payload cannot hold: anything but printable ASCII.
_NOT_PRINTABLE = re.compile(rb"[^\x20-\x7e]")

_LRC_LEN = 2 if profile.LRC_ENCODING == "hex" else 1


@dataclass(frozen=True)
class Frame:
    """One frame: the station number and the payload text after ``station SP``."""

    station: int
    payload: str

    @property
    def fields(self) -> list[str]:
        return self.payload.split(" ") if self.payload else []

    @property
    def is_error(self) -> bool:
        return self.payload.startswith(profile.ERROR_PREFIX)

    def encode(self) -> bytes:
        return encode_frame(self.station, self.payload)


#: A first field the controller could take for a command: LN or SN, in any case,
#: whatever follows (``SNOB``, ``snob``, ``SNOB1``, ``SN``).  The manual has no
#: other kind of command (``Z`` is "for semiconductors only").
_COMMAND_START = re.compile(r"[LS]N", re.IGNORECASE)


def off_allow_list(payload: str) -> str | None:
    """The first field of ``payload`` when it is not exactly one of
    ``profile.SENT_COMMANDS`` yet could be read as a command (such a payload is never
    encoded), else None.

    A first field that begins with a letter is a command unless it is an error reply
    (``profile.ERROR_PREFIX`` then the status): so ``S NOB 1``, ``N``, ``X1`` are
    refused along with ``SNO`` and ``SNOB1``, and a layer above cannot split or
    misspell its way round the list.  Replies otherwise begin with a digit, a sign
    or a decimal point, never a letter.
    """
    first = payload.split(" ", 1)[0]
    if first in profile.SENT_COMMANDS:
        return None
    if _COMMAND_START.match(first):
        return first
    if first[:1].isalpha() and not first.startswith(profile.ERROR_PREFIX):
        return first
    return None


def encode_frame(station: int, payload: str) -> bytes:
    """The bytes of one frame, LRC included.

    Fields are separated by exactly one space, none empty (no leading, trailing or
    double space).  A payload whose first field begins with LN or SN, in any case,
    is a request: that field must be exactly a command of ``profile.SENT_COMMANDS``,
    so SNO, SNB, SNZ, ``snm``, ``SNOB1`` ... are refused here and no layer above
    can put one on the wire.  Replies (the simulator's side) begin with a digit,
    a sign, a decimal or ``E``.

    Raises :class:`FrameError` when the payload holds a byte a frame cannot carry,
    an empty field, or begins with a command off the allow-list.
    """
    first = off_allow_list(payload)
    if first is not None:
        raise FrameError(f"{first} is not on the HARL-U2 allow-list: it is never sent")
    if not 0 <= station <= MAX_STATION:
        raise FrameError(f"station {station} out of range")
    try:
        raw = payload.encode("ascii")
    except UnicodeEncodeError as exc:
        raise FrameError(f"payload {payload!r} is not ASCII") from exc
    if _NOT_PRINTABLE.search(raw):
        raise FrameError(f"payload {payload!r} holds a control character")
    if payload and "" in payload.split(" "):
        raise FrameError(
            f"payload '{payload}' has an empty field: fields are separated by exactly one space"
        )
    body = f"{station} ".encode("ascii") + raw + bytes([profile.ETX])
    return bytes([profile.STX]) + body + _lrc_bytes(lrc(body))


def payload_room(station: int, max_frame: int = profile.MAX_FRAME) -> int:
    """The longest payload a frame for ``station`` can carry and a :class:`FrameDecoder`
    of ``max_frame`` still take: its ETX must come within ``max_frame`` bytes of its STX::

        STX  station  SP  payload  ETX    ETX at index 1 + len(station) + 1 + len(payload)
    """
    return max_frame - len(f"{station} ") - 1


class FrameDecoder:
    """Incremental frame decoder: ``feed(bytes)``, then ``next_frame()`` until None.

    ``dropped`` counts every byte discarded as noise (before an STX, or a frame
    cut short by a new STX or by the length limit).
    """

    def __init__(self, max_frame: int = profile.MAX_FRAME) -> None:
        self._buf = bytearray()
        self._max = max_frame
        self.dropped = 0

    def feed(self, data: bytes) -> None:
        self._buf += data

    @property
    def pending(self) -> int:
        """Bytes held that do not yet make a frame."""
        return len(self._buf)

    def clear(self) -> None:
        self.dropped += len(self._buf)
        self._buf.clear()

    def next_frame(self) -> Frame | None:
        """The next complete frame, or None when more bytes are needed.

        Raises :class:`FrameError` or :class:`ChecksumError` for a bad frame; the bad
        frame's bytes are consumed first, so calling again continues after it.
        """
        buf = self._buf
        while True:
            start = buf.find(profile.STX)
            if start < 0:
                self.dropped += len(buf)
                buf.clear()
                return None
            if start:
                self.dropped += start
                del buf[:start]
            # buf[0] is STX: look for ETX, but a new STX first means this frame was cut.
            # The length limit counts from the STX whatever the chunks were: a frame
            # fed whole must not pass where the same bytes fed one by one would not.
            limit = self._max + 1
            end = buf.find(profile.ETX, 1, limit)
            cut = buf.find(profile.STX, 1, end if end >= 0 else limit)
            if cut > 0:
                self.dropped += cut
                del buf[:cut]
                continue  # cut frame dropped; rescan from the new STX
            if end < 0:
                if len(buf) >= limit:
                    self.dropped += limit
                    del buf[:limit]
                    raise FrameError(f"no ETX within {self._max} bytes: frame dropped")
                return None
            if len(buf) < end + 1 + _LRC_LEN:
                return None
            body = bytes(buf[1 : end + 1])
            got = bytes(buf[end + 1 : end + 1 + _LRC_LEN])
            del buf[: end + 1 + _LRC_LEN]
            return _parse(body, got)


def _parse(body: bytes, got_lrc: bytes) -> Frame:
    want = _lrc_bytes(lrc(body))
    text = body[:-1]
    if got_lrc != want:
        raise ChecksumError(
            f"LRC {got_lrc.hex()} does not match {want.hex()} for frame {_show(text)}"
        )
    if _NOT_PRINTABLE.search(text):
        raise FrameError(f"control or non-ASCII byte in frame {_show(text)}")
    head, sep, payload = text.decode("ascii").partition(" ")
    if not sep or not head.isdigit() or len(head) > 2:
        raise FrameError(f"no station number in frame {_show(text)}")
    if payload and ("  " in payload or payload.startswith(" ") or payload.endswith(" ")):
        raise FrameError(f"empty field in frame {_show(text)}")
    return Frame(int(head), payload)


def _show(text: bytes) -> str:
    """Frame text for a message: quoted, any other byte as ``\\xNN`` (no ``b''`` repr)."""
    shown = "".join(
        chr(b) if 0x20 <= b <= 0x7E and b not in b"'\\" else f"\\x{b:02x}" for b in text
    )
    return f"'{shown}'"
