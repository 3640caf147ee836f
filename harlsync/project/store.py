"""Loading, validating and atomically saving a project directory.

A save is all or nothing, even when the process is killed half way.  It renders
every file and checks the result exactly as a load would, before touching the
disk; then it writes them all or none (:mod:`.atomic` says how: temporaries,
a journal, one ``syncfs``, renames), and a journal a killed save left behind
puts the previous project back on the next load or save.

Files whose content did not change are not rewritten, and files the new data no
longer has (the family's ``stale_files``) are removed in step 2 (and restored on
failure).  ``robot.yaml`` belongs to the user: a save writes it only when it
does not exist yet, unless asked to replace it.

Each save also records, in the same set, what it left: the SHA-256 of every
file it manages, in ``.harlsync/saved.json`` (harlsync's local state, ignored by
git).  :func:`edited_since_save` compares files with that record: a file still
as the last save left it was not edited by anyone since, even when git shows it
uncommitted (a backup whose commit failed).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from .. import lookup
from ..errors import ProjectError, ProjectFormatError, ProjectInvalid
from . import statefile, yamlio
from .atomic import (
    IN_PROGRESS,
    JOURNAL,
    _commit,
    check_replaceable,
    disk_error,
    recover,
    replace_file,
)
from .files import LOCAL_DIR, SCHEMAS_DIR, newer_format
from .robot import Robot
from .schema import Issue

if TYPE_CHECKING:
    from ..families.base import AnyFamily

__all__ = [
    "IN_PROGRESS",
    "JOURNAL",
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
    and the schema copies under ``.schemas/``.  Removes the files the data no
    longer has (the family's ``stale_files``), and ``registers.yaml`` when registers are not kept.

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
    recorded; a file the save manages but did not leave (one the data no longer
    has) when it is still absent.  Anything else counts as edited: a file
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
