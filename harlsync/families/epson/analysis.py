"""Reading an Epson project's files: every file checked (:mod:`.checks` for what
the schemas cannot say), then built into a :class:`~harlsync.project.robot.Robot`
and :class:`~.model.EpsonData` when nothing is wrong."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any

from ...project import yamlio as y
from ...project.files import (
    Flaws,
    build_windows,
    text_of,
    unique,
)
from ...project.robot import Robot
from ...project.schema import Issue
from ..base import Analysis
from . import profile
from .checks import UNCHECKABLE, check_points, check_settings, robot_problems
from .layout import CONTROLLER_FILE, FILES, LINE_DEFAULTS, ROOT_FILES
from .model import (
    ATTRIBUTE_NAMES,
    EXTRA_ATTRIBUTES,
    KINDS,
    POINT,
    EpsonData,
    Kind,
    NotThere,
    Point,
    PointKey,
    PointTable,
    SettingKey,
    TableKey,
    coordinate_names,
    type_code,
)
from .protocol import Limits

__all__ = ["analyse"]


def analyse(files: Mapping[str, bytes]) -> Analysis:
    """Read and check an Epson project's files (path relative to the project -> content).

    Every file is checked even when others are broken; the settings and points
    are checked against the manipulator's axes and robot.yaml's type, axes and
    point range when those files are valid.  ``data`` is set only when there is
    no issue at all.
    """
    issues: list[Issue] = []
    docs: dict[str, y.Parsed] = {}
    valid: set[str] = set()
    flaws: dict[str, Flaws] = {}
    for name, kind in ROOT_FILES.items():
        if name not in files:
            issues.append(Issue(name, None, None, "missing", fatal=True))
            continue
        before = len(issues)
        doc, ok = FILES.read(name, kind, files[name], issues)
        if doc is not None:
            docs[name] = doc
            flaws[name] = Flaws.of(issues[before:], name)
        if ok:
            valid.add(name)

    result = Analysis(issues=issues)
    if "robot.yaml" in valid:
        result.robot = _build_robot(docs["robot.yaml"], issues, result.notes)
    axes = None
    if "settings.yaml" in valid:
        axes = check_settings(docs["settings.yaml"], result.robot, issues)
    elif "settings.yaml" in docs:  # a schema error must not hide the other items' checks
        try:
            axes = check_settings(docs["settings.yaml"], result.robot, issues, partly=True)
        except UNCHECKABLE:  # the manipulator itself is broken: the schema said how
            pass
    if axes is None and result.robot is not None:
        axes = result.robot.options.get("axes")
    if "points.yaml" in docs:  # each point the schema passed, whatever the others hold
        robot_type = None
        if "settings.yaml" in docs and flaws["settings.yaml"].sound("manipulator", "type"):
            robot_type = type_code(docs["settings.yaml"].data["manipulator"]["type"])
        check_points(
            docs["points.yaml"], flaws["points.yaml"], result.robot, axes, issues, robot_type
        )
    table = None
    if CONTROLLER_FILE in files:
        doc, ok = FILES.read(CONTROLLER_FILE, "controller", files[CONTROLLER_FILE], issues)
        if doc is not None and ok:
            table = _build_table(doc, issues)
    if not issues and result.robot is not None:
        data = _build_data(docs["settings.yaml"].data, docs["points.yaml"].data)
        data.covered, data.probed_to = _covered(files["points.yaml"])
        data.table = table
        result.data = data
    result.issues = unique(issues, [*ROOT_FILES, CONTROLLER_FILE])
    return result


def _build_table(doc: y.Parsed, issues: list[Issue]) -> PointTable | None:
    """controller.yaml's point table (the schema has checked its form)."""
    points = doc.data["points"]
    answers: dict[str, NotThere] = {}
    for key in ("past_end", "not_defined"):
        if key in points:
            try:
                answers[key] = NotThere.parse(str(points[key]))
            except ValueError as exc:
                issues.append(
                    Issue(CONTROLLER_FILE, doc.line(("points", key)), f"points.{key}", str(exc))
                )
    if "past_end" not in answers:
        return None
    return PointTable(int(points["end"]), answers["past_end"], answers.get("not_defined"))


#: The comment :func:`render_points` writes of the range a pull covered.
_COVERED = re.compile(
    rb"^points: +# P(\d+)-P(\d+) read(?:, none defined (P\d+-P\d+(?: and P\d+-P\d+)?))? "
    rb"when pulled;",
    re.MULTILINE,
)


def _covered(text: bytes) -> tuple[tuple[int, int] | None, int | None]:
    """The range the pull that wrote points.yaml covered, read back from its comment,
    so that a project loaded and saved again keeps the record."""
    found = _COVERED.search(text)
    if found is None:
        return None, None
    last = int(found.group(2))
    probed = found.group(3)
    ends = [int(end) for end in re.findall(rb"-P(\d+)", probed)] if probed else []
    return (int(found.group(1)), last), max([last, *ends]) if ends else None


def _plain(value: object) -> object:
    """YAML data as plain Python: whole numbers as int (the register map's form)."""
    if isinstance(value, y.Number):
        return int(value) if value.integral else value
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _build_robot(doc: y.Parsed, issues: list[Issue], notes: list[str]) -> Robot | None:
    """robot.yaml, schema-valid, as the robot; None when :func:`~.checks.robot_problems`
    finds any (added to ``issues``)."""
    data = doc.data
    conn = data["connection"]
    options = _robot_options(conn, data.get("controller", {}))
    found = robot_problems(doc, options, notes)
    if found:
        issues += found
        return None
    return Robot(
        family="epson",
        name=data["name"],
        port=conn["port"],
        station=int(conn.get("unit", profile.DEFAULT_UNIT)),
        windows=build_windows(data),
        description=data.get("description"),
        options=options,
    )


def _robot_options(conn: Mapping[str, Any], controller: Mapping[str, Any]) -> dict[str, object]:
    """robot.yaml's connection and controller sections as the robot's options."""
    options: dict[str, object] = {
        key: _plain(conn.get(key, default)) for key, default in LINE_DEFAULTS.items()
    }
    options["map"] = _plain(conn.get("map", {}))
    if "writes_whole" in conn:
        options["writes_whole"] = bool(conn["writes_whole"])
    if "write_without" in conn:
        options["write_without"] = sorted(set(conn["write_without"]))
    first, last = profile.DEFAULT_POINT_RANGE
    options["first"] = int(controller.get("first_point", first))
    options["last"] = int(controller.get("last_point", last))
    if "point_table_end" in controller:
        options["point_table_end"] = int(controller["point_table_end"])
    if "type" in controller:
        options["type"] = str(controller["type"])
    if "axes" in controller:
        options["axes"] = int(controller["axes"])
    return options


def _value(kind: Kind, raw: Any) -> Any:
    """One value of a valid file, in the codec's types."""
    shape = kind.shape
    if shape == "record":
        assert kind.record is not None
        convert: Callable[[Any], Any] = text_of if kind.real else int
        return kind.record(*(convert(raw[f]) for f in kind.fields))
    if shape == "real":
        return text_of(raw)
    if shape == "integer":
        return int(raw)
    if shape == "joints":
        return tuple(int(v) for v in raw)
    if shape == "coords":
        return tuple(text_of(raw[c]) for c in coordinate_names(6) if c in raw)
    if shape == "limits":
        return tuple(Limits(text_of(raw[a][0]), text_of(raw[a][1])) for a in "xyz")
    attributes: dict[str, Any] = {}
    for name, names in ATTRIBUTE_NAMES.items():
        attributes[name] = names.index(raw[name]) if names else int(raw[name])
    for name in EXTRA_ATTRIBUTES:
        if name in raw:
            attributes[name] = text_of(raw[name]) if name == "j1angle" else int(raw[name])
    return Point(tuple(text_of(raw[c]) for c in coordinate_names(6) if c in raw), **attributes)


def _build_data(settings: Mapping[str, Any], points: Mapping[str, Any]) -> EpsonData:
    manipulator = settings["manipulator"]
    data = EpsonData(
        type_code(manipulator["type"]), int(manipulator["axes"]), str(manipulator["model"])
    )
    for kind in KINDS.values():
        raw = settings[kind.key]
        if not kind.numbered:
            data.items[SettingKey(kind.key)] = _value(kind, raw)
            continue
        key_type = TableKey if kind.table else SettingKey
        for n in sorted(raw, key=int):
            data.items[key_type(kind.key, int(n))] = _value(kind, raw[n])
    for n in sorted(points["points"], key=int):
        data.items[PointKey("point", int(n))] = _value(POINT, points["points"][n])
    return data
