"""Atomic saves of a project's files: all or nothing, even when the process is
killed half way.  :func:`harlsync.project.store.save_project` renders and checks
the files first, then hands them to :func:`_commit`, which

1. writes each changed file to a temporary file next to it, and gives each
   file it will replace or remove a second name (a hard link);
2. writes the journal ``.harlsync-save.json``: what it is about to replace,
   with those names, then makes all of it durable at once: one ``syncfs(2)``
   of the file system the project is on (a failure before this point removes
   the temporaries: nothing else was touched);
3. replaces the targets one by one and removes the files no longer wanted (a
   failure here puts every old file back, from its second name);
4. makes the new names durable (a second ``syncfs``), deletes the journal and
   fsyncs the root: the save is done.  Then it drops the second names.

One ``syncfs`` instead of an fsync per file and per directory: the same
guarantee (every byte of every temporary and the journal is on stable storage
before the first rename, every rename before the journal goes; since Linux 5.8
``syncfs`` reports a write-back error of any file on that file system since the
directory was opened, so a failed write still fails the save), in one journal
commit instead of one per file.  Where there is no ``syncfs`` (not Linux, or an
older kernel), each file is fsynced as it is written and each directory in
step 2 and 4, as before.

A journal left behind means a process was killed in step 3: the next load or
save puts the previous project back from it, after checking that the process
that wrote it is gone.  Temporaries and second names of a killed process (their
names carry its pid) are removed the same way::

    .timers.yaml.harlsync-new-4242-9f3ab2c1     the new file, before step 3
    .timers.yaml.harlsync-old-4242-0c77e1d4     the old file, until step 4 ends
"""

from __future__ import annotations

import errno
import functools
import json
import logging
import os
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from ..errors import ProjectError
from . import statefile
from .files import LOCAL_DIR, SCHEMAS_DIR

__all__ = [
    "IN_PROGRESS",
    "JOURNAL",
    "check_replaceable",
    "disk_error",
    "recover",
    "replace_file",
]

log = logging.getLogger(__name__)


#: The journal of a save in progress (module docstring), in the project's root.
JOURNAL = ".harlsync-save.json"
_SIBLING_RE = re.compile(r"^\..+\.harlsync-(?:new|old)-([0-9]+)-[0-9a-f]+$")
#: Glob patterns of every name a save in progress puts beside the project's files
#: (:func:`_sibling`'s temporaries and second names, and the journal).
IN_PROGRESS = (".*.harlsync-new-*", ".*.harlsync-old-*", JOURNAL)


def _sibling(target: Path, what: str) -> Path:
    import secrets  # a save's, not a load's (robot.yaml before a pull's first request)

    return target.with_name(f".{target.name}.harlsync-{what}-{os.getpid()}-{secrets.token_hex(4)}")


def _write_temp(target: Path, data: bytes, *, fsync: bool = True) -> Path:
    """``data`` in a new temporary file beside ``target``, fsynced unless ``fsync`` is
    false (a :class:`_Batch` makes it durable); its path.  When the disk fails (full,
    read-only) the temporary is removed before the OSError."""
    temp = _sibling(target, "new")
    try:
        # os.open as open(temp, "xb") opens it, without a file object around the
        # descriptor (its fstat, isatty and seek: a save writes dozens of files)
        fd = os.open(temp, _NEW_FILE, 0o666)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
            if fsync:
                os.fsync(fd)
        finally:
            os.close(fd)
    except BaseException:
        _quietly(temp.unlink, missing_ok=True)
        raise
    return temp


_NEW_FILE = (
    os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
)


def replace_file(target: Path, data: bytes) -> None:
    """Replace ``target`` by a file holding ``data``, atomically: readers see the old
    file or the new one, and a failure leaves the old one and no temporary.

    Raises OSError when the disk fails.
    """
    temp = _write_temp(target, data)
    try:
        os.replace(temp, target)
    finally:
        _quietly(temp.unlink, missing_ok=True)


def check_replaceable(target: Path) -> None:
    """Raise OSError unless :func:`replace_file` could replace ``target`` now: it is
    no directory, and a file can be made beside it (one is, and removed at once)."""
    if target.is_dir():
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(target))
    _write_temp(target, b"", fsync=False).unlink()


def disk_error(exc: OSError, where: Path, doing: str) -> ProjectError:
    """A file-system failure while harlsync writes its own files, as one line: what
    failed and where, why, and what to do."""
    number = exc.errno
    if number in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
        hint = "free some space on that file system (df -h) and run again"
    elif number == errno.EROFS:
        hint = "it is on a read-only file system: mount it read-write and run again"
    elif number in (errno.EACCES, errno.EPERM):
        hint = f"this user may not write there: check its owner and mode (ls -ld {where})"
    else:
        hint = "check the disk and run again"
    return ProjectError(f"{where}: cannot {doing} ({exc.strerror or exc}): {hint}")


def _backup(target: Path) -> Path | None:
    """A second name for the current file (hard link, or copy), or None if absent."""
    if not target.exists():
        return None
    backup = _sibling(target, "old")
    try:
        os.link(target, backup)
    except OSError:
        try:
            import shutil  # only for a file with no second name (another file system)

            shutil.copy2(target, backup)
        except BaseException:
            _quietly(backup.unlink, missing_ok=True)
            raise
    return backup


#: The first kernel whose syncfs(2) reports write-back errors (errseq on the superblock):
#: before it, syncfs returns 0 whatever failed, and a save must fsync each file.
_SYNCFS_REPORTS_ERRORS = (5, 8)


def _kernel() -> tuple[int, int]:
    found = re.match(r"(\d+)\.(\d+)", os.uname().release) if hasattr(os, "uname") else None
    return (int(found.group(1)), int(found.group(2))) if found else (0, 0)


@functools.cache
def _load_syncfs() -> Callable[[int], int] | None:
    """``syncfs`` of the C library; None where it does not keep fsync's guarantee
    (not Linux, a kernel before 5.8) or cannot be called."""
    if not sys.platform.startswith("linux") or _kernel() < _SYNCFS_REPORTS_ERRORS:
        return None
    try:
        import ctypes  # only here: a save is its one user, after the robot was read

        function = ctypes.CDLL(None, use_errno=True).syncfs
    except (OSError, AttributeError):
        return None
    function.argtypes = [ctypes.c_int]
    function.restype = ctypes.c_int
    return cast("Callable[[int], int]", function)


def _syncfs(fd: int) -> None:
    """syncfs(2) of the file system ``fd`` is on; raises OSError (EIO: a file on it
    could not be written back)."""
    function = _load_syncfs()
    if function is None:
        raise OSError(errno.ENOSYS, "syncfs is not available")
    if function(fd) != 0:
        import ctypes

        number = ctypes.get_errno()
        raise OSError(number, os.strerror(number))


class _Batch:
    """Files written anew, made durable together by :meth:`sync`: one syncfs(2) per
    file system they are on.  A directory is opened before the first file is
    written in it, so that syncfs reports any write-back error since.  Without
    syncfs (:attr:`per_file`), each file is fsynced as it is written instead."""

    def __init__(self) -> None:
        self.per_file = _load_syncfs() is None
        self._fds: dict[int, int] = {}  # st_dev -> a directory on it, open
        self._dirs: set[Path] = set()

    def watch(self, directory: Path) -> None:
        """Call before writing a file in ``directory``."""
        if directory in self._dirs:
            return
        self._dirs.add(directory)
        if self.per_file:
            return
        device = os.stat(directory).st_dev
        if device not in self._fds:
            self._fds[device] = os.open(directory, os.O_RDONLY)

    def sync(self) -> None:
        """Every file written since each :meth:`watch` is on stable storage, and
        so are the names given to them."""
        if self.per_file:  # the files are fsynced: their names still need it
            for directory in self._dirs:
                _fsync_dir(directory)
            return
        for fd in self._fds.values():
            _syncfs(fd)

    def close(self) -> None:
        for fd in self._fds.values():
            _quietly(os.close, fd)
        self._fds.clear()


def _fsync_dir(directory: Path) -> None:
    if os.name != "posix":
        return  # directories cannot be opened for fsync on Windows
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@dataclass(frozen=True)
class _Entry:
    """One file of a save: its new content (None: removed) and its old one (None: new)."""

    name: str
    temp: Path | None
    old: Path | None


def _commit(root: Path, writes: dict[str, bytes], removes: list[str]) -> None:
    """Write and remove files under ``root`` as one set (see the module docstring)."""
    made_dirs: list[Path] = []
    entries: list[_Entry] = []
    batch = _Batch()
    try:
        present: set[Path] = set()  # directories found or made: each looked at once
        for name, data in writes.items():
            target = root / name
            if target.parent not in present:
                for parent in reversed([target.parent, *target.parent.parents]):
                    if parent not in present and not parent.exists():
                        batch.watch(parent.parent)  # where its name is
                        parent.mkdir()
                        made_dirs.append(parent)
                    present.add(parent)
            batch.watch(target.parent)
            # The old file's second name first: until the temporary exists the
            # entry reads as a removal, which an undo restores from that name.
            entries.append(_Entry(name, None, _backup(target)))
            temp = _write_temp(target, data, fsync=batch.per_file)
            entries[-1] = _Entry(name, temp, entries[-1].old)
        for name in removes:
            batch.watch((root / name).parent)
            entries.append(_Entry(name, None, _backup(root / name)))
        batch.watch(root)  # the journal's
        _write_journal(root, entries, made_dirs, batch)
        batch.sync()  # every temporary, second name and the journal: durable at once
        for entry in entries:
            target = root / entry.name
            if entry.temp is not None:
                os.replace(entry.temp, target)
            else:
                target.unlink()
        batch.sync()  # the new names: every directory touched
        (root / JOURNAL).unlink()  # the save is done
    except BaseException:
        log.warning("save of %s failed: restoring the previous files", root)
        _undo(root, entries, made_dirs)
        raise
    finally:
        batch.close()
    _quietly(_fsync_dir, root)
    for entry in entries:
        if entry.old is not None:
            _quietly(entry.old.unlink, missing_ok=True)


def _write_journal(root: Path, entries: list[_Entry], made_dirs: list[Path], batch: _Batch) -> None:
    """The journal in place, durable once ``batch`` is synced."""
    record = {
        "pid": os.getpid(),
        "files": [[e.name, e.temp and e.temp.name, e.old and e.old.name] for e in entries],
        "made_dirs": [os.path.relpath(d, root) for d in made_dirs],
    }
    target = root / JOURNAL
    temp = _write_temp(target, json.dumps(record).encode("utf-8"), fsync=batch.per_file)
    try:
        os.replace(temp, target)
    finally:
        _quietly(temp.unlink, missing_ok=True)


def _undo(root: Path, entries: list[_Entry], made_dirs: list[Path]) -> None:
    """Put back every old file of an unfinished save and drop the new ones."""
    for entry in reversed(entries):
        target = root / entry.name
        if entry.old is None:
            _quietly(target.unlink, missing_ok=True)
        elif entry.old.exists():
            _quietly(os.replace, entry.old, target)
            # rename() between two links to one file does nothing: drop the link.
            _quietly(entry.old.unlink, missing_ok=True)
        if entry.temp is not None:
            _quietly(entry.temp.unlink, missing_ok=True)
    for directory in {(root / e.name).parent for e in entries if (root / e.name).parent.exists()}:
        _quietly(_fsync_dir, directory)
    _quietly((root / JOURNAL).unlink, missing_ok=True)
    for directory in reversed(made_dirs):
        _quietly(directory.rmdir)


def _gone(pid: int) -> bool:
    """Whether process ``pid`` no longer runs (ours counts as gone: its save ended)."""
    if pid == os.getpid() or os.name != "posix":
        return True  # Windows has no harmless way to ask (signal 0 is CTRL_C_EVENT there)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:
        return False  # it runs, as another user
    return False


def recover(root: Path) -> bool:
    """Finish off a save that a killed process left half done: put the previous
    project back and remove its temporaries.  Returns whether there was one.

    Raises ProjectError while the process that wrote the journal still runs.
    """
    journal = root / JOURNAL
    try:
        record = statefile.load(journal)
        pid = int(record["pid"])
        entries = [
            _Entry(
                name, temp and (root / name).with_name(temp), old and (root / name).with_name(old)
            )
            for name, temp, old in record["files"]
        ]
        made_dirs = [root / d for d in record["made_dirs"]]
    except FileNotFoundError:
        return _sweep(root)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ProjectError(
            f"{journal}: the journal of an interrupted save cannot be read ({exc}); "
            "check the project against git (git status) and remove that file"
        ) from exc
    if not _gone(pid):
        raise ProjectError(
            f"{root}: process {pid} is saving this project right now; "
            "wait for it to finish and run again"
        )
    log.warning(
        "%s: a save by process %d was interrupted; putting the previous files back", root, pid
    )
    _undo(root, entries, made_dirs)
    _sweep(root)
    return True


def _sweep(root: Path) -> bool:
    """Remove temporaries and second names left by killed processes."""
    found = False
    # The project's own sub-directories (programs/, ...), .schemas/ and .harlsync/.
    directories = (
        [root, root / SCHEMAS_DIR, root / LOCAL_DIR]
        + sorted(d for d in root.iterdir() if d.is_dir() and not d.name.startswith("."))
        if root.is_dir()
        else []
    )
    for directory in directories:
        if not directory.is_dir():
            continue
        for path in directory.iterdir():
            match = _SIBLING_RE.match(path.name)
            if match and _gone(int(match.group(1))):
                log.warning("removing %s, left by an interrupted save", path)
                _quietly(path.unlink, missing_ok=True)
                found = True
    return found


def _quietly(action: Callable[..., object], *args: object, **kwargs: object) -> None:
    """Run a clean-up step; log, don't raise, when it fails."""
    try:
        action(*args, **kwargs)
    except OSError as exc:
        log.error("clean-up failed: %s", exc)
