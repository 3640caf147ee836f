"""The fleet report page: one self-contained HTML file of a plant's :class:`~.status.PlantStatus`.

It holds no external asset and no script, so it opens from a file share on any
plant PC: a table of every robot with its coloured state; for each robot that
changed, was pushed or needs someone, what changed (the diff of its last backup's
commit, or what its last push wrote) and its recent backups and pushes; and the
plant's recent backups and pushes; for each robot, the items pending (approved,
not yet on the robot: who committed them) and drifted (changed on the robot, not
by a push), with the night a backup first saw each.  The template (``templates/status.html``) is
rendered by Jinja2 with autoescaping on: a step's text or a push's reason is
shown as text, never taken as markup.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import jinja2

from .. import __version__
from ..errors import SyncError
from ..project.store import SCHEMAS_DIR, replace_file
from . import audit, git
from .status import PlantStatus, RobotStatus, local_time

__all__ = ["DiffLine", "Event", "render_html", "write_html"]

#: Diff lines shown per robot; the rest is one ``git show`` away.
MAX_DIFF_LINES = 150
#: Lines of what a push wrote (a field each) shown per robot.
MAX_WRITTEN_LINES = 40
#: Events in a robot's timeline, and in the plant's.
ROBOT_EVENTS = 8
PLANT_EVENTS = 20


@dataclass(frozen=True)
class DiffLine:
    kind: str  # file, hunk, add, del, context, change (old → new)
    text: str


@dataclass(frozen=True)
class Event:
    """One line of a timeline: a backup commit, a push or rollback, a failed backup."""

    time: str  # ISO 8601
    robot: str
    kind: str  # commit, push, rollback, failed
    text: str
    result: str  # ok, failed, refused, unfinished... (the CSS class)

    @property
    def when(self) -> datetime:
        try:
            moment = datetime.fromisoformat(self.time)
        except ValueError:
            return datetime.min.replace(tzinfo=timezone.utc)
        return moment if moment.tzinfo else moment.replace(tzinfo=timezone.utc)


@dataclass
class Details:
    """What the page shows of one robot below the table."""

    robot: RobotStatus
    diff: list[DiffLine] = field(default_factory=list)
    diff_more: int = 0
    written: list[DiffLine] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)


def _diff_lines(text: str) -> tuple[list[DiffLine], int]:
    """git's diff as typed lines, at most MAX_DIFF_LINES, and how many were left out.

    A file the commit added or removed whole (a first backup, a new program) is one
    line, and the schema copies (``.schemas/``) are left out: neither is a change
    anyone reads line by line.
    """
    files: list[tuple[str, str, list[DiffLine]]] = []  # (name, how, lines)
    for line in text.splitlines():
        if line.startswith("diff --git "):
            files.append((line.split(" b/", 1)[-1], "changed", []))
        elif not files or line.startswith(("index ", "--- ", "+++ ")):
            continue
        elif line.startswith(("new file", "deleted file")):
            name, _, body = files[-1]
            files[-1] = (name, "new" if line.startswith("new") else "deleted", body)
        else:
            kind = (
                "hunk"
                if line.startswith("@@")
                else "add"
                if line.startswith("+")
                else "del"
                if line.startswith("-")
                else "context"
            )
            files[-1][2].append(DiffLine(kind, line))
    lines = []
    for name, how, body in files:
        if f"/{SCHEMAS_DIR}/" in f"/{name}":
            continue
        if how == "changed":
            lines += [DiffLine("file", name), *body]
        else:
            counted = sum(line.kind != "hunk" for line in body)
            lines.append(DiffLine("file", f"{name} ({how}, {counted} lines)"))
    return lines[:MAX_DIFF_LINES], max(0, len(lines) - MAX_DIFF_LINES)


def _written(robot: RobotStatus) -> list[DiffLine]:
    """What the last push wrote (or an unfinished one may have), item by item."""
    push = robot.last_push
    if push is None:
        return []
    lines = [DiffLine("change", line) for line in push.written_lines(MAX_WRITTEN_LINES)]
    if push.failed_item:
        lines.append(DiffLine("hunk", f"{push.failed_item}: may or may not have been written"))
    return lines


def _events(robot: RobotStatus) -> list[Event]:
    """The robot's recent commits (backups, edits), pushes and a failed last backup."""
    events = [
        Event(c.time, robot.label or robot.name, "commit", f"{c.sha[:10]} {c.subject}", "ok")
        for c in git.log(robot.path, ROBOT_EVENTS)
    ]
    events += [
        Event(
            p.time or "",
            robot.label or robot.name,
            p.shown_action,
            f"{p.shown_result} {p.details()}",
            p.shown_result,
        )
        for p in robot.pushes[-ROBOT_EVENTS:]
    ]
    if robot.last_result == "failed" and robot.last_attempt:
        events.append(
            Event(
                robot.last_attempt,
                robot.label or robot.name,
                "failed",
                f"backup failed: {audit.shorten(robot.last_error)}",
                "failed",
            )
        )
    return sorted(events, key=lambda e: e.when, reverse=True)[:ROBOT_EVENTS]


def _details(robot: RobotStatus) -> Details:
    found = Details(robot, written=_written(robot), events=_events(robot))
    if robot.changed and robot.last_commit:
        found.diff, found.diff_more = _diff_lines(git.show(robot.last_commit, robot.path))
    return found


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("harlsync.sync", "templates"),
        autoescape=True,  # every value is text: a reason or a step never becomes markup
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["local_time"] = local_time
    env.filters["shorten"] = audit.shorten
    return env


def render_html(status: PlantStatus) -> str:
    """The page, as text.  Reads git for the diffs and timelines."""
    details = [
        _details(r) for r in status.robots if r.state != "ok" or r.last_push or r.pending or r.drift
    ]
    anchors = {d.robot.path: f"robot-{n}" for n, d in enumerate(details, 1)}
    events = [e for d in details for e in d.events]
    events += [e for r in status.robots if r.path not in anchors for e in _events(r)]
    events.sort(key=lambda e: e.when, reverse=True)
    template = _environment().get_template("status.html")
    return template.render(
        status=status,
        details=details,
        events=events[:PLANT_EVENTS],
        anchors=anchors,
        version=__version__,
    )


def write_html(path: str | Path, status: PlantStatus) -> None:
    """Write the page to ``path`` atomically: a reader on the share sees the old page
    or the new one.  Raises SyncError when it cannot be written (the old one is kept)."""
    try:
        replace_file(Path(path), render_html(status).encode("utf-8"))
    except OSError as exc:
        raise SyncError(f"cannot write the report page {path}: {exc.strerror or exc}") from exc
