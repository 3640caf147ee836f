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

The log only grows, and it is never rotated: a log of any size, an older
harlsync's included, is one file read the one way.  Only ``harlsync log`` reads
it whole (:func:`results`); a pull, push, rollback, diff and status ask
:func:`index` (:mod:`.auditindex`, a cache beside the log that the readers keep),
which reads what was appended since the last reader.  Rotation into segments
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
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..link import lock_key
from ..project import statefile
from ..project.statefile import Fields, fold, kind_of

if TYPE_CHECKING:
    from .auditindex import AuditIndex

__all__ = [
    "append",
    "audit_path",
    "base_record",
    "describe_unfinished",
    "index",
    "of_robot",
    "read",
    "results",
    "unfinished",
    "unsettled",
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


def base_record(action: str) -> dict[str, Any]:
    """The fields every end record starts with: event, id, action, time, user, host, pid."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = str(os.getuid()) if hasattr(os, "getuid") else "unknown"
    return {
        "event": "end",
        "id": secrets.token_hex(8),
        "action": action,
        "time": now(),
        "user": user,
        "host": socket.gethostname(),
        "pid": os.getpid(),
    }


def append(record: dict[str, Any], path: Path | None = None) -> Path:
    """Append one record as a JSON line, fsynced; return the log's path.

    A line left unterminated by an earlier writer (a full disk) is ended first,
    so it cannot swallow this record.  Raises OSError.
    """
    path = path or audit_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    line = json.dumps(record, sort_keys=True, default=str) + "\n"
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


#: The fields of an audit record, by the type they must hold (anything else is read
#: as missing, and said so once).
_TEXT = (
    "event", "id", "action", "user", "host", "project", "commit", "reason", "result",
    "error", "failed_item", "snapshot", "item", "command", "outside_window", "time",
)  # fmt: skip
_TEXTS = ("plan", "warnings", "notes")
_WRITTEN_TEXT = ("item", "command", "old", "new")
_CHANGE_TEXT = ("item", "field", "old", "new")

#: Problems already said by this process (path, line): a backup of 40 robots reads
#: the log 40 times and says each once.
_said: set[tuple[str, int]] = set()


def _clean(record: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """The record with every field of the wrong type left out, and what was wrong."""
    fields = Fields(record)
    clean: dict[str, Any] = {k: v for k, v in record.items() if k not in _KNOWN}
    for name in _TEXT:
        clean[name] = fields.text(name)
    clean["pid"] = fields.integer("pid")
    for name in _TEXTS:
        clean[name] = fields.texts(name)
    robot = fields.object("robot")
    if robot is not None:
        of_robot = Fields(robot)
        clean["robot"] = {
            "name": of_robot.text("name"),
            "port": of_robot.text("port"),
            "station": of_robot.integer("station"),
        }
        fields.problems += [f"robot's {p}" for p in of_robot.problems]
    clean["changes"] = _changes(fields)  # a write record's, see written_entry
    written = fields.objects("written")
    if written is not None:
        clean["written"] = []
        for entry in written:
            one = Fields(entry)
            kept: dict[str, Any] = {}
            for name in _WRITTEN_TEXT:
                if (value := one.text(name)) is not None:
                    kept[name] = value
            if (changes := _changes(one)) is not None:
                kept["changes"] = changes
            clean["written"].append(kept)
            fields.problems += [f"written item's {p}" for p in one.problems]
    return {k: v for k, v in clean.items() if v is not None}, fields.problems


def _changes(fields: Fields) -> list[dict[str, Any]] | None:
    """The ``changes`` of a record or written entry (see :func:`written_entry`), each
    field checked; what was wrong is added to ``fields.problems``."""
    changes = fields.objects("changes")
    if changes is None:
        return None
    found = []
    for change in changes:
        of_change = Fields(change)
        found.append({n: of_change.text(n) for n in _CHANGE_TEXT})
        fields.problems += of_change.problems
    return found


_KNOWN = frozenset((*_TEXT, *_TEXTS, "pid", "robot", "written", "changes"))


def parse_line(raw: bytes) -> tuple[dict[str, Any] | None, str | None]:
    """One line of the log: the record (each field of the type it must have; None
    when the line is no record) and what was wrong with it (None: nothing)."""
    try:
        record = statefile.parse(raw.decode("utf-8"))
    except ValueError as exc:  # UnicodeDecodeError too
        why = str(exc) if not isinstance(exc, UnicodeDecodeError) else "not UTF-8 text"
        return None, f"not an audit record ({why}): {_LEFT_OUT}"
    if not isinstance(record, dict):
        return None, f"not an audit record ({kind_of(record)}, not an object): {_LEFT_OUT}"
    record, wrong = _clean(record)
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


def read(path: Path | None = None, problems: list[str] | None = None) -> list[dict[str, Any]]:
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


def pending(start: dict[str, Any]) -> dict[str, Any]:
    """An unfinished push or rollback, from its start record (see :func:`results`)."""
    return {**start, "result": "unfinished", "written": [], "failed_item": None}


def add_write(push: dict[str, Any], write: dict[str, Any]) -> None:
    """One more write record of the unfinished ``push``: the one before it was written."""
    if push["failed_item"] is not None:
        push["written"].append(push["failed_item"])
    push["failed_item"] = {k: write.get(k) for k in ("item", "command", "changes") if k in write}


def unended(push: dict[str, Any]) -> dict[str, Any]:
    """``push`` as :func:`results` gives it once the log has no more of it."""
    push["failed_item"] = (push["failed_item"] or {}).get("item")
    return push


def results(path: Path | None = None, problems: list[str] | None = None) -> list[dict[str, Any]]:
    """One record per push or rollback, in the order they started: the whole log
    (``harlsync log``; the other commands ask :func:`index`).

    A finished one is its end record.  An unfinished one is its start record
    with ``result: "unfinished"``, ``written`` (the write records but the last)
    and ``failed_item`` (the last: it may or may not have been written).
    """
    started: dict[str, dict[str, Any]] = {}
    where: dict[str, int] = {}
    order: list[dict[str, Any]] = []
    pushes: list[dict[str, Any]] = []  # every start: one whose id came back is unended too
    for record in read(path, problems):
        event = record.get("event", "end")
        rid = record.get("id")
        if event == "start" and rid:
            started[rid] = pending(record)
            pushes.append(started[rid])
            where[rid] = len(order)
            order.append(started[rid])
        elif event == "write" and rid in started:
            add_write(started[rid], record)
        elif event == "end":
            if rid in started:
                del started[rid]
                order[where[rid]] = record
            else:
                order.append(record)
    for push in pushes:
        unended(push)
    return order


def _same_robot(record: dict[str, Any], port: str, station: int) -> bool:
    robot = record.get("robot")
    if not isinstance(robot, dict) or robot.get("station") != station:
        return False
    other = robot.get("port")
    return isinstance(other, str) and (other == port or lock_key(other) == lock_key(port))


def of_robot(
    records: Iterable[dict[str, Any]], port: str, station: int, project: Path | None = None
) -> list[dict[str, Any]]:
    """The records of the robot at ``port``/``station``, whatever project pushed to it,
    and those of ``project`` (a push refused before it named its robot)."""
    where = str(project.resolve()) if project is not None else None
    return [
        r
        for r in records
        if _same_robot(r, port, station) or (where is not None and r.get("project") == where)
    ]


def unsettled(records: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The unfinished pushes and rollbacks among one robot's ``records`` (from
    :func:`results`) that no later one has settled."""
    found: list[dict[str, Any]] = []
    for record in records:
        if record.get("result") == "unfinished":
            found.append(record)
        elif record.get("result") in SETTLED:
            found = []
    return found


def index(path: Path | None = None, problems: list[str] | None = None) -> AuditIndex:
    """The log's index (:mod:`.auditindex`), brought up to its end: what a command
    asks of one robot, read without reading the whole log.  What is wrong with the
    log's lines is said as :func:`read` says it.  Raises OSError."""
    from . import auditindex

    found = auditindex.load(path)
    found.report(problems)
    return found


def unfinished(
    port: str, station: int, path: Path | None = None, problems: list[str] | None = None
) -> list[dict[str, Any]]:
    """The unfinished pushes and rollbacks of the robot at ``port``/``station``
    that no later push or rollback of it has settled (see :func:`results`)."""
    return index(path, problems).robot(port, station).unsettled


def describe_unfinished(record: dict[str, Any]) -> str:
    """One line: who started it when, what it wrote, what it may have written."""
    written = [w.get("item") for w in record.get("written", [])]
    plan = record.get("plan") or []
    reason = f", reason {record['reason']!r}" if record.get("reason") else ""
    text = (
        f"an earlier {record.get('action', 'push')} to this robot did not finish: started "
        f"{record.get('time')} by {record.get('user')} on {record.get('host')} "
        f"(pid {record.get('pid')}{reason}); it wrote {len(written)} of {len(plan)} item(s)"
    )
    if written:
        text += ": " + ", ".join(str(w) for w in written)
    if record.get("failed_item"):
        text += f"; unknown: {record['failed_item']} (may or may not have been written)"
    if record.get("snapshot"):
        text += f"; the robot before it: {record['snapshot']}"
    return text


# --- the record in the family's words ------------------------------------------------

#: A value an older harlsync recorded as Python's repr: ``Position(axes=..., ...)``.
_REPR = re.compile(r"^[A-Z]\w*\(.*\)$", re.DOTALL)
#: A run of hex a person cannot read: a frame on the wire (at least 12 bytes).
_HEX = re.compile(
    r"(?<![0-9A-Za-z])(?=[0-9A-Fa-f ]*[A-Fa-f])(?:[0-9A-Fa-f]{2} ?){12,}(?![0-9A-Za-z])"
)
#: How many changes a push's entry shows before "and 40 more".
SHOWN = 10
#: What an item one side does not have is called (an empty step, an undefined position).
EMPTY = "(empty)"


def change_entries(changes: Iterable[Any]) -> list[dict[str, str | None]]:
    """The changes (:class:`~.items.Change`) field by field, as ``diff`` shows them:
    ``{"item": "position 3", "field": "speed", "old": "150", "new": "200"}``."""
    found: list[dict[str, str | None]] = []
    for change in changes:
        for name, old, new in change.fields():
            for part, a, b in _narrow(name, old, new):
                found.append({"item": change.name, "field": part or None, "old": a, "new": b})
    return found


def difference(catalogue: Any, key: Any, old: Any, new: Any) -> str:
    """How ``new`` differs from ``old`` for the item ``key``, in the family's words:
    ``speed 150 → 200; acc 0.30 → 0.50`` (a run's values compared one by one)."""
    pairs = list(zip(old, new)) if isinstance(old, tuple) and isinstance(new, tuple) else []
    if not pairs or len(old) != len(new):
        pairs = [(old, new)]
    lines: list[str] = []
    try:
        for a, b in pairs:
            for name, x, y in catalogue.fields(key, a, b):
                for part, p, q in _narrow(name, x, y):
                    lines.append(change_line({"item": None, "field": part, "old": p, "new": q}))
    except (AttributeError, TypeError, ValueError):  # a value the family cannot show
        return "its value differs"
    texts = [line.split(": ", 1)[1] for line in lines]
    return "; ".join(fold(texts, 4, "more")) or "its value differs"


def written_entry(write: Any) -> dict[str, Any]:
    """A write (:class:`~.plan.PlannedWrite`) as the audit log keeps it: the item, the
    wire command (for the record; shown with -v only) and what it changes."""
    changes = change_entries(write.items)
    entry: dict[str, Any] = {"item": write.name, "command": write.command}
    if len(changes) == 1 and changes[0]["field"] is None and changes[0]["item"] == write.name:
        entry.update(old=changes[0]["old"], new=changes[0]["new"])  # as older records had
    return entry | {"changes": changes}


def change_line(entry: dict[str, Any]) -> str:
    """``position 3: speed 150 → 200``."""
    field = f"{entry['field']} " if entry.get("field") else ""
    old, new = entry.get("old"), entry.get("new")
    return f"{entry.get('item')}: {field}{EMPTY if old is None else old} → {EMPTY if new is None else new}"


def written_lines(written: Iterable[dict[str, Any]], most: int | None = SHOWN) -> list[str]:
    """What the written entries changed, a line per field (``position 3: speed 150 →
    200``), at most ``most`` then ``and 40 more``.  An entry an older harlsync recorded
    shows its values when they are the family's text, else only its item."""
    lines: list[str] = []
    for w in written:
        if w.get("changes") is not None:
            lines += [change_line(c) for c in w["changes"]]
            continue
        old, new = w.get("old"), w.get("new")
        if any(isinstance(v, str) and _REPR.match(v) for v in (old, new)) or (old is new is None):
            lines.append(f"{w.get('item')}: changed")
        else:
            lines.append(change_line({"item": w.get("item"), "old": old, "new": new}))
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
    same names (an IAI position's line), narrowed to the names whose values differ."""
    if name or old is None or new is None:
        return [(name, old, new)]
    a, b = _groups(old), _groups(new)
    if a is None or b is None or len(a) < 3 or [n for n, _ in a] != [n for n, _ in b]:
        return [(name, old, new)]
    differ: list[tuple[str, str | None, str | None]] = [
        (n, " ".join(x), " ".join(y)) for (n, x), (_, y) in zip(a, b) if x != y
    ]
    return differ if 0 < len(differ) < len(a) else [(name, old, new)]


def changed_names(changes: Iterable[Any]) -> list[str]:
    """What the changes (:class:`~.items.Change`) touch, item by item, with the fields
    that differ where an item has several: ``MAIN program 0 step 4``, ``position 12
    speed``, ``AccelS 3 decel``."""
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


def pushes_since(
    port: str, station: int, project: Path, since: str | None, path: Path | None = None
) -> list[str]:
    """The pushes and rollbacks of the robot at ``port``/``station`` (or of
    ``project``) recorded after ``since`` (a time as harlsync records them; None: all),
    each as ``push ok 2026-11-24T20:23:50+00:00 by alice@pc: "faster pick"``; one in
    the same second as ``since`` is named too (times are to the second).  The audit
    log unreadable, none."""
    try:
        latest = index(path, []).robot(port, station, project)
        records = latest.recent
        if not latest.complete and not _reaches(records, since):  # more than it keeps
            records = of_robot(results(path, []), port, station, project)
    except OSError:
        return []
    found = []
    for r in records:
        when = r.get("time")
        if since is not None and (
            not isinstance(when, str)
            or not statefile.timestamp(when)
            or when_of(when) < when_of(since)
        ):
            continue
        reason = f': "{r["reason"]}"' if r.get("reason") else ""
        found.append(
            f"{r.get('action', 'push')} {r.get('result', '?')} {when} by "
            f"{r.get('user', '?')}@{r.get('host', '?')}{reason}"
        )
    return found


def _reaches(records: list[dict[str, Any]], since: str | None) -> bool:
    """Whether ``records`` (a robot's latest) go back to before ``since``."""
    first = records[0].get("time") if records else None
    return (
        since is not None
        and isinstance(first, str)
        and statefile.timestamp(first)
        and when_of(first) < when_of(since)
    )


def when_of(stamp: str) -> datetime:
    return datetime.fromisoformat(stamp)
