"""File-system faults, in-process: a directory on a read-only file system, a full disk.

Both patch the calls through which Python writes files (``open`` for writing,
``os.open`` with a write flag, ``os.write``, ``mkdir``, ``rename``/``replace``,
``link``, ``unlink``, ``rmdir``) so that, for paths under one directory, they
fail as the kernel fails them, whoever the test runs as (``chmod`` does not stop
root).  Nothing outside that directory is affected: the simulator, the line
locks, the audit log and git work as usual.

- :func:`read_only`: every change under the directory fails with ``EROFS``.
- :func:`disk_full`: after ``after`` files were written whole, opening a file for
  writing still works (the empty file appears, as on a real full disk) and
  writing to it fails with ``ENOSPC``.
"""

from __future__ import annotations

import builtins
import errno
import io
import os
from pathlib import Path
from typing import Any

import pytest

_WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND


def _where(path: Any, dir_fd: int | None = None) -> str | None:
    """``path`` as an absolute path, or None for a file descriptor."""
    if isinstance(path, int):
        return None
    text = os.fsdecode(os.fspath(path))
    if dir_fd is not None and not os.path.isabs(text):
        text = os.path.join(os.readlink(f"/proc/self/fd/{dir_fd}"), text)
    return os.path.abspath(text)


def _under(root: str, path: Any, dir_fd: int | None = None) -> bool:
    where = _where(path, dir_fd)
    return where is not None and (where == root or where.startswith(root + os.sep))


def _fail(number: int, path: Any) -> None:
    raise OSError(number, os.strerror(number), os.fsdecode(os.fspath(path)))


def _writes(mode: str) -> bool:
    return any(c in mode for c in "wax+")


def read_only(monkeypatch: pytest.MonkeyPatch, directory: Path) -> None:
    """From now on, ``directory`` and everything below it is on a read-only file system."""
    root = os.path.abspath(directory)
    real_open, real_os_open = builtins.open, os.open

    def open_(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        if _writes(mode) and _under(root, file):
            _fail(errno.EROFS, file)
        return real_open(file, mode, *args, **kwargs)

    def os_open(path: Any, flags: int, mode: int = 0o777, *, dir_fd: int | None = None) -> int:
        if flags & _WRITE_FLAGS and _under(root, path, dir_fd):
            _fail(errno.EROFS, path)
        return real_os_open(path, flags, mode, dir_fd=dir_fd)

    monkeypatch.setattr(builtins, "open", open_)
    monkeypatch.setattr(io, "open", open_)
    monkeypatch.setattr(os, "open", os_open)
    for name in ("mkdir", "rmdir", "unlink", "remove"):
        monkeypatch.setattr(os, name, _refuse_one(root, getattr(os, name)))
    for name in ("rename", "replace", "link", "symlink"):
        monkeypatch.setattr(os, name, _refuse_two(root, getattr(os, name)))


def _refuse_one(root: str, real: Any) -> Any:
    def call(path: Any, *args: Any, dir_fd: int | None = None, **kwargs: Any) -> Any:
        if _under(root, path, dir_fd):
            _fail(errno.EROFS, path)
        return real(path, *args, dir_fd=dir_fd, **kwargs)

    return call


def _refuse_two(root: str, real: Any) -> Any:
    def call(src: Any, dst: Any, *args: Any, **kwargs: Any) -> Any:
        for path, fd in ((src, kwargs.get("src_dir_fd")), (dst, kwargs.get("dst_dir_fd"))):
            if _under(root, path, fd):
                _fail(errno.EROFS, path)
        return real(src, dst, *args, **kwargs)

    return call


class _NoSpace:
    """A file opened on a full disk: it exists, and every write to it fails."""

    def __init__(self, file: Any) -> None:
        self._file = file

    def write(self, data: Any) -> int:
        _fail(errno.ENOSPC, self._file.name)
        return 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self._file, name)

    def __enter__(self) -> _NoSpace:
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()


def disk_full(monkeypatch: pytest.MonkeyPatch, directory: Path, *, after: int = 0) -> list[str]:
    """From now on the disk that holds ``directory`` fills up: the first ``after``
    files opened for writing below it are written, every later write fails.

    Returns the list of files opened for writing below it, in order (for a test to
    see where the disk ran out).
    """
    root = os.path.abspath(directory)
    real_open, real_os_open, real_write = builtins.open, os.open, os.write
    opened: list[str] = []
    full_fds: set[int] = set()

    def open_(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        f = real_open(file, mode, *args, **kwargs)
        if _writes(mode) and _under(root, file):
            opened.append(str(file))
            if len(opened) > after:
                return _NoSpace(f)
        return f

    def os_open(path: Any, flags: int, mode: int = 0o777, *, dir_fd: int | None = None) -> int:
        fd = real_os_open(path, flags, mode, dir_fd=dir_fd)
        if flags & _WRITE_FLAGS and _under(root, path, dir_fd):
            opened.append(str(path))
            if len(opened) > after:
                full_fds.add(fd)
        return fd

    def write(fd: int, data: Any) -> int:
        if fd in full_fds:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(fd, data)

    def close(fd: int) -> None:
        full_fds.discard(fd)  # the number may name another file next
        real_close(fd)

    real_close = os.close
    monkeypatch.setattr(builtins, "open", open_)
    monkeypatch.setattr(io, "open", open_)
    monkeypatch.setattr(os, "open", os_open)
    monkeypatch.setattr(os, "write", write)
    monkeypatch.setattr(os, "close", close)
    return opened
