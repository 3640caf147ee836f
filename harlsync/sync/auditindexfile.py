"""The audit index's file (``audit.jsonl.index``): its entries, and each of them
checked as it is taken up again.

:mod:`harlsync.sync.auditindex` keeps the index and answers from it; this module
is the file's shape, drawn in that module's docstring.  An entry of any other
shape than :meth:`~harlsync.sync.auditindex.AuditIndex.state` writes (an offset
as text, a pair as a bare number) raises :class:`Stale`: the cache is built again
from the log.
"""

from __future__ import annotations

import bisect
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

from ..project import statefile
from . import audit

__all__ = [
    "CHECK",
    "RECENT",
    "VERSION",
    "Entries",
    "KeyEntry",
    "OpenEntry",
    "Stale",
    "marks",
    "read_saved",
    "take_up",
]

VERSION = 1
#: How many of a key's latest records the index keeps (``harlsync status`` shows 8).
RECENT = 32
#: How much of the log's start, and of its end as last read, identifies it.
CHECK = 4096


@dataclass
class KeyEntry:
    """One key's entries: its latest records, how many in all, the last settled
    push and the unsettled ones after it."""

    recent: list[list[int]] = field(default_factory=list)
    count: int = 0
    settled: int = -1
    unsettled: list[list[int]] = field(default_factory=list)

    def add(self, seq: int, offset: int) -> None:
        bisect.insort(self.recent, [seq, offset])
        del self.recent[:-RECENT]
        self.count += 1

    def drop(self, seq: int) -> None:
        self.recent = [e for e in self.recent if e[0] != seq]
        self.unsettled = [e for e in self.unsettled if e[0] != seq]
        self.count -= 1

    def ended(self, seq: int, offset: int, result: str | None) -> None:
        for entry in self.recent:
            if entry[0] == seq:
                entry[1] = offset
        self.unsettled = [e for e in self.unsettled if e[0] != seq]
        self.result(seq, offset, result)

    def result(self, seq: int, offset: int, result: str | None) -> None:
        if result == "unfinished":
            bisect.insort(self.unsettled, [seq, offset])
        elif result in audit.SETTLED:
            self.settled = max(self.settled, seq)
            self.unsettled = [e for e in self.unsettled if e[0] > self.settled]


@dataclass
class OpenEntry:
    """A push started and not ended: the offsets of its start and write records, and
    the keys its start record is found under."""

    start: int
    writes: list[int] = field(default_factory=list)
    keys: list[str] = field(default_factory=list)


class Stale(Exception):
    """The index does not match the log."""


@dataclass
class Entries:
    """What an index file holds of the log, as :func:`take_up` found it."""

    size: int
    lines: int
    seq: int
    open: dict[int, OpenEntry]
    ids: dict[str, int]
    keys: dict[str, KeyEntry]
    problems: list[tuple[int, str]]
    problem_count: int


def take_up(state: Mapping[str, object]) -> Entries:
    """The entries of ``state`` (an index file, parsed), each of the shape
    :meth:`~harlsync.sync.auditindex.AuditIndex.state` writes.  Raises
    :class:`Stale` for anything else: a cache that cannot be trusted is built
    again from the log, whatever is wrong with it."""
    if state.get("version") != VERSION:
        raise Stale("another version")
    try:
        size, lines = _count(state["size"]), _count(state["lines"])
        pushes = _count(state["seq"])
        open_ = {_seq(seq): _open(entry, size) for seq, entry in _object(state["open"])}
        ids = {rid: _count(seq) for rid, seq in _object(state["ids"])}
        keys = {name: _key(entry, size) for name, entry in _object(state["keys"])}
        problems = [_problem(entry) for entry in _array(state["problems"])]
        problem_count = _count(state["problem_count"])
    except KeyError as exc:
        raise Stale(f"not an index (no {exc})") from None
    if not all(seq in open_ for seq in ids.values()):
        raise Stale("not an index (an id of no open push)")
    return Entries(size, lines, pushes, open_, ids, keys, problems, problem_count)


# --- the index file's entries, checked as they are taken up --------------------------------


def _count(value: object) -> int:
    """A count, a sequence number or a byte offset: an integer, not negative."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise Stale(f"not an index ({statefile.kind_of(value)} where a count belongs)")
    return value


def _offset(value: object, size: int) -> int:
    """A line's offset in the part of the log the index has read."""
    offset = _count(value)
    if offset >= size:
        raise Stale(f"not an index (offset {offset} past the {size} bytes read)")
    return offset


def _seq(text: str) -> int:
    if not (text.isascii() and text.isdigit()):
        raise Stale("not an index (an open push's number is not a number)")
    return int(text)


def _array(value: object, size: int | None = None) -> list[Any]:
    """A JSON array (of ``size`` values, when given)."""
    if not isinstance(value, list) or (size is not None and len(value) != size):
        wanted = "an array" if size is None else f"an array of {size}"
        raise Stale(f"not an index ({statefile.kind_of(value)} where {wanted} belongs)")
    return value


def _object(value: object) -> list[tuple[str, object]]:
    """A JSON object's members."""
    if not isinstance(value, dict):
        raise Stale(f"not an index ({statefile.kind_of(value)} where an object belongs)")
    return list(value.items())


def _pairs(value: object, size: int) -> list[list[int]]:
    """``[[seq, offset], ...]``: a key's latest or unsettled pushes.  (One test a pair,
    not a call a value: a plant's index holds thousands of them.)"""
    pairs = _array(value)
    if not all(
        type(pair) is list  # JSON's types exactly: true is no count
        and len(pair) == 2
        and type(pair[0]) is int
        and type(pair[1]) is int
        and pair[0] >= 0
        and 0 <= pair[1] < size
        for pair in pairs
    ):
        raise Stale("not an index (a [seq, offset] pair of another shape)")
    return pairs


def _open(value: object, size: int) -> OpenEntry:
    entry = dict(_object(value))
    names = _array(entry.get("keys"))
    if not all(isinstance(name, str) for name in names):
        raise Stale("not an index (an open push's key is not text)")
    return OpenEntry(
        _offset(entry.get("start"), size),
        [_offset(write, size) for write in _array(entry.get("writes"))],
        names,
    )


def _key(value: object, size: int) -> KeyEntry:
    recent, count, settled, unsettled = _array(value, 4)
    if isinstance(settled, bool) or not isinstance(settled, int) or settled < -1:
        raise Stale(
            f"not an index ({statefile.kind_of(settled)} where the last settled push belongs)"
        )
    return KeyEntry(_pairs(recent, size), _count(count), settled, _pairs(unsettled, size))


def _problem(value: object) -> tuple[int, str]:
    line, text = _array(value, 2)
    if not isinstance(text, str):
        raise Stale(f"not an index ({statefile.kind_of(text)} where a problem's words belong)")
    return _count(line), text


def _digest(f: BinaryIO, start: int, end: int) -> str:
    f.seek(start)
    return hashlib.sha256(f.read(end - start)).hexdigest()


def marks(f: BinaryIO, size: int) -> tuple[str, str]:
    """The SHA-256 of the first and the last :data:`CHECK` bytes of the log's first
    ``size``: the index's ``head`` and ``tail``."""
    return _digest(f, 0, min(size, CHECK)), _digest(f, max(0, size - CHECK), size)


def read_saved(where: Path) -> dict[str, object] | None:
    """The index file at ``where``, parsed; None when it is missing or not a JSON object."""
    try:
        state = json.loads(where.read_bytes())
    except (OSError, ValueError):
        return None
    return state if isinstance(state, dict) else None
