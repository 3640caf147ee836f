"""Loading, validating and atomically saving a project directory.

A save is all or nothing.  It renders every file and checks the result exactly
as a load would, before touching the disk; then it

0. writes a journal, ``DIR/.harlsync-save`` (fsynced), naming every file it
   will write, replace or remove and the temporary names it will use;
1. writes each changed file to a temporary file next to it and fsyncs it
   (a failure here removes the temporaries: nothing else was touched);
2. replaces the targets one by one, keeping a hard link to each old file (a
   failure here puts every old file back and removes the new ones);
3. fsyncs the directories, removes the journal, and drops the old copies.

A save killed part way (SIGKILL, power loss) cannot clean up: the next load or
save of the directory finds the journal and puts every old file back, removes
the new and temporary ones (the previous project is then byte-identical), and
removes old copies left after step 3.  A journal whose writer still runs on
this host is left alone.

Files whose content did not change are not rewritten, and program files the
new configuration no longer has are removed in step 2 (and restored on
failure).  ``robot.yaml`` belongs to the user: a save writes it only when it
does not exist yet, unless asked to replace it.
"""

from __future__ import annotations

import json
import logging
import os
import re
import secrets
import shutil
import socket
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..errors import ProjectFormatError, ProjectInvalid
from ..model import RobotData
from .layout import (
    FORMAT,
    PROGRAMS_DIR,
    ROOT_FILES,
    SCHEMAS_DIR,
    analyse,
    program_key,
    render_files,
)
from .robot import Robot
from .schema import KINDS, Issue, schema_text

__all__ = ["Project", "load_project", "load_robot", "save_project", "validate_project"]

log = logging.getLogger(__name__)


@dataclass
class Project:
    """A robot project: where it lives, which robot, and what its memory holds."""

    path: Path
    robot: Robot
    data: RobotData


def _gather(root: Path, *, robot_only: bool = False) -> tuple[dict[str, bytes], list[Issue]]:
    """The project's YAML files by relative path (``.schemas/`` is never read)."""
    if not root.is_dir():
        raise ProjectFormatError(
            f"{root}: not a project directory (no such directory); "
            "a first 'harlsync pull DIR --port URL' makes one"
        )
    recover(root)
    names = [name for name in ROOT_FILES if (root / name).is_file()]
    if robot_only:
        names = [name for name in names if name == "robot.yaml"]
    programs = root / PROGRAMS_DIR
    if programs.is_dir() and not robot_only:
        names += sorted(
            f"{PROGRAMS_DIR}/{p.name}"
            for p in programs.iterdir()
            if p.is_file() and p.suffix in (".yaml", ".yml") and not p.name.startswith(".")
        )
    files: dict[str, bytes] = {}
    problems: list[Issue] = []
    for name in names:
        try:
            files[name] = (root / name).read_bytes()
        except OSError as exc:
            problems.append(Issue(name, None, None, f"cannot read: {exc.strerror}", fatal=True))
    return files, problems


def validate_project(path: str | os.PathLike[str]) -> list[str]:
    """Every issue of the project at ``path``, as ``file:line: field: message`` lines.

    An empty list means the project is valid.  Raises ProjectFormatError only when
    ``path`` is not a directory.
    """
    files, problems = _gather(Path(path))
    return [str(issue) for issue in problems + analyse(files).issues]


def load_project(path: str | os.PathLike[str]) -> Project:
    """Read the project at ``path``.

    Raises ProjectFormatError when a file cannot be read (YAML syntax, a newer
    format, a missing file) and ProjectInvalid (carrying every issue) when the
    files break their schemas or the configuration.
    """
    root = Path(path)
    files, problems = _gather(root)
    found = analyse(files)
    issues = problems + found.issues
    fatal = [str(i) for i in issues if i.fatal]
    if fatal:
        more = f" (and {len(fatal) - 1} more)" if len(fatal) > 1 else ""
        raise ProjectFormatError(fatal[0] + more)
    if issues or found.robot is None or found.data is None:
        raise ProjectInvalid([str(i) for i in issues])
    return Project(root, found.robot, found.data)


def load_robot(path: str | os.PathLike[str]) -> Robot:
    """Read only ``robot.yaml`` (enough to pull into a project that has nothing else).

    Raises ProjectFormatError or ProjectInvalid like :func:`load_project`.
    """
    files, problems = _gather(Path(path), robot_only=True)
    found = analyse(files)
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

    Returns the paths (relative to ``path``) written or removed.  Raises
    ProjectInvalid, before writing anything, when the data would not make a valid
    project, and OSError when the disk fails (the previous files are then intact).
    """
    root = Path(path)
    if root.is_dir():
        recover(root)
    texts = render_files(project.robot, project.data)
    # Step.problems() first: the YAML rendering cannot show every one of them
    # (a step with data but no command renders as empty).
    issues = [
        f"program {key[0].value} {key[1]} step {n}: {problem}"
        for key, steps in project.data.programs.items()
        for n, step in steps.items()
        for problem in step.problems()
    ]
    issues += [str(i) for i in analyse({k: v.encode() for k, v in texts.items()}).issues]
    if issues:
        raise ProjectInvalid(issues)

    wanted = {name: text.encode("utf-8") for name, text in texts.items()}
    if (root / "robot.yaml").exists() and not rewrite_robot:
        del wanted["robot.yaml"]
    for kind in KINDS:
        wanted[f"{SCHEMAS_DIR}/{kind}.schema.json"] = schema_text(kind).encode("utf-8")

    changed = {name: data for name, data in wanted.items() if _current(root / name) != data}
    stale = _stale_files(
        root,
        texts,
        keep_registers_file=project.robot.keep_registers and project.data.registers is None,
    )
    newer = [problem for name in [*changed, *stale] if (problem := _newer_format(root, name))]
    if newer:
        raise ProjectFormatError(
            newer[0] + (f" (and {len(newer) - 1} more)" if len(newer) > 1 else "")
        )
    _commit(root, changed, stale)
    return sorted([*changed, *stale])


_FORMAT_LINE = re.compile(rb"^format:[ \t]*([0-9]+)[ \t]*(?:#.*)?$", re.MULTILINE)


def _newer_format(root: Path, name: str) -> str | None:
    """Why the file ``name`` must not be overwritten: it has a newer format."""
    content = _current(root / name) if name.endswith(".yaml") else None
    match = _FORMAT_LINE.search(content) if content else None
    if match is None or int(match.group(1)) <= FORMAT:
        return None
    line = content.count(b"\n", 0, match.start()) + 1  # type: ignore[union-attr]
    return (
        f"{name}:{line}: format {int(match.group(1))} is newer than this harlsync "
        f"understands ({FORMAT}): upgrade harlsync (the file was not overwritten)"
    )


def _current(path: Path) -> bytes | None:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        return None


def _stale_files(root: Path, texts: dict[str, str], *, keep_registers_file: bool) -> list[str]:
    """Managed files on disk that the new project does not have."""
    stale = []
    unwanted = "registers.yaml" not in texts and not keep_registers_file
    if unwanted and (root / "registers.yaml").is_file():
        stale.append("registers.yaml")
    programs = root / PROGRAMS_DIR
    if programs.is_dir():
        for p in sorted(programs.iterdir()):
            name = f"{PROGRAMS_DIR}/{p.name}"
            if p.is_file() and program_key(name) is not None and name not in texts:
                stale.append(name)
    return stale


#: The journal of a save in progress (see the module docstring).
JOURNAL = ".harlsync-save"
_LEFTOVER = re.compile(r"\..+\.harlsync-(?:new|old)-[0-9a-f]{8}")


def recover(root: Path) -> bool:
    """Undo a save of ``root`` that was killed part way; drop its leftovers.

    Returns True when a save was undone.  Raises OSError when the disk fails.
    """
    journal = root / JOURNAL
    try:
        entry = json.loads(journal.read_text(encoding="utf-8"))
    except FileNotFoundError:
        entry = None
    except ValueError:  # killed while writing the journal: nothing else was touched yet
        entry = {}
    if entry is not None and _alive(entry):
        return False
    if entry is not None:
        for name, temp, old, existed in reversed(entry.get("writes", [])):
            target, temp_path, old_path = root / name, root / temp, root / old
            if old_path.exists():
                os.replace(old_path, target)
                old_path.unlink(missing_ok=True)  # rename() between two links to one file
            elif not existed and not temp_path.exists():
                target.unlink(missing_ok=True)  # it is the new file
            temp_path.unlink(missing_ok=True)
        for name, old in entry.get("removes", []):
            if (root / old).exists():
                os.replace(root / old, root / name)
        for directory in _managed_dirs(root):
            _fsync_dir(directory)
        journal.unlink()
        _fsync_dir(root)
        log.warning("%s: a save was interrupted; the previous files are back", root)
    for directory in _managed_dirs(root):
        for leftover in directory.iterdir():
            if _LEFTOVER.fullmatch(leftover.name):
                leftover.unlink(missing_ok=True)
    return entry is not None


def _alive(entry: dict[str, object]) -> bool:
    """Whether the process that wrote a journal still runs (so it is saving now)."""
    pid = entry.get("pid")
    if entry.get("host") != socket.gethostname() or not isinstance(pid, int):
        return False
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _managed_dirs(root: Path) -> list[Path]:
    return [d for d in (root, root / PROGRAMS_DIR, root / SCHEMAS_DIR) if d.is_dir()]


def _write_journal(root: Path, entry: dict[str, object]) -> None:
    journal = root / JOURNAL
    with open(journal, "w", encoding="utf-8") as f:
        json.dump(entry, f)
        f.flush()
        os.fsync(f.fileno())
    _fsync_dir(root)


def _sibling(target: Path, what: str) -> Path:
    return target.with_name(f".{target.name}.harlsync-{what}-{secrets.token_hex(4)}")


def _write_temp(temp: Path, data: bytes) -> Path:
    with open(temp, "xb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    return temp


def _backup(target: Path, backup: Path) -> Path | None:
    """A second name for the current file (hard link, or copy), or None if absent."""
    if not target.exists():
        return None
    try:
        os.link(target, backup)
    except OSError:
        shutil.copy2(target, backup)
    return backup


def _fsync_dir(directory: Path) -> None:
    if os.name != "posix":
        return  # directories cannot be opened for fsync on Windows
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _commit(root: Path, writes: dict[str, bytes], removes: list[str]) -> None:
    """Write and remove files under ``root`` as one set (see the module docstring)."""
    made_dirs: list[Path] = []
    staged: list[tuple[Path, Path, Path]] = []  # (temp, target, old copy)
    names = {name: (_sibling(root / name, "new"), _sibling(root / name, "old"))
             for name in [*writes, *removes]}
    journal = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "writes": [[name, str(names[name][0].relative_to(root)),
                    str(names[name][1].relative_to(root)), (root / name).exists()]
                   for name in writes],
        "removes": [[name, str(names[name][1].relative_to(root))] for name in removes],
    }
    try:
        for name, data in writes.items():
            target = root / name
            for parent in reversed([target.parent, *target.parent.parents]):
                if not parent.exists():
                    parent.mkdir()
                    made_dirs.append(parent)
            if not staged:
                _write_journal(root, journal)
            temp, old = names[name]
            staged.append((_write_temp(temp, data), target, old))
        if not staged and removes:
            _write_journal(root, journal)
    except BaseException:
        for temp, _, _ in staged:
            temp.unlink(missing_ok=True)
        _quietly((root / JOURNAL).unlink, missing_ok=True)
        for directory in reversed(made_dirs):
            _quietly(directory.rmdir)
        raise

    done: list[tuple[Path, Path | None]] = []  # (target, its old content or None)
    try:
        for temp, target, old in staged:
            done.append((target, _backup(target, old)))
            os.replace(temp, target)
        for name in removes:
            target = root / name
            old = names[name][1]
            os.replace(target, old)
            done.append((target, old))
    except BaseException:
        log.warning("save of %s failed: restoring the previous files", root)
        for target, saved in reversed(done):
            if saved is None:
                _quietly(target.unlink, missing_ok=True)
            else:
                _quietly(os.replace, saved, target)
                # rename() between two links to one file does nothing: drop the link.
                _quietly(saved.unlink, missing_ok=True)
        for temp, _, _ in staged:
            _quietly(temp.unlink, missing_ok=True)
        _quietly((root / JOURNAL).unlink, missing_ok=True)
        for directory in reversed(made_dirs):
            _quietly(directory.rmdir)
        raise

    for directory in {t.parent for _, t, _ in staged} | {(root / n).parent for n in removes}:
        _fsync_dir(directory)
    if staged or removes:
        (root / JOURNAL).unlink()
        _fsync_dir(root)
    for _, saved in done:
        if saved is not None:
            _quietly(saved.unlink, missing_ok=True)


def _quietly(action: Callable[..., object], *args: object, **kwargs: object) -> None:
    """Run a clean-up step; log, don't raise, when it fails."""
    try:
        action(*args, **kwargs)
    except OSError as exc:
        log.error("clean-up failed: %s", exc)
