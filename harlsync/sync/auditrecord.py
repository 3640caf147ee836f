"""The audit log's one record shape, :class:`AuditRecord`: what a push, a rollback or a
recovered connection wrote there, and how it reads to a person.

A line of the log (:mod:`.audit`) is one JSON object; :meth:`AuditRecord.from_json`
reads it field by field, each of the type it must hold.  A field of another type
is read as missing and said once (the log is only appended to: a bad line stays
there for good); a field this harlsync does not know (a newer harlsync's) is kept
as read in :attr:`AuditRecord.extra`.  :meth:`AuditRecord.to_json` writes it back
the same way, a field that is None left out (a reader takes a missing field and a
null alike)::

    AuditRecord                 event, id, action, time, user, host, pid, project,
      robot: RecordedRobot      commit, reason, outside_window, plan, reverts, snapshot,
      written: [Written]        result, error, failed_item, warnings, notes, note;
        changes: [Change]       a write record's item, command and changes
      partly_written: PartlyRecorded

What a person reads of a record (``log``, ``status``, the report page) is in the
family's words, as its files and diffs write them: a change field by field
(``position 3: speed 150 → 200``), an error's frame on the wire named by its size.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from datetime import datetime
from pathlib import Path

from ..errors import partly_words
from ..project.statefile import Fields, fold

__all__ = [
    "EMPTY",
    "SHOWN",
    "AuditRecord",
    "Change",
    "PartlyRecorded",
    "RecordedRobot",
    "Written",
    "change_line",
    "local_time",
    "shorten",
    "written_lines",
]

#: How many changes a push's entry shows before "and 40 more".
SHOWN = 10
#: What an item one side does not have is called (an empty step, an undefined position).
EMPTY = "(empty)"


@dataclass(frozen=True)
class Change:
    """One field of one item a write changed, as ``diff`` shows it: ``{"item":
    "position 3", "field": "speed", "old": "150", "new": "200"}`` (``field`` None:
    the item's value as a whole; ``old`` or ``new`` None: the item was not there)."""

    item: str | None
    field: str | None
    old: str | None
    new: str | None

    @classmethod
    def from_json(cls, value: Mapping[str, object], problems: list[str]) -> Change:
        one = Fields(value)
        found = cls(one.text("item"), one.text("field"), one.text("old"), one.text("new"))
        problems += one.problems
        return found

    def to_json(self) -> dict[str, str | None]:
        return {"item": self.item, "field": self.field, "old": self.old, "new": self.new}


@dataclass(frozen=True)
class Written:
    """One item a push wrote: its name, its wire command (for the record, shown with
    -v only) and what it changed.  ``old`` and ``new`` are the item's whole value
    when it is one field, as older records kept it (their only account)."""

    item: str | None = None
    command: str | None = None
    old: str | None = None
    new: str | None = None
    changes: tuple[Change, ...] | None = None

    @classmethod
    def from_json(cls, value: Mapping[str, object], problems: list[str]) -> Written:
        one = Fields(value)
        found = cls(
            one.text("item"),
            one.text("command"),
            one.text("old"),
            one.text("new"),
            _changes(one),
        )
        problems += [f"written item's {p}" for p in one.problems]
        return found

    def to_json(self) -> dict[str, object]:
        found: dict[str, object] = {
            name: value
            for name, value in (
                ("item", self.item),
                ("command", self.command),
                ("old", self.old),
                ("new", self.new),
            )
            if value is not None
        }
        if self.changes is not None:
            found["changes"] = [change.to_json() for change in self.changes]
        return found


@dataclass(frozen=True)
class RecordedRobot:
    """The robot a record is of: its name, and the port and station it was reached at."""

    name: str | None
    port: str | None
    station: int | None

    def to_json(self) -> dict[str, object]:
        return {"name": self.name, "port": self.port, "station": self.station}


@dataclass(frozen=True)
class PartlyRecorded:
    """The item a push stopped part way through (its write takes several commands):
    the parts that went out, the one that may or may not have, the parts not sent."""

    item: str | None
    command: str | None
    sent: tuple[str, ...] = ()
    unknown: str | None = None
    not_sent: tuple[str, ...] = ()

    def to_json(self) -> dict[str, object]:
        return {
            "item": self.item,
            "command": self.command,
            "sent": list(self.sent),
            "unknown": self.unknown,
            "not sent": list(self.not_sent),
        }

    def text(self) -> str:
        """``P12: x, y went out; z, hand not sent``."""
        return f"{self.item}: " + partly_words(list(self.sent), self.unknown, list(self.not_sent))


@dataclass
class AuditRecord:
    """One record of the audit log (see :mod:`.audit` for the events and when each is
    written).  Every field is None when the record does not hold it."""

    #: ``start``, ``write``, ``end`` or ``recover``; a record of an older harlsync has
    #: none and counts as an end record.
    event: str = "end"
    #: One per push or rollback, shared by its start, write and end records.
    id: str | None = None
    #: ``push``, ``rollback`` (or ``recover``).
    action: str | None = None
    #: When, ISO 8601 in UTC to the second.
    time: str | None = None
    user: str | None = None
    host: str | None = None
    pid: int | None = None
    robot: RecordedRobot | None = None
    #: The project's directory, absolute.
    project: str | None = None
    #: The commit the project was pushed from.
    commit: str | None = None
    reason: str | None = None
    outside_window: str | None = None
    #: The wire commands the push planned, in order.
    plan: list[str] | None = None
    #: Its writes that put back a change made on the robot, each ``item: why``.
    reverts: list[str] | None = None
    #: The snapshot of the robot taken just before the first write.
    snapshot: str | None = None
    #: ``ok``, ``nothing to write``, ``refused``, ``failed``, ``interrupted``; an
    #: unended push as :func:`.audit.results` gives it: ``unfinished``.
    result: str | None = None
    error: str | None = None
    #: Each item written and read back as written.
    written: list[Written] | None = None
    #: The item whose write may or may not have happened (the push stopped there).
    failed_item: str | None = None
    partly_written: PartlyRecorded | None = None
    warnings: list[str] | None = None
    notes: list[str] | None = None
    #: A write record's item, wire command and changes (see :class:`Written`).
    item: str | None = None
    command: str | None = None
    changes: list[Change] | None = None
    #: What a recovered connection found and did (event ``recover``).
    note: str | None = None
    #: Fields this harlsync does not know, as read (JSON).
    extra: dict[str, object] = field(default_factory=dict)

    # --- the log's JSON ----------------------------------------------------------------

    @classmethod
    def from_json(cls, value: Mapping[str, object]) -> tuple[AuditRecord, list[str]]:
        """The record a line's object holds, each field of the type it must have (one of
        another type read as missing), and what was wrong with it."""
        one = Fields(value)
        event = one.text("event")
        found = cls(
            event="end" if event is None else event,
            id=one.text("id"),
            action=one.text("action"),
            time=one.text("time"),
            user=one.text("user"),
            host=one.text("host"),
            pid=one.integer("pid"),
            project=one.text("project"),
            commit=one.text("commit"),
            reason=one.text("reason"),
            outside_window=one.text("outside_window"),
            snapshot=one.text("snapshot"),
            result=one.text("result"),
            error=one.text("error"),
            failed_item=one.text("failed_item"),
            item=one.text("item"),
            command=one.text("command"),
            note=one.text("note"),
            plan=one.texts("plan"),
            reverts=one.texts("reverts"),
            warnings=one.texts("warnings"),
            notes=one.texts("notes"),
            extra={k: v for k, v in value.items() if k not in _KNOWN},
        )
        robot = one.object("robot")
        if robot is not None:
            of_robot = Fields(robot)
            found.robot = RecordedRobot(
                of_robot.text("name"), of_robot.text("port"), of_robot.integer("station")
            )
            one.problems += [f"robot's {p}" for p in of_robot.problems]
        changes = _changes(one)
        found.changes = None if changes is None else list(changes)
        written = one.objects("written")
        if written is not None:
            found.written = [Written.from_json(entry, one.problems) for entry in written]
        partly = one.object("partly_written")
        if partly:
            of_partly = Fields(partly)
            found.partly_written = PartlyRecorded(
                of_partly.text("item"),
                of_partly.text("command"),
                tuple(of_partly.texts("sent") or ()),
                of_partly.text("unknown"),
                tuple(of_partly.texts("not sent") or ()),
            )
            one.problems += [f"partly written item's {p}" for p in of_partly.problems]
        return found, one.problems

    def to_json(self) -> dict[str, object]:
        """The record as a line of the log holds it (a field that is None left out)."""
        found: dict[str, object] = dict(self.extra)
        for each in fields(self):
            value = getattr(self, each.name)
            if each.name == "extra" or value is None:
                continue
            if isinstance(value, list):
                value = [v if isinstance(v, str) else v.to_json() for v in value]
            elif not isinstance(value, str | int):
                value = value.to_json()
            found[each.name] = value
        return found

    def as_written(self) -> Written:
        """A write record as the entry of its push's ``written`` it becomes once the
        next write (or the end) says it went out."""
        return Written(
            self.item, self.command, changes=None if self.changes is None else tuple(self.changes)
        )

    # --- in a person's words ------------------------------------------------------------

    @property
    def robot_name(self) -> str | None:
        """The robot's name, or its project directory's (a push refused before it read
        robot.yaml names no robot)."""
        name = self.robot.name if self.robot is not None else None
        if name is None and self.project:
            name = Path(self.project).name
        return name

    @property
    def shown_action(self) -> str:
        """``push`` or ``rollback``: what it was (a record that says nothing, a push)."""
        return "push" if self.action is None else self.action

    @property
    def shown_result(self) -> str:
        """How it ended (``ok``, ``refused``, ``unfinished`` ...; a record that says
        nothing, ``unknown``)."""
        return "unknown" if self.result is None else self.result

    @property
    def planned(self) -> int:
        """How many writes it planned."""
        return len(self.plan or [])

    @property
    def done(self) -> list[Written]:
        """The items it wrote (none recorded: none)."""
        return self.written or []

    def partly_text(self) -> str:
        """``P12: x, y went out; z, hand not sent`` ("" when nothing was partly written)."""
        return self.partly_written.text() if self.partly_written else ""

    def describe(self) -> str:
        """One line: ``push ok 2026-11-24 20:23 by alice@pc, wrote 2 of 2 item(s): "faster pick"``."""
        return f"{self.shown_action} {self.shown_result} {local_time(self.time)} {self.details()}"

    def details(self) -> str:
        """Who, what it wrote, why: ``by alice@pc, wrote 2 of 2 item(s): "faster pick"``."""
        text = f"by {self.user}@{self.host}"
        if self.written or self.planned:
            text += f", wrote {len(self.done)} of {self.planned} item(s)"
        if self.partly_written:
            text += f", partly written: {self.partly_text()}"
        elif self.failed_item:
            text += f", {self.failed_item} unknown"
        if self.reason:
            text += f': "{self.reason}"'
        if self.error and self.result != "ok":
            text += f" ({shorten(self.error)})"
        return text

    def written_lines(self, most: int | None = SHOWN) -> list[str]:
        """What it wrote, a line per field as ``diff`` shows it (``position 3: speed
        150 → 200``), at most ``most`` then ``and 40 more``."""
        return written_lines(self.done, most)

    def log_lines(self, verbose: int = 0) -> list[str]:
        """Its entry in ``harlsync log``: when, which robot, what, how it ended, who;
        why; what it wrote (every item with ``verbose``, and each wire command); what
        it may have written; its error."""
        head = (
            f"{local_time(self.time)}  {self.robot_name or '?'}  {self.shown_action} "
            f"{self.shown_result}  by {self.user}@{self.host}"
        )
        lines = [head + (f"  commit {self.commit[:10]}" if self.commit else "")]
        if self.reason:
            lines.append(f"    reason: {self.reason}")
        wrote = self.written_lines(None)
        shown = wrote if verbose or len(wrote) <= SHOWN else wrote[: SHOWN - 1]
        lines += [f"    wrote {line}" for line in shown]
        if len(shown) < len(wrote):
            lines.append(f"    and {len(wrote) - len(shown)} more (-v shows them)")
        lines += [f"    command {w.item}: {w.command}" for w in self.done if verbose]
        if self.partly_written:
            lines.append(f"    partly written: {self.partly_text()}")
        elif self.failed_item:
            lines.append(f"    unknown: {self.failed_item} (may or may not have been written)")
        if self.error and self.result != "ok":
            lines.append(f"    error: {shorten(self.error, verbose)}")
        return lines


#: The fields harlsync knows: the rest are kept as read (:attr:`AuditRecord.extra`).
_KNOWN = frozenset(f.name for f in fields(AuditRecord)) - {"extra"}


def _changes(fields: Fields) -> tuple[Change, ...] | None:
    """The ``changes`` of a record or a written entry, each field checked; what was
    wrong is added to ``fields.problems``."""
    changes = fields.objects("changes")
    if changes is None:
        return None
    return tuple(Change.from_json(change, fields.problems) for change in changes)


# --- words -------------------------------------------------------------------------------

#: A value an older harlsync recorded as Python's repr: ``Position(axes=..., ...)``.
_REPR = re.compile(r"^[A-Z]\w*\(.*\)$", re.DOTALL)
#: A run of hex a person cannot read: a frame on the wire (at least 12 bytes).
_HEX = re.compile(
    r"(?<![0-9A-Za-z])(?=[0-9A-Fa-f ]*[A-Fa-f])(?:[0-9A-Fa-f]{2} ?){12,}(?![0-9A-Za-z])"
)


def change_line(change: Change) -> str:
    """``position 3: speed 150 → 200``."""
    named = f"{change.field} " if change.field else ""
    old = EMPTY if change.old is None else change.old
    new = EMPTY if change.new is None else change.new
    return f"{change.item}: {named}{old} → {new}"


def written_lines(written: list[Written], most: int | None = SHOWN) -> list[str]:
    """What the written entries changed, a line per field (``position 3: speed 150 →
    200``), at most ``most`` then ``and 40 more``.  An entry an older harlsync recorded
    shows its values when they are the family's text, else only its item."""
    lines: list[str] = []
    for w in written:
        if w.changes is not None:
            lines += [change_line(c) for c in w.changes]
            continue
        if any(v is not None and _REPR.match(v) for v in (w.old, w.new)) or (
            w.old is w.new is None
        ):
            lines.append(f"{w.item}: changed")
        else:
            lines.append(change_line(Change(w.item, None, w.old, w.new)))
    return lines if most is None else fold(lines, most, "more")


def shorten(text: str | None, verbose: int = 0) -> str | None:
    """A recorded error as a line a person reads: a frame on the wire (a long run of
    hex) named by its size, unless ``verbose`` >= 2 (the advice around it is kept)."""
    if text is None or verbose >= 2:
        return text
    return _HEX.sub(_frame, text)


def _frame(match: re.Match[str]) -> str:
    found = match.group()
    if found.strip() == found and len(found) in (40, 64):  # a git commit, a SHA-256
        return found
    size = len(re.sub(r"\s", "", found)) // 2
    return f"[a {size}-byte frame: -vv shows it]"


def local_time(stamp: str | None) -> str:
    """A recorded time (ISO 8601, UTC) as this machine's wall clock: ``2026-11-24 21:23``."""
    if not stamp:
        return "-"
    try:
        return datetime.fromisoformat(stamp).astimezone().strftime("%Y-%m-%d %H:%M")
    except ValueError:
        return stamp
