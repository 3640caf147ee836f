"""The audit log: what every push and rollback did, appended, never rewritten.

Where it lives: ``$HARLSYNC_AUDIT_LOG`` if set, else
``$XDG_STATE_HOME/harlsync/audit.jsonl`` (``~/.local/state/harlsync/audit.jsonl``).
The file is opened in append mode and each record is one JSON line, written
whole and fsynced; on a server, ``chattr +a`` makes it append-only for root too.

Records, tied together by ``id`` (one per push or rollback)::

    {"event": "start", "id", "action", "time", "user", "host", "pid", "robot",
     "project", "commit", "reason", "outside_window", "plan", "snapshot"}
        before the first write command is sent (write-ahead)
    {"event": "write", "id", "time", "item", "command"}
        just before each write command is sent; the push reads each item back
        before it logs the next one, so every write record but the last of an
        unfinished push was written and verified
    {"event": "end", "id", "action", "time", "user", "host", "pid", "robot", ...,
     "plan", "result", "error", "written": [{"item", "command", "old", "new"}],
     "failed_item"}
        when the push ends, whatever the result (ok, nothing to write, refused,
        failed, interrupted): the whole story in one record

A push refused, or with nothing to write, has only its end record.  A push
killed after its start record (SIGKILL, power loss) has no end record:
:func:`results` reports it as ``"unfinished"``, and :func:`unfinished` finds it
for the next push, rollback or diff of that robot, until a push or rollback of
that robot ends ok.  Records written before these events existed have no
``event`` and count as end records.

Each record is an :class:`~.auditrecord.AuditRecord`, read and written: that
module says how a line is read, field by field, and how a record reads to a person.

The log only grows, and it is never rotated: a log of any size, an older
harlsync's included, is one file read the one way.  Only ``harlsync log`` reads
it whole (:func:`results`); a pull, push, rollback, diff and status ask its index
(:mod:`.auditindex`, a cache beside the log that the readers keep, and the API
that reads it: ``index``, ``unfinished``, ``pushes_since``), which reads what was
appended since the last reader.  This module imports no index.  Rotation into segments
would bound the file but not the question: a push killed a year ago is still
unsettled, so the reader would still have to open every segment to find it.
"""

from __future__ import annotations

import errno
import getpass
import json
import logging
import os
import re
import secrets
import socket
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING

from ..link import lock_key
from ..project import statefile
from ..project.statefile import fold, kind_of
from .auditrecord import (
    EMPTY,
    SHOWN,
    AuditRecord,
    Change,
    PartlyRecorded,
    RecordedRobot,
    Written,
    change_line,
    shorten,
    written_lines,
)

if TYPE_CHECKING:
    from ..families.base import Catalogue, D, K
    from . import items
    from .plan import PlannedWrite

__all__ = [
    "EMPTY",
    "SETTLED",
    "SHOWN",
    "AuditRecord",
    "Change",
    "OpenPush",
    "PartlyRecorded",
    "RecordedRobot",
    "Written",
    "append",
    "audit_path",
    "base_record",
    "change_entries",
    "change_line",
    "changed_names",
    "describe_unfinished",
    "difference",
    "of_robot",
    "parse_line",
    "read",
    "results",
    "shorten",
    "unsettled",
    "written_entry",
    "written_lines",
]

log = logging.getLogger(__name__)

#: A push or rollback after which an earlier unfinished one no longer matters.
SETTLED = ("ok", "nothing to write")


def audit_path() -> Path:
    explicit = os.environ.get("HARLSYNC_AUDIT_LOG")
    if explicit:
        return Path(explicit)
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "harlsync" / "audit.jsonl"


def now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def base_record(action: str) -> AuditRecord:
    """An end record with what every one starts with: event, id, action, time, user,
    host, pid."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = str(os.getuid()) if hasattr(os, "getuid") else "unknown"
    return AuditRecord(
        event="end",
        id=secrets.token_hex(8),
        action=action,
        time=now(),
        user=user,
        host=socket.gethostname(),
        pid=os.getpid(),
    )


def append(record: AuditRecord, path: Path | None = None) -> Path:
    """Append one record as a JSON line, fsynced; return the log's path.

    A line left unterminated by an earlier writer (a full disk) is ended first,
    so it cannot swallow this record.  Raises OSError.
    """
    path = path or audit_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    line = json.dumps(record.to_json(), sort_keys=True, default=str) + "\n"
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        size = os.fstat(fd).st_size
        if size and os.pread(fd, 1, size - 1) != b"\n":
            line = "\n" + line
        data = line.encode("utf-8")
        while data:  # a full disk can take part of it without an error
            written = os.write(fd, data)
            if written == 0:
                raise OSError(errno.ENOSPC, f"cannot append to {path}")
            data = data[written:]
        os.fsync(fd)
    finally:
        os.close(fd)
    return path


#: Problems already said by this process (path, line): a backup of 40 robots reads
#: the log 40 times and says each once.
_said: set[tuple[str, int]] = set()


def parse_line(raw: bytes) -> tuple[AuditRecord | None, str | None]:
    """One line of the log: the record (each field of the type it must have; None
    when the line is no record) and what was wrong with it (None: nothing)."""
    try:
        value = statefile.parse(raw.decode("utf-8"))
    except ValueError as exc:  # UnicodeDecodeError too
        why = str(exc) if not isinstance(exc, UnicodeDecodeError) else "not UTF-8 text"
        return None, f"not an audit record ({why}): {_LEFT_OUT}"
    if not isinstance(value, dict):
        return None, f"not an audit record ({kind_of(value)}, not an object): {_LEFT_OUT}"
    record, wrong = AuditRecord.from_json(value)
    return record, (f"{'; '.join(fold(wrong, 3))}: {_MISSING}" if wrong else None)


def report(
    path: Path, found: list[tuple[int, str]], problems: list[str] | None, total: int | None = None
) -> None:
    """Say what was wrong with the log's lines: ``found`` (line number, problem), the
    first of ``total`` (default: all of them).  Appended to ``problems`` when given,
    else logged, each line once per process; at most 5 lines, then ``and 40 more``."""
    total = len(found) if total is None else total
    if problems is None:
        fresh = [(number, text) for number, text in found if (str(path), number) not in _said]
        _said.update((str(path), number) for number, _ in fresh)
        # The lines past the first few were said with them, or are new with them.
        total = len(fresh) + (total - len(found) if len(fresh) == len(found) else 0)
        found = fresh
    texts = [f"{path}:{number}: {text}" for number, text in found]
    if total > SHOWN_PROBLEMS:
        texts = [
            *texts[: SHOWN_PROBLEMS - 1],
            f"and {total - SHOWN_PROBLEMS + 1} more malformed lines in {path}",
        ]
    if problems is not None:
        problems += texts
    else:
        for text in texts:
            log.warning("%s", text)


#: How many malformed lines are named, the last of them as ``and 40 more``.
SHOWN_PROBLEMS = 5


def read(path: Path | None = None, problems: list[str] | None = None) -> list[AuditRecord]:
    """Every record, in order, each field of the type it must have.

    A line that is not a JSON object is left out, a field of the wrong type is read
    as missing; each is said once, naming the file and line: appended to
    ``problems`` when given, else logged.  Raises OSError when the log cannot be read.
    """
    path = path or audit_path()
    if not path.exists():
        return []
    found: list[tuple[int, str]] = []
    records = []
    for number, raw in enumerate(path.read_bytes().splitlines(), 1):
        if not raw.strip():
            continue
        record, problem = parse_line(raw)
        if problem is not None:
            found.append((number, problem))
        if record is not None:
            records.append(record)
    report(path, found, problems)
    return records


_MISSING = "read as missing; fix that line, or move it to another file"
_LEFT_OUT = "left out; move that line to another file to keep it (harlsync only appends)"


@dataclass
class OpenPush:
    """A push or rollback whose start record has been read and its end not (yet):
    the start, and its write records so far."""

    start: AuditRecord
    writes: list[AuditRecord] = field(default_factory=list)

    def record(self) -> AuditRecord:
        """The push as :func:`results` gives it while the log has no end of it: its
        start record with ``result`` unfinished, ``written`` (the write records but
        the last) and ``failed_item`` (the last: it may or may not have been written)."""
        return replace(
            self.start,
            result="unfinished",
            written=[write.as_written() for write in self.writes[:-1]],
            failed_item=self.writes[-1].item if self.writes else None,
        )


def results(path: Path | None = None, problems: list[str] | None = None) -> list[AuditRecord]:
    """One record per push or rollback, in the order they started: the whole log
    (``harlsync log``; the other commands ask :mod:`.auditindex`).

    A finished one is its end record.  An unfinished one is its start record
    with ``result`` unfinished (see :meth:`OpenPush.record`).
    """
    started: dict[str, int] = {}  # the id of each open one -> its place in ``order``
    order: list[AuditRecord | OpenPush] = []
    for record in read(path, problems):
        rid = record.id
        if record.event == "start" and rid:
            started[rid] = len(order)
            order.append(OpenPush(record))
        elif record.event == "write" and rid in started:
            opened = order[started[rid]]
            assert isinstance(opened, OpenPush)
            opened.writes.append(record)
        elif record.event == "end":
            if rid in started:
                order[started.pop(rid)] = record
            else:
                order.append(record)
    return [r.record() if isinstance(r, OpenPush) else r for r in order]


def _same_robot(record: AuditRecord, port: str, station: int) -> bool:
    robot = record.robot
    if robot is None or robot.station != station:
        return False
    other = robot.port
    return other is not None and (other == port or lock_key(other) == lock_key(port))


def of_robot(
    records: Iterable[AuditRecord], port: str, station: int, project: Path | None = None
) -> list[AuditRecord]:
    """The records of the robot at ``port``/``station``, whatever project pushed to it,
    and those of ``project`` (a push refused before it named its robot)."""
    where = str(project.resolve()) if project is not None else None
    return [
        r
        for r in records
        if _same_robot(r, port, station) or (where is not None and r.project == where)
    ]


def unsettled(records: Iterable[AuditRecord]) -> list[AuditRecord]:
    """The unfinished pushes and rollbacks among one robot's ``records`` (from
    :func:`results`) that no later one has settled."""
    found: list[AuditRecord] = []
    for record in records:
        if record.result == "unfinished":
            found.append(record)
        elif record.result in SETTLED:
            found = []
    return found


def describe_unfinished(record: AuditRecord) -> str:
    """One line: who started it when, what it wrote, what it may have written."""
    written = [w.item for w in record.done]
    reason = f", reason {record.reason!r}" if record.reason else ""
    text = (
        f"an earlier {record.shown_action} to this robot did not finish: started "
        f"{record.time} by {record.user} on {record.host} "
        f"(pid {record.pid}{reason}); it wrote {len(written)} of {record.planned} item(s)"
    )
    if written:
        text += ": " + ", ".join(str(w) for w in written)
    if record.failed_item:
        text += f"; unknown: {record.failed_item} (may or may not have been written)"
    if record.snapshot:
        text += f"; the robot before it: {record.snapshot}"
    return text


# --- the record in the family's words ------------------------------------------------


def change_entries(changes: Iterable[items.Change[K]]) -> list[Change]:
    """The changes field by field, as ``diff`` shows them: ``position 3: speed 150 →
    200`` is ``Change("position 3", "speed", "150", "200")``."""
    found: list[Change] = []
    for change in changes:
        for name, old, new in change.fields():
            for part, a, b in _narrow(name, old, new):
                found.append(Change(change.name, part or None, a, b))
    return found


def difference(catalogue: Catalogue[K, D], key: K, old: object, new: object) -> str:
    """How ``new`` differs from ``old`` for the item (or run of items) ``key``, in the
    family's words: ``speed 150 → 200; acc 0.30 → 0.50`` (the family's
    :meth:`~harlsync.families.base.Catalogue.fields`, each field narrowed as diff
    narrows it)."""
    texts = [
        change_line(Change(None, part, p, q)).split(": ", 1)[1]
        for name, x, y in catalogue.fields(key, old, new)
        for part, p, q in _narrow(name, x, y)
    ]
    return "; ".join(fold(texts, 4, "more")) or "its value differs"


def written_entry(write: PlannedWrite[K]) -> Written:
    """A write as the audit log keeps it: the item, the wire command (for the record;
    shown with -v only) and what it changes."""
    changes = change_entries(write.items)
    if len(changes) == 1 and changes[0].field is None and changes[0].item == write.name:
        # as older records had it too
        return Written(write.name, write.command, changes[0].old, changes[0].new, tuple(changes))
    return Written(write.name, write.command, changes=tuple(changes))


_TOKEN = re.compile(r"\[[^\]]*\]|\S+")
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def _groups(text: str) -> list[tuple[str, list[str]]] | None:
    """``axes [1, 2] acc 0.30 speed 150`` as [(axes, [[1, 2]]), (acc, [0.30]), ...];
    None when it does not read so."""
    groups: list[tuple[str, list[str]]] = []
    for token in _TOKEN.findall(text):
        if groups and (not groups[-1][1] or not _NAME.match(token)):
            groups[-1][1].append(token)
        elif _NAME.match(token):
            groups.append((token, []))
        else:
            return None
    return groups if groups and all(values for _, values in groups) else None


def _narrow(
    name: str, old: str | None, new: str | None
) -> list[tuple[str, str | None, str | None]]:
    """One field whose text reads ``name value name value ...`` on both sides with the
    same names (a table row's line), narrowed to the names whose values differ."""
    if name or old is None or new is None:
        return [(name, old, new)]
    a, b = _groups(old), _groups(new)
    if a is None or b is None or len(a) < 3 or [n for n, _ in a] != [n for n, _ in b]:
        return [(name, old, new)]
    differ: list[tuple[str, str | None, str | None]] = [
        (n, " ".join(x), " ".join(y)) for (n, x), (_, y) in zip(a, b) if x != y
    ]
    return differ if 0 < len(differ) < len(a) else [(name, old, new)]


def changed_names(changes: Iterable[items.Change[K]]) -> list[str]:
    """What the changes touch, item by item, with the fields that differ where an item
    has several: ``MAIN program 0 step 4``, ``position 12 speed``, ``AccelS 3 decel``."""
    names = []
    for change in changes:
        parts = [
            part
            for name, old, new in change.fields()
            for part, _, _ in _narrow(name, old, new)
            if part
        ]
        names.append(f"{change.name} {', '.join(parts)}" if parts else change.name)
    return names


def pushes(
    project: Path | None = None, most: int | None = None, problems: list[str] | None = None
) -> list[AuditRecord]:
    """The pushes and rollbacks ``harlsync log`` lists, the latest first, at most
    ``most``: every robot's, or (``project``) those of that project's robot, whatever
    project pushed to it.  What could not be read is added to ``problems``; then
    ProjectFormatError is raised for a ``project`` that holds none."""
    records = results(problems=problems)
    if project is not None:
        from ..project.store import load_robot

        robot = load_robot(project)
        records = of_robot(records, robot.port, robot.station, project)
    return records[::-1][:most]
