"""What the link does with the frames it receives: each is a reply for this
station, a frame for another station, the echo of our own request, a reply owed
to an earlier attempt (late), or one nobody asked for; bad frames and line
noise are counted.  :class:`Received` is the part of
:class:`~harlsync.link.exchange.Link` that sorts them, on the link's decoder and
counters; it reads no port and keeps no time (the exchange does both).

Replies nobody asked for.  A frame for our station that answers nothing we sent
(not the reply, not one still owed, not one past its late window) means the
line delivers replies twice (two devices answering, a device server that
retransmits, a reflection), and a repeated reply that fits would pass for the
answer to the next request: a wrong value, no error.  Replies echo too little
to be bound to their request (the station and a message id or an item number
at most), so the link counts these frames, and from the second in one
session (:data:`UNREQUESTED_LIMIT`) it fails every read and sends nothing more:
a :class:`LinkError` that names the port and station and says to fix the line.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from ..errors import LinkError, LinkTimeout, ProtocolError, WriteUnconfirmed
from ..settings import seconds
from .codec import Codec, Decoder, Frame, Request

__all__ = [
    "MAX_REASONS",
    "UNREQUESTED_LIMIT",
    "Failure",
    "LinkStats",
    "Received",
    "hex_line",
    "missed",
]

log = logging.getLogger(__name__)

#: Retry reasons kept in :attr:`LinkStats.reasons` (the oldest are dropped).
MAX_REASONS = 500
#: Frames nobody asked for, in one session, that make the link refuse the line.  One
#: is tolerated (the last reply to a program killed mid-request); a second says the
#: line repeats replies, and a repeated reply may pass for the answer to the next
#: request.
UNREQUESTED_LIMIT = 2


@dataclass
class LinkStats:
    """What the link went through, for pull/backup reports.  Counts since creation."""

    exchanges: int = 0
    retries: int = 0
    #: attempts whose deadline passed without a fitting reply
    timeouts: int = 0
    #: frames with a bad checksum or malformed
    bad_frames: int = 0
    #: bytes discarded as line noise (outside any frame)
    noise_bytes: int = 0
    #: frames for another station, ignored
    other_station: int = 0
    #: well-formed frames for our station that did not answer the request
    unfitting: int = 0
    #: replies to earlier attempts that arrived after their deadline, discarded
    late_replies: int = 0
    #: well-formed frames for our station that no request of ours can explain, discarded
    unrequested: int = 0
    #: frames byte for byte the request we sent last (a line that echoes), skipped
    echoes: int = 0
    #: writes whose reply was lost (WriteUnconfirmed)
    unconfirmed_writes: int = 0
    #: one line per retry or unconfirmed write: "port, station, command: reason"
    reasons: list[str] = field(default_factory=list)

    def note(self, reason: str) -> None:
        self.reasons.append(reason)
        del self.reasons[:-MAX_REASONS]


@dataclass(frozen=True)
class Failure:
    """Why one attempt got no reply."""

    reason: str
    cause: ProtocolError | None = None


def missed(timeout: float, configured: float) -> str:
    """The deadline a reply missed, as configured (``0.5 s``), and the time the
    codec added for a reply long on the wire, if any."""
    extra = timeout - configured
    return f"{seconds(configured)} s" + (
        f" (+{extra:.3f} s for its time on the wire)" if extra >= 0.0005 else ""
    )


F = TypeVar("F", bound=Frame)


class Received(Generic[F]):
    """The frames a :class:`~harlsync.link.exchange.Link` received, sorted; the
    link sets these attributes up when it opens."""

    url: str
    codec: Codec[F]
    stats: LinkStats
    _decoder: Decoder[F]
    _rx: bytearray  # received bytes not yet logged; ends with the decoder's
    _dropped_seen: int
    _owed: dict[int, tuple[int, float]]  # station -> (replies, due by)
    _overdue: dict[int, int]  # station -> owed replies past their late window
    _unrequested: int  # frames nobody asked for since open()
    _sent: bytes  # the last frame sent, to know its echo

    def _note(self, level: int, station: int, command: str, reason: str) -> None:
        line = (
            f"port {self.url}, station {self.codec.station_text(station)}, command {command}: "
            f"{reason}"
        )
        self.stats.note(line)
        log.log(level, "%s", line)

    def _no_reply(
        self, request: Request[F, object], station: int, attempts: int, failure: Failure
    ) -> LinkError:
        """What an exchange that got no valid reply after ``attempts`` raises: a
        write unconfirmed (never re-sent), a read timed out."""
        command = request.payload
        shown = self.codec.station_text(station)
        if request.is_write:
            self.stats.unconfirmed_writes += 1
            self._note(logging.WARNING, station, command, f"write unconfirmed: {failure.reason}")
            error: LinkError = WriteUnconfirmed(
                f"no valid reply to this write ({failure.reason}); it may or may not have "
                "taken: read the item back before sending it again",
                port=self.url,
                station=station,
                station_text=shown,
                command=command,
            )
        else:
            error = LinkTimeout(
                f"no valid reply after {attempts} attempt(s) (last: {failure.reason}); "
                f"{self.codec.no_reply_hint(station)}",
                port=self.url,
                station=station,
                station_text=shown,
                command=command,
            )
        error.__cause__ = failure.cause
        return error

    def _log_rx(self) -> bytes:
        """Log, as one hex line, the received bytes the decoder is done with; return them.

        Called after each frame (or bad frame, or noise) is taken from the
        decoder, so a reply that came in single bytes is still one line, and
        what it returns ends with that frame's bytes.
        """
        done = len(self._rx) - self._decoder.pending
        if done <= 0:
            return b""
        consumed = bytes(self._rx[:done])
        if log.isEnabledFor(logging.DEBUG):
            log.debug("%s <- %s", self.url, hex_line(consumed))
        del self._rx[:done]
        return consumed

    def _count_noise(self) -> None:
        self.stats.noise_bytes += self._decoder.dropped - self._dropped_seen
        self._dropped_seen = self._decoder.dropped

    def _frames(self, station: int) -> Iterator[F | ProtocolError]:
        """What the buffered bytes hold for ``station``: its frames, and each bad frame
        as the error it raised (counted).  Frames for other stations are counted and
        skipped."""
        while True:
            try:
                frame = self._decoder.next_frame()
            except ProtocolError as exc:
                self._log_rx()
                self.stats.bad_frames += 1
                yield exc
                continue
            consumed = self._log_rx()
            if frame is None:
                return
            if self._sent and consumed.endswith(self._sent):
                self._echo(frame)
                continue
            if frame.station != station:
                self.stats.other_station += 1
                log.debug(
                    "%s: ignored a frame for station %s",
                    self.url,
                    self.codec.station_text(frame.station),
                )
                continue
            yield frame

    def _echo(self, frame: F) -> None:
        """Count and skip a frame byte for byte what we sent last: the line echoes us."""
        self.stats.echoes += 1
        level = logging.INFO if self.stats.echoes == 1 else logging.DEBUG
        log.log(
            level,
            "%s station %s: skipped the echo of our own request %s (the line echoes what "
            "we send, as 2-wire RS-485 adapters do)",
            self.url,
            self.codec.station_text(frame.station),
            frame.payload,
        )

    def _discard_frames(self, station: int) -> None:
        for item in self._frames(station):
            if isinstance(item, ProtocolError):
                log.info("%s: discarded bad frame: %s", self.url, item)
            else:
                self._stray(station, item.payload)

    def _stray(self, station: int, payload: str) -> None:
        """Discard a frame for ``station`` that answers no request now: a reply still
        owed, or one past its late window, else a frame nobody asked for."""
        if station in self._owed:
            self._late_reply(station, payload)
        elif self._overdue.get(station):
            self._overdue[station] -= 1
            self.stats.late_replies += 1
            self._discarded(station, "a reply later than its window", payload)
        else:
            self._unrequested += 1
            self.stats.unrequested += 1
            self._discarded(station, "a frame nobody asked for", payload)

    def _discarded(self, station: int, what: str, payload: str) -> None:
        log.info(
            "%s station %s: discarded %s %r",
            self.url,
            self.codec.station_text(station),
            what,
            payload,
        )

    def _check_line(self, station: int) -> None:
        """Raise LinkError once the line has delivered too many frames nobody asked for."""
        if self._unrequested >= UNREQUESTED_LIMIT:
            raise LinkError(
                f"the line delivers replies nobody asked for ({self._unrequested} unrequested "
                "frames): two devices answering, or a device server retransmitting; fix the line",
                port=self.url,
                station=station,
                station_text=self.codec.station_text(station),
            )

    def _late_reply(self, station: int, payload: str) -> None:
        count, due = self._owed.get(station, (0, 0.0))
        self.stats.late_replies += 1
        self._discarded(station, "late reply", payload)
        if count > 1:
            self._owed[station] = (count - 1, due)
        else:
            self._owed.pop(station, None)


def hex_line(data: bytes) -> str:
    """Bytes as the -vv log shows them: ``02 30 31``."""
    return data.hex(" ").upper()
