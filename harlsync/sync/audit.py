"""The audit log: what every push and rollback did, appended, never rewritten.

Where it lives: ``$HARLSYNC_AUDIT_LOG`` if set, else
``$XDG_STATE_HOME/harlsync/audit.jsonl`` (``~/.local/state/harlsync/audit.jsonl``).
The file is opened in append mode and each record is one JSON line, written
whole and fsynced; on a server, ``chattr +a`` makes it append-only for root too.

Records, tied together by ``id`` (one per push or rollback)::

    {"event": "start", "id", "action", "time", "user", "host", "pid", "robot",
     "project", "commit", "reason", "outside_window", "plan", "snapshot"}
        before the first SN command is sent (write-ahead)
    {"event": "write", "id", "time", "item", "command"}
        just before each SN command is sent; the push reads each item back
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
"""

from __future__ import annotations

import errno
import getpass
import json
import logging
import os
import secrets
import socket
from collections.abc import Iterable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from ..link import lock_key
from ..project import statefile
from ..project.statefile import Fields, fold, kind_of

__all__ = [
    "append",
    "audit_path",
    "base_record",
    "describe_unfinished",
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
    written = fields.objects("written")
    if written is not None:
        clean["written"] = []
        for entry in written:
            one = Fields(entry)
            kept: dict[str, Any] = {name: one.text(name) for name in _WRITTEN_TEXT}
            changes = one.objects("fields")  # [{"field", "old", "new"}], as items.to_json
            if changes is not None:
                kept["fields"] = []
                for change in changes:
                    of_change = Fields(change)
                    kept["fields"].append({n: of_change.text(n) for n in ("field", "old", "new")})
                    one.problems += of_change.problems
            clean["written"].append(kept)
            fields.problems += [f"written item's {p}" for p in one.problems]
    return {k: v for k, v in clean.items() if v is not None}, fields.problems


_KNOWN = frozenset((*_TEXT, *_TEXTS, "pid", "robot", "written"))


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
        try:
            record = statefile.parse(raw.decode("utf-8"))
        except ValueError as exc:  # UnicodeDecodeError too
            why = str(exc) if not isinstance(exc, UnicodeDecodeError) else "not UTF-8 text"
            found.append((number, f"{path}:{number}: not an audit record ({why}): {_LEFT_OUT}"))
            continue
        if not isinstance(record, dict):
            why = f"{kind_of(record)}, not an object"
            found.append((number, f"{path}:{number}: not an audit record ({why}): {_LEFT_OUT}"))
            continue
        record, wrong = _clean(record)
        if wrong:
            what = "; ".join(fold(wrong, 3))
            found.append((number, f"{path}:{number}: {what}: {_MISSING}"))
        records.append(record)
    more = f"more malformed lines in {path}"
    if problems is not None:
        problems += fold([text for _, text in found], 5, more)
    else:
        fresh = [(n, text) for n, text in found if (str(path), n) not in _said]
        _said.update((str(path), n) for n, _ in fresh)
        for problem in fold([text for _, text in fresh], 5, more):
            log.warning("%s", problem)
    return records


_MISSING = "read as missing; fix that line, or move it to another file"
_LEFT_OUT = "left out; move that line to another file to keep it (harlsync only appends)"


def results(path: Path | None = None, problems: list[str] | None = None) -> list[dict[str, Any]]:
    """One record per push or rollback, in the order they started.

    A finished one is its end record.  An unfinished one is its start record
    with ``result: "unfinished"``, ``written`` (the write records but the last)
    and ``failed_item`` (the last: it may or may not have been written).
    """
    started: dict[str, dict[str, Any]] = {}
    where: dict[str, int] = {}
    order: list[dict[str, Any]] = []
    for record in read(path, problems):
        event = record.get("event", "end")
        rid = record.get("id")
        if event == "start" and rid:
            started[rid] = {**record, "result": "unfinished", "written": [], "failed_item": None}
            where[rid] = len(order)
            order.append(started[rid])
        elif event == "write" and rid in started:
            pending = started[rid]
            if pending["failed_item"] is not None:
                pending["written"].append(pending["failed_item"])
            pending["failed_item"] = {"item": record.get("item"), "command": record.get("command")}
        elif event == "end":
            if rid in started:
                del started[rid]
                order[where[rid]] = record
            else:
                order.append(record)
    for pending in started.values():
        pending["failed_item"] = (pending["failed_item"] or {}).get("item")
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


def unfinished(
    port: str, station: int, path: Path | None = None, problems: list[str] | None = None
) -> list[dict[str, Any]]:
    """The unfinished pushes and rollbacks of the robot at ``port``/``station``
    that no later push or rollback of it has settled (see :func:`results`)."""
    return unsettled(of_robot(results(path, problems), port, station))


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
