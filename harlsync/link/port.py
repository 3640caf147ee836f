"""Opening a port by URL, and saying in one line why it failed or went away.

:func:`open_port` opens a device path (``/dev/ttyUSB0``, ``COM3``) or any pyserial
URL (``socket://``, ``rfc2217://``, ``loop://``, ``spy://``, and our ``sim://``)
with a robot's serial settings.  Whatever pyserial raises on the way (ValueError
for an unknown scheme, SerialException, OSError, termios.error ...) becomes a
:class:`PortError` or :class:`PortBusyError` whose message names the port and
says what to do: :func:`open_error` reads the errno and the text to tell a
missing adapter from a refused connection, a busy device, a file that is no
terminal, a missing permission.  :func:`gone_hint` is the advice for a port that
fails after it was opened.
"""

from __future__ import annotations

import errno
import logging
import os
import re
import socket
import stat
import sys
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, ClassVar, Protocol
from urllib.parse import urlsplit

import serial
from serial.urlhandler import protocol_socket

from ..errors import LinkError, PortBusyError, PortError
from ..settings import SerialSettings
from .capture import spied
from .lock import is_com_port, lock_key, port_number

if TYPE_CHECKING:  # for the checker only: not imported before a first request
    from typing_extensions import Buffer

__all__ = [
    "POLL_INTERVAL",
    "SerialPort",
    "describe",
    "direct_fd",
    "fileno",
    "gone_hint",
    "open_error",
    "open_port",
]

log = logging.getLogger(__name__)

try:
    import fcntl
    import termios
except ImportError:  # Windows: pyserial's in_waiting for sockets
    _FIONREAD: int | None = None
else:
    _FIONREAD = termios.FIONREAD

#: pyserial read timeout: how often the link looks at its own deadline.
POLL_INTERVAL = 0.02


class SerialPort(Protocol):
    """What the link uses of an open pyserial port."""

    @property
    def in_waiting(self) -> int: ...

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes, /) -> int | None: ...

    def reset_input_buffer(self) -> None: ...

    def close(self) -> None: ...


def open_port(url: str, settings: SerialSettings, write_timeout: float) -> SerialPort:
    """The port ``url`` opened with ``settings``, its input buffer emptied.

    Its read timeout is :data:`POLL_INTERVAL`.  Raises :class:`PortError` (or
    :class:`PortBusyError` when another program holds the device) with a hint.
    """
    s = settings
    try:
        if url.lower().startswith("socket://"):
            port: serial.Serial | _SocketPort = _SocketPort(None)
            port.port = url
        else:
            port = serial.serial_for_url(url, do_not_open=True)
            if _PosixSerial is not None and type(port) is _PosixSerial:
                port.__class__ = _DevicePort
    except Exception as exc:  # ValueError for an unknown scheme, SerialException for a bad URL
        raise open_error(url, exc) from exc
    try:
        port.baudrate = s.baudrate
        port.bytesize = s.bytesize
        port.parity = s.parity
        port.stopbits = s.stopbits
        port.rtscts = s.rtscts
        port.timeout = POLL_INTERVAL
        port.write_timeout = write_timeout
        if "://" not in url:
            port.exclusive = True
    except Exception as exc:
        raise PortError(
            f"serial settings not accepted: {describe(exc)}; fix baud, data bits, parity "
            "and stop bits in robot.yaml",
            port=url,
        ) from exc
    try:
        port.open()
    except Exception as exc:
        raise open_error(url, exc) from exc
    try:
        port.reset_input_buffer()
    except Exception as exc:
        try:
            port.close()
        except Exception as close_exc:  # noqa: BLE001  the error worth raising is exc
            log.debug("port %s: closing failed: %s", url, describe(close_exc))
        raise PortError(
            f"port went away right after opening: {describe(exc)}; {gone_hint(url)}",
            port=url,
        ) from exc
    opened: SerialPort = spied(port)  # harlsync probe --capture: recorded
    return opened


def open_error(url: str, exc: Exception) -> LinkError:
    """What opening ``url`` failed with, one line with what to do."""
    text = describe(exc)
    device = "://" not in url
    unknown = re.search(r"protocol '([^']*)' not known", text)
    if isinstance(exc, ValueError) and unknown:
        return PortError(
            f"unknown port type '{unknown.group(1)}://'; use a device path (/dev/ttyUSB0, "
            "COM3), socket://HOST:PORT, rfc2217://HOST:PORT or sim://PROJECT_DIR",
            port=url,
        )
    scheme = url.split("://", 1)[0].lower() if "://" in url else ""
    if scheme in ("socket", "rfc2217") and not port_number(url):
        return PortError(
            f"not a {scheme}:// address; give {scheme}://HOST:PORT, PORT a number from 1 to 65535",
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
        listing = "Device Manager > Ports" if is_com_port(url) else "ls /dev/ttyUSB* /dev/ttyACM*"
        return PortError(
            "no such device; check that the USB-serial adapter is plugged in and the port "
            f"name ({listing})",
            port=url,
        )
    if device and not is_com_port(url):
        what = _not_a_tty(url, exc)
        if what:
            return PortError(
                f"not a serial port ({what}); give the serial device the robot's cable is "
                "on, e.g. /dev/ttyUSB0 (ls /dev/ttyUSB* /dev/ttyACM* /dev/serial/by-id)",
                port=url,
            )
    if device and not is_com_port(url) and _has_errno(exc, errno.EACCES, PermissionError):
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


class _SocketPort(protocol_socket.Serial):
    """pyserial's ``socket://`` port, whose close() does not sleep and which says
    how many bytes are waiting.

    pyserial sleeps 0.3 s after every close, "in case of quick reconnects, give
    the server some time": every command, and every robot of a backup, paid it.
    Here only a reconnect to the same address within that time waits for the rest.

    pyserial's ``in_waiting`` is 1 when anything is waiting, so a reader that reads
    what is waiting took a reply a byte per wake-up; here it is the byte count
    (``FIONREAD``, where the platform has it).

    pyserial's ``write`` waits in ``select`` after every ``send``, with a timer
    object; here a frame the socket's buffer takes whole is one ``send`` (the rest,
    and every error, goes to pyserial's, as for :class:`_DevicePort`).
    """

    def write(self, b: Buffer, /) -> int:
        data = bytes(b)
        sock: socket.socket | None = getattr(self, "_socket", None)
        done = 0
        if self.is_open and sock is not None:
            try:
                done = sock.send(data)
            except OSError:
                done = 0  # pyserial's write tells a full buffer from a connection gone
            if done == len(data):
                return done
        rest: int | None = super().write(data[done:])
        return done + (rest or 0)

    REOPEN_GAP = 0.3
    _closed_at: ClassVar[dict[str, float]] = {}  # address -> when last closed

    @property
    def in_waiting(self) -> int:
        if _FIONREAD is None or not self.is_open:
            waiting: int = super().in_waiting
            return waiting
        count = fcntl.ioctl(self.fileno(), _FIONREAD, b"\0\0\0\0")
        return int.from_bytes(count, sys.byteorder)

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


_PosixSerial: type[serial.SerialBase] | None = None
if os.name == "posix":
    from serial.serialposix import Serial as _Posix

    _PosixSerial = _Posix

    class _DevicePort(_Posix):
        """pyserial's port on a device path (a USB adapter, a pty), written and read
        with one system call each where one does.

        pyserial's ``write`` waits in ``select`` after every ``os.write`` and its
        ``read`` before every ``os.read``, with a timer object each: the link only
        reads what ``in_waiting`` or ``poll`` says is there and writes frames the
        kernel's buffer takes whole, so those calls cost more than the I/O.  Anything
        else (a partial write, a read that finds less than asked, an error) goes to
        pyserial's own, which waits, times out and words its errors as before.
        """

        def write(self, b: Buffer, /) -> int:
            data = bytes(b)  # the frame itself when it is bytes: no copy
            done = 0
            if self.is_open and self.fd is not None:
                try:
                    done = os.write(self.fd, data)
                except OSError:
                    done = 0  # pyserial's write tells EAGAIN from a port gone
                if done == len(data):
                    return done
            rest = super().write(data[done:])
            return done + (rest or 0)

        def read(self, size: int = 1) -> bytes:
            data = b""
            if self.is_open and self.fd is not None:
                try:
                    data = os.read(self.fd, size)
                except OSError:
                    pass  # nothing there, or the port gone: pyserial's read tells which
                if len(data) == size:
                    return data
            rest: bytes = super().read(size - len(data))
            return data + rest


def direct_fd(port: object) -> int | None:
    """The descriptor of a port the link may read with ``os.read`` itself: one of
    ours (a device path, ``socket://``), open, non-blocking as pyserial leaves it,
    and nothing between the descriptor and the bytes (``spy://`` logs them in its
    ``read``: it is read through pyserial).  None for any other port."""
    if _PosixSerial is not None and type(port) is _DevicePort:
        fd: int | None = port.fd
    elif type(port) is _SocketPort:
        sock: socket.socket | None = getattr(port, "_socket", None)
        fd = sock.fileno() if sock is not None else None
    else:
        return None
    return fd if isinstance(fd, int) and fd >= 0 else None


def fileno(port: object) -> int | None:
    """The descriptor of a device or socket:// port; None for ports without one
    (sim://, loop://, rfc2217://), which the link waits on with a timed read."""
    try:
        fd = port.fileno()  # type: ignore[attr-defined]
    except (AttributeError, OSError, ValueError, serial.SerialException):
        return None
    return fd if isinstance(fd, int) and fd >= 0 else None


def describe(exc: BaseException) -> str:
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


def gone_hint(url: str) -> str:
    """What to check when the port ``url`` fails after it was opened."""
    scheme = url.split("://", 1)[0].lower() if "://" in url else ""
    if not scheme:
        return "check that the USB-serial adapter is still plugged in and the cable is seated"
    if scheme in ("socket", "rfc2217"):
        return "check that the serial device server is still up and reachable"
    return "check the port URL"
