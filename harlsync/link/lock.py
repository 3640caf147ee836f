"""The line lock: one harlsync at a time on a line, whatever the port is called.

pyserial's ``exclusive=True`` is advisory and device-only, so the link also holds
an inter-process :class:`filelock.FileLock` named after the line (see
:func:`lock_path`) for as long as it is open: processes that share a line
(stations 1-4 on one HNC) never interleave frames.  A second harlsync waits for
it up to its lock timeout, then fails with :class:`PortBusyError` naming the
holder, whose pid and host sit in a file beside the lock::

    <lock dir>/dev_ttyUSB0-3f2a9c1b7d04.lock          the lock (a readable name + a hash)
    <lock dir>/dev_ttyUSB0-3f2a9c1b7d04.lock.owner    "4242 cell-pc"
"""

from __future__ import annotations

import hashlib
import ipaddress
import logging
import os
import re
import socket
import tempfile
from pathlib import Path
from urllib.parse import urlsplit

import filelock

from ..errors import PortBusyError, PortError

__all__ = [
    "DEFAULT_LOCK_TIMEOUT",
    "LineLock",
    "default_lock_dir",
    "is_com_port",
    "lock_key",
    "lock_path",
    "port_number",
]

log = logging.getLogger(__name__)

#: Seconds a second harlsync waits for the port before PortBusyError.
DEFAULT_LOCK_TIMEOUT = 10.0

_COM_RE = re.compile(r"(?:\\\\\.\\)?(COM\d+)", re.IGNORECASE)


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


def is_com_port(url: str) -> bool:
    """Whether ``url`` names a Windows COM port (``COM3``, ``\\\\.\\COM12``)."""
    return _COM_RE.fullmatch(url) is not None


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
        port = port_number(url)
        if port is None:  # not a port number: opening it will say so
            return f"{scheme}://{parts.netloc.lower()}"
        return f"{scheme}://{_host_key(parts.hostname or '')}:{port}"
    return url


def port_number(url: str) -> int | None:
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


class LineLock:
    """The inter-process lock on the line ``url`` opens, at ``path`` (None: no lock)."""

    def __init__(self, url: str, path: Path | None) -> None:
        self.url = url
        self.path = path
        self._lock: filelock.BaseFileLock | None = None

    def acquire(self, timeout: float) -> None:
        """Take the lock and record this process as its holder.

        ``timeout`` is the seconds to wait for another holder (0: fail at once,
        negative: wait for ever).  Raises :class:`PortBusyError` when another holder keeps it past the
        timeout, :class:`PortError` when the lock directory is unusable.
        """
        path = self.path
        if path is None:
            return
        try:
            if not path.parent.is_dir():
                path.parent.mkdir(parents=True, exist_ok=True)
                # Shared by every user who runs harlsync (sticky, like /tmp).
                os.chmod(path.parent, 0o1777)
            lock = filelock.FileLock(str(path), mode=0o666, thread_local=False)
            lock.acquire(timeout=timeout)
        except filelock.Timeout as exc:
            raise PortBusyError(self._busy_message(path), port=self.url) from exc
        except OSError as exc:
            raise PortError(
                f"cannot take the port lock {path}: {exc}; set HARLSYNC_LOCK_DIR to a writable "
                "directory",
                port=self.url,
            ) from exc
        self._lock = lock
        try:
            _owner_path(path).write_text(f"{os.getpid()} {socket.gethostname()}\n")
        except OSError as exc:  # the pid is only for the message of a waiting harlsync
            log.debug("cannot record the lock holder in %s: %s", _owner_path(path), exc)

    def release(self) -> None:
        """Give the lock back (nothing when it is not held)."""
        lock, self._lock = self._lock, None
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
