"""Loading, validating and atomically saving a project directory.

A save is all or nothing, even when the process is killed half way.  It renders
every file and checks the result exactly as a load would, before touching the
disk; then it

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

Files whose content did not change are not rewritten, and program files the
new configuration no longer has are removed in step 2 (and restored on
failure).  ``robot.yaml`` belongs to the user: a save writes it only when it
does not exist yet, unless asked to replace it.

Each save also records, in the same set, what it left: the SHA-256 of every
file it manages, in ``.harlsync/saved.json`` (harlsync's local state, ignored by
git).  :func:`edited_since_save` compares files with that record: a file still
as the last save left it was not edited by anyone since, even when git shows it
uncommitted (a backup whose commit failed).
"""

from __future__ import annotations

import errno
import functools
import hashlib
import json
import logging
import os
import re
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, cast

from .. import lookup
from ..errors import ProjectError, ProjectFormatError, ProjectInvalid
from . import statefile, yamlio
from .files import SCHEMAS_DIR, newer_format
from .robot import Robot
from .schema import Issue

if TYPE_CHECKING:
    from ..families.base import AnyFamily

__all__ = [
    "LOCAL_DIR",
    "SCHEMAS_DIR",
    "Checked",
    "Project",
    "check_project",
    "check_replaceable",
    "disk_error",
    "edited_since_save",
    "family_name",
    "family_of",
    "load_project",
    "load_robot",
    "migrate_project",
    "read_project",
    "replace_file",
    "require_project",
    "save_project",
    "validate_project",
]

log = logging.getLogger(__name__)


def family_name(root: Path, *, strict: bool = False) -> tuple[str | None, int | None]:
    """The family name robot.yaml gives under ``root``, and its line: the one
    reader of ``family:``.  ``(None, None)`` when it gives none, or when the file
    cannot be read (then the default family's reading of it says why); with
    ``strict`` an unreadable file raises ProjectFormatError instead."""
    path = root / "robot.yaml"
    try:
        doc = yamlio.parse(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        if strict:
            raise ProjectFormatError(f"{path}: cannot read: {exc.strerror or exc}") from exc
        return None, None
    except yamlio.YamlSyntaxError as exc:
        if strict:
            raise ProjectFormatError(f"{path}:{exc.line}: {exc.message}") from exc
        return None, None
    except ValueError as exc:
        if strict:
            raise ProjectFormatError(f"{path}: not UTF-8 text ({exc})") from exc
        return None, None
    name = doc.data.get("family") if isinstance(doc.data, dict) else None
    if name is None:
        return None, None
    return str(name), doc.line(("family",))


def family_of(root: Path, *, strict: bool = False) -> AnyFamily:
    """The family of the project in ``root`` (see :func:`family_name`; none: the
    default).  Raises ProjectFormatError, naming the file and line, for a family
    harlsync does not know."""
    name, line = family_name(root, strict=strict)
    try:
        return lookup.family(name)
    except ProjectError as exc:
        raise ProjectFormatError(f"{root / 'robot.yaml'}:{line}: family: {exc}") from None


@dataclass
class Project:
    """A robot project: where it lives, which robot, what its memory holds (the
    family's data: see :mod:`harlsync.families.base`) and the family that reads it.

    ``family`` left out is the one ``robot.family`` names.
    """

    path: Path
    robot: Robot
    data: Any
    family: AnyFamily = None  # type: ignore[assignment]  # filled in by __post_init__

    def __post_init__(self) -> None:
        if self.family is None:
            self.family = lookup.family(self.robot.family)
        if not self.robot.family:  # a robot built in memory: of the project's family
            self.robot.family = self.family.name


def _gather(
    root: Path, family: AnyFamily | None, *, robot_only: bool = False
) -> tuple[AnyFamily, dict[str, bytes], list[Issue]]:
    """The project's family (``family``, or the one its robot.yaml names) and YAML
    files by relative path (``.schemas/`` is never read)."""
    require_project(root)
    family = family or family_of(root)
    names = family.project_files(root)
    if robot_only:
        names = [name for name in names if name == "robot.yaml"]
    files: dict[str, bytes] = {}
    problems: list[Issue] = []
    for name in names:
        try:
            files[name] = (root / name).read_bytes()
        except OSError as exc:
            problems.append(Issue(name, None, None, f"cannot read: {exc.strerror}", fatal=True))
    return family, files, problems


def require_project(root: Path) -> None:
    """Finish an interrupted save in ``root`` (which may bring robot.yaml back), then
    raise ProjectFormatError, naming ``root``, unless it holds a robot project."""
    if not root.is_dir():
        raise ProjectFormatError(
            f"{root}: not a project directory (no such directory); "
            "a first 'harlsync pull DIR --port URL' makes one"
        )
    recover(root)
    if not (root / "robot.yaml").exists():
        raise ProjectFormatError(
            f"{root}: not a robot project (no robot.yaml); "
            "a first 'harlsync pull DIR --port URL' makes one"
        )


class Checked(NamedTuple):
    """What a check of a project found (:func:`check_project`)."""

    issues: list[str]  # ``file:line: field: message`` each; none: the project is valid
    notes: list[str]  # what its family tells beyond the issues
    files: list[str]  # the files checked, relative to the project
    family: str  # the family's name, which read them


def check_project(path: str | os.PathLike[str], family: AnyFamily | None = None) -> Checked:
    """Check the project at ``path`` against its schemas and its own configuration,
    as ``harlsync validate`` does.  Raises ProjectFormatError only when ``path`` is
    not a project directory (none, or no robot.yaml in it)."""
    family, files, problems = _gather(Path(path), family)
    found = family.analyse(files)
    issues = [str(issue) for issue in problems + found.issues]
    return Checked(issues, list(found.notes), sorted(files), family.name)


def validate_project(path: str | os.PathLike[str], family: AnyFamily | None = None) -> list[str]:
    """Every issue of the project at ``path``, as ``file:line: field: message`` lines.

    An empty list means the project is valid.  Raises ProjectFormatError only when
    ``path`` is not a project directory (none, or no robot.yaml in it).
    """
    return check_project(path, family).issues


def project_notes(path: str | os.PathLike[str], family: AnyFamily | None = None) -> list[str]:
    """What ``validate`` tells of the project at ``path`` beyond its issues (its
    family's notes).  Raises as :func:`validate_project`."""
    return check_project(path, family).notes


def load_project(path: str | os.PathLike[str], family: AnyFamily | None = None) -> Project:
    """Read the project at ``path``, of ``family`` (default: the one its robot.yaml
    names).

    Raises ProjectFormatError when a file cannot be read (YAML syntax, a newer
    format, a missing file) and ProjectInvalid (carrying every issue) when the
    files break their schemas or the configuration.
    """
    return read_project(path, family)[0]


def read_project(
    path: str | os.PathLike[str], family: AnyFamily | None = None
) -> tuple[Project, dict[str, bytes]]:
    """Read the project at ``path``, as :func:`load_project` does, and return the
    exact bytes it was made from too: relative path -> content of every file read
    (what a push must find in the commit it names).  Raises as load_project."""
    root = Path(path)
    family, files, problems = _gather(root, family)
    found = family.analyse(files)
    issues = problems + found.issues
    fatal = [str(i) for i in issues if i.fatal]
    if fatal:
        more = f" (and {len(fatal) - 1} more)" if len(fatal) > 1 else ""
        raise ProjectFormatError(fatal[0] + more)
    if issues or found.robot is None or found.data is None:
        raise ProjectInvalid([str(i) for i in issues])
    return Project(root, found.robot, found.data, family), files


def load_robot(path: str | os.PathLike[str], family: AnyFamily | None = None) -> Robot:
    """Read only ``robot.yaml`` (enough to pull into a project that has nothing else).

    Raises ProjectFormatError or ProjectInvalid like :func:`load_project`.
    """
    family, files, problems = _gather(Path(path), family, robot_only=True)
    found = family.analyse(files)
    issues = problems + [i for i in found.issues if i.file == "robot.yaml"]
    fatal = [i for i in issues if i.fatal]
    if fatal:
        raise ProjectFormatError(str(fatal[0]))
    if issues or found.robot is None:
        raise ProjectInvalid([str(i) for i in issues])
    return found.robot


def save_project(
    path: str | os.PathLike[str], project: Project, *, rewrite_robot: bool = False
) -> list[str]:
    """Write ``project`` to ``path`` as one set: every file changes, or none does.

    Writes ``robot.yaml`` only when it does not exist (or ``rewrite_robot``),
    ``registers.yaml`` only when the robot keeps registers and the data has them,
    and the schema copies under ``.schemas/``.  Removes program files the
    configuration no longer has, and ``registers.yaml`` when registers are not kept.

    Returns the paths (relative to ``path``) written or removed; nothing is written
    when nothing changed.  Raises ProjectInvalid, before writing anything, when the
    data would not make a valid project, and ProjectError when the disk fails (full,
    read-only): the previous files are then intact and no temporary is left.
    """
    root = Path(path)
    if root.is_dir():
        recover(root)
    family = project.family
    texts = family.render_files(project.robot, project.data)
    rendered = {name: text.encode("utf-8") for name, text in texts.items()}
    issues = family.data_problems(project.data)
    issues += [str(i) for i in family.analyse(rendered).issues]
    if issues:
        raise ProjectInvalid(issues)

    wanted = dict(rendered)
    if (root / "robot.yaml").exists() and not rewrite_robot:
        del wanted["robot.yaml"]
    for name, text in family.schemas().items():
        wanted[f"{SCHEMAS_DIR}/{name}"] = text.encode("utf-8")
    wanted[SAVED] = _saved_record(wanted)
    if not (root / LOCAL_IGNORE).exists():
        wanted[LOCAL_IGNORE] = LOCAL_IGNORE_TEXT

    changed = {name: data for name, data in wanted.items() if _current(root / name) != data}
    stale = family.stale_files(root, texts, project.robot, project.data)
    newer = [
        problem for name in [*changed, *stale] if (problem := _newer_format(root, name, family))
    ]
    if newer:
        raise ProjectFormatError(
            newer[0] + (f" (and {len(newer) - 1} more)" if len(newer) > 1 else "")
        )
    if changed or stale:
        try:
            _commit(root, changed, stale)
        except OSError as exc:
            raise disk_error(exc, root, "save the project") from exc
    return sorted(name for name in [*changed, *stale] if not name.startswith(f"{LOCAL_DIR}/"))


#: harlsync's local state in a project: not versioned (its .gitignore says so).
LOCAL_DIR = ".harlsync"
LOCAL_IGNORE = f"{LOCAL_DIR}/.gitignore"
LOCAL_IGNORE_TEXT = b"# harlsync's local state (snapshots, backup times): not versioned\n*\n"
#: What the last save left: ``{"files": {name: sha256}}`` for every file it manages.
SAVED = f"{LOCAL_DIR}/saved.json"


def migrate_project(path: str | os.PathLike[str], family: AnyFamily | None = None) -> list[str]:
    """Rewrite the project's files in the current format, from the files alone (no
    robot): what the save after a pull does to them.  The data is unchanged;
    ``robot.yaml``, a person's file, is left as it is (its format still loads).

    Returns the paths written, as :func:`save_project` does; raises as
    :func:`load_project` does (a newer format is refused, nothing is written).
    """
    return save_project(path, load_project(path, family))


def _saved_record(files: dict[str, bytes]) -> bytes:
    digests = {name: hashlib.sha256(data).hexdigest() for name, data in sorted(files.items())}
    return (json.dumps({"files": digests}, indent=1) + "\n").encode("utf-8")


def _managed(name: str, family: AnyFamily) -> bool:
    """Whether a save writes or removes the file ``name`` (relative to the project):
    the family's YAML files at the top or in its directories, and the schema copies."""
    folder = name.rpartition("/")[0]
    if folder == SCHEMAS_DIR:
        return name.endswith(".schema.json")
    return name.endswith(".yaml") and (folder == "" or folder in family.directories)


def edited_since_save(
    path: str | os.PathLike[str], names: Iterable[str], family: AnyFamily | None = None
) -> list[str]:
    """Those of ``names`` (files relative to the project) that are not as the last
    save left them: changed, made or removed by someone else since.

    A file the save wrote is as it left it when its content has the SHA-256 the save
    recorded; a file the save manages but did not leave (a program the configuration
    no longer has) when it is still absent.  Anything else counts as edited: a file
    harlsync does not manage, and every file when there is no readable record.
    """
    root = Path(path)
    family = family or family_of(root)
    try:
        record = statefile.load(root / SAVED)["files"]
        if not isinstance(record, dict):
            raise TypeError("not a mapping")
    except (OSError, ValueError, KeyError, TypeError):
        record = {}
    edited = []
    for name in names:
        content = _current(root / name)
        if name in record:
            same = content is not None and hashlib.sha256(content).hexdigest() == record[name]
        else:
            same = bool(record) and content is None and _managed(name, family)
        if not same:
            edited.append(name)
    return edited


def _newer_format(root: Path, name: str, family: AnyFamily) -> str | None:
    """Why the file ``name`` must not be overwritten: it has a newer format."""
    content = _current(root / name) if name.endswith(".yaml") else None
    issue = newer_format(name, content, family.format) if content else None
    return f"{issue} (the file was not overwritten)" if issue else None


def _current(path: Path) -> bytes | None:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        return None


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
