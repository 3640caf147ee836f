"""The line lock: one harlsync at a time on a line, whatever the port is called.

pyserial's ``exclusive=True`` is advisory and device-only, so the link also holds
an inter-process lock file named after the line (see :func:`lock_path`) for as
long as it is open: processes that share a line
(several stations on one controller) never interleave frames.  A second harlsync waits for
it up to its lock timeout, then fails with :class:`PortBusyError` naming the
holder, whose pid and host sit in a file beside the lock::

    <lock dir>/dev_ttyUSB0-3f2a9c1b7d04.lock          the lock (a readable name + a hash)
    <lock dir>/dev_ttyUSB0-3f2a9c1b7d04.lock.owner    "4242 cell-pc"

Both files go when the lock is released, so that the directory does not fill with
one file per line and project ever used.  On POSIX the lock is ``flock(2)`` held by
:class:`LockFile`, which removes its file while it still holds it; a taker checks,
once it holds the lock, that the file it locked is still the one at the path, and
starts again if not.  On Windows it is a byte of the file locked with
``msvcrt.locking`` (:class:`WindowsLockFile`): a file another process has open
cannot be removed there, so its last holder removes it.  A holder killed without
releasing leaves both files, its flock gone with it: the next lock taken in the
directory reclaims them (:func:`reclaim_dead`).

Both are a few system calls of this module's own, not a library's: a pull takes the
lock before its first request, and every module imported before it is start-up
(issue 24; ``filelock`` was 21 modules).
"""

from __future__ import annotations

import errno
import hashlib
import logging
import os
import re
import socket
import stat
import time
from pathlib import Path
from typing import Protocol

from ..errors import PortBusyError, PortError
from .linename import add_tcp_scheme, is_com_port, lock_key, port_number

__all__ = [
    "DEFAULT_LOCK_TIMEOUT",
    "FALLBACK_LOCK_DIR",
    "SYSTEM_LOCK_DIRS",
    "HeldLock",
    "LineLock",
    "LockFile",
    "LockTimeout",
    "WindowsLockFile",
    "add_tcp_scheme",
    "default_lock_dir",
    "is_com_port",
    "lock_key",
    "lock_path",
    "port_number",
    "reclaim_dead",
    "take_lock_file",
    "unusable_hint",
]

log = logging.getLogger(__name__)

#: Seconds a second harlsync waits for the port before PortBusyError.
DEFAULT_LOCK_TIMEOUT = 10.0

#: Where the machine keeps lock files, in order of preference (FHS: ``/run/lock``,
#: and ``/var/lock``, often a link to it).  Not under ``/tmp``: systemd's
#: ``PrivateTmp`` gives a service a ``/tmp`` of its own.
SYSTEM_LOCK_DIRS: tuple[Path, ...] = (Path("/run/lock"), Path("/var/lock"))
#: The last resort on a POSIX machine without a usable ``/run/lock``: fixed, never
#: ``$TMPDIR``, which differs between processes.
FALLBACK_LOCK_DIR = Path("/tmp/harlsync-locks")


def default_lock_dir() -> Path:
    """The directory of every harlsync lock on this machine (lines and projects).

    ``$HARLSYNC_LOCK_DIR`` when set; else ``harlsync/`` under the first of
    :data:`SYSTEM_LOCK_DIRS` that has it already or that every user may write
    (mode o+w: it is made there, sticky and writable by all); else
    :data:`FALLBACK_LOCK_DIR` (on Windows ``%ProgramData%\\harlsync\\locks``).

    The choice depends on the machine only, never on the process: not on
    ``$TMPDIR`` (a cron job or a service may have another one, or systemd's
    ``PrivateTmp``), not on the session (``$XDG_RUNTIME_DIR``: cron has none),
    not on the user (root and an engineer must meet on one line).  A ``/run/lock``
    only root may write is therefore not used until an administrator makes
    ``/run/lock/harlsync`` (mode 1777).
    """
    env = os.environ.get("HARLSYNC_LOCK_DIR")
    if env:
        return Path(env)
    if os.name == "nt":
        return Path(os.environ.get("PROGRAMDATA") or r"C:\ProgramData") / "harlsync" / "locks"
    for base in SYSTEM_LOCK_DIRS:
        mine = base / "harlsync"
        try:
            if mine.is_dir() or (base.is_dir() and base.stat().st_mode & stat.S_IWOTH):
                return mine
        except OSError:
            continue
    return FALLBACK_LOCK_DIR


class HeldLock(Protocol):
    """A lock file this process holds (:class:`LockFile`, :class:`WindowsLockFile`)."""

    @property
    def lock_file(self) -> str: ...

    def release(self) -> None: ...


#: Seconds between two tries of a lock another process holds.
_POLL = 0.05
_CONTENDED = frozenset({errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK})


class LockTimeout(TimeoutError):
    """Another process held the lock file past the timeout (its path is the message)."""


class _HeldFile:
    """A lock file held through the descriptor ``fd`` (None once released)."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path = path
        self._fd: int | None = fd

    @property
    def lock_file(self) -> str:
        return str(self.path)


class LockFile(_HeldFile):
    """A lock file held with ``flock(2)`` through the descriptor ``fd``: closing it
    releases the lock, and :meth:`release` removes the file first (while the lock is
    still held, so that no other process can have taken it)."""

    @classmethod
    def take(cls, path: Path, timeout: float) -> LockFile:
        """Hold ``path``, waiting up to ``timeout`` seconds for another holder
        (negative: for ever).  Raises :class:`LockTimeout` past it, OSError when
        the file cannot be opened or made."""
        import fcntl  # POSIX only: Windows has WindowsLockFile

        deadline = None if timeout < 0 else time.monotonic() + timeout
        while True:
            fd = _open_lock_file(path)
            if fd is None:
                continue  # removed by its holder between our two opens
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                os.close(fd)
                if exc.errno not in _CONTENDED:
                    raise
                if deadline is not None and time.monotonic() >= deadline:
                    raise LockTimeout(str(path)) from None
                time.sleep(_POLL)
                continue
            try:
                if os.path.samestat(os.fstat(fd), os.stat(path, follow_symlinks=False)):
                    return cls(path, fd)
            except FileNotFoundError:
                pass
            os.close(fd)  # its last holder removed that file as we locked it: take the new one

    def release(self) -> None:
        """Remove the file, then give the lock back (nothing when it is not held)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            if os.path.samestat(os.fstat(fd), os.stat(self.path, follow_symlinks=False)):
                self.path.unlink()
        except OSError as exc:  # another user's file in a sticky directory: it stays, empty
            log.debug("cannot remove the lock file %s: %s", self.path, exc)
        finally:
            os.close(fd)


def _open_lock_file(path: Path) -> int | None:
    """A descriptor of the lock file ``path``, made (mode 0666) when there is none;
    None when it went between the tries.  An existing file is opened without
    ``O_CREAT``, which Linux refuses (``fs.protected_regular``) for another user's
    file in a sticky directory."""
    flags = os.O_RDWR | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        return os.open(path, flags)
    except FileNotFoundError:
        pass
    try:
        fd = os.open(path, flags | os.O_CREAT | os.O_EXCL, 0o666)
    except FileExistsError:
        return None
    try:
        os.fchmod(fd, 0o666)  # whatever the umask: root's cron job and a user share it
    except OSError:
        pass
    return fd


class WindowsLockFile(_HeldFile):
    """Windows: the first byte of the lock file locked with ``msvcrt.locking``, through
    the descriptor ``fd``.  :meth:`release` unlocks and closes it, then removes the
    file, which Windows refuses while another process has it open (a waiter): the
    last holder removes it."""

    @classmethod
    def take(cls, path: Path, timeout: float) -> WindowsLockFile:
        """As :meth:`LockFile.take`: raises :class:`LockTimeout` past ``timeout``
        seconds (negative: waits for ever), OSError when the file cannot be opened."""
        try:
            import msvcrt
        except ImportError:
            raise OSError(
                errno.ENOSYS, "this system has neither flock(2) nor msvcrt.locking"
            ) from None
        deadline = None if timeout < 0 else time.monotonic() + timeout
        flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOINHERIT", 0)
        while True:
            try:
                fd = os.open(path, flags, 0o666)
            except PermissionError:
                # the holder's file, removed as it let go while a scanner had it open,
                # is "delete pending" until the scanner closes it: contended, not broken
                if deadline is not None and time.monotonic() >= deadline:
                    raise LockTimeout(str(path)) from None
                time.sleep(_POLL)
                continue
            try:
                msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)  # type: ignore[attr-defined,unused-ignore]
            except OSError as exc:
                os.close(fd)
                if exc.errno not in _CONTENDED | {errno.EDEADLK}:
                    raise
                if deadline is not None and time.monotonic() >= deadline:
                    raise LockTimeout(str(path)) from None
                time.sleep(_POLL)
                continue
            return cls(path, fd)

    def release(self) -> None:
        """Unlock and close the file, then remove it unless another process has it
        open (nothing when it is not held)."""
        import msvcrt

        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)  # type: ignore[attr-defined,unused-ignore]
        finally:
            os.close(fd)
        try:
            self.path.unlink()
        except OSError as exc:  # a waiter has it open: it is that one's now
            log.debug("cannot remove the lock file %s: %s", self.path, exc)


def take_lock_file(path: Path, timeout: float) -> HeldLock:
    """Hold the lock file ``path``, making its directory first if need be: one every
    user of the machine may use (sticky and writable by all, like ``/tmp``), since
    root's cron job and an engineer's shell must meet in it.  The locks that
    processes of this machine died holding are reclaimed first (:func:`reclaim_dead`).

    Raises :class:`LockTimeout` when another holder keeps it past ``timeout``
    seconds, and :class:`OSError` when the directory or the file cannot be made.
    """
    directory = path.parent
    if not directory.is_dir():
        try:
            directory.mkdir(parents=True)
        except FileExistsError:
            pass  # another harlsync made it meanwhile: it set the mode
        else:
            os.chmod(directory, 0o1777)
    if os.name == "nt":
        return WindowsLockFile.take(path, timeout)
    reclaim_dead(directory)
    return LockFile.take(path, timeout)


def _owner_pid(owner: Path) -> int | None:
    """The pid an owner file names when it is of this machine, else None."""
    try:
        pid, host = (owner.read_text().split() + ["", ""])[:2]
        return int(pid) if host == socket.gethostname() else None
    except (OSError, ValueError):
        return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process, or a pid we may not ask about
        return True
    return True


def reclaim_dead(directory: Path) -> list[Path]:
    """Remove the locks in ``directory`` whose owner file names a process of this
    machine that is gone (killed while it held them: the kernel released its lock,
    the files stayed), and return the lock files removed.  A lock some process holds
    now, or one of another machine, is left alone."""
    removed: list[Path] = []
    try:
        owners = [p for p in directory.iterdir() if p.name.endswith(".lock.owner")]
    except OSError:
        return removed
    for owner in owners:
        pid = _owner_pid(owner)
        if pid is None or _alive(pid):
            continue
        path = owner.with_name(owner.name[: -len(".owner")])
        try:
            lock = LockFile.take(path, 0)
        except OSError:  # LockTimeout too
            continue  # taken again meanwhile, or not ours to take
        try:
            if _owner_pid(owner) == pid:  # not rewritten by a new holder meanwhile
                owner.unlink()
        except OSError:
            pass
        finally:
            lock.release()
        log.debug("reclaimed the lock %s of pid %d, which is gone", path, pid)
        removed.append(path)
    return removed


def unusable_hint(directory: Path) -> str:
    """What to do about a lock directory this process cannot use, for a message."""
    return (
        f"every harlsync of this machine keeps its locks in {directory}: make it writable by "
        "all (chmod 1777), or set HARLSYNC_LOCK_DIR to one directory every user can write, "
        "the same for all"
    )


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
        self._lock: HeldLock | None = None

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
            lock = take_lock_file(path, timeout)
        except LockTimeout as exc:
            raise PortBusyError(self._busy_message(path), port=self.url) from exc
        except OSError as exc:
            raise PortError(
                f"cannot take the port lock {path}: {exc}; {unusable_hint(path.parent)}",
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
        except (OSError, ValueError):  # gone, or not text: the holder is only for the message
            pid, host = "", ""
        if pid == str(os.getpid()) and host == socket.gethostname():
            who = "another Link of this process"
        elif pid:
            who += f" (pid {pid}{'' if host == socket.gethostname() else ' on ' + host})"
        return f"in use by {who}; wait for it to finish or use --lock-timeout (lock file {path})"
