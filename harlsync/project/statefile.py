"""Reading harlsync's own state files, whatever a person, a full disk or another
program left in them.

The audit log, ``DIR/.harlsync/backup.json``, the save record and journal, a saved
plan: harlsync writes them, but anything may be found there later.  A reader here
never raises anything but ``ValueError`` (with the line when JSON gives one) for
bad content, and :class:`Fields` checks each field's type, so that a malformed
file costs one line naming it and what to do, never a traceback::

    parse(text)            -> JSON value; ValueError (bad JSON, nested too deep)
    load(path)             -> JSON value; OSError, ValueError (also not UTF-8)
    Fields(record, where)  -> .text("time"), .integer("pid"), ...: the value, or None
                              and a problem saying which field held what
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["MAX_DEPTH", "Fields", "fold", "kind_of", "load", "parse", "timestamp"]

#: How deep a state file's JSON may nest; harlsync's own go 3 levels deep.
MAX_DEPTH = 16

T = TypeVar("T")


def _depth(value: object) -> int:
    """How deep ``value`` nests, walked without recursion."""
    deepest, todo = 0, [(value, 1)]
    while todo:
        item, level = todo.pop()
        deepest = max(deepest, level)
        if deepest > MAX_DEPTH:
            break
        if isinstance(item, dict):
            todo += [(v, level + 1) for v in item.values()]
        elif isinstance(item, list):
            todo += [(v, level + 1) for v in item]
    return deepest


def parse(text: str) -> Any:
    """``text`` as JSON.  Raises ValueError: bad JSON (``line N``), or nested deeper than
    :data:`MAX_DEPTH` (which harlsync never writes)."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from exc
    except RecursionError as exc:
        raise ValueError(f"nested more than {MAX_DEPTH} levels deep") from exc
    if _depth(value) > MAX_DEPTH:
        raise ValueError(f"nested more than {MAX_DEPTH} levels deep")
    return value


def load(path: Path) -> Any:
    """The JSON in ``path``.  Raises OSError, and ValueError for content that is not
    UTF-8 JSON harlsync could have written."""
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text (byte {exc.start})") from exc
    return parse(text)


def kind_of(value: object) -> str:
    """What a JSON value is, in words: ``a number``, ``null``, ``a list``."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return "a number"
    if isinstance(value, str):
        return "text"
    return "a list" if isinstance(value, list) else "an object"


def timestamp(value: str) -> bool:
    """Whether ``value`` is a time as harlsync records them: ISO 8601 with a zone."""
    try:
        from datetime import datetime  # not at import: robot.yaml's reading needs none

        return datetime.fromisoformat(value).tzinfo is not None
    except ValueError:
        return False


def fold(lines: list[str], most: int = 5, what: str = "more") -> list[str]:
    """At most ``most`` of ``lines``, then ``"and 40 more"``."""
    if len(lines) <= most:
        return lines
    return [*lines[: most - 1], f"and {len(lines) - most + 1} {what}"]


class Fields:
    """The fields of one JSON object, each checked for its type as it is asked for.

    A field that is absent or null is None and no problem; one of another type is
    None too, and :attr:`problems` says which field held what.
    """

    def __init__(self, record: Mapping[str, object]) -> None:
        self.record = record
        self.problems: list[str] = []

    def _get(
        self, name: str, kind: type[T], expected: str, ok: Callable[[T], bool] = lambda v: True
    ) -> T | None:
        value = self.record.get(name)
        if value is None:
            return None
        if isinstance(value, kind) and ok(value):
            return value
        self.problems.append(f"{name} holds {kind_of(value)}, not {expected}")
        return None

    def text(self, name: str) -> str | None:
        return self._get(name, str, "text")

    def time(self, name: str) -> str | None:
        return self._get(name, str, "a time with its zone", timestamp)

    def integer(self, name: str) -> int | None:
        return self._get(name, int, "a whole number", lambda v: not isinstance(v, bool))

    def flag(self, name: str) -> bool | None:
        return self._get(name, bool, "true or false")

    def _list(self, name: str, kind: type[T], what: str) -> list[T] | None:
        """A list whose elements are ``kind``; an element of another type is left out."""
        value = self._get(name, list, "a list")
        if value is None:
            return None
        kept = [v for v in value if isinstance(v, kind)]
        if len(kept) != len(value):
            self.problems.append(f"{name} holds {len(value) - len(kept)} element(s) not {what}")
        return kept

    def texts(self, name: str) -> list[str] | None:
        """A list of text; an element of another type is left out."""
        return self._list(name, str, "text")

    def objects(self, name: str) -> list[dict[str, Any]] | None:
        """A list of objects; an element of another type is left out."""
        return self._list(name, dict, "objects")

    def object(self, name: str) -> dict[str, Any] | None:
        return self._get(name, dict, "an object")
