"""IAI protocol B, sans I/O: frames, SC, typed requests and the decoding of replies.

How this works::

    command  '!'  station  id     data           SC    CR LF
              21  '99'     '212'  '01'           '89'  0D 0A
    reply    '#'  station  id     data           SC    CR LF
              23  '99'     '212'  '021C000...'   'AF'  0D 0A
    error    '&'  station  code                  SC    CR LF     always 10 bytes, no id
              26  '99'     '0A1'                 '3A'  0D 0A

    SC = (sum of the bytes from the header through the last data byte) mod 256,
         two hex digits; SC, CR and LF are not summed.

Every field is fixed-width hex ASCII.  :func:`encode_frame` writes upper case and
a real SC, and refuses any message id off the profile's allow-list.

A :class:`FrameDecoder` is fed whatever bytes arrive, whole, one at a time or
after line noise, and hands back complete frames: header (``!``, ``#`` or ``&``)
through LF.  Bytes before a header are noise: dropped and counted, and so is a
frame cut short by a new header (no field of a valid frame can hold one).  A bad
frame raises a :class:`~harlsync.errors.ProtocolError` subclass after the frame
is consumed, so the next call goes on after it; a frame with no LF within the
length limit is dropped the same way.  ``!`` frames are decoded too: a line that
echoes commands shows them, and the link recognises its own.

A :class:`Request` is a message id and its data, and knows how to decode its reply
into a typed value: :class:`~harlsync.families.iai.model.Version`,
:class:`~harlsync.families.iai.model.SystemStatus`, axis statuses, positions,
counts.  An ``&`` reply decodes to an :class:`ErrorReply` value; a reply that
does not answer the request raises :class:`~harlsync.errors.ReplyError`.

Request builders, one per message of the allow-list::

    201H version          215H system_status     212H axis_status
    22DH read_positions   291H write_positions
    opt-in:  20DH read_flags      20EH read_integers      20FH read_reals
             24BH write_flag      24CH write_integers     24DH write_reals
    records: 2A0H read_coordinate_systems                 210H read_strings
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Generic, Literal, TypeVar

from ...errors import FrameError, ReplyError
from . import profile
from .model import (
    INTEGER_MAX,
    INTEGER_MIN,
    AxisStatus,
    Position,
    SystemStatus,
    Version,
    arms_from_extended,
    axes_from_pattern,
    coord_from_wire,
    coord_to_wire,
    extended_from_arms,
    g_from_wire,
    g_to_wire,
    pattern_from_axes,
    speed_from_wire,
    speed_to_wire,
)

__all__ = [
    "ChecksumError",
    "ErrorReply",
    "Frame",
    "FrameDecoder",
    "FrameKind",
    "Request",
    "axis_status",
    "encode_frame",
    "max_coordinate_systems_per_read",
    "max_flags_per_read",
    "max_positions_per_read",
    "max_positions_per_write",
    "max_string_columns_per_read",
    "max_variables_per_read",
    "max_variables_per_write",
    "parse_write_positions",
    "position_fields",
    "position_record",
    "read_coordinate_systems",
    "read_flags",
    "read_integers",
    "read_positions",
    "read_reals",
    "read_strings",
    "real_from_wire",
    "real_to_wire",
    "sc",
    "system_status",
    "version",
    "write_flag",
    "write_integers",
    "write_positions",
    "write_reals",
]

T = TypeVar("T")
#: A request's reply type: a ``Request[int]`` is a ``Request[object]`` too.
R_co = TypeVar("R_co", covariant=True)

#: ``!`` command, ``#`` normal reply, ``&`` error reply.
FrameKind = Literal["!", "#", "&"]

_CR = 0x0D
_LF = 0x0A
_KINDS: dict[int, FrameKind] = {0x21: "!", 0x23: "#", 0x26: "&"}
_HEADER_RE = re.compile(rb"[!#&]")
_NOT_PRINTABLE_RE = re.compile(rb"[^\x20-\x7e]")
_LOWER_HEX_RE = re.compile(rb"[a-f]")
_HEX_RE = re.compile(r"[0-9A-Fa-f]*")
_UPPER_HEX_RE = re.compile(r"[0-9A-F]*")
#: What a reply's data may hold when we encode one: printable, no header, no CR/LF.
_REPLY_DATA_RE = re.compile(r"[\x20\x22\x24\x25\x27-\x7e]*")
#: Bytes a frame adds around its data: header, station, id, SC, CR, LF.
_FRAME_OVERHEAD = 10
#: A 22DH reply around its records: the frame, reserved 00 and the record count.
_READ_OVERHEAD = _FRAME_OVERHEAD + 2 + 4
#: A 291H command around its records: the frame, reserved 00, start and count.
_WRITE_OVERHEAD = _FRAME_OVERHEAD + 2 + 4 + 4
#: A 20DH reply around its flag bytes: the frame, program, start flag and count.
_FLAGS_OVERHEAD = _FRAME_OVERHEAD + 2 + 4 + 4
#: A 20EH/20FH reply or 24CH/24DH command around its values: the frame, program,
#: start variable and count.
_VARIABLES_OVERHEAD = _FRAME_OVERHEAD + 2 + 3 + 2
#: Hex digits of one value: integer variables (20EH, 24CH), real variables (20FH, 24DH).
_VARIABLE_WIDTH = {"integers": 8, "reals": 16}
#: The most variables the 2-hex count field carries.
_VARIABLES_MAX = 0xFF


class ChecksumError(FrameError):
    """A frame whose SC does not match its bytes."""


def sc(data: bytes) -> int:
    """The SC of ``data`` (the header through the last data byte): their sum mod 256."""
    return sum(data) & 0xFF


def _build(header: str, station: int, middle: str) -> bytes:
    if not 0 <= station <= 0xFF:
        raise ValueError(f"station {station} out of range (allowed: 00h to FFh)")
    body = f"{header}{station:02X}{middle}".encode("ascii")
    return body + f"{sc(body):02X}".encode("ascii") + b"\r\n"


def encode_frame(station: int, message_id: int, data: str) -> bytes:
    """The bytes of one command frame: ``!`` station id data SC CR LF, upper case.

    Raises :class:`ValueError` for a message id not on the profile's allow-list
    (nothing else is ever sent), a station outside 00h-FFh, or data that is not
    upper-case hex digits.
    """
    if message_id not in profile.ALLOWED_MESSAGE_IDS:
        shown = f"{message_id:03X}H" if 0 <= message_id <= 0xFFF else str(message_id)
        raise ValueError(f"message {shown} is not on the IAI allow-list: it is never sent")
    if not _UPPER_HEX_RE.fullmatch(data):
        raise ValueError(f"command data {data!r} is not upper-case hex digits")
    return _build("!", station, f"{message_id:03X}{data}")


@dataclass(frozen=True)
class Frame:
    """One decoded frame.

    ``message_id`` is None for an ``&`` error reply, whose ``data`` is the 3-hex
    error code as received.  Hex is kept in the case it came in.
    """

    kind: FrameKind
    station: int
    message_id: int | None
    data: str

    @property
    def is_error(self) -> bool:
        return self.kind == "&"

    @property
    def payload(self) -> str:
        """The text between station and SC: id and data, or an error's code."""
        if self.message_id is None:
            return self.data
        return f"{self.message_id:03X}{self.data}"

    def encode(self) -> bytes:
        """The frame's bytes.  A command goes through :func:`encode_frame` (and its
        allow-list); replies are for the controller's side (the simulator).

        Raises :class:`ValueError` for a frame that cannot be put on the wire.
        """
        if self.kind == "!":
            if self.message_id is None:
                raise ValueError("a command frame needs a message id")
            return encode_frame(self.station, self.message_id, self.data)
        if self.kind == "&":
            if self.message_id is not None or not re.fullmatch(r"[0-9A-Fa-f]{3}", self.data):
                raise ValueError(f"an error reply carries a 3-hex code and no id: {self!r}")
            return _build("&", self.station, self.data)
        if self.message_id is None or not 0 <= self.message_id <= 0xFFF:
            raise ValueError(f"a reply needs a message id 000h-FFFh: {self!r}")
        if not _REPLY_DATA_RE.fullmatch(self.data):
            raise ValueError(f"reply data {self.data!r} holds a byte a frame cannot carry")
        return _build("#", self.station, self.payload)


class FrameDecoder:
    """Incremental frame decoder: ``feed(bytes)``, then ``next_frame()`` until None.

    ``pending`` is the bytes held that are not yet part of a returned or failed
    frame.  ``dropped`` counts every byte discarded as noise: before a header, a
    frame cut short by a new header, and whatever :meth:`clear` throws away.
    """

    def __init__(self, max_frame: int = profile.MAX_FRAME) -> None:
        if max_frame < _FRAME_OVERHEAD:
            raise ValueError(f"max_frame {max_frame} is shorter than the shortest frame")
        self._buf = bytearray()
        self._max = max_frame
        self._dropped = 0
        #: bytes at the front of the buffer already searched for an LF and a header
        self._scanned = 0

    def feed(self, data: bytes) -> None:
        self._buf += data

    @property
    def pending(self) -> int:
        return len(self._buf)

    @property
    def dropped(self) -> int:
        return self._dropped

    def clear(self) -> None:
        """Drop every buffered byte (counted in ``dropped``)."""
        self._dropped += len(self._buf)
        self._buf.clear()
        self._scanned = 0

    def next_frame(self) -> Frame | None:
        """The next complete frame, or None when more bytes are needed.

        Raises :class:`FrameError` (or its :class:`ChecksumError`) for a bad frame;
        its bytes are consumed first, so calling again continues after it.
        """
        buf = self._buf
        while True:
            found = _HEADER_RE.search(buf)
            if found is None:
                self._dropped += len(buf)
                buf.clear()
                self._scanned = 0
                return None
            if found.start():
                self._dropped += found.start()
                del buf[: found.start()]
                self._scanned = 0
            # The limit counts from the header whatever the chunks were: a frame fed
            # whole must not pass where the same bytes fed one by one would not.
            # Bytes already searched for an LF or a header (a reply arriving a few
            # bytes at a time) are not searched again: a 2 KiB 22DH reply fed byte
            # by byte would otherwise cost a scan of the whole frame per byte.
            start = max(1, self._scanned)
            end = buf.find(_LF, start, self._max)
            cut = _HEADER_RE.search(buf, start, end if end >= 0 else self._max)
            if cut is not None:
                self._dropped += cut.start()
                del buf[: cut.start()]
                self._scanned = 0
                continue
            if end < 0:
                if len(buf) >= self._max:
                    head = bytes(buf[:16])
                    del buf[: self._max]
                    self._scanned = 0
                    raise FrameError(
                        f"no LF within {self._max} bytes after {_show(head)}...: dropped"
                    )
                self._scanned = len(buf)  # bytes 1 .. len - 1 hold no LF and no header
                return None
            raw = bytes(buf[: end + 1])
            del buf[: end + 1]
            self._scanned = 0
            return _parse(raw)


def _parse(raw: bytes) -> Frame:
    """One frame, header through LF."""
    if len(raw) < 2 or raw[-2] != _CR:
        raise FrameError(f"no CR before LF in frame {_show(raw)}")
    text = raw[:-2]
    if _NOT_PRINTABLE_RE.search(text):
        raise FrameError(f"control or non-ASCII byte in frame {_show(text)}")
    if not profile.ACCEPT_LOWER_CASE_HEX and _LOWER_HEX_RE.search(text):
        raise FrameError(f"lower-case hex in frame {_show(text)}")
    kind = _KINDS[text[0]]
    if len(text) < _FRAME_OVERHEAD - 2 or (kind == "&" and len(text) != _FRAME_OVERHEAD - 2):
        raise FrameError(f"frame {_show(text)} is {len(raw)} bytes: wrong length")
    body, got = text[:-2].decode("ascii"), text[-2:].decode("ascii")
    if not _HEX_RE.fullmatch(got):
        raise FrameError(f"SC {got!r} is not hex in frame {_show(text)}")
    want = sc(text[:-2])
    if int(got, 16) != want:
        raise ChecksumError(f"SC {got} does not match {want:02X} for frame {_show(text)}")
    station, code = body[1:3], body[3:6]
    if not _HEX_RE.fullmatch(station + code):
        raise FrameError(f"station or message id not hex in frame {_show(text)}")
    if kind == "&":
        return Frame(kind, int(station, 16), None, code)
    return Frame(kind, int(station, 16), int(code, 16), body[6:])


def _show(text: bytes) -> str:
    """Frame text for a message: quoted, any other byte as ``\\xNN`` (no ``b''`` repr)."""
    shown = "".join(
        chr(b) if 0x20 <= b <= 0x7E and b not in b"'\\" else f"\\x{b:02x}" for b in text
    )
    return f"'{shown}'"


# --- requests -----------------------------------------------------------------------


@dataclass(frozen=True)
class ErrorReply:
    """The controller answered ``&``: the command was well formed but not executed.

    ``code`` is the raw 3-hex error code (its list is not in our manual pages).
    """

    code: str

    def __str__(self) -> str:
        return f"error reply &{self.code}"


@dataclass(frozen=True)
class Request(Generic[R_co]):
    """One command: message id and data, and how to read its normal reply.

    ``parse`` turns the reply's data into the value (raising :class:`ValueError`
    when it does not fit); ``reply_bytes`` is the longest reply frame the command
    can get, for the reply deadline.  Requests compare by id and data.
    """

    message_id: int
    data: str
    is_write: bool
    volatile: bool
    parse: Callable[[str], R_co] = field(repr=False, compare=False)
    reply_bytes: int = field(default=max(b.send for b in profile.BUFFERS.values()), compare=False)

    def __post_init__(self) -> None:
        if not 0 <= self.message_id <= 0xFFF:
            raise ValueError(f"message id {self.message_id} is not 3 hex digits")
        if self.message_id in profile.ALLOWED_MESSAGE_IDS and self.is_write != (
            self.message_id in profile.WRITE_MESSAGE_IDS
        ):
            raise ValueError(f"{self.message_id:03X}H: is_write must be {not self.is_write}")

    @property
    def payload(self) -> str:
        """Message id and data as on the wire: ``"21201"``."""
        return f"{self.message_id:03X}{self.data}"

    @property
    def frame_size(self) -> int:
        """Bytes of the command frame, to check against the controller's receive buffer."""
        return _FRAME_OVERHEAD + len(self.data)

    def encode(self, station: int) -> bytes:
        """The command frame.  Raises :class:`ValueError` as :func:`encode_frame` does."""
        return encode_frame(station, self.message_id, self.data)

    def decode(self, frame: Frame) -> R_co | ErrorReply:
        """The typed value ``frame`` answers, or :class:`ErrorReply` for ``&``.

        Raises :class:`ReplyError` when the frame does not answer this request:
        a command echo, another message id, or data of the wrong length or form.
        (The station is the link's to check.)
        """
        if frame.kind == "&":
            return ErrorReply(frame.data)
        if frame.kind != "#":
            raise ReplyError(f"{self.payload}: a command frame {frame.payload!r}, not a reply")
        if frame.message_id != self.message_id:
            raise ReplyError(f"{self.payload}: a reply to message {frame.payload[:3]}H")
        try:
            return self.parse(frame.data)
        except ValueError as exc:
            shown = frame.data if len(frame.data) <= 48 else frame.data[:45] + "..."
            raise ReplyError(f"{self.payload}: bad reply data {shown!r}: {exc}") from exc

    def __str__(self) -> str:
        return self.payload


class _Fields:
    """A cursor over reply data: fixed-width fields, each checked as it is taken."""

    def __init__(self, text: str) -> None:
        self._text = text
        self._at = 0

    def take(self, width: int, what: str) -> str:
        part = self._text[self._at : self._at + width]
        if len(part) != width:
            raise ValueError(f"data ends inside {what}")
        self._at += width
        return part

    def hex(self, width: int, what: str) -> int:
        part = self.take(width, what)
        if not _HEX_RE.fullmatch(part):
            raise ValueError(f"{what} {part!r} is not hex")
        return int(part, 16)

    def code(self, width: int, what: str) -> str:
        """A hex code kept as text, in upper case."""
        return f"{self.hex(width, what):0{width}X}"

    def expect(self, width: int, value: int, what: str) -> None:
        got = self.hex(width, what)
        if got != value:
            raise ValueError(f"{what} {got:0{width}X}h, expected {value:0{width}X}h")

    def end(self) -> None:
        left = len(self._text) - self._at
        if left:
            raise ValueError(f"{left} characters after the last field")


def _check(value: int, low: int, high: int, what: str) -> None:
    if not low <= value <= high:
        raise ValueError(f"{what} {value} out of range (allowed: {low} to {high})")


def _no_data(data: str) -> None:
    _Fields(data).end()


# --- 201H, 215H, 212H: version and status -------------------------------------------

_TIME_FIELDS = ("month", "day", "hour", "minute", "second")


def version(unit_type: int = 0, device: int = 0) -> Request[Version]:
    """201H: the version of unit ``unit_type`` (0 main CPU application), device 0."""
    _check(unit_type, 0, 0xFF, "unit type")
    _check(device, 0, 0xF, "device number")

    def parse(data: str) -> Version:
        f = _Fields(data)
        f.expect(2, unit_type, "unit type")
        f.expect(1, device, "device number")
        model_code, unit_code = f.code(2, "model code"), f.code(2, "unit code")
        number = f.code(4, "version")
        year = f.hex(4, "year")
        month, day, hour, minute, second = (f.hex(2, name) for name in _TIME_FIELDS)
        f.end()
        built = f"{year:04d}-{month:02d}-{day:02d} {hour:02d}:{minute:02d}:{second:02d}"
        return Version(unit_type, device, model_code, unit_code, number, built)

    return Request(0x201, f"{unit_type:02X}{device:X}", False, False, parse, 35)


def system_status() -> Request[SystemStatus]:
    """215H: mode, error numbers and status bytes; the interlock reads it."""

    def parse(data: str) -> SystemStatus:
        f = _Fields(data)
        mode = f.hex(1, "system mode")
        critical, latest = f.code(3, "critical error"), f.code(3, "latest error")
        s1, s2, s3, s4 = (f.hex(2, f"status byte {n}") for n in range(1, 5))
        f.end()
        return SystemStatus(mode, critical, latest, s1, s2, s3, s4)

    return Request(0x215, "", False, True, parse, 25)


def axis_status(pattern: int) -> Request[tuple[AxisStatus, ...]]:
    """212H: the status of the axes in ``pattern`` (bit n = axis n+1).

    The reply lists the axes it reports, lowest first; an axis left out is not
    connected (see :func:`~harlsync.families.iai.model.axes_refusal`).
    """
    _check(pattern, 1, 0xFF, "axis pattern")

    def parse(data: str) -> tuple[AxisStatus, ...]:
        f = _Fields(data)
        got = f.hex(2, "axis pattern")
        if got & ~pattern:
            raise ValueError(f"reports axis pattern {got:02X}h, asked for {pattern:02X}h")
        out = []
        for axis in axes_from_pattern(got):
            what = f"axis {axis}"
            status, sensors = f.hex(2, f"{what} status"), f.hex(1, f"{what} sensors")
            error, encoder = f.code(3, f"{what} error"), f.hex(2, f"{what} encoder")
            position = coord_from_wire(f.take(8, f"{what} position"))
            out.append(AxisStatus(axis, status, sensors, error, encoder, position))
        f.end()
        return tuple(out)

    reply = _FRAME_OVERHEAD + 2 + 16 * len(axes_from_pattern(pattern))
    return Request(0x212, f"{pattern:02X}", False, True, parse, reply)


# --- 22DH, 291H: positions ----------------------------------------------------------


def _buffers(model: str) -> profile.Buffers:
    buffers = profile.BUFFERS.get(model)
    if buffers is None:
        raise ValueError(f"unknown IAI model {model!r} (known: {', '.join(profile.BUFFERS)})")
    return buffers


def max_positions_per_read(model: str) -> int:
    """How many position numbers one 22DH may ask for on ``model``: as many as fit
    the send buffer if every one held 8 axes.

    Raises :class:`ValueError` for a model the profile does not know (so do the
    other ``max_*`` functions).
    """
    return (_buffers(model).send - _READ_OVERHEAD) // profile.READ_RECORD_MAX


def max_positions_per_write(model: str) -> int:
    """The most positions one 291H may carry to ``model``'s receive buffer, if every
    one held 8 axes."""
    return (_buffers(model).receive - _WRITE_OVERHEAD) // profile.WRITE_RECORD_MAX


def max_flags_per_read(model: str) -> int:
    """How many flags one 20DH may ask for on ``model``: the whole bytes of 8 flags
    its reply can carry in the send buffer (a multiple of 8, so that queries which
    follow one another stay aligned)."""
    return (_buffers(model).send - _FLAGS_OVERHEAD) // 2 * 8


def max_variables_per_read(model: str, kind: str) -> int:
    """How many ``kind`` (``"integers"`` or ``"reals"``) variables one 20EH/20FH
    reply can carry in ``model``'s send buffer (at most 255)."""
    room = _buffers(model).send - _VARIABLES_OVERHEAD
    return min(_VARIABLES_MAX, room // _VARIABLE_WIDTH[kind])


def max_variables_per_write(model: str, kind: str) -> int:
    """How many ``kind`` (``"integers"`` or ``"reals"``) variables one 24CH/24DH may
    carry to ``model``'s receive buffer (at most 255)."""
    room = _buffers(model).receive - _VARIABLES_OVERHEAD
    return min(_VARIABLES_MAX, room // _VARIABLE_WIDTH[kind])


def position_fields(position: Position, *, numbered: bool) -> list[str]:
    """One position's record, field by field (pattern, acc, dec, speed, coordinates,
    extended; the number first when ``numbered``).

    Raises :class:`ValueError` naming every problem of a position the wire cannot carry.
    """
    problems = position.problems()
    if problems:
        raise ValueError(f"position {position.number}: {'; '.join(problems)}")
    return [
        *([f"{position.number:04X}"] if numbered else []),
        f"{pattern_from_axes(position.axes):02X}",
        g_to_wire(position.acc, "acceleration"),
        g_to_wire(position.dec, "deceleration"),
        speed_to_wire(position.speed),
        *(coord_to_wire(c) for c in position.coords),
        f"{extended_from_arms(position.arm1, position.arm2):02X}",
    ]


def position_record(position: Position, *, numbered: bool) -> str:
    """One position as record text: 22DH's form with the number in front
    (``numbered``), 291H's without.

    Raises :class:`ValueError` naming every problem of a position the wire cannot carry.
    """
    return "".join(position_fields(position, numbered=numbered))


def _take_position(f: _Fields, number: int | None) -> Position:
    if number is None:
        number = f.hex(4, "position number")
    what = f"position {number}"
    axes = axes_from_pattern(f.hex(2, f"{what} axis pattern"))
    acc = g_from_wire(f.take(4, f"{what} acceleration"))
    dec = g_from_wire(f.take(4, f"{what} deceleration"))
    speed = speed_from_wire(f.take(4, f"{what} speed"))
    coords = tuple(coord_from_wire(f.take(8, f"{what} axis {a}")) for a in axes)
    arm1, arm2 = arms_from_extended(f.hex(2, f"{what} extended data"))
    return Position(number, axes, acc, dec, speed, coords, arm1, arm2)


def read_positions(
    head: int, count: int, send_buffer: int | None = None
) -> Request[tuple[Position, ...]]:
    """22DH: the defined positions among ``count`` numbers from ``head``, by number.

    An undefined position is absent from the reply.  Size ``count`` with
    :func:`max_positions_per_read` so that a reply is never cut; a probe that
    asks for more gives the model's ``send_buffer``, the longest reply it can get.
    """
    _check(head, 1, 0xFFFF, "head position")
    _check(count, 1, 0xFFFF - head + 1, "position count")

    def parse(data: str) -> tuple[Position, ...]:
        f = _Fields(data)
        f.expect(2, 0, "reserved field")
        records = f.hex(4, "number of records")
        if records > count:
            raise ValueError(f"{records} records, asked for {count} positions")
        out: dict[int, Position] = {}
        for _ in range(records):
            position = _take_position(f, None)
            if not head <= position.number < head + count:
                raise ValueError(f"position {position.number} was not asked for")
            if position.number in out:
                raise ValueError(f"position {position.number} twice")
            out[position.number] = position
        f.end()
        return tuple(out[n] for n in sorted(out))

    reply = _READ_OVERHEAD + profile.READ_RECORD_MAX * count
    if send_buffer is not None:
        reply = min(reply, send_buffer)
    return Request(0x22D, f"00{head:04X}{count:04X}", False, False, parse, reply)


def write_positions(start: int, positions: Sequence[Position]) -> Request[int]:
    """291H: write consecutive positions ``start``, ``start + 1`` ...

    The reply gives the number of positions written.  Raises :class:`ValueError`
    for no positions, numbers that do not run on from ``start``, or a position
    the wire cannot carry.  Check :attr:`Request.frame_size` against the model's
    receive buffer.
    """
    count = len(positions)
    _check(start, 1, 0xFFFF, "start position")
    _check(count, 1, 0xFFFF - start + 1, "position count")
    for offset, position in enumerate(positions):
        if position.number != start + offset:
            raise ValueError(
                f"position {position.number} where {start + offset} was due: "
                "291H writes consecutive positions"
            )
    records = "".join(position_record(p, numbered=False) for p in positions)

    def parse(data: str) -> int:
        f = _Fields(data)
        f.expect(2, 0, "reserved field")
        written = f.hex(4, "number written")
        f.end()
        if written > count:
            raise ValueError(f"{written} positions written of {count} sent")
        return written

    return Request(0x291, f"00{start:04X}{count:04X}{records}", True, False, parse, 16)


def parse_write_positions(data: str) -> tuple[int, tuple[Position, ...]]:
    """The controller's side of 291H: (start, positions) from the command data.

    Raises :class:`ValueError` for data that is not a 291H command.
    """
    f = _Fields(data)
    f.expect(2, 0, "reserved field")
    start = f.hex(4, "start position")
    count = f.hex(4, "position count")
    positions = tuple(_take_position(f, start + i) for i in range(count))
    f.end()
    return start, positions


# --- opt-in: flags and variables ----------------------------------------------------


def read_flags(start: int, count: int, program: int = 0) -> Request[tuple[bool, ...]]:
    """20DH: ``count`` flags from ``start`` (program 0: global), bit 0 first.

    ``start`` must be a category's head flag plus a multiple of 8 (p.22).
    """
    _check(program, 0, 0xFF, "program number")
    _check(start, 0, 0xFFFF, "start flag")
    _check(count, 1, 0xFFFF, "flag count")

    def parse(data: str) -> tuple[bool, ...]:
        f = _Fields(data)
        f.expect(2, program, "program number")
        f.expect(4, start, "start flag")
        f.expect(4, count, "number of flags")
        octets = [f.hex(2, "flag data") for _ in range((count + 7) // 8)]
        f.end()
        return tuple(bool(octets[i // 8] >> (i % 8) & 1) for i in range(count))

    reply = _FLAGS_OVERHEAD + 2 * ((count + 7) // 8)
    return Request(0x20D, f"{program:02X}{start:04X}{count:04X}", False, True, parse, reply)


def _variable_args(program: int, start: int, count: int) -> str:
    _check(program, 0, 0xFF, "program number")
    _check(start, 0, 0xFFF, "start variable")
    _check(count, 1, _VARIABLES_MAX, "variable count")
    return f"{program:02X}{start:03X}{count:02X}"


def _read_variables(
    message_id: int, width: int, convert: Callable[[str], T], program: int, start: int, count: int
) -> Request[tuple[T, ...]]:
    data = _variable_args(program, start, count)

    def parse(reply: str) -> tuple[T, ...]:
        f = _Fields(reply)
        f.expect(2, program, "program number")
        f.expect(3, start, "start variable")
        f.expect(2, count, "number of variables")
        values = tuple(convert(f.take(width, f"variable {start + i}")) for i in range(count))
        f.end()
        return values

    reply_bytes = _VARIABLES_OVERHEAD + width * count
    return Request(message_id, data, False, True, parse, reply_bytes)


def _int_from_wire(wire: str) -> int:
    if not (len(wire) == 8 and _HEX_RE.fullmatch(wire)):
        raise ValueError(f"integer {wire!r} is not 8 hex digits")
    value = int(wire, 16)
    return value - (1 << 32) if value & 0x80000000 else value


def real_from_wire(wire: str, order: str = profile.DEFAULT_REAL_WORD_ORDER) -> float:
    """A real variable's 16 hex digits in the robot's word order (p.24) as its double.

    Raises :class:`ValueError` for anything but 16 hex digits, or an unknown order.
    """
    if not (len(wire) == 16 and _HEX_RE.fullmatch(wire)):
        raise ValueError(f"real {wire!r} is not 16 hex digits")
    value: float = struct.unpack(">d", bytes.fromhex(_in_order(wire, order)))[0]
    return value


def real_to_wire(value: float, order: str = profile.DEFAULT_REAL_WORD_ORDER) -> str:
    """A double as a real variable's 16 upper-case hex digits in the robot's word order."""
    return _in_order(struct.pack(">d", value).hex().upper(), order)


def _in_order(digits: str, order: str) -> str:
    """Big-endian hex digits of a double to ``order``'s, or back (a swap is its own inverse)."""
    if order not in profile.REAL_WORD_ORDERS:
        raise ValueError(
            f"real word order {order!r} (allowed: {', '.join(profile.REAL_WORD_ORDERS)})"
        )
    return digits[8:] + digits[:8] if order == "lower-first" else digits


def read_integers(start: int, count: int, program: int = 0) -> Request[tuple[int, ...]]:
    """20EH: ``count`` integer variables from ``start`` (program 0: global).

    32-bit two's complement each (profile: the page is missing; mirrors 24CH).
    """
    return _read_variables(0x20E, 8, _int_from_wire, program, start, count)


def read_reals(
    start: int,
    count: int,
    program: int = 0,
    order: str = profile.DEFAULT_REAL_WORD_ORDER,
) -> Request[tuple[float, ...]]:
    """20FH: ``count`` real variables from ``start``, each an IEEE double in the
    robot's word ``order`` (p.24; a float holds the double exactly)."""
    _in_order("0" * 16, order)  # an unknown order is refused before anything is sent
    return _read_variables(
        0x20F, 16, lambda wire: real_from_wire(wire, order), program, start, count
    )


def write_flag(number: int, on: bool, program: int = 0) -> Request[None]:
    """24BH: set or clear one flag (program 0: global).  The reply has no data."""
    _check(program, 0, 0xFF, "program number")
    _check(number, 0, 0xFFFF, "flag number")
    return Request(0x24B, f"{program:02X}{number:04X}{int(on):X}", True, False, _no_data, 10)


def _write_variables(message_id: int, start: int, texts: list[str], program: int) -> Request[int]:
    count = len(texts)
    data = _variable_args(program, start, count) + "".join(texts)

    def parse(reply: str) -> int:
        f = _Fields(reply)
        f.expect(2, program, "program number")
        f.expect(3, start, "start variable")
        written = f.hex(2, "number changed")
        f.end()
        if written > count:
            raise ValueError(f"{written} variables changed of {count} sent")
        return written

    return Request(message_id, data, True, False, parse, 17)


def write_integers(start: int, values: Sequence[int], program: int = 0) -> Request[int]:
    """24CH: integer variables from ``start``; the reply gives the number changed.

    Raises :class:`ValueError` for no values, more than 255, or one outside 32 bits.
    """
    for i, value in enumerate(values):
        _check(value, INTEGER_MIN, INTEGER_MAX, f"integer variable {start + i}")
    return _write_variables(0x24C, start, [f"{v & 0xFFFFFFFF:08X}" for v in values], program)


def write_reals(
    start: int,
    values: Sequence[float],
    program: int = 0,
    order: str = profile.DEFAULT_REAL_WORD_ORDER,
) -> Request[int]:
    """24DH: real variables from ``start``, each an IEEE double in the robot's word
    ``order`` (the profile writes in the order 20FH reads)."""
    texts = [real_to_wire(v, order) for v in values]
    return _write_variables(0x24D, start, texts, program)


# --- read-only records: coordinate systems and string variables ---------------------

#: A 2A0H reply around its records: the frame, type, start number and count.
_COORDINATES_OVERHEAD = _FRAME_OVERHEAD + 1 + 2 + 2
#: One 2A0H record: X, Y, Z offsets (0.001 mm) and R (0.001 deg), 8 hex digits each.
_COORDINATE_RECORD = 4 * 8


def max_coordinate_systems_per_read(model: str) -> int:
    """How many coordinate system definitions one 2A0H reply carries in ``model``'s
    send buffer (at most 255: the count is 2 hex digits)."""
    return min(0xFF, (_buffers(model).send - _COORDINATES_OVERHEAD) // _COORDINATE_RECORD)


def max_string_columns_per_read(model: str) -> int:
    """How many string variable columns (one character each) one 210H reply carries
    in ``model``'s send buffer (at most 255)."""
    return min(_VARIABLES_MAX, (_buffers(model).send - _VARIABLES_OVERHEAD) // 2)


def read_coordinate_systems(
    kind: int, head: int, count: int
) -> Request[tuple[tuple[str, str, str, str], ...]]:
    """2A0H (p.65): ``count`` coordinate system definitions from number ``head``,
    work (``kind`` 0) or tool (1); each the X, Y, Z offsets and R, as coordinate text."""
    _check(kind, 0, 1, "coordinate system type")
    _check(head, 0, 0xFF, "head definition number")
    _check(count, 1, 0xFF - head + 1, "number of records")

    def parse(data: str) -> tuple[tuple[str, str, str, str], ...]:
        f = _Fields(data)
        f.expect(1, kind, "coordinate system type")
        f.expect(2, head, "start number")
        f.expect(2, count, "number of records")
        out = []
        for n in range(head, head + count):
            x, y, z, r = (coord_from_wire(f.take(8, f"definition {n} {a}")) for a in "XYZR")
            out.append((x, y, z, r))
        f.end()
        return tuple(out)

    reply = _COORDINATES_OVERHEAD + _COORDINATE_RECORD * count
    return Request(0x2A0, f"{kind:X}{head:02X}{count:02X}", False, False, parse, reply)


def read_strings(start: int, count: int, program: int = 0) -> Request[tuple[int, ...]]:
    """210H (p.26): ``count`` string variable columns from ``start`` (program 0:
    global), each one character as its code ('XX', hex ASCII)."""
    return _read_variables(0x210, 2, _code_from_wire, program, start, count)


def _code_from_wire(wire: str) -> int:
    if not (len(wire) == 2 and _HEX_RE.fullmatch(wire)):
        raise ValueError(f"character code {wire!r} is not 2 hex digits")
    return int(wire, 16)
