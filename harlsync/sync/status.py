"""The plant at a glance, from what pulls, backups and pushes recorded: no robot is touched.

For each robot project it reads ``robot.yaml`` (family, port, station, as the
family writes them), ``DIR/.harlsync/backup.json`` (:mod:`.history`: the last
attempt, the last good backup, what it changed and its commit), the audit log
(:mod:`.audit`: pushes, rollbacks, and those that never ended), git (the commit
that holds a backup harlsync did not commit itself), the snapshots, and
``DIR/.harlsync/states.json`` (:mod:`.states`: what the last backup found pending
and drifted, shown beside the state, never changing it).

A robot's state is the first of these that applies::

    unfinished push   a push or rollback of it never ended (killed part way)
    partial push      its last push or rollback stopped part way (refused or failed
                      after writing some items): the robot holds some of it
    never backed up   no good backup recorded (on this machine: .harlsync is local)
    failed            its last pull or backup failed, or its project cannot be read
    stale             its last good backup is older than stale_after
    changed           its last good backup changed what git holds
    ok
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from datetime import datetime, timedelta, timezone
from pathlib import Path

from .. import columns
from ..errors import HarlsyncError
from ..project import family_of, load_robot
from . import audit, auditindex, git, history, states
from .auditindex import AuditIndex, RobotRecords
from .auditrecord import AuditRecord, local_time
from .backup import find_projects, project_labels, shown_names
from .snapshots import snapshots
from .states import Seen

__all__ = [
    "ATTENTION",
    "STATES",
    "PlantStatus",
    "RobotStatus",
    "collect",
    "local_time",
]

log = logging.getLogger(__name__)

#: Every state, the most urgent first.
STATES = (
    "unfinished push",
    "partial push",
    "never backed up",
    "failed",
    "stale",
    "changed",
    "ok",
)
#: The states someone must look at: ``harlsync status`` exits 1 when a robot is in one.
ATTENTION = frozenset(("unfinished push", "partial push", "never backed up", "failed", "stale"))


def _items(found: list[Seen]) -> str:
    return f"{len(found)} item{'s' * (len(found) != 1)}" if found else "0"


@dataclass
class RobotStatus:
    """One robot's state, and what it comes from."""

    name: str
    path: str
    family: str | None
    port: str | None
    #: As its family writes it (``Family.format_station``).
    station: str | None
    state: str = "ok"
    last_attempt: str | None = None
    last_result: str | None = None
    last_error: str | None = None
    last_success: str | None = None
    #: The commit that holds the last good backup; None when it is not committed.
    last_commit: str | None = None
    changed: bool = False
    changes: str | None = None
    stale: bool = False
    never_backed_up: bool = False
    last_push: AuditRecord | None = None
    #: Pushes and rollbacks of this robot that never ended, with what they wrote.
    unfinished: list[str] = field(default_factory=list)
    #: How many snapshots a rollback can restore.
    snapshots: int = 0
    #: Its latest pushes and rollbacks (at most :data:`.auditindex.RECENT`), oldest first.
    pushes: list[AuditRecord] = field(default_factory=list, repr=False)
    #: Its project's directory under the plant's (``lineA/cell``).
    project: str = ""
    #: Its name as a person reads it: ``cell``, or ``cell (lineA/cell)`` when
    #: another robot of the plant has that name.
    label: str = ""
    #: What its last backup found against the approved version (:mod:`.states`):
    #: each pending item (approved, not yet on the robot) and each drifted one
    #: (changed on the robot, not by a push); ``{"item", "first_seen", "by"}`` in JSON.
    pending: list[Seen] = field(default_factory=list)
    drift: list[Seen] = field(default_factory=list)
    #: When that backup read it (None: no backup under the three-state model yet).
    compared: str | None = None

    @property
    def attention(self) -> bool:
        return self.state in ATTENTION

    @property
    def commit_text(self) -> str:
        """The last good backup's commit as a table shows it."""
        if self.last_commit:
            return self.last_commit[:10]
        return "uncommitted" if self.last_success else "-"

    @property
    def changes_text(self) -> str:
        """What the last good backup changed, as a table shows it."""
        return (self.changes or "-") if self.last_success else "-"

    @property
    def pending_text(self) -> str:
        """``2 items``, or ``-``."""
        return _items(self.pending) if self.compared else "-"

    @property
    def drift_text(self) -> str:
        return _items(self.drift) if self.compared else "-"

    def seen(self) -> list[str]:
        """A line per pending and drifted item: ``drift: timer 3 (first seen 2026-11-25)``."""
        return [
            f"{what}: {s.describe()}"
            for what, found in (("pending", self.pending), ("drift", self.drift))
            for s in found
        ]

    def to_json(self) -> dict[str, object]:
        data = asdict(self)
        del data["pushes"]
        data["last_push"] = None if self.last_push is None else _push_json(self.last_push)
        return data


def _push_json(push: AuditRecord) -> dict[str, object]:
    """The last push as ``status --format json`` gives it: who, when, what it wrote."""
    return {
        "action": push.shown_action,
        "time": push.time,
        "user": push.user,
        "host": push.host,
        "commit": push.commit,
        "reason": push.reason,
        "result": push.shown_result,
        "error": push.error,
        "robot": push.robot_name,
        "written": [w.to_json() for w in push.done],
        "failed_item": push.failed_item,
        "planned": push.planned,
        "partly_written": None if push.partly_written is None else push.partly_written.to_json(),
    }


@dataclass
class PlantStatus:
    robots: list[RobotStatus]
    generated: str
    stale_after_hours: float
    audit_log: str
    #: What could not be read (the audit log), said once for the plant.
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """No robot needs someone to look at it."""
        return not any(r.attention for r in self.robots)

    def counts(self) -> dict[str, int]:
        """How many robots are in each state, most urgent first (states with none left out)."""
        found = {state: sum(r.state == state for r in self.robots) for state in STATES}
        return {state: n for state, n in found.items() if n}

    def summary(self) -> str:
        """``"5 robot(s): 1 failed, 1 changed, 3 ok"``."""
        parts = [f"{n} {state}" for state, n in self.counts().items()]
        return f"{len(self.robots)} robot(s): {', '.join(parts) or 'none'}"

    def to_json(self) -> dict[str, object]:
        return {
            "ok": self.ok,
            "generated": self.generated,
            "stale_after_hours": self.stale_after_hours,
            "audit_log": self.audit_log,
            "warnings": self.warnings,
            "counts": self.counts(),
            "robots": [r.to_json() for r in self.robots],
        }

    def render(self, *, color: bool = False) -> str:
        """The table a person reads, a line per robot, then what needs saying at length."""
        rows = [
            (
                "robot",
                "state",
                "family",
                "port",
                "station",
                "last good backup",
                "commit",
                "changes",
                "last attempt",
                "last push",
                "pending",
                "drift",
            )
        ]
        notes = []
        for r in self.robots:
            push = r.last_push
            rows.append(
                (
                    r.label or r.name,
                    r.state,
                    r.family or "?",
                    r.port or "?",
                    r.station or "?",
                    local_time(r.last_success) if r.last_success else "never",
                    r.commit_text,
                    r.changes_text,
                    f"{local_time(r.last_attempt)} {r.last_result}" if r.last_attempt else "-",
                    f"{local_time(push.time)} {push.shown_action} {push.shown_result}"
                    if push
                    else "-",
                    r.pending_text,
                    r.drift_text,
                )
            )
            shown = r.label or r.name
            if r.last_result == "failed":
                notes.append(f"{shown}: failed: {audit.shorten(r.last_error)}")
            notes += [f"{shown}: {text}" for text in r.unfinished]
            notes += [f"{shown}: {line}" for line in r.seen()]
            if push is not None:
                notes.append(f"{shown}: last {push.describe()}")
                notes += [f"    {line}" for line in push.written_lines(3)]
        widths = [min(max(columns.width(row[i]) for row in rows), 40) for i in range(len(rows[0]))]
        lines = []
        for row in rows:
            # A cell longer than its column is cut ("…"), so every column starts where
            # the header's does; the whole text is in the notes below or in --format json.
            cells = [fit(cell, widths[i]) for i, cell in enumerate(row)]
            if color and row is not rows[0]:
                cells[1] = _paint(row[1], cells[1])
            lines.append("  ".join(cells).rstrip())
        tail = [""] + notes if notes else []
        tail += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines + tail + ["", self.summary()]) + "\n"


#: ANSI colours of the states on a terminal.
_COLOURS = {
    "ok": "32",  # green
    "changed": "36",  # cyan
    "stale": "33",  # yellow
    "never backed up": "33",
    "failed": "1;31",  # bold red
    "unfinished push": "1;35",  # bold magenta
    "partial push": "1;35",
}


def fit(cell: str, width: int) -> str:
    """``cell`` padded to ``width`` terminal columns, or cut to them with an ellipsis."""
    return columns.fit(cell, width)


def _paint(state: str, text: str) -> str:
    return f"\x1b[{_COLOURS.get(state, '0')}m{text}\x1b[0m"


def _audit_index(warnings: list[str]) -> AuditIndex | None:
    try:
        return auditindex.index(problems=warnings)
    except (OSError, ValueError) as exc:
        warnings.append(
            f"cannot read the audit log {audit.audit_path()} ({exc}): pushes are not shown"
        )
        return None


def _pushes(
    log: AuditIndex | None, port: str, station: int, path: Path, warnings: list[str]
) -> RobotRecords:
    """The robot's latest pushes and its unsettled ones; none when the log cannot be read."""
    try:
        if log is not None:
            return log.robot(port, station, path)
    except OSError as exc:
        warnings.append(
            f"cannot read the audit log {audit.audit_path()} ({exc}): pushes are not shown"
        )
    return RobotRecords([], [], True)


def _robot_status(
    path: Path,
    log: AuditIndex | None,
    now: datetime,
    stale_after: timedelta,
    warnings: list[str],
) -> RobotStatus:
    """One robot's line of the status: its last backup, its three states, its pushes."""
    try:
        family = family_of(path)
        robot = load_robot(path, family)
    except HarlsyncError as exc:  # that robot cannot be read: the others still are
        return RobotStatus(
            path.name,
            str(path),
            None,
            None,
            None,
            state="failed",
            last_result="failed",
            last_error=str(exc),
        )
    station = family.format_station(robot.station)
    state = history.read(path, warnings)
    status = RobotStatus(
        robot.name,
        str(path),
        family.name,
        robot.port,
        station,
        last_attempt=state.get("last_attempt"),
        last_result=state.get("last_result")
        or (("failed" if "last_error" in state else "ok") if state.get("last_attempt") else None),
        last_error=state.get("last_error"),
        last_success=state.get("last_success"),
        last_commit=state.get("last_commit"),
        changed=bool(state.get("last_changed")),
        changes=state.get("last_changes"),
        snapshots=len(snapshots(path)),
    )
    if status.last_success and status.last_commit is None and not git.changed_files(path):
        # Committed, though not by harlsync (by hand, or by a harlsync that did not
        # record commits): the last commit of the directory holds it.
        found = git.log(path, 1)
        status.last_commit = found[0].sha if found else None
    standing = states.read(path)
    if standing is not None:
        status.compared = standing.checked
        status.pending = list(standing.pending)
        status.drift = list(standing.drift)
    status.never_backed_up = status.last_success is None
    status.stale = history.stale(status.last_success, now, stale_after)
    _note_pushes(status, _pushes(log, robot.port, robot.station, path, warnings))
    status.state = _state(status)
    return status


def _note_pushes(status: RobotStatus, mine: RobotRecords) -> None:
    """The robot's latest pushes in ``status``, and each one left unfinished."""
    status.pushes = list(mine.recent)
    status.last_push = status.pushes[-1] if status.pushes else None
    status.unfinished = [audit.describe_unfinished(r) for r in mine.unsettled]
    last = status.last_push
    if last is not None and last.partly_written:
        # The item holds neither what it held nor what the push wanted, until the
        # next push or rollback completes it.
        status.unfinished.append(
            f"the last {last.action} ({local_time(last.time)}) stopped part way through "
            f"{last.partly_text()}; run it again (or roll back) to complete it"
        )


def _state(r: RobotStatus) -> str:
    if r.unfinished:
        return "unfinished push"
    push = r.last_push
    if push is not None and push.result not in audit.SETTLED and push.written:
        return "partial push"
    if r.never_backed_up:
        return "never backed up"
    if r.last_result == "failed":
        return "failed"
    if r.stale:
        return "stale"
    return "changed" if r.changed else "ok"


def collect(
    paths: Iterable[str | Path],
    *,
    stale_after: timedelta = timedelta(hours=36),
    now: datetime | None = None,
) -> PlantStatus:
    """The state of every robot project under ``paths``, sorted by name.

    Reads files, the audit log and git only: no port is opened.  Raises
    ProjectError for a PATH that holds no project.
    """
    now = now or datetime.now(timezone.utc)
    projects = find_projects(paths)
    warnings: list[str] = []
    log = _audit_index(warnings)
    labels = project_labels(projects)
    robots = []
    for path in projects:
        robot = _robot_status(path, log, now, stale_after, warnings)
        robot.project = labels[path]
        robots.append(robot)
    robots.sort(key=lambda r: (r.name, r.project))
    for robot, shown in zip(robots, shown_names((r.name, r.project) for r in robots)):
        robot.label = shown
    return PlantStatus(
        robots,
        now.isoformat(timespec="seconds"),
        stale_after.total_seconds() / 3600,
        str(audit.audit_path()),
        warnings,
    )
