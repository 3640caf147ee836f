"""robot.yaml read without the project store, for a pull's first request (issue 24).

A pull's first request needs the robot's port, station and serial settings, and
reading robot.yaml the whole way (the store, PyYAML, the family's layout and
schemas) took longer than everything else before that request.  :func:`robot`
reads it here instead, with nothing but ``re``, ``json`` and ``decimal``, when the
file is in a plain form, the one harlsync writes and the hand edits it usually
gets:

- ``key: value`` lines at the top, and under ``connection:`` (any indentation,
  the same for each key), and ``maintenance_windows:`` as ``[]`` or a list of
  ``- days: [mon, tue]`` / ``start: "22:00"`` / ``end: "06:00"`` items;
- values: decimal numbers (``1``, ``0.5``), ``true``/``false``, a single- or
  double-quoted string on one line (no backslash), a plain ASCII string (a port
  URL, a name), a flow list of words; comments and blank lines anywhere.

Anything else (a tab, a carriage return, a document marker, an anchor, a block
scalar, an escape, a key written twice, a number as ``1e3`` or ``0012``, a key the
schema does not name, a value it refuses, the journal of an interrupted save beside
the file...) and it gives up: :func:`robot` returns None and the pull reads the file
the whole way, before its line opens, as before, which says what is wrong.  It
never reports an error of its own.

What it takes it checks against the family's own JSON Schema (:func:`valid`, the
keywords robot.yaml schemas use; any other makes it give up) and the family builds
the robot (:meth:`~harlsync.families.base.Family.quick_robot`).  The pull then reads
the file the whole way after its first request, before anything is saved, and
stops if the two readings differ (harlsync/sync/pulling.py).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from decimal import Decimal
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import lookup
from ..errors import ProjectError

if TYPE_CHECKING:
    from ..families.base import AnyFamily
    from .robot import Robot

__all__ = ["JOURNAL", "parse", "robot", "schema", "valid"]

#: The journal an interrupted save leaves (:data:`harlsync.project.store.JOURNAL`):
#: beside it, robot.yaml may be a new file the store puts the old one back over.
JOURNAL = ".harlsync-save.json"


class _GiveUp(Exception):
    """Not in the plain form: the full reading takes the file."""


_KEY = re.compile(r"([a-z_][a-z0-9_]*):(?: (.*))?")
_INT = re.compile(r"0|[1-9][0-9]*")
_DECIMAL = re.compile(r"(?:0|[1-9][0-9]*)\.[0-9]+")
_TIME = re.compile(r"[0-9]{1,2}:[0-9]{2}")
#: A plain string that the YAML 1.2 core schema reads as itself: a letter, ``/`` or
#: ``_`` first (no indicator, no number), no ``: `` or `` #`` in it and no space at
#: its end (:func:`parse` has made sure every character is printable, no tab).
#: (The first character as all but the ASCII it may not be: a class of every
#: character beyond ASCII takes re 10 ms to compile.)
_PLAIN = re.compile(r"[^\x00-\x2e\x30-\x40\x5b-\x5e\x60\x7b-\x7f](?:[^ :]|:(?=[^ ])| (?=[^ #]))*")
#: Plain words the core schema reads as null or a boolean (any case, to be safe).
_NOT_TEXT = {"null", "true", "false"}
_WORD = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")


def _comment(rest: str) -> None:
    """What follows a value on its line must be nothing or a comment."""
    if rest and not re.fullmatch(r" +#.*| *", rest):
        raise _GiveUp


def _scalar(text: str) -> Any:
    """One value on the rest of a ``key: `` line (leading spaces gone)."""
    first = text[0]
    if first == "'":
        end, parts = 1, []
        while True:
            close = text.find("'", end)
            if close < 0:
                raise _GiveUp  # runs on to another line
            parts.append(text[end:close])
            if text[close + 1 : close + 2] != "'":
                break
            parts.append("'")
            end = close + 2
        _comment(text[close + 1 :])
        return "".join(parts)
    if first == '"':
        close = text.find('"', 1)
        if close < 0 or "\\" in text[1:close]:
            raise _GiveUp
        _comment(text[close + 1 :])
        return text[1:close]
    if first == "[":
        close = text.find("]")
        if close < 0:
            raise _GiveUp
        _comment(text[close + 1 :])
        inside = text[1:close].strip(" ")
        if not inside:
            return []
        words = [word.strip(" ") for word in inside.split(",")]
        if not all(_WORD.fullmatch(w) and w.lower() not in _NOT_TEXT for w in words):
            raise _GiveUp
        return words
    cut = text.find(" #")
    plain = (text if cut < 0 else text[:cut]).rstrip(" ")
    if _INT.fullmatch(plain):
        return int(plain)
    if _DECIMAL.fullmatch(plain):
        return Decimal(plain)
    if plain in ("true", "false"):
        return plain == "true"
    if _TIME.fullmatch(plain) or (_PLAIN.fullmatch(plain) and plain.lower() not in _NOT_TEXT):
        return plain
    raise _GiveUp


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _pairs(lines: list[str], indent: int, into: dict[str, Any]) -> None:
    """``key: value`` lines, each at ``indent``, into the mapping ``into``."""
    for line in lines:
        match = _KEY.fullmatch(line[indent:]) if _indent(line) == indent else None
        if match is None:
            raise _GiveUp
        key, rest = match.group(1), (match.group(2) or "").lstrip(" ")
        if key in into or not rest or rest.startswith("#"):
            raise _GiveUp  # twice, or a block under it
        into[key] = _scalar(rest)


def _block(lines: list[str]) -> Any:
    """The indented lines under a ``key:``: a mapping, or a list of mappings."""
    indent = _indent(lines[0])
    if not lines[0][indent:].startswith("- "):
        found: dict[str, Any] = {}
        _pairs(lines, indent, found)
        return found
    items: list[list[str]] = []
    for line in lines:
        if _indent(line) == indent and line[indent:].startswith("- "):
            items.append([" " * (indent + 2) + line[indent + 2 :]])
        elif _indent(line) == indent + 2 and items:
            items[-1].append(line)
        else:
            raise _GiveUp
    listed = []
    for item in items:
        one: dict[str, Any] = {}
        _pairs(item, indent + 2, one)
        listed.append(one)
    return listed


def parse(text: str) -> dict[str, Any] | None:
    """robot.yaml's data, as the full reading's would be (a number as ``int`` or
    ``Decimal``), when ``text`` is in the plain form; else None."""
    every = text.split("\n")
    # Printable (str.isprintable) is a part of what YAML allows that holds no line
    # break of its own (U+2028, U+0085), no byte order mark, tab or carriage return.
    if not all(map(str.isprintable, every)):
        return None
    lines = [line for line in every if line.strip(" ") and not _is_comment(line)]
    data: dict[str, Any] = {}
    try:
        at = 0
        while at < len(lines):
            line = lines[at]
            match = _KEY.fullmatch(line)
            if match is None:
                return None  # indented where no key opened a block, a marker, a directive
            key, rest = match.group(1), (match.group(2) or "").lstrip(" ")
            if key in data:
                return None
            at += 1
            if rest and not rest.startswith("#"):
                data[key] = _scalar(rest)
                continue
            end = at
            while end < len(lines) and lines[end].startswith(" "):
                end += 1
            if end == at:
                return None  # null
            data[key] = _block(lines[at:end])
            at = end
    except _GiveUp:
        return None
    return data


def _is_comment(line: str) -> bool:
    return line.lstrip(" ").startswith("#")


@cache
def schema(path: Path) -> dict[str, Any] | None:
    """The JSON Schema at ``path`` (a family's own file), or None when it cannot be
    read here (a package not on disk): the full reading is then the only one."""
    try:
        found: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"), parse_float=Decimal)
    except (OSError, ValueError):
        return None
    return found


#: Keywords that say nothing of what is valid.
_ANNOTATIONS = frozenset({"$schema", "$comment", "title", "description", "x-allowed", "default"})
_TYPES: dict[str, Any] = {
    "object": dict,
    "array": list,
    "string": str,
    "boolean": bool,
    "integer": int,
    "number": (int, Decimal),
}


def _same(a: Any, b: Any) -> bool:
    """JSON's equality of two scalars: ``true`` is not ``1``."""
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if isinstance(a, (list, dict)) or isinstance(b, (list, dict)):
        raise _GiveUp
    return bool(a == b)


def _check(schema: Mapping[str, Any], value: Any) -> bool:
    """Whether ``value`` passes ``schema``; raises _GiveUp for a keyword not known here."""
    for keyword in schema:
        if keyword not in _KNOWN:
            raise _GiveUp
    kind = schema.get("type")
    if kind is not None:
        if not isinstance(kind, str) or kind not in _TYPES:
            raise _GiveUp
        if not isinstance(value, _TYPES[kind]) or (
            kind in ("integer", "number") and isinstance(value, bool)
        ):
            return False
    if "const" in schema and not _same(value, schema["const"]):
        return False
    if "enum" in schema and not any(_same(value, one) for one in schema["enum"]):
        return False
    if isinstance(value, (int, Decimal)) and not isinstance(value, bool):
        if "minimum" in schema and not value >= schema["minimum"]:
            return False
        if "maximum" in schema and not value <= schema["maximum"]:
            return False
        if "exclusiveMinimum" in schema and not value > schema["exclusiveMinimum"]:
            return False
        if "exclusiveMaximum" in schema and not value < schema["exclusiveMaximum"]:
            return False
    if isinstance(value, str):
        if len(value) < schema.get("minLength", 0):
            return False
        if "maxLength" in schema and len(value) > schema["maxLength"]:
            return False
        if "pattern" in schema and re.search(schema["pattern"], value) is None:
            return False
    if isinstance(value, list):
        if len(value) < schema.get("minItems", 0):
            return False
        if "maxItems" in schema and len(value) > schema["maxItems"]:
            return False
        if schema.get("uniqueItems") and any(
            _same(a, b) for n, a in enumerate(value) for b in value[n + 1 :]
        ):
            return False
        if "items" in schema and not all(_check(schema["items"], item) for item in value):
            return False
    if isinstance(value, dict):
        properties = schema.get("properties", {})
        if not all(key in value for key in schema.get("required", ())):
            return False
        extra = schema.get("additionalProperties", True)
        if extra is False and any(key not in properties for key in value):
            return False
        if extra is not True and extra is not False:
            raise _GiveUp
        if not all(_check(properties[k], v) for k, v in value.items() if k in properties):
            return False
    return True


_KNOWN = _ANNOTATIONS | {
    "type",
    "const",
    "enum",
    "minimum",
    "maximum",
    "exclusiveMinimum",
    "exclusiveMaximum",
    "minLength",
    "maxLength",
    "pattern",
    "minItems",
    "maxItems",
    "uniqueItems",
    "items",
    "properties",
    "required",
    "additionalProperties",
}


def valid(schema: Mapping[str, Any] | None, data: Any) -> bool:
    """Whether ``data`` (as :func:`parse` gives it) passes ``schema``, for sure: a
    keyword this checker does not know (or no schema) is a no."""
    if schema is None:
        return False
    try:
        return _check(schema, data)
    except _GiveUp:
        return False


def robot(root: Path, family: AnyFamily | None = None) -> tuple[AnyFamily, Robot] | None:
    """The family and robot of ``root/robot.yaml`` when it is in the plain form and
    valid (``family``: only when it is of that family); None: read it the whole way."""
    if (root / JOURNAL).exists():
        return None
    try:
        text = (root / "robot.yaml").read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    data = parse(text)
    name = data.get("family") if data is not None else None
    if data is None or not isinstance(name, (str, type(None))):
        return None
    try:
        found = lookup.family(name)
    except ProjectError:
        return None
    if family is not None and family.name != found.name:
        return None
    read = found.quick_robot(data)
    return None if read is None else (found, read)
