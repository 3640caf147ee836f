"""Two versions of a project compared item by item, without a robot.

``harlsync diff DIR --rev A [--rev B]`` names each version by a git revision
(``HEAD~1``, a commit, a tag, ``main@{yesterday}``) or by the number ``harlsync
snapshots DIR`` lists (the robot as it was before a push or rollback); with one
``--rev`` the other side is the project as it is on disk::

    revision --> git ls-tree + cat-file --> a temporary copy --> load_project --+
                                                                                 +--> diff
    snapshot number --> DIR/.harlsync/snapshots/NNNNNN-... --> load_project ------+
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import HarlsyncError, ProjectError
from ..project import Project, load_project
from ..project.store import require_project
from . import git
from .items import Differences, diff
from .snapshots import all_snapshots, load_snapshot

__all__ = ["Version", "compare_versions", "snapshot_path", "version_of"]


@dataclass
class Version:
    """One side of a comparison: what it is called and the project it holds."""

    label: str
    project: Project


def _snapshot(path: Path, number: int) -> Version | None:
    for taken in all_snapshots(path):
        if taken.number == number:
            return Version(
                f"snapshot {number} (before a {taken.action})", load_snapshot(path, taken.path)
            )
    return None


def _at_revision(path: Path, rev: str) -> Version:
    """The project ``path`` as the commit ``rev`` holds it.  Raises ProjectError."""
    root = git.repo_root(path)
    if root is None:
        raise ProjectError(
            f"{path}: not inside a git repository, so --rev {rev} names nothing; "
            "give a snapshot number ('harlsync snapshots DIR' lists them)"
        )
    where = path.resolve().relative_to(root).as_posix()
    commit = git.resolve(root, rev)
    if commit is None:
        raise ProjectError(
            f"{path}: --rev {rev} is neither a git revision of {root} nor a snapshot "
            "number ('git log -- DIR' and 'harlsync snapshots DIR' list them)"
        )
    files = git.files_at(root, commit, where)
    if "robot.yaml" not in files:
        raise ProjectError(
            f"{path}: the commit {commit[:10]} ({rev}) holds no robot project there "
            "(no robot.yaml); 'git log -- DIR' lists the commits that do"
        )
    with tempfile.TemporaryDirectory(prefix="harlsync-rev-") as temp:
        copy = Path(temp) / path.name
        for name, data in files.items():
            target = copy / name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        try:
            project = load_project(copy)
        except HarlsyncError as exc:
            raise ProjectError(
                f"{path} at {rev} ({commit[:10]}): {str(exc).replace(str(copy), '.')}"
            ) from exc
    return Version(f"{rev} ({commit[:10]})", Project(path, project.robot, project.data))


def version_of(path: str | Path, rev: str | None) -> Version:
    """The project at ``rev``: a snapshot number, else a git revision; None: on disk.
    Raises ProjectError naming what was not found."""
    path = Path(path)
    if rev is None:
        return Version(f"project {path}", load_project(path))
    if rev.isdigit() and len(rev) <= 6:
        found = _snapshot(path, int(rev))
        if found is not None:
            return found
    return _at_revision(path, rev)


def compare_versions(
    path: str | Path, old: str, new: str | None, *, registers: bool = False
) -> Differences:
    """The differences between the project at ``old`` and at ``new`` (None: as on
    disk), item by item: ``-`` is ``old``, ``+`` is ``new``.  Raises
    ProjectFormatError for a ``path`` that holds no project."""
    require_project(Path(path))
    a, b = version_of(path, old), version_of(path, new)
    if a.project.family.name != b.project.family.name:
        raise ProjectError(
            f"{path}: {a.label} is a {a.project.family.name} robot and {b.label} a "
            f"{b.project.family.name} one: nothing to compare item by item"
        )
    things = b.project.family.catalogue
    changes = diff(things, a.project.data, b.project.data, registers=registers)
    about: dict[str, object] = {"robot": b.project.robot.name, "old": a.label, "new": b.label}
    return Differences(changes, a.label, b.label, about)


def snapshot_path(path: str | Path, given: str) -> Path:
    """The snapshot ``rollback --snapshot`` names: the number ``harlsync snapshots``
    shows, or a snapshot directory.  Raises ProjectError for a number it does not list,
    or a ``path`` that holds no project."""
    path = Path(path)
    require_project(path)
    if given.isdigit():
        for taken in all_snapshots(path):
            if taken.number == int(given):
                return taken.path
        listed = ", ".join(str(s.number) for s in all_snapshots(path)) or "none"
        raise ProjectError(
            f"{path}: no snapshot {given} (taken: {listed}); 'harlsync snapshots {path}' lists them"
        )
    return Path(given)
