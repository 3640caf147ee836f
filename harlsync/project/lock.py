"""One harlsync command at a time per project directory.

A command that saves into a project (pull, the backup of that robot, push and
rollback with their snapshot) holds this lock for as long as it runs.  Without
it, two pulls of one directory over two different lines (the line lock does not
meet them) each read their robot and save, and the project ends up as a mix of
the two robots, or as one of them with the other's summary and commit.

The lock is a lock file (:func:`harlsync.link.lock.take_lock_file`, removed when
released) in the directory of the line locks
(:func:`harlsync.link.default_lock_dir`), named after the project's resolved
path, with the holder's pid, host and command beside it for the message of a
command that finds it taken.  It lives outside the project so that a project
that cannot be written (a read-only mount) or does not exist yet (a first pull)
can still be locked, and it does not dirty the git work tree.  Within one
process it is reentrant per thread: a backup holds it around the pull it makes.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import re
import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import ParamSpec, TypeVar

from ..errors import ProjectError
from ..link import default_lock_dir
from ..link.lock import HeldLock, LockTimeout, take_lock_file, unusable_hint

__all__ = ["holding_project", "lock_path", "project_lock"]

_P = ParamSpec("_P")
_R = TypeVar("_R")

_guard = threading.Lock()
#: Locks this process holds: (lock file, thread) -> how many times it was entered.
_held: dict[tuple[Path, int], int] = {}


def lock_path(project: str | os.PathLike[str]) -> Path:
    """The lock file of the project directory ``project``."""
    key = str(Path(project).resolve())
    digest = hashlib.sha256(key.encode()).hexdigest()[:12]
    readable = re.sub(r"[^A-Za-z0-9.-]+", "_", key).strip("_")[-48:]
    return default_lock_dir() / f"project-{readable}-{digest}.lock"


def _owner_path(path: Path) -> Path:
    return path.with_name(path.name + ".owner")


@contextmanager
def project_lock(
    project: str | os.PathLike[str], *, timeout: float = 0.0, command: str = "harlsync"
) -> Iterator[None]:
    """Hold the project's lock for the ``with`` block, waiting up to ``timeout``
    seconds for another command to release it (negative: for ever).

    Raises ProjectError, naming the holder, when it is still taken after
    ``timeout``, and when the lock file cannot be made.
    """
    path = lock_path(project)
    mine = (path, threading.get_ident())
    with _guard:
        if mine in _held:
            _held[mine] += 1
            entered = True
        else:
            entered = False
    if entered:
        try:
            yield
        finally:
            with _guard:
                _held[mine] -= 1
        return
    lock = _acquire(project, path, timeout, command)
    with _guard:
        _held[mine] = 1
    try:
        yield
    finally:
        with _guard:
            del _held[mine]
        try:
            _owner_path(path).unlink()
        except OSError:
            pass
        lock.release()


def _acquire(project: str | os.PathLike[str], path: Path, timeout: float, command: str) -> HeldLock:
    try:
        lock = take_lock_file(path, timeout)
    except LockTimeout as exc:
        raise ProjectError(_busy_message(project, path)) from exc
    except OSError as exc:
        raise ProjectError(
            f"project {project}: cannot take its lock {path} ({exc.strerror or exc}); "
            f"{unusable_hint(path.parent)}"
        ) from exc
    try:
        _owner_path(path).write_text(f"{os.getpid()} {socket.gethostname()} {command}\n")
    except OSError:
        pass  # the holder is only for the message of a command that waits
    return lock


def holder(path: Path) -> str:
    """Who holds the lock file ``path``, as its owner file says: ``pid 4242 (harlsync
    backup)``, or ``another harlsync``."""
    try:
        pid, host, command = (_owner_path(path).read_text().split(" ", 2) + ["", ""])[:3]
    except (OSError, ValueError):  # gone, or not text: the holder is only for the message
        pid, host, command = "", "", ""
    who = "another harlsync"
    if pid:
        where = "" if host == socket.gethostname() else f" on {host}"
        what = f" (harlsync {command.strip()})" if command.strip() else ""
        who = f"pid {pid}{where}{what}"
    return who


def _busy_message(project: str | os.PathLike[str], path: Path) -> str:
    who = holder(path)
    return (
        f"project {project} is in use by {who}; wait for it to finish and run again, or "
        f"give --lock-timeout SECONDS to wait for it (lock file {path})"
    )


def holding_project(command: str) -> Callable[[Callable[_P, _R]], Callable[_P, _R]]:
    """Decorate a command so that it runs holding the lock of its project.

    The command names the project in its ``path`` argument and how long to wait
    for the lock in ``lock_timeout``, or in ``opts.lock_timeout``.
    """

    def decorate(func: Callable[_P, _R]) -> Callable[_P, _R]:
        signature = inspect.signature(func)

        @functools.wraps(func)
        def run(*args: _P.args, **kwargs: _P.kwargs) -> _R:
            given = signature.bind(*args, **kwargs)
            given.apply_defaults()
            values = given.arguments
            timeout = (
                values["lock_timeout"] if "lock_timeout" in values else values["opts"].lock_timeout
            )
            with project_lock(values["path"], timeout=float(timeout), command=command):
                return func(*args, **kwargs)

        return run

    return decorate
