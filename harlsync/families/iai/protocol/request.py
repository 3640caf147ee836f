"""A request: a message id and its data, and how its reply is decoded."""

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from ....errors import ReplyError
from .. import profile
from .frame import _FRAME_OVERHEAD, _HEX_RE, Frame, encode_frame

log = logging.getLogger(__name__)

T = TypeVar("T")
#: A request's reply type: a ``Request[int]`` is a ``Request[object]`` too.
R_co = TypeVar("R_co", covariant=True)

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
            log.debug("%s: a command frame %s, not a reply", self.payload, frame.payload)
            raise ReplyError(f"{self.payload}: a command frame, not a reply (-vv shows it)")
        if frame.message_id != self.message_id:
            raise ReplyError(f"{self.payload}: a reply to message {frame.payload[:3]}H")
        try:
            return self.parse(frame.data)
        except ValueError as exc:
            log.debug("%s: bad reply data %s", self.payload, frame.data)
            raise ReplyError(
                f"{self.payload}: a reply of {len(frame.data)} characters that does not read "
                f"as its answer: {exc} (-vv shows it)"
            ) from exc

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
            raise ValueError(f"{what} is not hex")
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
