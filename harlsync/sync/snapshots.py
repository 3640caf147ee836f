"""Snapshots: the live robot saved as a project just before a push or rollback
writes to it, under ``DIR/.harlsync/snapshots/``, for rollback to restore."""

from __future__ import annotations

import os
import re
import shutil
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from ..errors import HarlsyncError, ProjectError
from ..project import Project, Robot, load_project, save_project
from ..project.store import disk_error
from . import history

if TYPE_CHECKING:
    from ..families.base import AnyFamily

__all__ = [
    "SNAPSHOT_DIR",
    "Snapshot",
    "all_snapshots",
    "load_snapshot",
    "save_snapshot",
    "snapshots",
]


SNAPSHOT_DIR = history.LOCAL_DIR / "snapshots"


#: A snapshot's name: a sequence number, which orders the snapshots whatever the clock
#: did between two pushes, then the time (for people) and the action:
#: ``000012-20261124T202350.294650Z-push``.  Names an older harlsync gave have no
#: number (``20261124T202350.294650Z-push``): they come before every numbered one.
_SNAPSHOT_NAME = re.compile(
    r"(?:(?P<number>[0-9]+)-)?(?P<time>[0-9]{8}T[0-9.]+Z)-(?P<action>[a-z]+)"
)


def _snapshot_number(snapshot: Path) -> int:
    """Its sequence number; 0 for a name without one."""
    match = _SNAPSHOT_NAME.fullmatch(snapshot.name)
    return int(match["number"]) if match and match["number"] else 0


class Snapshot(NamedTuple):
    """A snapshot, as its name tells it."""

    number: int  # 0 for a name an older harlsync gave
    time: datetime | None  # UTC; None in a name harlsync did not give
    action: str  # what it was taken before: push or rollback
    path: Path


def all_snapshots(path: str | Path) -> list[Snapshot]:
    """Every snapshot of the project (before pushes and rollbacks), oldest first."""
    root = Path(path) / SNAPSHOT_DIR
    if not root.is_dir():
        return []
    found = []
    for taken in root.iterdir():
        match = _SNAPSHOT_NAME.fullmatch(taken.name)
        if match and taken.is_dir():
            try:
                when = datetime.strptime(match["time"], "%Y%m%dT%H%M%S.%fZ")
            except ValueError:  # not a time harlsync wrote: the number still orders it
                when = None
            found.append(
                Snapshot(
                    int(match["number"] or 0),
                    when and when.replace(tzinfo=timezone.utc),
                    match["action"],
                    taken,
                )
            )
    return sorted(found, key=lambda s: (s.number, s.path.name))


def snapshots(path: str | Path, action: str = "push") -> list[Path]:
    """The snapshots taken before each ``action`` (push or rollback), oldest first:
    rollback restores the last of the pushes'."""
    return [s.path for s in all_snapshots(path) if s.action == action]


def load_snapshot(project: str | Path, snapshot: Path, family: AnyFamily | None = None) -> Project:
    """The robot as the snapshot ``snapshot`` of ``project`` holds it.

    Raises ProjectError naming the snapshot (its number and directory) when it
    cannot be read: its file names alone would point at the project's own files.
    """
    try:
        return load_project(snapshot, family)
    except HarlsyncError as exc:
        number = _snapshot_number(snapshot) if _SNAPSHOT_NAME.fullmatch(snapshot.name) else 0
        named = f"snapshot {number} ({snapshot})" if number else f"snapshot {snapshot}"
        raise ProjectError(
            f"{project}: {named} cannot be read: {exc}; it cannot be compared or restored: "
            f"'harlsync snapshots {project}' lists the others"
        ) from exc


def save_snapshot(path: Path, robot: Robot, live: object, action: str) -> Path:
    """Save the robot as a snapshot, whole or not at all: it is saved under a
    hidden name and renamed, so a process killed meanwhile leaves no half
    snapshot for rollback to pick (the next snapshot removes the leftover)."""
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S.%fZ")
    history.ensure_local_dir(path)
    root = (path / SNAPSHOT_DIR).resolve()
    try:
        root.mkdir(exist_ok=True)
        for leftover in root.glob(".*.partial"):
            shutil.rmtree(leftover, ignore_errors=True)
        number = 1 + max((_snapshot_number(p) for p in root.iterdir()), default=0)
        name = f"{number:06d}-{stamp}-{action}"
        partial = root / f".{name}.partial"
        save_project(partial, Project(partial, robot, live))
        target = root / name
        os.rename(partial, target)
        if os.name == "posix":  # the rename must be on disk before the first write
            fd = os.open(root, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
    except OSError as exc:
        raise disk_error(exc, root, f"save the snapshot before the {action}") from exc
    return target
