"""IAI protocol B frames, sans I/O: the SC checksum, encoding a frame and the
decoder that finds frames in whatever bytes arrive."""

import re
from dataclasses import dataclass
from typing import Literal

from ....errors import ChecksumError, FrameError
from .. import profile

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
