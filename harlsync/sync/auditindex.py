"""The audit log's index: what a pull, push or status needs from the log, without
reading all of it.

The log only grows (every push appends three records or more, every recovered
connection one), and a pull asks it two things about one robot: the pushes to
it that never ended, and those since its last backup.  ``audit.jsonl.index``,
beside the log, answers both and ``harlsync status``'s question (each robot's
latest pushes) from a few hundred bytes a robot.  It is JSON::

    {"version": 1,
     "size": 20480000, "lines": 50000,    how much of the log it has read
     "ino": 1234, "head": "9f3a...", "tail": "0c77..."    SHA-256 of the first and
                                           the last 4 KiB it read: the same file?
     "seq": 10000,                         pushes and rollbacks so far
     "open": {"9998": {"start": 20479000, "writes": [20479400], "keys": [...]}},
                                           started, not ended (by seq): byte offsets
     "ids": {"3f9a1c2e4b5d6e7f": 9998},    the id of each open one
     "keys": {"robot 1 /dev/ttyUSB0": {"recent": [[9990, 20470000], ...],
                                       "count": 212, "settled": 9990,
                                       "unsettled": [[9998, 20479000]]}, ...},
     "problems": [[77, "not an audit record (...)"]], "problem_count": 1}

A key is a robot (its station and port, once as recorded and once as its line:
:func:`~harlsync.link.lock_key`) or a project directory; each keeps the offsets of
its latest :data:`RECENT` records (``[seq, offset]``: an end record, or the start
of an open one), how many it had in all, the last settled one and the unfinished
ones after it.  A query reads those few lines at their offsets.

It is a cache, kept by the readers: the appender (``audit.append``) never touches
it, so a log written by an older harlsync, or by several processes at once, is
read as it always was.  A reader checks that the log still starts and continues
as the index read it (``ino``, ``head``, ``tail``, a size no smaller), reads only
what was appended since (a few records) and, when there was some, writes the
index again (a temporary and a rename: readers see the old index or the new
one).  An index that does not match, is missing, cannot be parsed or holds an
entry of another shape than it writes (an offset as text, a pair as a bare
number: :meth:`AuditIndex.restore` checks each) is built again from the whole
log, once.  A last line without its newline (a writer
still at it, or killed mid-append) is read but left out of the index: the next
append ends it, and the index reads it then.  A directory the reader may not
write in only costs it the whole log on every read.
"""

from __future__ import annotations

import json
import logging
import os
import re
import secrets
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import BinaryIO

from ..link import lock_key
from ..project import statefile
from . import audit
from .audit import AuditRecord, OpenPush
from .auditindexfile import (
    CHECK,
    RECENT,
    VERSION,
    KeyEntry,
    OpenEntry,
    Stale,
    marks,
    read_saved,
    take_up,
)

__all__ = [
    "RECENT",
    "AuditIndex",
    "RobotRecords",
    "index",
    "index_path",
    "load",
    "pushes_since",
    "unfinished",
]

log = logging.getLogger(__name__)

#: A line and its end: ``\n``, ``\r\n`` or ``\r``, as ``bytes.splitlines`` counts them.
_LINE = re.compile(rb"[^\r\n]*(?:\r\n|\r|\n)")
#: The key of every line no other process can share (``loop://``): all one.
_PRIVATE = "(private)"


def index_path(log_path: Path) -> Path:
    return log_path.with_name(log_path.name + ".index")


def robot_keys(port: str, station: int) -> set[str]:
    """The keys a robot's records are found under: its port as written, and its line."""
    line = lock_key(port)
    return {f"robot {station} {port}", f"robot {station} {_PRIVATE if line is None else line}"}


def _project_key(project: str) -> str:
    return f"project {project}"


@dataclass
class RobotRecords:
    """What the log says about one robot (and its project)."""

    #: its latest pushes and rollbacks (at most :data:`RECENT`), as :func:`audit.results`
    recent: list[AuditRecord]
    #: the unfinished ones no later one settled (:func:`audit.unsettled`)
    unsettled: list[AuditRecord]
    #: whether ``recent`` is all of them
    complete: bool


class AuditIndex:
    """The log at ``path`` as the index knows it, read up to its end (:func:`load`).

    ``bytes_read`` and ``lines_parsed`` say what this reader read of the log."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.size = 0
        self.lines = 0
        self.seq = 0
        self.open: dict[int, OpenEntry] = {}
        self.ids: dict[str, int] = {}
        self.keys: dict[str, KeyEntry] = {}
        self.problems: list[tuple[int, str]] = []
        self.problem_count = 0
        self.bytes_read = 0
        self.lines_parsed = 0
        self._ports: dict[tuple[str, int], set[str]] = {}

    # --- reading the log --------------------------------------------------------------

    def _keys_of(self, record: AuditRecord) -> set[str]:
        keys = set()
        robot = record.robot
        if robot is not None and robot.port is not None and robot.station is not None:
            port, station = robot.port, robot.station
            if (port, station) not in self._ports:
                self._ports[(port, station)] = robot_keys(port, station)
            keys |= self._ports[(port, station)]
        if record.project is not None:
            keys.add(_project_key(record.project))
        return keys

    def _key(self, name: str) -> KeyEntry:
        if name not in self.keys:
            self.keys[name] = KeyEntry()
        return self.keys[name]

    def fold(self, data: bytes, offset: int, *, partial: bool = False) -> None:
        """Read the lines of ``data``, found at ``offset`` in the log (with
        ``partial``, the last may have no end)."""
        end = 0
        for match in _LINE.finditer(data):
            self._line(offset + match.start(), match.group())
            end = match.end()
        if partial and end < len(data):
            self._line(offset + end, data[end:])
        self.size = offset + len(data)

    def _line(self, offset: int, raw: bytes) -> None:
        self.lines += 1
        if not raw.strip():
            return
        self.lines_parsed += 1
        record, problem = audit.parse_line(raw)
        if problem is not None:
            if len(self.problems) < audit.SHOWN_PROBLEMS:
                self.problems.append((self.lines, problem))
            self.problem_count += 1
        if record is None:
            return
        event, rid = record.event, record.id
        if event == "start" and rid:
            seq = self._next()
            keys = self._keys_of(record)
            self.open[seq] = OpenEntry(offset, [], sorted(keys))
            self.ids[rid] = seq
            for name in keys:
                self._key(name).add(seq, offset)
                self._key(name).result(seq, offset, "unfinished")
        elif event == "write" and rid is not None and rid in self.ids:
            self.open[self.ids[rid]].writes.append(offset)
        elif event == "end" and rid is not None and rid in self.ids:
            seq = self.ids.pop(rid)
            before = set(self.open.pop(seq).keys)
            after = self._keys_of(record)
            for name in before - after:
                self._key(name).drop(seq)
            for name in after - before:
                self._key(name).add(seq, offset)
            for name in after:
                self._key(name).ended(seq, offset, record.result)
        elif event == "end":
            seq = self._next()
            for name in self._keys_of(record):
                self._key(name).add(seq, offset)
                self._key(name).result(seq, offset, record.result)

    def _next(self) -> int:
        self.seq += 1
        return self.seq - 1

    # --- answering --------------------------------------------------------------------

    def robot(self, port: str, station: int, project: Path | None = None) -> RobotRecords:
        """What the log says of the robot at ``port``/``station`` and of ``project``
        (as :func:`audit.of_robot` chooses them).  Raises OSError."""
        try:
            return self._robot(port, station, project)
        except Stale as why:  # the log was changed under the index: read it all again
            log.debug("%s: %s; reading the whole audit log", self.path, why)
            self.__dict__.update(_rebuilt(self.path).__dict__)
        try:
            return self._robot(port, station, project)
        except Stale as why:
            raise OSError(f"{self.path} changed while it was read ({why})") from None

    def _robot(self, port: str, station: int, project: Path | None) -> RobotRecords:
        names = robot_keys(port, station)
        if project is not None:
            names.add(_project_key(str(project.resolve())))
        keys = [self.keys[name] for name in sorted(names) if name in self.keys]
        recent = sorted({seq: offset for key in keys for seq, offset in key.recent}.items())
        settled = max((key.settled for key in keys), default=-1)
        unsettled = sorted(
            {seq: off for key in keys for seq, off in key.unsettled if seq > settled}.items()
        )
        complete = all(key.count == len(key.recent) for key in keys)
        if not recent and not unsettled:  # nothing to read (perhaps no log at all)
            return RobotRecords([], [], complete)
        with open(self.path, "rb") as f:
            return RobotRecords(
                [self._record(f, seq, offset) for seq, offset in recent[-RECENT:]],
                [self._record(f, seq, offset) for seq, offset in unsettled],
                complete,
            )

    def _record(self, f: BinaryIO, seq: int, offset: int) -> AuditRecord:
        if seq not in self.open:
            return self._at(f, offset)
        opened = self.open[seq]
        return OpenPush(
            self._at(f, opened.start), [self._at(f, write) for write in opened.writes]
        ).record()

    def _at(self, f: BinaryIO, offset: int) -> AuditRecord:
        f.seek(offset)
        raw = f.readline()
        self.bytes_read += len(raw)
        record, _ = audit.parse_line(raw)
        if record is None:
            raise Stale(f"no record at byte {offset}")
        return record

    def report(self, problems: list[str] | None) -> None:
        """Say what was wrong with the log's lines, as :func:`audit.read` does."""
        audit.report(self.path, list(self.problems), problems, self.problem_count)

    # --- the index file ---------------------------------------------------------------

    def state(self, ino: int, head: str, tail: str) -> dict[str, object]:
        referenced = {seq for key in self.keys.values() for seq, _ in key.recent + key.unsettled}
        kept = set(self.ids.values()) | referenced
        return {
            "version": VERSION,
            "size": self.size,
            "lines": self.lines,
            "ino": ino,
            "head": head,
            "tail": tail,
            "seq": self.seq,
            "open": {
                str(seq): {"start": entry.start, "writes": entry.writes, "keys": entry.keys}
                for seq, entry in self.open.items()
                if seq in kept
            },
            "ids": self.ids,
            "keys": {
                name: [key.recent, key.count, key.settled, key.unsettled]
                for name, key in self.keys.items()
            },
            "problems": self.problems,
            "problem_count": self.problem_count,
        }

    def restore(self, state: Mapping[str, object]) -> None:
        """Take up ``state`` (:meth:`state`'s), each of its entries of the shape
        :meth:`state` writes.  Raises Stale for anything else: a cache that cannot be
        trusted is built again from the log, whatever is wrong with it."""
        taken = take_up(state)
        self.size, self.lines, self.seq = taken.size, taken.lines, taken.seq
        self.open, self.ids, self.keys = taken.open, taken.ids, taken.keys
        self.problems, self.problem_count = taken.problems, taken.problem_count


def load(path: Path | None = None) -> AuditIndex:
    """The index of the log at ``path`` (default :func:`audit.audit_path`), brought up
    to the log's end.  Raises OSError when the log cannot be read."""
    path = path or audit.audit_path()
    index = AuditIndex(path)
    if not path.exists():
        return index
    with open(path, "rb") as f:
        ino = os.fstat(f.fileno()).st_ino
        saved = read_saved(index_path(path))
        try:
            if saved is None:
                raise Stale("none")
            index.restore(saved)
            if saved.get("ino") != ino or os.fstat(f.fileno()).st_size < index.size:
                raise Stale("another file")
            if [saved.get("head"), saved.get("tail")] != list(marks(f, index.size)):
                raise Stale("changed")
        except Stale as why:
            log.debug("%s: reading the whole audit log (%s)", index_path(path), why)
            index = AuditIndex(path)
        start = index.size
        f.seek(start)
        data = f.read()
        index.bytes_read += len(data) + 2 * min(start, CHECK)
        whole = data[: data.rfind(b"\n") + 1] if b"\n" in data else b""
        index.fold(whole, start)
        if whole:
            _save(index, ino, *marks(f, index.size))
        if len(whole) < len(data):  # a line not ended yet: read, not kept
            index.fold(data[len(whole) :], index.size, partial=True)
    return index


def _save(index: AuditIndex, ino: int, head: str, tail: str) -> None:
    """Write the index (a temporary, renamed: a cache, so not fsynced); a directory
    that refuses only costs the next reader the whole log."""
    target = index_path(index.path)
    temp = target.with_name(f".{target.name}.{os.getpid()}-{secrets.token_hex(4)}")
    try:
        temp.write_text(json.dumps(index.state(ino, head, tail), separators=(",", ":")))
        os.replace(temp, target)
    except OSError as exc:
        log.debug("cannot write the audit log's index %s: %s", target, exc)
        try:
            temp.unlink(missing_ok=True)
        except OSError:
            pass


def _rebuilt(path: Path) -> AuditIndex:
    """The index built again from the whole log (the one saved is dropped)."""
    try:
        index_path(path).unlink(missing_ok=True)
    except OSError:
        pass
    return load(path)


# --- what the commands ask ----------------------------------------------------------------


def index(path: Path | None = None, problems: list[str] | None = None) -> AuditIndex:
    """The log's index, brought up to its end: what a command asks of one robot, read
    without reading the whole log.  What is wrong with the log's lines is said as
    :func:`audit.read` says it.  Raises OSError."""
    found = load(path)
    found.report(problems)
    return found


def unfinished(
    port: str, station: int, path: Path | None = None, problems: list[str] | None = None
) -> list[AuditRecord]:
    """The unfinished pushes and rollbacks of the robot at ``port``/``station``
    that no later push or rollback of it has settled (see :func:`audit.results`)."""
    return index(path, problems).robot(port, station).unsettled


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
            records = audit.of_robot(audit.results(path, []), port, station, project)
    except OSError:
        return []
    found = []
    for r in records:
        when = r.time
        if since is not None and (
            when is None or not statefile.timestamp(when) or _when(when) < _when(since)
        ):
            continue
        reason = f': "{r.reason}"' if r.reason else ""
        result, user, host = (("?" if v is None else v) for v in (r.result, r.user, r.host))
        found.append(f"{r.shown_action} {result} {when} by {user}@{host}{reason}")
    return found


def _reaches(records: list[AuditRecord], since: str | None) -> bool:
    """Whether ``records`` (a robot's latest) go back to before ``since``."""
    first = records[0].time if records else None
    return (
        since is not None
        and first is not None
        and statefile.timestamp(first)
        and _when(first) < _when(since)
    )


def _when(stamp: str) -> datetime:
    return datetime.fromisoformat(stamp)
