"""Reading and checking an IAI robot's project files (:mod:`.layout` names them
and writes them): every file checked even when others are broken, each by its
JSON Schema and then for what a schema cannot say (the positions against the
robot's axes and range, numbers in their one form), and the data built only
from a project with no issue at all.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ...project import yamlio as y
from ...project.files import (
    HUGE,
    Flaws,
    build_serial,
    build_windows,
    check_canonical,
    numbers,
    text_of,
    unique,
)
from ...project.robot import Robot
from ...project.schema import Issue, show
from ..base import Analysis
from . import profile
from .codec import SETTINGS
from .layout import (
    FILES,
    RECORD_SECTIONS,
    RECORDED_WORD_ORDER,
    RECORDS_FILE,
    REPORTED_AXES,
    ROOT_FILES,
    STATION,
    VARIABLES_FILE,
    IaiData,
    position_range,
    record_ranges,
    variable_ranges,
)
from .model import (
    ARM_NAMES,
    VARIABLE_SECTIONS,
    Position,
    Version,
    canonical_coord,
    canonical_g,
    canonical_integer,
    canonical_real,
    coord_in_one_form,
    g_in_one_form,
)
from .tables import Coverage

__all__ = ["analyse"]

#: A position's arm system by its name in positions.yaml.
_ARMS = {name: n for n, name in ARM_NAMES.items()}


def analyse(files: Mapping[str, bytes]) -> Analysis:
    """Read and check an IAI project's files (path relative to the project -> content).

    Every file is checked even when others are broken; the positions are checked
    against the robot's axes and position range, and the flags and variables
    against its ranges, when robot.yaml is valid.  variables.yaml is read only
    when the robot keeps registers (or robot.yaml is too broken to say); a
    project that keeps them without a variables.yaml yet is valid.  ``data`` is
    set only when there is no issue at all.
    """
    issues: list[Issue] = []
    docs: dict[str, y.Parsed] = {}
    valid: set[str] = set()
    flaws: dict[str, Flaws] = {}

    def read(name: str, kind: str) -> None:
        before = len(issues)
        doc, ok = FILES.read(name, kind, files[name], issues)
        if doc is not None:
            docs[name] = doc
            flaws[name] = Flaws.of(issues[before:], name)
        if ok:
            valid.add(name)

    for name, kind in ROOT_FILES.items():
        if name not in files:
            issues.append(Issue(name, None, None, "missing", fatal=True))
            continue
        read(name, kind)

    result = Analysis(issues=issues)
    if "robot.yaml" in valid:
        result.robot = _build_robot(docs["robot.yaml"], issues)
    keep = result.robot is None or result.robot.keep_registers
    if keep and VARIABLES_FILE in files:
        read(VARIABLES_FILE, "variables")
    keeps_records = result.robot is None or bool(record_ranges(result.robot))
    if keeps_records and RECORDS_FILE in files:
        read(RECORDS_FILE, "records")
    if "positions.yaml" in valid:
        _check_positions(docs["positions.yaml"], result.robot, issues)
    elif "positions.yaml" in docs:  # a schema error must not hide the other positions' checks
        _check_positions(docs["positions.yaml"], result.robot, issues, partly=True)
    # each record and variable the schema passed, whatever the others hold
    if RECORDS_FILE in docs:
        _check_records(docs[RECORDS_FILE], flaws[RECORDS_FILE], result.robot, issues)
    if VARIABLES_FILE in docs:
        _check_variables(docs[VARIABLES_FILE], flaws[VARIABLES_FILE], result.robot, issues)
    if not issues and result.robot is not None:
        result.data = _build_data(docs, result.robot)
    result.issues = unique(issues, [*ROOT_FILES, VARIABLES_FILE, RECORDS_FILE])
    return result


def _build_data(docs: Mapping[str, y.Parsed], robot: Robot) -> IaiData:
    """The data of a project with no issue; ``robot``'s options get what
    controller.yaml carries to the connection (its axes, its word order)."""
    controller = docs["controller.yaml"].data
    data = IaiData(
        version=_build_version(controller["version"]),
        positions=_build_positions(docs["positions.yaml"].data["positions"]),
        model=str(robot.options.get("model", profile.DEFAULT_MODEL)),
        covered={
            section: _build_coverage(c) for section, c in controller.get("covered", {}).items()
        },
        axes=tuple(sorted(int(a) for a in controller.get("axes", []))),
        real_word_order=controller.get("real_word_order"),
    )
    if data.axes:  # the connection's interlock wants them from its first 212H
        robot.options[REPORTED_AXES] = data.axes
    if data.real_word_order is not None:  # for a push to a blank controller
        robot.options[RECORDED_WORD_ORDER] = data.real_word_order
    if VARIABLES_FILE in docs:
        _build_variables(docs[VARIABLES_FILE].data, data)
    if RECORDS_FILE in docs:
        _build_records(docs[RECORDS_FILE].data, data)
    return data


def _build_robot(doc: y.Parsed, issues: list[Issue]) -> Robot | None:
    data = doc.data
    connection = data["connection"]
    station = text_of(connection.get("station", f"{profile.DEFAULT_STATION:02X}"))
    if not STATION.fullmatch(station):
        issues.append(
            Issue(
                "robot.yaml",
                doc.line(("connection", "station")),
                "connection.station",
                f"{show(connection['station'])} is not a station (allowed: {profile.STATION_ALLOWED})",
            )
        )
        return None
    controller = data.get("controller", {})
    options: dict[str, object] = {"model": str(controller.get("model", profile.DEFAULT_MODEL))}
    if "axes" in controller:
        axes = sorted(int(a) for a in controller["axes"])
        options["axes"] = tuple(axes)
    if "real_word_order" in controller:
        options["real_word_order"] = str(controller["real_word_order"])
    default_first, default_last = profile.DEFAULT_POSITION_RANGE
    first = int(controller.get("first_position", default_first))
    last = int(controller.get("last_position", default_last))
    options["first"], options["last"] = first, last
    ranges: list[tuple[tuple[str, ...], int, int, str]] = [
        (("controller", "last_position"), first, last, "first_position")
    ]
    for section in (*VARIABLE_SECTIONS, *RECORD_SECTIONS):
        if section in controller:
            bounds = controller[section]
            options[section] = kept = (int(bounds["first"]), int(bounds["last"]))
            ranges.append((("controller", section, "last"), *kept, "first"))
    backwards = [
        Issue(
            "robot.yaml",
            doc.line(path),
            ".".join(path),
            f"{last} is before {before} {first} (allowed: a number at or after {before})",
        )
        for path, first, last, before in ranges
        if first > last
    ]
    if backwards:
        issues += backwards
        return None
    return Robot(
        family="iai",
        name=data["name"],
        port=connection["port"],
        station=int(station, 16),
        serial=build_serial(connection, SETTINGS),
        windows=build_windows(data),
        keep_registers=bool(data.get("keep_registers", False)),
        description=data.get("description"),
        options=options,
    )


#: What checking a position the schema refused can raise: that one is skipped (the
#: schema's issue names it), the others are still checked.
_UNCHECKABLE = (KeyError, IndexError, TypeError, ValueError, AttributeError, ArithmeticError)


def _check_positions(
    doc: y.Parsed, robot: Robot | None, issues: list[Issue], *, partly: bool = False
) -> None:
    """What the schema cannot say: the coordinates against the axes, canonical
    numbers, and the robot's axes and range.  ``partly``: the file has schema
    errors; a position that cannot be checked is skipped, and the others are."""
    try:
        table = doc.data["positions"]
        found = numbers(table)
    except _UNCHECKABLE:
        if not partly:
            raise
        return
    first, last = position_range(robot) if robot is not None else (1, 0xFFFF)
    axes_allowed = robot.options.get("axes") if robot is not None else None
    for key, n in found:
        try:
            _check_position(doc, (first, last, axes_allowed), issues, table, key, n)
        except _UNCHECKABLE:
            if not partly:
                raise


def _check_position(
    doc: y.Parsed,
    robot: tuple[int, int, Sequence[int] | None],
    issues: list[Issue],
    table: Mapping[str, Any],
    key: str,
    n: int,
) -> None:
    """One position; ``robot``: its table's first and last number and its axes."""
    first, last, axes_allowed = robot
    entry = table[key]
    at = ("positions", key)

    def issue(message: str, *where: str | int, at: tuple[str, str] = at) -> None:
        path = at + where
        name = ".".join(str(p) for p in path)
        issues.append(Issue("positions.yaml", doc.line(path), name, message))

    if not first <= n <= last:
        issue(
            f"position {show(y.Number(key))} is outside the robot's table "
            f"(allowed: {first}-{last}, robot.yaml controller.first_position/"
            "last_position)"
        )
    axes = [int(a) for a in entry["axes"]]
    if axes != sorted(axes):
        issue(f"{axes} are not in ascending order (allowed: ascending, {sorted(axes)})", "axes")
    if axes_allowed is not None and not set(axes) <= set(axes_allowed):
        extra = sorted(set(axes) - set(axes_allowed))
        issue(
            f"axis {', '.join(map(str, extra))} is not one of the robot's "
            f"(allowed: {', '.join(map(str, axes_allowed))}, robot.yaml "
            "controller.axes)",
            "axes",
        )
    coords = entry["coords"]
    if len(coords) != len(axes):
        issue(
            f"{len(coords)} coordinate(s) for {len(axes)} axis/axes "
            "(allowed: one coordinate per axis in axes)",
            "coords",
        )
    for i, value in enumerate(coords):
        text = text_of(value)
        if not coord_in_one_form(text):  # the common case at once; else worked out
            check_canonical(issue, text, canonical_coord, "coords", i)
    for name in ("acc", "dec"):
        text = text_of(entry[name])
        if not g_in_one_form(text):
            check_canonical(issue, text, canonical_g, name)


def _check_variables(doc: y.Parsed, flaws: Flaws, robot: Robot | None, issues: list[Issue]) -> None:
    """What the schema cannot say of each variable it passed: its number within the
    robot's range for it, and integers and reals in their one form."""
    ranges = variable_ranges(robot) if robot is not None else {}
    canonical = {"integers": canonical_integer, "reals": canonical_real}
    for section, called in VARIABLE_SECTIONS.items():
        table = doc.data.get(section) if isinstance(doc.data, dict) else None
        if not isinstance(table, dict):
            continue  # the schema reports it
        first, last = ranges.get(section, (0, HUGE))
        for key, n in numbers(table):
            at = (section, key)
            if not flaws.sound(*at):
                continue

            def issue(message: str, *where: str | int, at: tuple[str, str] = at) -> None:
                issues.append(Issue(VARIABLES_FILE, doc.line(at), ".".join(at), message))

            if not first <= n <= last:
                issue(
                    f"{called} {show(y.Number(key))} is outside the robot's range "
                    f"(allowed: {first}-{last}, robot.yaml controller.{section})"
                )
            if section in canonical:
                check_canonical(issue, text_of(table[key]), canonical[section])


def _check_records(doc: y.Parsed, flaws: Flaws, robot: Robot | None, issues: list[Issue]) -> None:
    """What the schema cannot say of each record it passed: its number within
    robot.yaml's range for its section, and coordinates in their one form."""
    ranges = record_ranges(robot) if robot is not None else {}
    for section in RECORD_SECTIONS:
        table = doc.data.get(section) if isinstance(doc.data, dict) else None
        if not isinstance(table, dict):
            continue  # the schema reports it
        first, last = ranges.get(section, (0, HUGE))
        for key, n in numbers(table):
            at = (section, key)
            if not flaws.sound(*at):
                continue

            def issue(message: str, *where: str | int, at: tuple[str, str] = at) -> None:
                path = at + where
                issues.append(
                    Issue(RECORDS_FILE, doc.line(path), ".".join(map(str, path)), message)
                )

            if not first <= n <= last:
                issue(
                    f"{show(y.Number(key))} is outside the robot's range "
                    f"(allowed: {first}-{last}, robot.yaml controller.{section})"
                )
            if section != "strings":
                for i, value in enumerate(table[key]):
                    check_canonical(issue, text_of(value), canonical_coord, i)


def _build_records(doc: Mapping[str, Any], data: IaiData) -> None:
    for section in ("work_coordinates", "tool_coordinates"):
        if (table := doc.get(section)) is not None:
            setattr(
                data,
                section,
                {
                    int(n): tuple(text_of(c) for c in v)
                    for n, v in sorted(table.items(), key=_by_number)
                },
            )
    if (strings := doc.get("strings")) is not None:
        data.strings = {int(n): str(v) for n, v in sorted(strings.items(), key=_by_number)}


def _build_coverage(data: Mapping[str, Any]) -> Coverage:
    def number(name: str) -> int | None:
        return None if name not in data else int(data[name])

    def reply(name: str) -> str | None:
        return None if name not in data else text_of(data[name])

    return Coverage(
        int(data["first"]),
        int(data["last"]),
        int(data["checked_to"]),
        number("checked_from"),
        number("start"),
        number("end"),
        reply("before"),
        reply("past"),
    )


def _build_version(data: Mapping[str, Any]) -> Version:
    return Version(
        unit_type=int(data["unit_type"]),
        device=int(data["device"]),
        model_code=str(data["model_code"]),
        unit_code=str(data["unit_code"]),
        version=str(data["version"]),
        built=str(data["built"]),
    )


def _build_positions(table: Mapping[str, Any]) -> dict[int, Position]:
    out: dict[int, Position] = {}
    for key in sorted(table, key=int):
        entry = table[key]
        out[int(key)] = Position(
            number=int(key),
            axes=tuple(int(a) for a in entry["axes"]),
            acc=text_of(entry["acc"]),
            dec=text_of(entry["dec"]),
            speed=int(entry["speed"]),
            coords=tuple(text_of(c) for c in entry["coords"]),
            arm1=_ARMS[entry.get("arm1", "none")],
            arm2=_ARMS[entry.get("arm2", "none")],
        )
    return out


def _build_variables(doc: Mapping[str, Any], data: IaiData) -> None:
    if (flags := doc.get("flags")) is not None:
        data.flags = {int(n): bool(v) for n, v in sorted(flags.items(), key=_by_number)}
    if (integers := doc.get("integers")) is not None:
        data.integers = {int(n): int(v) for n, v in sorted(integers.items(), key=_by_number)}
    if (reals := doc.get("reals")) is not None:
        data.reals = {int(n): text_of(v) for n, v in sorted(reals.items(), key=_by_number)}


def _by_number(item: tuple[str, object]) -> int:
    return int(item[0])
