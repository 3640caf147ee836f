"""What every family's project files share: the header and ``format:`` of each
file, reading one file (UTF-8, YAML, duplicate keys, migration, schema), numbered
mappings, and robot.yaml's common parts (serial settings, maintenance windows).

Every file starts with a ``yaml-language-server`` comment naming its schema copy
in ``.schemas/`` and a ``format:`` number.  A file written in an older format is
migrated on load (the family's ``MIGRATIONS``) and written in the current one on
the next save; a newer format is refused.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TypeVar

from yaml.nodes import MappingNode, Node, SequenceNode

from ..settings import SerialSettings
from . import yamlio as y
from .robot import Robot, build_serial, build_windows
from .schema import Issue, SchemaSet, show

__all__ = [
    "LOCAL_DIR",
    "SCHEMAS_DIR",
    "FileSet",
    "Flaws",
    "MigrationError",
    "Migrations",
    "build_serial",
    "build_windows",
    "canonical_integer",
    "check_canonical",
    "newer_format",
    "not_canonical",
    "numbers",
    "older_format",
    "robot_items",
    "serial_items",
    "text_of",
    "window_nodes",
]

SCHEMAS_DIR = ".schemas"
#: harlsync's local state in a project (snapshots, backup times), not versioned.
LOCAL_DIR = ".harlsync"

#: ``MIGRATIONS[n](kind, data)`` turns a format-``n`` document of file kind ``kind``
#: into a format-``n+1`` one (data as :func:`yamlio.parse` gives it), or raises
#: :class:`MigrationError` naming what it cannot carry over.
Migrations = dict[int, Callable[[str, dict[str, object]], dict[str, object]]]


class MigrationError(ValueError):
    """What a migration cannot carry over from the older format, each problem a
    (path in the document, message): the read reports each at the line it is on."""

    def __init__(self, problems: Sequence[tuple[tuple[str | int, ...], str]]) -> None:
        super().__init__("; ".join(message for _, message in problems))
        self.problems = list(problems)


V = TypeVar("V")

_DIGITS = re.compile(r"[0-9]+")
_INTEGER = re.compile(r"[-+]?[0-9]+")
#: Stands for a numbered key too long to be any item (and to convert with int()).
HUGE = 10**9


@dataclass
class FileSet:
    """One family's files: their schemas, format number and migrations."""

    schemas: SchemaSet
    format: int
    migrations: Migrations = field(default_factory=dict)

    def document(
        self,
        kind: str,
        path: str,
        items: Iterable[tuple[str, Node]],
        comments: Mapping[str, str] | None = None,
    ) -> str:
        """A file's text: the schema comment, ``format:``, then ``items``; each
        top-level key named in ``comments`` gets its comment at the end of its line
        (``accel:  # volatile: ...``)."""
        up = "../" * path.count("/")
        header = f"# yaml-language-server: $schema={up}{SCHEMAS_DIR}/{kind}.schema.json\n"
        node = y.mapping([("format", y.num(str(self.format))), *items])
        text = y.dump(node, header=header)
        if not comments:
            return text
        lines = text.split("\n")
        for i, line in enumerate(lines):
            key = line.split(":", 1)[0]
            if key in comments and line.startswith(f"{key}:"):
                lines[i] = f"{line}  # {comments[key]}"
        return "\n".join(lines)

    def read(
        self, name: str, kind: str, raw: bytes, issues: list[Issue]
    ) -> tuple[y.Parsed | None, bool]:
        """Parse, migrate and schema-check one file.

        Returns the document (``None`` when unreadable) and whether it is valid.
        """
        try:
            source = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = raw[: exc.start].count(b"\n") + 1
            issues.append(Issue(name, line, None, "not UTF-8 text", fatal=True))
            return None, False
        try:
            doc = y.parse(source)
        except y.YamlSyntaxError as exc:
            issues.append(
                Issue(name, exc.line, None, f"YAML syntax error: {exc.message}", fatal=True)
            )
            return None, False
        for path, first, second in doc.duplicates:
            field_name = ".".join(str(p) for p in path)
            issues.append(
                Issue(name, second, field_name, f"written twice (lines {first} and {second})")
            )
        if isinstance(doc.data, dict) and not self._migrate(name, kind, doc, issues):
            return None, False
        found = self.schemas.check(kind, name, doc)
        issues.extend(found)
        return doc, not found

    def _migrate(self, name: str, kind: str, doc: y.Parsed, issues: list[Issue]) -> bool:
        """Bring ``doc`` to the current format; ``False`` (with an issue) when it cannot be."""
        value = doc.data.get("format")
        if not (isinstance(value, y.Number) and value.integral):
            return True  # the schema reports it
        line = doc.line(("format",))
        newer = _newer(name, doc, self.format)
        if newer is not None:
            issues.append(newer)
            return False
        number = int(value)
        while number < self.format:
            if number not in self.migrations:
                issues.append(
                    Issue(
                        name,
                        line,
                        "format",
                        f"{number} is not a known format (allowed: 1-{self.format})",
                        fatal=True,
                    )
                )
                return False
            try:
                doc.data = self.migrations[number](kind, doc.data)
            except MigrationError as exc:
                for path, message in exc.problems:
                    field_name = ".".join(str(p) for p in path) or None
                    issues.append(Issue(name, doc.line(path), field_name, message))
                return False
            number += 1
            doc.data["format"] = y.Number(str(number))
            _listed_lines(doc)
        return True


@dataclass(frozen=True)
class Flaws:
    """Where one file's reading found problems (the schema's, a key written twice),
    so that a file with one bad value still has its other values checked in depth:
    only what lies at, under or above a flawed field is skipped.

    ``Flaws.of(issues, name)`` takes the issues :meth:`FileSet.read` reported of
    ``name``; an issue that names no field (the file itself) flaws everything.
    """

    fields: frozenset[str] = frozenset()
    whole: bool = False

    @classmethod
    def of(cls, issues: Iterable[Issue], name: str) -> Flaws:
        mine = [issue for issue in issues if issue.file == name]
        return cls(
            frozenset(i.field for i in mine if i.field is not None),
            any(i.field is None or i.field == "(top)" for i in mine),
        )

    def sound(self, *path: str | int) -> bool:
        """No problem at ``path``, inside it or in what holds it."""
        if self.whole:
            return False
        if not self.fields:  # a file without a problem: asked of every step of a save
            return True
        at = ".".join(str(p) for p in path)
        return not any(
            field == at or field.startswith(at + ".") or at.startswith(field + ".")
            for field in self.fields
        )

    def number(self, *path: str | int, data: object) -> int | None:
        """The whole number at ``path`` of ``data`` when it is sound, else None."""
        if not self.sound(*path):
            return None
        value = data
        for part in path:
            if not isinstance(value, dict) or part not in value:
                return None
            value = value[part]
        return int(value) if isinstance(value, y.Number) and value.integral else None


def _listed_lines(doc: y.Parsed) -> None:
    """A migration that made a mapping keyed by number into a list (a sequence's
    items, in a family's format 1 to 2): give each item the line its key was on
    (``("steps", "3")`` -> ``("steps", 3)``), so that issues name where it is written."""
    for path, line in list(doc.lines.items()):
        if (
            len(path) >= 2
            and isinstance(doc.data.get(path[0]), list)
            and isinstance(path[1], str)
            and _DIGITS.fullmatch(path[1])
        ):
            doc.lines.setdefault((path[0], int(path[1]), *path[2:]), line)


def newer_format(name: str, raw: bytes, current: int) -> Issue | None:
    """Why the file ``name`` with content ``raw`` must not be read or overwritten:
    its format is newer than ``current``.  None when it is not, or when the text
    cannot be parsed at all (that file is broken, not newer).

    The format is read by the YAML parser, as a load reads it, never matched as
    text: ``"format": 2`` is the same key as ``format: 2``.
    """
    try:
        doc = y.parse(raw.decode("utf-8"))
    except (UnicodeDecodeError, y.YamlSyntaxError):
        return None
    return _newer(name, doc, current)


def older_format(raw: bytes, current: int) -> int | None:
    """The format of a file whose content is ``raw`` when it is older than
    ``current`` (a load migrates it, a save rewrites it); None when it is not, or
    cannot be read.  Read by the YAML parser, as :func:`newer_format` reads it."""
    try:
        doc = y.parse(raw.decode("utf-8"))
    except (UnicodeDecodeError, y.YamlSyntaxError):
        return None
    value = doc.data.get("format") if isinstance(doc.data, dict) else None
    if isinstance(value, y.Number) and value.integral and 0 < value < current:
        return int(value)
    return None


def _newer(name: str, doc: y.Parsed, current: int) -> Issue | None:
    value = doc.data.get("format") if isinstance(doc.data, dict) else None
    # Compared as a Decimal: format 10**5000 has no str(int).
    if not (isinstance(value, y.Number) and value.integral and value > current):
        return None
    return Issue(
        name,
        doc.line(("format",)),
        None,
        f"format {show(value)} is newer than this harlsync understands ({current}): "
        "upgrade harlsync",
        fatal=True,
    )


def unique(issues: list[Issue], order: Sequence[str]) -> list[Issue]:
    """Sorted by file (``order`` first) and line; one issue per field (the schema's,
    when both speak)."""
    rank = {name: i for i, name in enumerate(order)}
    seen: set[tuple[str, str]] = set()
    out = []
    for issue in issues:
        if issue.field is not None:
            if (issue.file, issue.field) in seen:
                continue
            seen.add((issue.file, issue.field))
        out.append(issue)
    return sorted(out, key=lambda i: (rank.get(i.file, len(rank)), i.file, i.line or 0))


def numbered(values: Mapping[int, V], node: Callable[[V], Node]) -> MappingNode:
    """A mapping keyed by number, in number order."""
    return y.mapping([(y.num(str(n)), node(values[n])) for n in sorted(values)])


def numbers(mapping: object) -> list[tuple[str, int]]:
    """The keys of a numbered mapping that are numbers, as (text, number); the schema
    reports the rest.  A key of more than 9 digits counts as :data:`HUGE`."""
    if not isinstance(mapping, dict):
        return []
    return [(k, int(k) if len(k) <= 9 else HUGE) for k in mapping if _DIGITS.fullmatch(k)]


def not_canonical(text: str, one: str) -> str:
    """The message for a number written otherwise than as the controller gives it back."""
    return (
        f"{text} is not written in its one form (write {one}: the controller reads it "
        "back so, and a push would never converge)"
    )


def check_canonical(
    issue: Callable[..., None], text: str, canonical: Callable[[str], str], *where: object
) -> None:
    """Report ``text`` through ``issue(message, *where)`` unless it is in its one
    form: what ``canonical`` makes of it (a ValueError it raises is the message)."""
    try:
        one = canonical(text)
    except ValueError as exc:
        issue(f"{text}: {exc}", *where)
        return
    if one != text:
        issue(not_canonical(text, one), *where)


def canonical_integer(text: str) -> str:
    """A whole number in its one form: ``"0012"`` -> ``"12"``, ``"+5"`` -> ``"5"``."""
    if not _INTEGER.fullmatch(text):
        raise ValueError("not a whole number")
    return str(int(text))


def text_of(value: object) -> str:
    """A scalar as its exact text (a number as written)."""
    return value.text if isinstance(value, y.Number) else str(value)


# -- robot.yaml -----------------------------------------------------------------------


def _whole(value: float) -> str:
    """``1`` or ``1.0`` -> ``"1"``; ``1.5`` stays ``"1.5"``."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def serial_items(serial: SerialSettings) -> list[tuple[str, Node]]:
    """The serial settings as robot.yaml's ``connection`` writes them."""
    return [
        ("baudrate", y.num(str(int(serial.baudrate)))),
        ("bytesize", y.num(str(int(serial.bytesize)))),
        ("parity", y.text(serial.parity)),
        ("stopbits", y.scalar_for(_whole(serial.stopbits))),
        ("rtscts", y.boolean(serial.rtscts)),
        ("timeout", y.scalar_for(repr(float(serial.timeout)))),
        ("retries", y.num(str(int(serial.retries)))),
    ]


def robot_items(
    robot: Robot, connection: Sequence[tuple[str, Node]], controller: Sequence[tuple[str, Node]]
) -> list[tuple[str, Node]]:
    """robot.yaml's items for a family that names itself: ``family``, ``name``,
    ``description`` (when there is one), ``connection``, ``controller`` and
    ``maintenance_windows``, in that order."""
    items: list[tuple[str, Node]] = [("family", y.text(robot.family)), ("name", y.text(robot.name))]
    if robot.description is not None:
        items.append(("description", y.text(robot.description)))
    return items + [
        ("connection", y.mapping(connection)),
        ("controller", y.mapping(controller)),
        ("maintenance_windows", window_nodes(robot)),
    ]


def window_nodes(robot: Robot) -> SequenceNode:
    """``maintenance_windows`` as robot.yaml writes it."""
    windows = [
        y.mapping(
            [
                ("days", y.sequence([y.text(d) for d in w.days], flow=True)),
                ("start", y.quoted(w.start.strftime("%H:%M"))),
                ("end", y.quoted(w.end.strftime("%H:%M"))),
            ]
        )
        for w in robot.windows
    ]
    return y.sequence(windows, flow=not windows)
