"""What the schemas cannot say of an Epson project's files: the register map and the
point range of robot.yaml, the numbers' one form, coordinates and joints against
the manipulator's axes, a point's attributes against its type."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from ...project import yamlio as y
from ...project.files import (
    Flaws,
    canonical_integer,
    check_canonical,
    numbers,
    text_of,
)
from ...project.robot import Robot
from ...project.schema import Issue, show
from . import profile
from .layout import point_range
from .map_form import MAP_KEYS, map_from_dict
from .model import (
    ATTRIBUTE_NAMES,
    ATTRIBUTES,
    EXTRA_ATTRIBUTES,
    KINDS,
    POINT,
    Kind,
    axes_of_type,
    coordinate_names,
    type_attributes,
    type_code,
)
from .profile import RegisterMap, RegisterMapInvalid
from .protocol import ROBOT_TYPES, canonical_real
from .protocol.reads import fewest_response_words

__all__ = ["UNCHECKABLE", "check_points", "check_settings", "robot_problems"]


def _map_issue(doc: y.Parsed, message: str) -> Issue:
    """A register map problem (:class:`RegisterMapInvalid`'s words) at its line."""
    at: tuple[str, ...] = ("connection", "map")
    head, sep, rest = message.partition(": ")
    if sep and head in MAP_KEYS:
        at += (head,)
        message = rest
        if head == "signals":  # at the last signal named that the file gives
            given = doc.data["connection"]["map"].get("signals", {})
            named = [name for name in re.findall(r"[A-Za-z]+", rest) if name in given]
            if named:
                at += (named[-1],)
    return Issue("robot.yaml", doc.line(at), ".".join(at), message)


def _too_few_words(doc: y.Parsed, register_map: RegisterMap) -> list[Issue]:
    """A map whose response words are fewer than a backup's reads need: every pull,
    diff and push of the robot would stop at that read (the schema allows what the
    manual does, 3-8; harlsync's reads need more)."""
    widest = fewest_response_words()
    need, have = widest.response_words, register_map.response_words
    if have >= need:
        return []
    return [
        _map_issue(
            doc,
            f"response_words: {have} words are fewer than harlsync's reads need: {widest} "
            f"answers in {need} (allowed: {need}-{profile.WORDS_RANGE[1]}, as many "
            "assigned in RC+)",
        )
    ]


def robot_problems(doc: y.Parsed, options: Mapping[str, Any], notes: list[str]) -> list[Issue]:
    """What robot.yaml's schema cannot say (``options``: the robot's, as read): a
    register map that cannot work, or with too few response words (what the map
    risks goes to ``notes``); a last point past the point table or before the first;
    axes the manipulator's type contradicts."""
    found = _map_problems(doc, options, notes)
    if "point_table_end" in options and options["last"] > options["point_table_end"]:
        found.append(
            Issue(
                "robot.yaml",
                doc.line(("controller", "last_point")),
                "controller.last_point",
                f"{options['last']} is past point_table_end {options['point_table_end']}, "
                "the controller's last point (allowed: at most point_table_end)",
            )
        )
    if options["first"] > options["last"]:
        found.append(
            Issue(
                "robot.yaml",
                doc.line(("controller", "last_point")),
                "controller.last_point",
                f"{options['last']} is before first_point {options['first']} (allowed: a number "
                "at or after first_point)",
            )
        )
    if "axes" in options:
        implied = axes_of_type(type_code(options["type"])) if "type" in options else None
        if implied is not None and implied != options["axes"]:
            found.append(
                Issue(
                    "robot.yaml",
                    doc.line(("controller", "axes")),
                    "controller.axes",
                    f"{options['axes']} axes for a {options['type']} robot (allowed: {implied}, "
                    "or leave axes out)",
                )
            )
    return found


def _map_problems(doc: y.Parsed, options: Mapping[str, Any], notes: list[str]) -> list[Issue]:
    try:
        register_map = map_from_dict(options["map"])
    except RegisterMapInvalid as exc:
        return [_map_issue(doc, message) for message in exc.issues]
    register_map = replace(register_map, write_without=frozenset(options.get("write_without", ())))
    note = register_map.unwritable or register_map.ready_note
    if note is not None:
        notes.append(f"robot.yaml: connection.map: {note}")
    return _too_few_words(doc, register_map)


#: A number's path within one value, its text and whether it is a real.
_Leaf = tuple[tuple[str | int, ...], str, bool]


def _leaves(kind: Kind, raw: Any) -> list[_Leaf]:
    """Every number of one value of a schema-valid file, for the canonical check."""
    shape = kind.shape
    if shape == "record":
        return [((f,), text_of(raw[f]), kind.real) for f in kind.fields]
    if shape in ("real", "integer"):
        return [((), text_of(raw), shape == "real")]
    if shape == "joints":
        return [((i,), text_of(v), False) for i, v in enumerate(raw)]
    if shape == "coords":
        return [((c,), text_of(v), True) for c, v in raw.items()]
    if shape == "limits":
        return [((a, i), text_of(raw[a][i]), True) for a in "xyz" for i in (0, 1)]
    coords: list[_Leaf] = [((c,), text_of(raw[c]), True) for c in coordinate_names(6) if c in raw]
    extras: list[_Leaf] = [
        ((a,), text_of(raw[a]), a == "j1angle") for a in EXTRA_ATTRIBUTES if a in raw
    ]
    return (
        coords
        + [((a,), text_of(raw[a]), False) for a in ATTRIBUTES if ATTRIBUTE_NAMES[a] is None]
        + extras
    )


def _real_form(text: str) -> str:
    """A real in its one form; ValueError says what is allowed (the schema has
    checked that it is a number within 32 bits of thousandths)."""
    try:
        return canonical_real(text)
    except ValueError:
        raise ValueError(
            "more than three decimals (allowed: thousandths, three decimals, "
            "as the controller gives them back)"
        ) from None


def _check_value(kind: Kind, raw: Any, axes: int | None, issue: Callable[..., None]) -> None:
    for where, text, real in _leaves(kind, raw):
        check_canonical(issue, text, _real_form if real else canonical_integer, *where)
    if axes is None:
        return
    wanted = coordinate_names(axes)
    if kind.shape in ("coords", "point"):
        have = [c for c in coordinate_names(6) if c in raw]
        extra = [c for c in have if c not in wanted]
        missing = [c for c in wanted if c not in have]
        allowed = f"allowed: {', '.join(wanted)} on a {axes}-axis robot"
        if extra:
            issue(f"{', '.join(extra)}: for a 6-axis robot ({allowed})", extra[0])
        elif missing:
            issue(f"{', '.join(missing)} missing ({allowed})")
    elif kind.shape == "joints" and len(raw) != axes:
        issue(f"{len(raw)} joints (allowed: one value per joint, {axes} on a {axes}-axis robot)")


#: What checking a value the schema refused can raise: that value is skipped (the
#: schema's issue names it), the others are still checked.
UNCHECKABLE = (KeyError, IndexError, TypeError, ValueError, AttributeError, ArithmeticError)


def check_settings(
    doc: y.Parsed, robot: Robot | None, issues: list[Issue], *, partly: bool = False
) -> int:
    """What the schema cannot say: the numbers' one form, coordinates and joints
    against the manipulator's axes, which agree with its type and robot.yaml.
    Returns the axes.  ``partly``: the file has schema errors; a setting that
    cannot be checked is skipped, and the others are."""
    data = doc.data

    def issue_at(*at: str | int) -> Callable[..., None]:
        def issue(message: str, *where: str | int) -> None:
            path = at + where
            issues.append(
                Issue("settings.yaml", doc.line(path), ".".join(str(p) for p in path), message)
            )

        return issue

    manipulator = data["manipulator"]
    axes = int(manipulator["axes"])
    implied = axes_of_type(type_code(manipulator["type"]))
    if implied is not None and implied != axes:
        issue_at("manipulator", "axes")(
            f"{axes} axes for a {manipulator['type']} robot (allowed: {implied})"
        )
    if robot is not None:
        for key, have in (("type", manipulator["type"]), ("axes", axes)):
            wanted = robot.options.get(key)
            if wanted is not None and wanted != have:
                issue_at("manipulator", key)(
                    f"{have}, but robot.yaml controller.{key} says {wanted} (allowed: "
                    f"{wanted}: this project is of another robot, or robot.yaml is wrong)"
                )
    for kind in KINDS.values():
        try:
            raw = data[kind.key]
            if not kind.numbered:
                _check_value(kind, raw, axes, issue_at(kind.key))
                continue
            for key, n in numbers(raw):
                if kind.key == "jrange" and n > axes:
                    issue_at(kind.key, key)(f"joint {n} of a {axes}-axis robot (allowed: 1-{axes})")
                try:
                    _check_value(kind, raw[key], axes, issue_at(kind.key, key))
                except UNCHECKABLE:
                    if not partly:
                        raise
        except UNCHECKABLE:
            if not partly:
                raise
    return axes


def check_points(
    doc: y.Parsed,
    flaws: Flaws,
    robot: Robot | None,
    axes: int | None,
    issues: list[Issue],
    robot_type: int | None = None,
) -> None:
    """What the schema cannot say of each point it passed: the robot's range, the
    coordinates against the axes, the type's own attributes."""
    table = doc.data.get("points") if isinstance(doc.data, dict) else None
    first, last = point_range(robot) if robot is not None else (0, 0xFFFF)
    if not isinstance(table, dict):
        return  # the schema reports it
    for key, n in numbers(table):
        at = ("points", key)
        if not flaws.sound(*at):
            continue

        def issue(message: str, *where: str | int, at: tuple[str, str] = at) -> None:
            path = at + where
            issues.append(
                Issue("points.yaml", doc.line(path), ".".join(str(p) for p in path), message)
            )

        if not first <= n <= last:
            issue(
                f"P{show(y.Number(key))} is outside the robot's range (allowed: "
                f"{first}-{last}, robot.yaml controller.first_point/last_point)"
            )
        _check_value(POINT, table[key], axes, issue)
        if robot_type is not None:
            _check_extras(table[key], robot_type, issue)


def _check_extras(raw: Mapping[str, Any], robot_type: int, issue: Callable[..., None]) -> None:
    """A point has the attributes of its manipulator's type (J1Flag and J2Flag on a
    6-axis robot, J1Angle on an RS), and no other type's."""
    wanted = type_attributes(robot_type)
    name = ROBOT_TYPES.get(robot_type, str(robot_type))
    missing = [a for a in wanted if a not in raw]
    if missing:
        issue(
            f"{', '.join(missing)} missing: a {name} robot's points have "
            f"{' and '.join(wanted)} (manual 10.25); pull again to take "
            f"{'it' if len(missing) == 1 else 'them'} in"
        )
    for extra in (a for a in EXTRA_ATTRIBUTES if a in raw and a not in wanted):
        issue(f"a {name} robot's points have no {extra} (manual 10.25)", extra)
