"""An IAI robot's project files: their names and their text (read and checked by
:mod:`.analysis`).

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

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from ...project import yamlio as y
from ...project.files import (
    FileSet,
    numbered,
    robot_items,
    serial_items,
)
from ...project.robot import Robot
from ...project.schema import SchemaSet
from . import profile
from .model import (
    ARM_NAMES,
    VARIABLE_SECTIONS,
    Position,
    Version,
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

    def records(self) -> dict[str, Mapping[int, object]]:
        """The kept read-only records by section; empty when none is kept."""
        sections = {
            "work_coordinates": self.work_coordinates,
            "tool_coordinates": self.tool_coordinates,
            "strings": self.strings,
        }
        return {name: values for name, values in sections.items() if values is not None}

    def variables(self) -> dict[str, Mapping[int, object]]:
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
    controller: list[tuple[str, Node]] = [
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


def _covered_node(covered: Coverage) -> MappingNode:
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
    items: list[tuple[str, Node]] = [("version", _version_node(version))]
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


def _version_node(version: Version) -> MappingNode:
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


def position_node(position: Position) -> MappingNode:
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


def _string_row(value: object) -> ScalarNode:
    return y.quoted(str(value))  # hex digits could read as a number


def _coordinate_system(value: object) -> SequenceNode:
    assert isinstance(value, tuple)  # a coordinate system's values, as read
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
