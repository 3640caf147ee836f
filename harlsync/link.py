"""One serial line to a HARL-U2 controller: send a request, get its reply.

How this works::

    exchange(request)
      | wait out replies still owed by earlier attempts, then drop pending input
      v
    write  STX station SP payload ETX LRC  ------------------------------->  controller
      |                                                                         |
    read in short polls into a FrameDecoder  <----------------------------  reply
      |   bad LRC, malformed, noise   : log, keep reading (the reply may follow)
      |   frame for another station   : ignore
      |   frame that does not fit     : discard (a late reply), keep reading
      v   deadline (settings.timeout) passes without a fitting reply
    read  : drain input, re-send; after settings.retries re-sends -> LinkTimeout
    write : never re-sent here -> WriteUnconfirmed (the controller reads the item back)

Late replies.  A reply that missed its deadline may still arrive, and most
replies carry no echo of what they answer (``LNT 3`` and ``LNT 4`` are both
answered ``0.50``), so a late reply would pass for the answer to the next
request.  Every attempt that got no reply therefore leaves a reply *owed* by
that station; before the next request is sent the link listens until owed
replies have come (and are discarded) or cannot come any more (``late_window``
seconds after their deadline).  That costs one ``late_window`` after a reply
that was really lost, and never returns a value that answers another request.

A retry of the same read may take the earlier attempt's late reply as its own
answer: the value is the same.  Not so for a volatile read (LNR, I/O and memory
bits): the task states may have changed between the two attempts, and a late
"idle" must never pass for the retry's "in execution".  Before re-sending a
volatile read the link therefore waits out owed replies too, as before a new
request.

Errors.  Whatever a pyserial call on the port raises (SerialException, OSError,
but also termios.error from a pty that went away, or TypeError from a port
closed under it) leaves the link as :class:`PortError`, one line that names the
port and says what to do; pyserial's own exceptions never get further.

Exclusive access.  pyserial's ``exclusive=True`` is advisory and device-only, so
the link also holds an inter-process :class:`filelock.FileLock` named after the
port (see :func:`lock_path`) for as long as it is open: processes that share a
line (stations 1-4 on one HNC) never interleave frames.  Within a process a lock
around each exchange does the same for threads sharing one :class:`Link`.
"""

from __future__ import annotations

import errno
import hashlib
import ipaddress
import logging
import os
import re
import select
import socket
import stat
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, ClassVar
from urllib.parse import urlsplit

import filelock
import serial
from serial.urlhandler import protocol_socket

from .errors import (
    LinkError,
    LinkTimeout,
    PortBusyError,
    PortError,
    ProtocolError,
    ReplyError,
    WriteUnconfirmed,
)
from .families.harl_u2.protocol import Frame, FrameDecoder, Request, decode_reply, encode_frame
from .settings import SerialSettings

__all__ = [
    "DEFAULT_LOCK_TIMEOUT",
    "POLL_INTERVAL",
    "Link",
    "LinkStats",
    "SerialSettings",
    "default_lock_dir",
    "lock_key",
    "lock_path",
]

log = logging.getLogger(__name__)

# sim:// URLs are served by harlsync/sim/protocol_sim.py.  pyserial imports the
# handler by name when such a URL is opened: the link itself never imports sim.
if "harlsync.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("harlsync.sim")

#: Seconds a second harlsync waits for the port before PortBusyError.
DEFAULT_LOCK_TIMEOUT = 10.0
#: pyserial read timeout: how often the link looks at its own deadline.
POLL_INTERVAL = 0.02
#: Retry reasons kept in :attr:`LinkStats.reasons` (the oldest are dropped).
MAX_REASONS = 500


@dataclass
class LinkStats:
    """What the link went through, for pull/backup reports.  Counts since creation."""

    exchanges: int = 0
    retries: int = 0
    #: attempts whose deadline passed without a fitting reply
    timeouts: int = 0
    #: frames with a bad LRC or malformed
    bad_frames: int = 0
    #: bytes discarded as line noise (outside any frame)
    noise_bytes: int = 0
    #: frames for another station, ignored
    other_station: int = 0
    #: well-formed frames for our station that did not answer the request
    unfitting: int = 0
    #: replies to earlier attempts that arrived after their deadline, discarded
    late_replies: int = 0
    #: writes whose reply was lost (WriteUnconfirmed)
    unconfirmed_writes: int = 0
    #: one line per retry or unconfirmed write: "port, station, command: reason"
    reasons: list[str] = field(default_factory=list)

    def note(self, reason: str) -> None:
        self.reasons.append(reason)
        del self.reasons[:-MAX_REASONS]


@dataclass(frozen=True)
class _Failure:
    """Why one attempt got no reply."""

    reason: str
    cause: ProtocolError | None = None


class Link:
    """One port (and the default station on it), opened by pyserial URL.

    ``url`` is a device path (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL
    (``socket://host:port``, ``rfc2217://``, ``loop://``, ``spy://``, ``sim://``).
    ``lock_timeout`` is the seconds to wait for another harlsync to release the
    port (0: fail at once, negative: wait for ever).  ``late_window`` is how long
    after its deadline a missed reply may still arrive (default: settings.timeout).
    """

    def __init__(
        self,
        url: str,
        station: int = 1,
        settings: SerialSettings | None = None,
        *,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | os.PathLike[str] | None = None,
        late_window: float | None = None,
    ) -> None:
        self.url = url
        self.station = station
        settings = SerialSettings() if settings is None else settings
        self.settings = settings
        self.lock_timeout = lock_timeout
        self.lock_path = lock_path(url, lock_dir)
        self.late_window = settings.timeout if late_window is None else late_window
        self.stats = LinkStats()
        self._port: Any = None  # serial.SerialBase once open
        self._fd: int | None = None  # the port's file descriptor, when select() can wait on it
        self._file_lock: filelock.BaseFileLock | None = None
        self._lock = threading.RLock()
        self._decoder = FrameDecoder()
        self._rx = bytearray()  # received bytes not yet logged; ends with the decoder's
        self._dropped_seen = 0
        self._owed: dict[int, tuple[int, float]] = {}  # station -> (replies, due by)

    # --- open / close ---------------------------------------------------------------

    @property
    def is_open(self) -> bool:
        return self._port is not None

    def open(self) -> Link:
        """Take the port's lock and open it.

        Raises :class:`PortBusyError` when another harlsync holds the port, and
        :class:`PortError` when it cannot be opened.
        """
        with self._lock:
            if self._port is not None:
                return self
            self._take_file_lock()
            try:
                self._port = self._open_port()
            except BaseException:
                self._release_file_lock()
                raise
            self._fd = _fileno(self._port)
            self._decoder = FrameDecoder()
            self._rx.clear()
            self._dropped_seen = 0
            self._owed.clear()
            log.info("opened %s (station %d, %s)", self.url, self.station, self.settings)
        return self

    def close(self) -> None:
        """Close the port and give its lock back.

        Never raises for the port itself: close runs on the way out of every
        job, and a port that fails to close has nothing left to lose (every
        reply was already taken); raising would fail a finished job or hide the
        error that is already on its way out.  It is logged as a warning.
        """
        with self._lock:
            port, self._port, self._fd = self._port, None, None
            try:
                if port is not None:
                    port.close()
            except Exception as exc:  # noqa: BLE001  any failure of pyserial: logged, see above
                log.warning("port %s: closing failed: %s", self.url, _describe(exc))
            finally:
                self._release_file_lock()

    def __enter__(self) -> Link:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _open_port(self) -> Any:
        s = self.settings
        try:
            if self.url.lower().startswith("socket://"):
                port = _SocketPort(None)
                port.port = self.url
            else:
                port = serial.serial_for_url(self.url, do_not_open=True)
        except Exception as exc:  # ValueError for an unknown scheme, SerialException for a bad URL
            raise self._open_error(exc) from exc
        try:
            port.baudrate = s.baudrate
            port.bytesize = s.bytesize
            port.parity = s.parity
            port.stopbits = s.stopbits
            port.rtscts = s.rtscts
            port.timeout = POLL_INTERVAL
            port.write_timeout = self._write_timeout
            if "://" not in self.url:
                port.exclusive = True
        except Exception as exc:
            raise PortError(
                f"serial settings not accepted: {_describe(exc)}; fix baud, data bits, parity "
                "and stop bits in robot.yaml",
                port=self.url,
            ) from exc
        try:
            port.open()
        except Exception as exc:
            raise self._open_error(exc) from exc
        try:
            port.reset_input_buffer()
        except Exception as exc:
            try:
                port.close()
            except Exception as close_exc:  # noqa: BLE001  the error worth raising is exc
                log.debug("port %s: closing failed: %s", self.url, _describe(close_exc))
            raise PortError(
                f"port went away right after opening: {_describe(exc)}; {_gone_hint(self.url)}",
                port=self.url,
            ) from exc
        return port

    def _open_error(self, exc: Exception) -> LinkError:
        """What opening the port failed with, one line with what to do."""
        url = self.url
        text = _describe(exc)
        device = "://" not in url
        unknown = re.search(r"protocol '([^']*)' not known", text)
        if isinstance(exc, ValueError) and unknown:
            return PortError(
                f"unknown port type '{unknown.group(1)}://'; use a device path (/dev/ttyUSB0, "
                "COM3), socket://HOST:PORT, rfc2217://HOST:PORT or sim://PROJECT_DIR",
                port=url,
            )
        scheme = url.split("://", 1)[0].lower() if "://" in url else ""
        if scheme in ("socket", "rfc2217") and not _port_number(url):
            return PortError(
                f"not a {scheme}:// address; give {scheme}://HOST:PORT, PORT a number from "
                "1 to 65535",
                port=url,
            )
        if "exclusively lock" in text:
            return PortBusyError(
                "in use by another program (it holds the device lock); close that program "
                f"(fuser -v {url} names it) and run again",
                port=url,
            )
        if _caused_by(exc, ConnectionRefusedError) or re.search(
            r"\[Errno (111|61|10061)\]|connection refused", text, re.IGNORECASE
        ):
            where = urlsplit(url.split("://", 1)[-1] if url.startswith("spy://") else url).netloc
            return PortError(
                f"nothing accepts connections at {where or url}; is the serial device server "
                "(or harlsync sim --listen) running, and is the address right?",
                port=url,
            )
        if device and _has_errno(exc, errno.ENOENT, FileNotFoundError):
            windows = _COM_RE.fullmatch(url)
            listing = "Device Manager > Ports" if windows else "ls /dev/ttyUSB* /dev/ttyACM*"
            return PortError(
                "no such device; check that the USB-serial adapter is plugged in and the port "
                f"name ({listing})",
                port=url,
            )
        if device and not _COM_RE.fullmatch(url):
            what = _not_a_tty(url, exc)
            if what:
                return PortError(
                    f"not a serial port ({what}); give the serial device the robot's cable is "
                    "on, e.g. /dev/ttyUSB0 (ls /dev/ttyUSB* /dev/ttyACM* /dev/serial/by-id)",
                    port=url,
                )
        if device and not _COM_RE.fullmatch(url) and _has_errno(exc, errno.EACCES, PermissionError):
            return PortError(
                "permission denied; add your user to the group that owns the device "
                f"(ls -l {url}, usually dialout) and log in again",
                port=url,
            )
        # pyserial says "[Errno N] could not open port URL: why"; the port is named already.
        why = re.sub(
            r"^(?:\[Errno \d+\] )?could not open port .*?: ", "", text, count=1, flags=re.IGNORECASE
        )
        return PortError(f"cannot open: {why}; {_open_hint(url)}", port=url)

    def _take_file_lock(self) -> None:
        path = self.lock_path
        if path is None:
            return
        try:
            if not path.parent.is_dir():
                path.parent.mkdir(parents=True, exist_ok=True)
                # Shared by every user who runs harlsync (sticky, like /tmp).
                os.chmod(path.parent, 0o1777)
            lock = filelock.FileLock(str(path), mode=0o666, thread_local=False)
            lock.acquire(timeout=self.lock_timeout)
        except filelock.Timeout as exc:
            raise PortBusyError(self._busy_message(path), port=self.url) from exc
        except OSError as exc:
            raise PortError(
                f"cannot take the port lock {path}: {exc}; set HARLSYNC_LOCK_DIR to a writable "
                "directory",
                port=self.url,
            ) from exc
        self._file_lock = lock
        try:
            _owner_path(path).write_text(f"{os.getpid()} {socket.gethostname()}\n")
        except OSError as exc:  # the pid is only for the message of a waiting harlsync
            log.debug("cannot record the lock holder in %s: %s", _owner_path(path), exc)

    def _release_file_lock(self) -> None:
        lock, self._file_lock = self._file_lock, None
        if lock is None:
            return
        try:
            _owner_path(Path(lock.lock_file)).unlink()
        except OSError:
            pass
        lock.release()

    def _busy_message(self, path: Path) -> str:
        who = "another harlsync"
        try:
            pid, _, host = _owner_path(path).read_text().strip().partition(" ")
        except OSError:
            pid, host = "", ""
        if pid == str(os.getpid()) and host == socket.gethostname():
            who = "another Link of this process"
        elif pid:
            who += f" (pid {pid}{'' if host == socket.gethostname() else ' on ' + host})"
        return f"in use by {who}; wait for it to finish or use --lock-timeout (lock file {path})"

    # --- exchange -------------------------------------------------------------------

    def exchange(self, request: Request, *, station: int | None = None) -> Any:
        """Send ``request`` to ``station`` (default: the link's) and return its reply.

        Returns what :func:`~harlsync.protocol.decode_reply` makes of the reply:
        a typed value, or an :class:`~harlsync.protocol.ErrorReply` for ``E`` +
        status.  Raises :class:`LinkTimeout` when a read got no valid reply after
        every retry, :class:`WriteUnconfirmed` when a write got none (it is never
        re-sent here), :class:`PortError` when the port fails.
        """
        st = self.station if station is None else station
        frame = encode_frame(st, request.payload)
        with self._lock:
            port = self._port
            if port is None:
                raise LinkError("link is not open", port=self.url, station=st)
            self.stats.exchanges += 1
            self._settle(port, st, request, wait=True)
            attempts = 1 if request.is_write else 1 + max(0, self.settings.retries)
            failure = _Failure("not sent")
            for attempt in range(attempts):
                if attempt:
                    self.stats.retries += 1
                    self._note(
                        logging.WARNING,
                        st,
                        request,
                        f"retry {attempt}/{attempts - 1} after {failure.reason}",
                    )
                    self._settle(port, st, request, wait=request.volatile)
                sent = self._send(port, frame, st, request)
                # A reply still owed may be this attempt's (the earlier one's was taken):
                # it can come until this attempt's late window ends.
                due_by = sent + self.settings.timeout + self.late_window
                if st in self._owed:
                    count, due = self._owed[st]
                    self._owed[st] = (count, max(due, due_by))
                result = self._await(port, request, st)
                if not isinstance(result, _Failure):
                    return result
                failure = result
                self.stats.timeouts += 1
                count, due = self._owed.get(st, (0, 0.0))
                self._owed[st] = (count + 1, max(due, due_by))
            if request.is_write:
                self.stats.unconfirmed_writes += 1
                self._note(logging.WARNING, st, request, f"write unconfirmed: {failure.reason}")
                raise WriteUnconfirmed(
                    f"no valid reply to this write ({failure.reason}); it may or may not have "
                    "taken: read the item back before sending it again",
                    port=self.url,
                    station=st,
                    command=request.payload,
                ) from failure.cause
            raise LinkTimeout(
                f"no valid reply after {attempts} attempt(s) (last: {failure.reason}); check "
                "the station number (pendant: SYSTEM GENERATION > MAINTENANCE > STATION NO.), "
                "the cable, and the serial settings (baud, parity) in robot.yaml",
                port=self.url,
                station=st,
                command=request.payload,
            ) from failure.cause

    def _note(self, level: int, station: int, request: Request, reason: str) -> None:
        line = f"port {self.url}, station {station}, command {request.payload}: {reason}"
        self.stats.note(line)
        log.log(level, "%s", line)

    @property
    def _write_timeout(self) -> float:
        return max(self.settings.timeout, 1.0)

    def _send(self, port: Any, frame: bytes, station: int, request: Request) -> float:
        if log.isEnabledFor(logging.DEBUG):
            log.debug("%s -> %s", self.url, _hex(frame))
        # No flush(): tcdrain waits, without any timeout, until the UART has sent the
        # frame (for ever if flow control holds it), and the reply deadline is far
        # longer than a request's time on the wire (1 s against 12 ms at 9600 baud).
        try:
            port.write(frame)
        except serial.SerialTimeoutException as exc:
            raise PortError(
                f"write timed out after {self._write_timeout:g} s: the line takes no data; check "
                "the cable and the rtscts (hardware flow control) setting in robot.yaml",
                port=self.url,
                station=station,
                command=request.payload,
            ) from exc
        except Exception as exc:  # any failure of pyserial; see the module docstring
            raise self._gone(exc, station, request, " while sending") from exc
        return time.monotonic()

    def _read(self, port: Any, station: int, request: Request, *, block: bool) -> bytes:
        """Whatever input is there; with ``block``, wait up to one poll for a byte."""
        try:
            if block and self._fd is not None:
                # One select, then one read of all that came: a blocking read(1) and a
                # second read of the rest would cost two more syscalls per wake-up.
                select.select([self._fd], [], [], POLL_INTERVAL)
                block = False
            waiting = port.in_waiting
            data: bytes = port.read(waiting or 1) if waiting or block else b""
            if data and not waiting and port.in_waiting:  # the rest of what arrived with it
                data += port.read(port.in_waiting)
        except Exception as exc:  # any failure of pyserial; see the module docstring
            raise self._gone(exc, station, request, "") from exc
        if data:
            self._rx += data
            self._decoder.feed(data)
        return data

    def _gone(self, exc: Exception, station: int, request: Request, doing: str) -> PortError:
        return PortError(
            f"port went away{doing}: {_describe(exc)}; {_gone_hint(self.url)}",
            port=self.url,
            station=station,
            command=request.payload,
        )

    def _log_rx(self) -> None:
        """Log, as one hex line, the received bytes the decoder is done with.

        Called after each frame (or bad frame, or noise) is taken from the
        decoder, so a reply that came in single bytes is still one line.
        """
        done = len(self._rx) - self._decoder.pending
        if done > 0:
            if log.isEnabledFor(logging.DEBUG):
                log.debug("%s <- %s", self.url, _hex(bytes(self._rx[:done])))
            del self._rx[:done]

    def _count_noise(self) -> None:
        self.stats.noise_bytes += self._decoder.dropped - self._dropped_seen
        self._dropped_seen = self._decoder.dropped

    def _settle(self, port: Any, station: int, request: Request, *, wait: bool) -> None:
        """Discard pending input; with ``wait``, first let replies owed by ``station`` come."""
        while True:
            count, due = self._owed.get(station, (0, 0.0))
            if count and time.monotonic() >= due:
                log.debug(
                    "%s station %d: %d missed reply(ies) never came", self.url, station, count
                )
                del self._owed[station]
                count = 0
            data = self._read(port, station, request, block=wait and count > 0)
            self._discard_frames(station)
            if not data and not (wait and count):
                break
        self._decoder.clear()
        self._log_rx()
        self._count_noise()

    def _frames(self, station: int) -> Iterator[Frame | ProtocolError]:
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
            self._log_rx()
            if frame is None:
                return
            if frame.station != station:
                self.stats.other_station += 1
                log.debug("%s: ignored a frame for station %d", self.url, frame.station)
                continue
            yield frame

    def _discard_frames(self, station: int) -> None:
        for item in self._frames(station):
            if isinstance(item, ProtocolError):
                log.info("%s: discarded bad frame: %s", self.url, item)
            else:
                self._late_reply(station, item.payload)

    def _late_reply(self, station: int, payload: str) -> None:
        count, due = self._owed.get(station, (0, 0.0))
        self.stats.late_replies += 1
        log.info("%s station %d: discarded late reply %r", self.url, station, payload)
        if count > 1:
            self._owed[station] = (count - 1, due)
        else:
            self._owed.pop(station, None)

    def _await(self, port: Any, request: Request, station: int) -> Any:
        """The decoded reply, or a :class:`_Failure` once the deadline has passed."""
        deadline = time.monotonic() + self.settings.timeout
        failure = _Failure(f"no reply within {self.settings.timeout:g} s")
        while True:
            for frame in self._frames(station):
                if isinstance(frame, ProtocolError):
                    log.info("%s station %d %s: bad frame: %s", self.url, station, request, frame)
                    failure = _Failure(f"bad frame: {frame}", frame)
                    continue
                try:
                    value = decode_reply(request, frame.payload)
                except ReplyError as exc:
                    self.stats.unfitting += 1
                    log.info("%s station %d %s: discarded: %s", self.url, station, request, exc)
                    failure = _Failure(f"reply does not fit: {exc}", exc)
                    if station in self._owed:
                        self._late_reply(station, frame.payload)
                    continue
                self._count_noise()
                return value
            if time.monotonic() >= deadline:
                self._count_noise()
                return failure
            self._read(port, station, request, block=True)


class _SocketPort(protocol_socket.Serial):  # type: ignore[misc]
    """pyserial's ``socket://`` port, whose close() does not sleep.

    pyserial sleeps 0.3 s after every close, "in case of quick reconnects, give
    the server some time": every command, and every robot of a backup, paid it.
    Here only a reconnect to the same address within that time waits for the rest.
    """

    REOPEN_GAP = 0.3
    _closed_at: ClassVar[dict[str, float]] = {}  # address -> when last closed

    def open(self) -> None:
        address = lock_key(self.portstr or "") or ""
        wait = self._closed_at.get(address, 0.0) + self.REOPEN_GAP - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        super().open()

    def close(self) -> None:
        sock: socket.socket | None = getattr(self, "_socket", None)
        if sock is not None:
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass  # the peer has gone already: close all the same
            finally:
                sock.close()
            self._socket = None
            self._closed_at[lock_key(self.portstr or "") or ""] = time.monotonic()
        self.is_open = False


def _fileno(port: Any) -> int | None:
    """The descriptor of a device or socket:// port; None for ports without one
    (sim://, loop://, rfc2217://), which the link waits on with a timed read."""
    try:
        fd = port.fileno()
    except (AttributeError, OSError, ValueError, serial.SerialException):
        return None
    return fd if isinstance(fd, int) and fd >= 0 else None


def _hex(data: bytes) -> str:
    return data.hex(" ").upper()


def _describe(exc: BaseException) -> str:
    """One line for an exception from pyserial or below it."""
    args = exc.args
    if isinstance(exc, (OSError, ValueError)):  # SerialException is an OSError
        text = str(exc)
    elif len(args) == 2 and isinstance(args[0], int) and isinstance(args[1], str):
        text = f"[Errno {args[0]}] {args[1]}"  # termios.error, which is not an OSError
    else:
        text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    return " ".join(text.split())


def _chain(exc: BaseException) -> Iterator[BaseException]:
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        yield current
        current = current.__cause__ or current.__context__


def _caused_by(exc: BaseException, kind: type[BaseException]) -> bool:
    return any(isinstance(e, kind) for e in _chain(exc))


def _has_errno(exc: BaseException, number: int, kind: type[OSError]) -> bool:
    """``exc`` or what it came from is errno ``number``, or names ``kind`` (Windows)."""
    return any(
        getattr(e, "errno", None) == number or isinstance(e, kind) for e in _chain(exc)
    ) or kind.__name__ in str(exc)


def _not_a_tty(path: str, exc: BaseException) -> str | None:
    """What ``path`` is, when opening it failed because it is no terminal device
    (pyserial's "Could not configure port: (25, 'Inappropriate ioctl ...')", or
    "Is a directory")."""
    codes = {getattr(e, "errno", None) or (e.args[:1] or (None,))[0] for e in _chain(exc)}
    if not codes & {errno.ENOTTY, errno.EISDIR}:
        return None
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return "not a terminal device"
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISREG(mode):
        return "a regular file"
    return "a device that is not a terminal"


def _open_hint(url: str) -> str:
    scheme = url.split("://", 1)[0].lower() if "://" in url else ""
    if not scheme:
        return "check the cable/adapter and the port name"
    if scheme in ("socket", "rfc2217"):
        return "check the address and that the serial device server is up and reachable"
    if scheme == "sim":
        return "check the sim:// options and project directory"
    return "check the port URL"


def _gone_hint(url: str) -> str:
    scheme = url.split("://", 1)[0].lower() if "://" in url else ""
    if not scheme:
        return "check that the USB-serial adapter is still plugged in and the cable is seated"
    if scheme in ("socket", "rfc2217"):
        return "check that the serial device server is still up and reachable"
    return "check the port URL"


# --- the port lock -----------------------------------------------------------------


def default_lock_dir() -> Path:
    """``$HARLSYNC_LOCK_DIR``, else ``<tmp>/harlsync-locks``.

    One directory for every session and user of the machine: a per-session one
    (``$XDG_RUNTIME_DIR``) would let a cron job, which has no login session, and
    a push from a shell lock different files and share the line.
    """
    env = os.environ.get("HARLSYNC_LOCK_DIR")
    if env:
        return Path(env)
    return Path(tempfile.gettempdir()) / "harlsync-locks"


_COM_RE = re.compile(r"(?:\\\\\.\\)?(COM\d+)", re.IGNORECASE)


def lock_key(url: str) -> str | None:
    """The identity of the line ``url`` opens, or None for one no other process can share.

    Device paths resolve symlinks (``/dev/serial/by-id/...`` and ``/dev/ttyUSB0``
    are one line), ``COM3`` is upper-cased, ``spy://`` is the port it wraps,
    ``socket://`` and ``rfc2217://`` are host:port without options, the host
    resolved (``localhost`` and ``127.0.0.1`` are one machine), ``loop://``
    is private to its process (None), any other URL is taken as it is.
    """
    if "://" not in url:
        com = _COM_RE.fullmatch(url)
        if com:
            return com.group(1).upper()
        return os.path.realpath(url)
    scheme = url.split("://", 1)[0].lower()
    parts = urlsplit(url)
    if scheme == "loop":
        return None
    if scheme == "spy":
        return lock_key(parts.netloc + parts.path)
    if scheme in ("socket", "rfc2217"):
        port = _port_number(url)
        if port is None:  # not a port number: opening it will say so
            return f"{scheme}://{parts.netloc.lower()}"
        return f"{scheme}://{_host_key(parts.hostname or '')}:{port}"
    return url


def _port_number(url: str) -> int | None:
    """The TCP port of a ``socket://`` or ``rfc2217://`` URL, or None if it has none."""
    try:
        return urlsplit(url).port
    except ValueError:
        return None


def _host_key(host: str) -> str:
    """One name per machine: ``localhost``, ``127.0.0.1`` and ``::1`` are one
    (``loopback``), a name and its address are one (the lowest address it has)."""
    try:
        addresses = sorted({str(info[4][0]) for info in socket.getaddrinfo(host, None)})
    except (OSError, UnicodeError):
        return host.lower()  # unknown: opening the port will say so
    if not addresses:
        return host.lower()
    try:
        if any(ipaddress.ip_address(a.split("%", 1)[0]).is_loopback for a in addresses):
            return "loopback"
    except ValueError:
        pass
    return addresses[0]


def lock_path(url: str, lock_dir: str | os.PathLike[str] | None = None) -> Path | None:
    """The lock file for the line ``url`` opens (None when it needs none)."""
    key = lock_key(url)
    if key is None:
        return None
    digest = hashlib.sha256(key.encode()).hexdigest()[:12]
    readable = re.sub(r"[^A-Za-z0-9.-]+", "_", key).strip("_")[-48:]
    directory = Path(lock_dir) if lock_dir is not None else default_lock_dir()
    return directory / f"{readable}-{digest}.lock"


def _owner_path(path: Path) -> Path:
    return path.with_name(path.name + ".owner")
