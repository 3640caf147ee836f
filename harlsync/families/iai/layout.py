"""An IAI robot's project files: their names, their text, and checking a set of them.

::

    robot.yaml         family: iai, connection (station in hex), controller model,
                       axes, position range and the flag and variable ranges,
                       maintenance windows, keep_registers (user-edited)
    controller.yaml    what 201H reports (model and unit codes, version, build date),
                       the axes 212H reported (when robot.yaml names none), the
                       real variables' word order their values showed, and the
                       range of each table the pull covered, with the controller's
                       "not there" replies around it (tables.py):

        covered:
          positions: {first: 1, last: 1000, checked_from: 1, checked_to: 1000, end: 1000, past: "error 0A3H"}
    positions.yaml     the position table, one defined position per line:

        positions:
          1: {axes: [1, 2, 3], coords: [100.000, -1.000, 0.000], acc: 0.30, dec: 0.30, speed: 100}
          7: {axes: [1, 2], coords: [0.000, 25.500], acc: 0.00, dec: 0.00, speed: 0, arm1: right}

    records.yaml       only when robot.yaml gives their ranges: records, the work
                       and tool coordinate systems (2A0H, read only) and string
                       variables (210H, written back with 24EH; a row of 32
                       columns a line, as hex codes)

        work_coordinates:
          1: [100.000, 50.000, 0.000, 90.000]
        strings:
          1: 48454C4C4F

    variables.yaml     only when robot.yaml says keep_registers: true (runtime data):
                       global flags, integer and real variables, one per line

        flags:
          600: false
          601: true
        integers:
          200: -1000
        reals:
          300: 0.1

Numbers are kept as the exact decimal text the controller's units give
(coordinates three decimals, acc/dec two, a real the shortest text of its
double), so a review reads what the robot holds.  A number written any other
way (``0012.5``, ``-0.000``, a real ``0.10``) is refused with its one form in
the message, so a push always converges.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ...project import yamlio as y
from ...project.files import (
    HUGE,
    FileSet,
    Flaws,
    build_serial,
    build_windows,
    check_canonical,
    numbered,
    numbers,
    robot_items,
    serial_items,
    text_of,
    unique,
)
from ...project.robot import Robot
from ...project.schema import Issue, SchemaSet, show
from ..base import Analysis
from . import profile
from .codec import SETTINGS
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

__all__ = [
    "FILES",
    "FORMAT",
    "RECORDED_WORD_ORDER",
    "RECORDS_FILE",
    "RECORD_SECTIONS",
    "REPORTED_AXES",
    "ROOT_FILES",
    "STATION",
    "VARIABLES_FILE",
    "Coverage",
    "IaiData",
    "analyse",
    "record_ranges",
    "render_files",
    "variable_ranges",
]

#: The format number this harlsync reads and writes for IAI projects.
FORMAT = 1
ROOT_FILES = {
    "robot.yaml": "robot",
    "controller.yaml": "controller",
    "positions.yaml": "positions",
}
#: Only when robot.yaml keeps registers.
VARIABLES_FILE = "variables.yaml"
#: Only when robot.yaml gives a range of read-only records.
RECORDS_FILE = "records.yaml"
#: The read-only records' sections, as robot.yaml and records.yaml name them.
RECORD_SECTIONS = ("work_coordinates", "tool_coordinates", "strings")
SCHEMAS = SchemaSet(
    f"{__package__}.schemas",
    [*ROOT_FILES.values(), "variables", "records"],
    {
        "iai-coord": re.compile(r"[-+]?[0-9]+(\.[0-9]+)?"),
        "iai-g": re.compile(r"[0-9]+(\.[0-9]+)?"),
    },
)
FILES = FileSet(SCHEMAS, FORMAT)

_ARMS = {name: n for n, name in ARM_NAMES.items()}
#: The robot option that carries controller.yaml's ``axes`` (every axis an earlier
#: 212H reported) to the connection; never written to robot.yaml.
REPORTED_AXES = "reported_axes"
#: The robot option that carries controller.yaml's ``real_word_order`` (the order
#: the last pull saw the real variables' values in) to the connection.
RECORDED_WORD_ORDER = "recorded_real_word_order"

#: A station as robot.yaml and --station write it (profile.STATION_ALLOWED).
STATION = re.compile(r"[0-9A-Fa-f]{2}")


@dataclass
class IaiData:
    """What a backup of an IAI controller holds: its version and its position table,
    and its global flags and variables when the project keeps them.

    ``model`` is the controller model the buffer sizes come from (robot.yaml's,
    not read from the controller); it sizes the writes of a plan.  ``flags``,
    ``integers`` and ``reals`` (exact text, see :func:`~.model.canonical_real`)
    are by number, each None when not kept or not read.
    """

    version: Version
    positions: dict[int, Position] = field(default_factory=dict)
    model: str = profile.DEFAULT_MODEL
    flags: dict[int, bool] | None = None
    integers: dict[int, int] | None = None
    reals: dict[int, str] | None = None
    #: section (``positions``, ``flags`` ...) -> the range a pull covered
    covered: dict[str, Coverage] = field(default_factory=dict)
    #: every axis a 212H reported (controller.yaml ``axes``) when robot.yaml names
    #: none: a later push's interlock wants each of them in every 212H reply
    axes: tuple[int, ...] = ()
    #: read-only records (None: not kept): coordinate system definitions by number,
    #: X, Y, Z and R as coordinate text; string variable rows by first column, the
    #: characters' codes as hex text (two digits each)
    work_coordinates: dict[int, tuple[str, ...]] | None = None
    tool_coordinates: dict[int, tuple[str, ...]] | None = None
    strings: dict[int, str] | None = None
    #: the word order the real variables' values showed at this read (p.24;
    #: controller.yaml), None when they did not tell
    real_word_order: str | None = None

    def records(self) -> dict[str, dict[int, Any]]:
        """The kept read-only records by section; empty when none is kept."""
        sections = {
            "work_coordinates": self.work_coordinates,
            "tool_coordinates": self.tool_coordinates,
            "strings": self.strings,
        }
        return {name: values for name, values in sections.items() if values is not None}

    def variables(self) -> dict[str, dict[int, Any]]:
        """The kept sections of runtime data by name (``flags``, ``integers``,
        ``reals``); empty when none is kept."""
        sections = {"flags": self.flags, "integers": self.integers, "reals": self.reals}
        return {name: values for name, values in sections.items() if values is not None}


# -- rendering --------------------------------------------------------------------------


def render_robot(robot: Robot) -> str:
    options = robot.options
    connection = [
        ("port", y.text(robot.port)),
        ("station", y.quoted(f"{robot.station:02X}")),
        *serial_items(robot.serial),
    ]
    controller: list[tuple[str, Any]] = [
        ("model", y.text(str(options.get("model", profile.DEFAULT_MODEL))))
    ]
    if options.get("axes"):
        controller.append(("axes", y.sequence([y.num(str(a)) for a in options["axes"]], flow=True)))
    first, last = position_range(robot)
    controller += [
        ("first_position", y.num(str(first))),
        ("last_position", y.num(str(last))),
    ]
    if "real_word_order" in options:  # absent: read from the values at each pull
        controller.append(("real_word_order", y.text(str(options["real_word_order"]))))
    controller += [
        (
            section,
            y.mapping(
                [
                    ("first", y.num(str(options[section][0]))),
                    ("last", y.num(str(options[section][1]))),
                ],
                flow=True,
            ),
        )
        for section in (*VARIABLE_SECTIONS, *RECORD_SECTIONS)
        if section in options
    ]
    items = robot_items(robot, connection, controller)
    if robot.keep_registers:  # absent when false: a positions-only robot.yaml as before
        items.append(("keep_registers", y.boolean(True)))
    return FILES.document("robot", "robot.yaml", items)


#: controller.yaml's order of a table's covered fields (those that are None left out).
_COVERED_FIELDS = ("first", "last", "checked_from", "checked_to", "start", "end", "before", "past")


def _covered_node(covered: Coverage) -> Any:
    fields = covered._asdict()
    return y.mapping(
        [
            (
                name,
                y.quoted(fields[name]) if name in ("before", "past") else y.num(str(fields[name])),
            )
            for name in _COVERED_FIELDS
            if fields[name] is not None
        ],
        flow=True,
    )


def render_controller(
    version: Version,
    covered: Mapping[str, Coverage] | None = None,
    axes: tuple[int, ...] = (),
    real_word_order: str | None = None,
) -> str:
    items = [("version", _version_node(version))]
    if axes:
        items.append(("axes", y.sequence([y.num(str(a)) for a in axes], flow=True)))
    if real_word_order is not None:
        items.append(("real_word_order", y.text(real_word_order)))
    if covered:
        items.append(
            (
                "covered",
                y.mapping([(section, _covered_node(c)) for section, c in covered.items()]),
            )
        )
    return FILES.document("controller", "controller.yaml", items)


def _version_node(version: Version) -> Any:
    return y.mapping(
        [
            ("unit_type", y.num(str(version.unit_type))),
            ("device", y.num(str(version.device))),
            ("model_code", y.quoted(version.model_code)),
            ("unit_code", y.quoted(version.unit_code)),
            ("version", y.quoted(version.version)),
            ("built", y.quoted(version.built)),
        ]
    )


def position_node(position: Position) -> Any:
    """A position's line: a row of numbers (:func:`yamlio.row`, a thousand a table)."""
    items: list[tuple[str, y.RowValue]] = [
        ("axes", [str(a) for a in position.axes]),
        ("coords", list(position.coords)),
        ("acc", position.acc),
        ("dec", position.dec),
        ("speed", str(position.speed)),
    ]
    for name, arm in (("arm1", position.arm1), ("arm2", position.arm2)):
        if arm:
            items.append((name, y.text(ARM_NAMES.get(arm, str(arm)))))
    return y.row(items)


def render_positions(positions: Mapping[int, Position]) -> str:
    return FILES.document(
        "positions", "positions.yaml", [("positions", numbered(positions, position_node))]
    )


_VARIABLE_NODES = {
    "flags": y.boolean,
    "integers": lambda value: y.num(str(value)),
    "reals": y.scalar_for,  # NaN as text: the check names it rather than a crash here
}


def render_variables(data: IaiData) -> str:
    """variables.yaml: each kept section, one value per line by number."""
    return FILES.document(
        "variables",
        VARIABLES_FILE,
        [
            (name, numbered(values, _VARIABLE_NODES[name]))
            for name, values in data.variables().items()
        ],
    )


def _string_row(value: Any) -> Any:
    return y.quoted(str(value))  # hex digits could read as a number


def _coordinate_system(value: Any) -> Any:
    return y.sequence([y.num(c) for c in value], flow=True)


def render_records(data: IaiData) -> str:
    """records.yaml: each kept read-only section, one record (or row) per line."""
    return FILES.document(
        "records",
        RECORDS_FILE,
        [
            (name, numbered(values, _string_row if name == "strings" else _coordinate_system))
            for name, values in data.records().items()
        ],
    )


def render_files(robot: Robot, data: IaiData) -> dict[str, str]:
    """Every file of the project, by relative path, in a fixed order.

    variables.yaml only when the robot keeps registers and the data has them.
    """
    out = {
        "robot.yaml": render_robot(robot),
        "controller.yaml": render_controller(
            data.version, data.covered, data.axes, data.real_word_order
        ),
        "positions.yaml": render_positions(data.positions),
    }
    if robot.keep_registers and data.variables():
        out[VARIABLES_FILE] = render_variables(data)
    if data.records():
        out[RECORDS_FILE] = render_records(data)
    return out


def record_ranges(robot: Robot) -> dict[str, tuple[int, int]]:
    """The read-only records robot.yaml keeps: section -> (first, last); none by default."""
    return {
        section: (int(robot.options[section][0]), int(robot.options[section][1]))
        for section in RECORD_SECTIONS
        if section in robot.options
    }


def position_range(robot: Robot) -> tuple[int, int]:
    """The first and last position number of the robot's table."""
    first, last = profile.DEFAULT_POSITION_RANGE
    return int(robot.options.get("first", first)), int(robot.options.get("last", last))


def variable_ranges(robot: Robot) -> dict[str, tuple[int, int]]:
    """The flags and variables a robot that keeps them backs up: section -> (first,
    last), robot.yaml's or the profile's default."""
    out = {}
    for section, default in profile.DEFAULT_VARIABLE_RANGES.items():
        first, last = robot.options.get(section, default)
        out[section] = (int(first), int(last))
    return out


# -- reading and checking ---------------------------------------------------------------


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
        result.data = IaiData(
            version=_build_version(docs["controller.yaml"].data["version"]),
            positions=_build_positions(docs["positions.yaml"].data["positions"]),
            model=str(result.robot.options.get("model", profile.DEFAULT_MODEL)),
            covered={
                section: _build_coverage(c)
                for section, c in docs["controller.yaml"].data.get("covered", {}).items()
            },
            axes=tuple(sorted(int(a) for a in docs["controller.yaml"].data.get("axes", []))),
            real_word_order=docs["controller.yaml"].data.get("real_word_order"),
        )
        if result.data.axes:  # the connection's interlock wants them from its first 212H
            result.robot.options[REPORTED_AXES] = result.data.axes
        if result.data.real_word_order is not None:  # for a push to a blank controller
            result.robot.options[RECORDED_WORD_ORDER] = result.data.real_word_order
        if VARIABLES_FILE in docs:
            _build_variables(docs[VARIABLES_FILE].data, result.data)
        if RECORDS_FILE in docs:
            _build_records(docs[RECORDS_FILE].data, result.data)
    result.issues = unique(issues, [*ROOT_FILES, VARIABLES_FILE, RECORDS_FILE])
    return result


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
    options: dict[str, Any] = {"model": str(controller.get("model", profile.DEFAULT_MODEL))}
    if "axes" in controller:
        axes = sorted(int(a) for a in controller["axes"])
        options["axes"] = tuple(axes)
    if "real_word_order" in controller:
        options["real_word_order"] = str(controller["real_word_order"])
    first, last = profile.DEFAULT_POSITION_RANGE
    options["first"] = int(controller.get("first_position", first))
    options["last"] = int(controller.get("last_position", last))
    ranges = [
        (("controller", "last_position"), options["first"], options["last"], "first_position")
    ]
    for section in (*VARIABLE_SECTIONS, *RECORD_SECTIONS):
        if section in controller:
            bounds = controller[section]
            options[section] = (int(bounds["first"]), int(bounds["last"]))
            ranges.append((("controller", section, "last"), *options[section], "first"))
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
    robot: tuple[int, int, Any],
    issues: list[Issue],
    table: Any,
    key: Any,
    n: int,
) -> None:
    """One position; ``robot``: its table's first and last number and its axes."""
    first, last, axes_allowed = robot
    entry = table[key]
    at = ("positions", key)

    def issue(message: str, *where: Any, at: tuple[str, str] = at) -> None:
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
        table: Any = doc.data.get(section) if isinstance(doc.data, dict) else None
        first, last = ranges.get(section, (0, HUGE))
        for key, n in numbers(table):
            at = (section, key)
            if not flaws.sound(*at):
                continue

            def issue(message: str, *where: Any, at: tuple[str, str] = at) -> None:
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
        table: Any = doc.data.get(section) if isinstance(doc.data, dict) else None
        first, last = ranges.get(section, (0, HUGE))
        for key, n in numbers(table):
            at = (section, key)
            if not flaws.sound(*at):
                continue

            def issue(message: str, *where: Any, at: tuple[str, str] = at) -> None:
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


def _by_number(item: tuple[str, Any]) -> int:
    return int(item[0])
