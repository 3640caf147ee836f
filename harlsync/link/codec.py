"""What the link needs from a family's sans-I/O codec, as typing Protocols.

The link knows bytes, deadlines and retries; a family's codec knows its frames.
A serial family's frames (a start byte, the station, a payload, an end and a
checksum, say) fit these shapes without an adapter::

    Codec.decoder()        -> Decoder   feed(bytes); next_frame() -> Frame | None
    Request.encode(station) -> bytes    what goes on the wire
    Request.decode(Frame)   -> T        the typed reply, or ReplyError: not the answer

A request knows its reply type: ``Link.exchange(request)`` returns exactly what
``request.decode`` does (a read of one item gives that item, or the family's error reply).
Protocols are structural: a family implements them without importing this module.
"""

from __future__ import annotations

from typing import Protocol, TypeVar

from ..settings import SerialSettings

__all__ = ["Codec", "Decoder", "Frame", "Request"]

F_co = TypeVar("F_co", bound="Frame", covariant=True)
F_contra = TypeVar("F_contra", bound="Frame", contravariant=True)
T_co = TypeVar("T_co", covariant=True)


class Frame(Protocol):
    """One decoded frame: the station it names, and its payload as text (for logs)."""

    @property
    def station(self) -> int: ...

    @property
    def payload(self) -> str: ...


class Decoder(Protocol[F_co]):
    """An incremental frame decoder: fed whatever bytes arrive, it hands back frames.

    ``next_frame`` returns None when more bytes are needed, and raises a
    :class:`~harlsync.errors.ProtocolError` for a bad frame only after consuming
    it, so the next call goes on after it.  ``pending`` is the bytes held that are
    not yet a frame; ``dropped`` counts the bytes discarded as noise, and
    :meth:`clear` drops what is held (counted in ``dropped``).
    """

    def feed(self, data: bytes) -> None: ...

    def next_frame(self) -> F_co | None: ...

    @property
    def pending(self) -> int: ...

    @property
    def dropped(self) -> int: ...

    def clear(self) -> None: ...


class Request(Protocol[F_contra, T_co]):
    """One command and how to read its reply.

    ``is_write`` requests are never re-sent by the link; ``volatile`` reads (whose
    answer may change between two attempts) are re-sent only once no earlier
    reply can still come.  ``decode`` raises :class:`~harlsync.errors.ReplyError`
    when the frame does not answer this request (the link then keeps listening).
    """

    @property
    def payload(self) -> str: ...

    @property
    def is_write(self) -> bool: ...

    @property
    def volatile(self) -> bool: ...

    def encode(self, station: int) -> bytes: ...

    def decode(self, frame: F_contra) -> T_co: ...


class Codec(Protocol[F_co]):
    """A family's codec, as the link drives it.

    ``settings`` are the family's serial defaults.  ``no_reply_hint`` ends the
    message of a read that got no valid reply: what to check on this family's
    controller.  ``reply_timeout`` is the seconds to wait for the reply to one
    request (``settings.timeout``, or longer for a long reply).
    ``reply_gap`` is the seconds the controller needs after a reply before it
    takes the next command.
    """

    @property
    def settings(self) -> SerialSettings: ...

    @property
    def reply_gap(self) -> float: ...

    def decoder(self) -> Decoder[F_co]: ...

    def no_reply_hint(self, station: int) -> str: ...

    def station_text(self, station: int) -> str:
        """A station as the family's people write it, for messages (decimal, hex...)."""
        ...

    def reply_timeout(self, request: Request[F_co, object], settings: SerialSettings) -> float: ...
