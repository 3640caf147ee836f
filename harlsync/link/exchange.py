"""One serial line to a controller: send a request, get its reply.

The link is generic over a family's sans-I/O codec (:mod:`harlsync.link.codec`):
the codec makes and reads the frames, the link owns the port, the deadlines and
the retries.

How this works::

    exchange(request)
      | wait out replies still owed by earlier attempts, then drop pending input
      v
    write  request.encode(station)  -------------------------------------->  controller
      |                                                                         |
    wait for the reply's bytes, feed them to the codec's decoder  <-------  reply
      |   bad frame, noise            : log, keep reading (the reply may follow)
      |   our own request, echoed     : skip (2-wire RS-485 adapters echo what we send)
      |   frame for another station   : ignore
      |   frame that does not fit     : discard (a late reply, or one nobody asked for)
      v   deadline (codec.reply_timeout) passes without a fitting reply
    read  : drain input, re-send; after settings.retries re-sends -> LinkTimeout
    write : never re-sent here -> WriteUnconfirmed (the controller reads the item back)

Late replies.  A reply that missed its deadline may still arrive, and most
replies carry no echo of what they answer (reads of two timers may both be
answered ``0.50``), so a late reply would pass for the answer to the next
request.  Every attempt that got no reply therefore leaves a reply *owed* by
that station; before the next request is sent the link listens until owed
replies have come (and are discarded) or cannot come any more (``late_window``
seconds after their deadline).  That costs one ``late_window`` after a reply
that was really lost, and never returns a value that answers another request.

A retry of the same read may take the earlier attempt's late reply as its own
answer: the value is the same.  Not so for a volatile read (the robot's status,
I/O and memory bits): the status may have changed between the two attempts, and
a late "idle" must never pass for the retry's "running".
Before re-sending a volatile read the link therefore waits out owed replies too,
as before a new request.

Replies nobody asked for: see :mod:`harlsync.link.received`, which sorts what
comes.

Waiting.  The link reads a reply as it comes: it waits until bytes arrive or the
reply's deadline passes, never for a time it works out itself (not from robot.yaml's
baud rate, which is not the line's behind a device server, nor from how a USB
adapter or a device server groups the bytes).  A port of our own with a descriptor
(a device path, ``socket://``: :func:`~harlsync.link.port.direct_fd`) waits in
``poll``, woken by the bytes, and takes all that is there in one ``os.read`` (no
``in_waiting`` ioctl), written with one ``write``; the decoder says when the frame
is whole.  One thread per line, blocking on its own port: a reply paced by a slow
line wakes it once per arrival, as it wakes a bare client (docs/BENCHMARKS.md,
"Issue 33", measures it against one selector loop and against the timers that
predicted a reply's end).  The baud rate still sets a local port, and a codec's
reply deadline where the codec derives it from the rate: a bound on a reply that
does not come.  Other ports
(``spy://``, ``sim://``, ``loop://``, ``rfc2217://``, Windows) go through pyserial,
with its timeout of :data:`~harlsync.link.port.POLL_INTERVAL`.

Draining.  Before each request the link reads the line and drops what it holds
(replies owed, frames nobody asked for), so that nothing that came before the
request passes for its answer.  It does so before every request, a read after a
read too: a frame that began to come in just before the request (a second device
on the station, a device server that repeats) would otherwise keep its first
bytes and be taken whole as the reply when it fits, and its value saved in the
backup (issue 24's review).  On a port of our own that read is one ``os.read``
that finds nothing: no ioctl.

Errors.  Whatever a pyserial call on the port raises (SerialException, OSError,
but also termios.error from a pty that went away, or TypeError from a port
closed under it) leaves the link as :class:`PortError`, one line that names the
port and says what to do; pyserial's own exceptions never get further.

Exclusive access.  The link holds the line lock (:mod:`harlsync.link.lock`) for
as long as it is open, so processes that share a line never interleave frames.
Within a process a lock around each exchange does the same for threads sharing
one :class:`Link`.
"""

from __future__ import annotations

import logging
import os
import select
import threading
import time
from dataclasses import dataclass
from types import TracebackType
from typing import Generic, TypeVar

import serial

from ..errors import LinkError, PortError, ProtocolError, ReplyError
from ..settings import SerialSettings, seconds
from .codec import Codec, Decoder, Frame, Request
from .lock import DEFAULT_LOCK_TIMEOUT, LineLock, lock_path
from .port import SerialPort, describe, direct_fd, fileno, gone_hint, open_port
from .readonly import refuse_write
from .received import Failure, LinkStats, Received, hex_line, missed

__all__ = ["Link", "LinkStats"]

log = logging.getLogger(__name__)


def _closed() -> ConnectionResetError:
    return ConnectionResetError("the other end closed the connection")


#: How much one read takes from a descriptor the link reads itself: more than any
#: reply of any family, so that a reply waiting whole is one read.
READ_SIZE = 65536


F = TypeVar("F", bound=Frame)
T = TypeVar("T")


class Link(Received[F]):
    """One port (and the default station on it), opened by pyserial URL, speaking
    the frames of ``codec``.

    ``url`` is a device path (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL
    (``socket://host:port``, ``rfc2217://``, ``loop://``, ``spy://``, ``sim://``).
    ``settings`` default to the codec's.  ``lock_timeout`` is the seconds to wait
    for another harlsync to release the port (0: fail at once, negative: wait for
    ever).  ``late_window`` is how long after its deadline a missed reply may still
    arrive (default: that reply's deadline).
    """

    def __init__(
        self,
        url: str,
        station: int = 1,
        settings: SerialSettings | None = None,
        *,
        codec: Codec[F],
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | os.PathLike[str] | None = None,
        late_window: float | None = None,
    ) -> None:
        self.url = url
        self.station = station
        self.codec = codec
        self.settings = codec.settings if settings is None else settings
        self.lock_timeout = lock_timeout
        self.lock_path = lock_path(url, lock_dir)
        self.late_window = late_window
        self.stats = LinkStats()
        self._port: SerialPort | None = None
        self._fd: int | None = None  # the port's file descriptor, when poll() can wait on it
        self._direct: int | None = None  # ... when the link reads it with os.read itself
        self._poll = select.poll()
        self._line_lock = LineLock(url, self.lock_path)
        self._lock = threading.RLock()
        self._decoder: Decoder[F] = codec.decoder()
        self._rx = bytearray()  # received bytes not yet logged; ends with the decoder's
        self._dropped_seen = 0
        self._owed: dict[int, tuple[int, float]] = {}  # station -> (replies, due by)
        self._overdue: dict[int, int] = {}  # station -> owed replies past their late window
        self._unrequested = 0  # frames nobody asked for since open()
        self._replied_at = 0.0  # when the last reply was taken, for the codec's reply_gap
        self._sent = b""  # the last frame sent, to know its echo

    # --- open / close ---------------------------------------------------------------

    @property
    def is_open(self) -> bool:
        return self._port is not None

    def open(self) -> Link[F]:
        """Take the port's lock and open it.

        Raises :class:`PortBusyError` when another harlsync holds the port, and
        :class:`PortError` when it cannot be opened.
        """
        with self._lock:
            if self._port is not None:
                return self
            self._line_lock.acquire(self.lock_timeout)
            try:
                port = open_port(self.url, self.settings, self._write_timeout)
            except BaseException:
                self._line_lock.release()
                raise
            self._port = port
            self._fd = fileno(port)
            self._direct = direct_fd(port)
            self._poll = select.poll()
            if self._fd is not None:
                self._poll.register(self._fd, select.POLLIN)
            self._decoder = self.codec.decoder()
            self._rx.clear()
            self._dropped_seen = 0
            self._owed.clear()
            self._overdue.clear()
            self._unrequested = 0
            self._sent = b""
            log.info(
                "opened %s (station %s, %s)",
                self.url,
                self.codec.station_text(self.station),
                self.settings,
            )
        return self

    def close(self) -> None:
        """Close the port and give its lock back.

        Never raises for the port itself: close runs on the way out of every
        job, and a port that fails to close has nothing left to lose (every
        reply was already taken); raising would fail a finished job or hide the
        error that is already on its way out.  It is logged as a warning.
        """
        with self._lock:
            port, self._port, self._fd, self._direct = self._port, None, None, None
            try:
                if port is not None:
                    port.close()
            except Exception as exc:  # noqa: BLE001  any failure of pyserial: logged, see above
                log.warning("port %s: closing failed: %s", self.url, describe(exc))
            finally:
                self._line_lock.release()

    def __enter__(self) -> Link[F]:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # --- exchange -------------------------------------------------------------------

    def exchange(self, request: Request[F, T], *, station: int | None = None) -> T:
        """Send ``request`` to ``station`` (default: the link's) and return its reply.

        Returns what ``request.decode`` makes of the reply: a typed value (or the
        family's error reply, when its codec decodes one: a value the caller inspects).
        Raises :class:`LinkTimeout` when a read got no valid reply after every
        retry, :class:`WriteUnconfirmed` when a write got none (it is never re-sent
        here), :class:`PortError` when the port fails.
        """
        st = self.station if station is None else station
        if request.is_write:  # before a byte of it is made (harlsync probe: reads only)
            refuse_write(request.payload, port=self.url, station=st)
        frame = request.encode(st)
        command = request.payload
        timeout = self.codec.reply_timeout(request, self.settings)
        late_window = timeout if self.late_window is None else self.late_window
        with self._lock:
            port = self._port
            if port is None:
                raise LinkError(
                    "link is not open",
                    port=self.url,
                    station=st,
                    station_text=self.codec.station_text(st),
                )
            self.stats.exchanges += 1
            self._settle(port, st, command, wait=True)
            self._check_line(st)
            attempts = 1 if request.is_write else 1 + max(0, self.settings.retries)
            failure = Failure("not sent")
            for attempt in range(attempts):
                if attempt:
                    self.stats.retries += 1
                    self._note(
                        logging.WARNING,
                        st,
                        command,
                        f"retry {attempt}/{attempts - 1} after {failure.reason}",
                    )
                    self._settle(port, st, command, wait=request.volatile)
                    self._check_line(st)
                sent = self._send(port, frame, st, command)
                # A reply still owed may be this attempt's (the earlier one's was taken):
                # it can come until this attempt's late window ends.
                due_by = sent + timeout + late_window
                if st in self._owed:
                    count, due = self._owed[st]
                    self._owed[st] = (count, max(due, due_by))
                result = self._await(port, request, st, timeout)
                if not isinstance(result, Failure):
                    if not request.is_write:  # a write's ack stands: it was sent, it took
                        self._check_line(st)
                    return result.value
                failure = result
                self.stats.timeouts += 1
                count, due = self._owed.get(st, (0, 0.0))
                self._owed[st] = (count + 1, max(due, due_by))
            raise self._no_reply(request, st, attempts, failure)

    @property
    def _write_timeout(self) -> float:
        return max(self.settings.timeout, 1.0)

    def _send(self, port: SerialPort, frame: bytes, station: int, command: str) -> float:
        """Write ``frame``; when it was written (``time.monotonic``)."""
        gap = self._replied_at + self.codec.reply_gap - time.monotonic()
        if gap > 0:  # the controller is not ready for the next command yet
            time.sleep(gap)
        if log.isEnabledFor(logging.DEBUG):
            log.debug("%s -> %s", self.url, hex_line(frame))
        self._sent = frame
        # No flush(): tcdrain waits, without any timeout, until the UART has sent the
        # frame (for ever if flow control holds it), and the reply deadline is far
        # longer than a request's time on the wire (1 s against 12 ms at 9600 baud).
        try:
            port.write(frame)
        except serial.SerialTimeoutException as exc:
            raise PortError(
                f"write timed out after {seconds(self._write_timeout)} s: the line takes no data; check "
                "the cable and the rtscts (hardware flow control) setting in robot.yaml",
                port=self.url,
                station=station,
                station_text=self.codec.station_text(station),
                command=command,
            ) from exc
        except Exception as exc:  # any failure of pyserial; see the module docstring
            raise self._gone(exc, station, command, " while sending") from exc
        return time.monotonic()

    def _take(self, port: SerialPort, station: int, command: str, *, ready: bool = False) -> bytes:
        """Whatever input is there, without waiting.  ``ready``: ``poll`` said there
        is some, so at least a byte is read (or pyserial says the port is gone).

        A port of our own with a descriptor is one ``os.read`` of what is there
        (non-blocking: nothing there is ``BlockingIOError``), no ``in_waiting``
        ioctl before it; an empty read when ``poll`` said there is input is the
        other end gone (a socket closed, a pty hung up).  Other ports go through
        pyserial.
        """
        fd = self._direct
        if fd is not None:
            try:
                data = os.read(fd, READ_SIZE)
            except BlockingIOError:
                data = b""
            except OSError as exc:
                raise self._gone(exc, station, command, "") from exc
            if not data and ready:
                raise self._gone(_closed(), station, command, "")
            return self._fed(data)
        try:
            waiting = port.in_waiting
            got: bytes = port.read(waiting or 1) if waiting or ready else b""
        except Exception as exc:  # any failure of pyserial; see the module docstring
            raise self._gone(exc, station, command, "") from exc
        return self._fed(got)

    def _wait(self, port: SerialPort, station: int, command: str, until: float) -> bytes:
        """Wait until input arrives or ``until`` (``time.monotonic``) passes; what came.

        A port without a descriptor is read with pyserial's timeout instead, at most
        :data:`~harlsync.link.port.POLL_INTERVAL` at a time.  On a port of our own
        the wait and the read are one ``poll`` and one ``os.read``, inline: a reply
        paced by a slow line comes in a dozen arrivals, each a wake-up of this loop.
        """
        if self._fd is None:
            return self._read_polled(port, station, command)
        try:  # poll, not select: a fleet's descriptors may pass select's 1024
            ready = self._poll.poll(max(0.0, until - time.monotonic()) * 1000)
        except Exception as exc:  # a descriptor closed under us; see the module docstring
            raise self._gone(exc, station, command, "") from exc
        fd = self._direct
        if not ready or fd is None:
            return self._take(port, station, command, ready=True) if ready else b""
        try:
            data = os.read(fd, READ_SIZE)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise self._gone(exc, station, command, "") from exc
        if not data:  # poll said there is input: the other end is gone
            raise self._gone(_closed(), station, command, "")
        self._rx += data
        self._decoder.feed(data)
        return data

    def _read_polled(self, port: SerialPort, station: int, command: str) -> bytes:
        """A port without a descriptor: wait up to one pyserial timeout for a byte,
        then take all that came."""
        try:
            waiting = port.in_waiting
            data: bytes = port.read(waiting or 1)
            if data and not waiting and port.in_waiting:  # the rest of what arrived with it
                data += port.read(port.in_waiting)
        except Exception as exc:  # any failure of pyserial; see the module docstring
            raise self._gone(exc, station, command, "") from exc
        return self._fed(data)

    def _fed(self, data: bytes) -> bytes:
        """``data`` counted and given to the decoder."""
        if data:
            self._rx += data
            self._decoder.feed(data)
        return data

    def _gone(self, exc: Exception, station: int, command: str, doing: str) -> PortError:
        return PortError(
            f"port went away{doing}: {describe(exc)}; {gone_hint(self.url)}",
            port=self.url,
            station=station,
            station_text=self.codec.station_text(station),
            command=command,
        )

    def _settle(self, port: SerialPort, station: int, command: str, *, wait: bool) -> None:
        """Discard pending input; with ``wait``, first let replies owed by ``station`` come."""
        # the usual case: nothing owed, and one read that finds nothing
        if (
            station not in self._owed
            and not self._take(port, station, command)
            and not self._decoder.pending
        ):
            return
        while True:
            count, due = self._owed.get(station, (0, 0.0))
            if count and time.monotonic() >= due:
                log.debug(
                    "%s station %s: %d missed reply(ies) never came",
                    self.url,
                    self.codec.station_text(station),
                    count,
                )
                del self._owed[station]
                self._overdue[station] = self._overdue.get(station, 0) + count
                count = 0
            if wait and count:
                data = self._wait(port, station, command, due)
            else:
                data = self._take(port, station, command)
            self._discard_frames(station)
            if not data and not (wait and count):
                break
        self._decoder.clear()
        self._log_rx()
        self._count_noise()

    def _await(
        self, port: SerialPort, request: Request[F, T], station: int, timeout: float
    ) -> _Reply[T] | Failure:
        """The decoded reply, read as it comes, or a :class:`Failure` once ``timeout``
        has passed."""
        deadline = time.monotonic() + timeout
        failure = Failure(f"no reply within {missed(timeout, self.settings.timeout)}")
        command = request.payload
        shown = self.codec.station_text(station)
        # Nothing is buffered when the request goes out (_settle cleared it): wait first.
        while True:
            if time.monotonic() >= deadline:
                self._count_noise()
                return failure
            if not self._wait(port, station, command, deadline):
                continue
            for frame in self._frames(station):
                if isinstance(frame, ProtocolError):
                    log.info("%s station %s %s: bad frame: %s", self.url, shown, command, frame)
                    failure = Failure(f"bad frame: {frame}", frame)
                    continue
                try:
                    value = request.decode(frame)
                except ReplyError as exc:
                    self.stats.unfitting += 1
                    log.info("%s station %s %s: discarded: %s", self.url, shown, command, exc)
                    failure = Failure(f"reply does not fit: {exc}", exc)
                    self._stray(station, frame.payload)
                    continue
                self._count_noise()
                self._replied_at = time.monotonic()
                return _Reply(value)


@dataclass(frozen=True)
class _Reply(Generic[T]):
    """The value an attempt got (a reply may decode to None, so it is wrapped)."""

    value: T
