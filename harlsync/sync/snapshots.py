"""Snapshots: the live robot saved as a project just before a push or rollback
writes to it, under ``DIR/.harlsync/snapshots/``, for rollback to restore."""

from __future__ import annotations

import os
import re
import shutil
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from ..columns import ljust, rjust, width
from ..errors import HarlsyncError, ProjectError
from ..project import Project, Robot, load_project, save_project
from ..project.store import disk_error, require_project
from . import history
from .auditrecord import local_time

if TYPE_CHECKING:
    from ..families.base import AnyFamily

__all__ = [
    "SNAPSHOT_DIR",
    "Listing",
    "Snapshot",
    "all_snapshots",
    "listing",
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


@dataclass
class Listing:
    """What ``harlsync snapshots`` shows of a project: its snapshots, the latest
    first, and the one a rollback restores (the last taken before a push)."""

    #: the project, as it was given
    where: str
    taken: list[Snapshot]
    restores: Path | None

    def to_json(self) -> list[dict[str, object]]:
        return [
            {
                "number": s.number,
                "time": s.time.isoformat() if s.time else None,
                "action": s.action,
                "path": str(s.path),
                "rollback_restores": s.path == self.restores,
            }
            for s in self.taken
        ]

    def lines(self) -> list[str]:
        """A table: number, time, action and path, the one a rollback restores marked."""
        if not self.taken:
            return [f"no snapshot in {self.where}: a push takes one before its first write"]
        rows = [("number", "time", "action", "path")] + [
            (
                str(s.number),
                local_time(s.time.isoformat() if s.time else None),
                s.action,
                str(s.path) + ("  <- rollback restores this" if s.path == self.restores else ""),
            )
            for s in self.taken
        ]
        widths = [max(width(row[i]) for row in rows) for i in range(3)]
        return [
            "  ".join(
                [
                    rjust(row[0], widths[0]),
                    *(ljust(c, w) for c, w in zip(row[1:3], widths[1:])),
                    row[3],
                ]
            )
            for row in rows
        ]


def listing(path: str | Path) -> Listing:
    """The snapshots of the project at ``path``.  Raises ProjectFormatError for a
    directory that holds no project."""
    require_project(Path(path))
    taken = all_snapshots(path)
    pushes = [s.path for s in taken if s.action == "push"]
    return Listing(str(path), taken[::-1], pushes[-1] if pushes else None)


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
