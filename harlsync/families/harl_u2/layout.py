"""The project's files: their names, their format, their schemas and their text.

``render_files`` turns a robot and its data into file texts; :mod:`.analysis`
turns file contents back into a robot and its data, reporting every issue it
meets.  Both work in memory: :mod:`harlsync.project.store` does the disk I/O.

Every file starts with a ``yaml-language-server`` comment naming its schema
copy in ``.schemas/`` and a ``format:`` number.  A file written in an older
format is migrated on load (:data:`MIGRATIONS`) and written in the current one
on the next save; a newer format is refused.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from yaml.nodes import MappingNode, Node

from ...project import yamlio as y
from ...project.files import (
    SCHEMAS_DIR,
    FileSet,
    MigrationError,
    Migrations,
    numbered,
    serial_items,
    window_nodes,
)
from ...project.robot import Robot
from ...project.schema import SchemaSet, show
from .declared import FIRST_STATION, LAST_STATION, PROGRAMS_DIR, STATION_ALLOWED
from .model import (
    CODE_RE,
    OFFSET_FIELDS,
    OFFSET_RE,
    REGISTER_RE,
    TIMER_RE,
    Config,
    OffsetEnd,
    OffsetTable,
    Parameters,
    ProgramArea,
    ProgramKey,
    ProgramType,
    RobotData,
    Step,
    no_such_table,
    offset_tables,
)

__all__ = [
    "FIRST_STATION",
    "FORMAT",
    "KINDS",
    "LAST_STATION",
    "MIGRATIONS",
    "PROGRAMS_DIR",
    "ROOT_FILES",
    "SCHEMAS",
    "SCHEMAS_DIR",
    "STATION_ALLOWED",
    "program_key",
    "program_order",
    "program_path",
    "render_controller",
    "render_files",
    "render_offsets",
    "render_parameters",
    "render_program",
    "render_registers",
    "render_robot",
    "render_timers",
]

#: The format number this harlsync reads and writes.  Format 2 writes a program's
#: steps as a list in step order (format 1: a mapping keyed by step number).
FORMAT = 2

#: ``MIGRATIONS[n](kind, data)`` turns a format-``n`` document of file kind
#: ``kind`` into a format-``n+1`` one (data as :func:`yamlio.parse` gives it).
#: Load applies them in turn up to :data:`FORMAT`; the next save writes the
#: result.
MIGRATIONS: Migrations = {}

#: The most steps a program area has (controller.yaml's schema: ``steps`` 0-9999).
MAX_STEPS = 9999
_STEP_NUMBER = re.compile(r"0|[1-9][0-9]{0,3}")


def migrate_1_to_2(kind: str, data: dict[str, object]) -> dict[str, object]:
    """Format 1 to 2: a program's ``steps`` mapping (step number -> step, empty steps
    left out) becomes the list of its steps in step order, an empty step ``null``.

    Raises MigrationError naming each key that is no step number (``-1``, ``'07'``,
    ``1.5``), at its line; ``steps`` that is not a mapping is left as it is, for the
    schema to report.  Every other file is unchanged.
    """
    steps = data.get("steps") if kind == "program" else None
    if not isinstance(steps, dict):
        return data
    bad = [
        k
        for k in steps
        if not (isinstance(k, str) and _STEP_NUMBER.fullmatch(k) and int(k) <= MAX_STEPS)
    ]
    if bad:
        allowed = f"(allowed: 0-{MAX_STEPS}, written without sign, point or leading zero)"
        raise MigrationError(
            [(("steps", k), f"{show(k)} is not a step number {allowed}") for k in bad]
        )
    listed: list[object] = [None] * (max((int(k) for k in steps), default=-1) + 1)
    for k, step in steps.items():
        listed[int(k)] = step
    return {**data, "steps": listed}


MIGRATIONS[1] = migrate_1_to_2

#: Top-level files in the order they are checked and reported.
ROOT_FILES = {
    "robot.yaml": "robot",
    "controller.yaml": "controller",
    "parameters.yaml": "parameters",
    "offsets.yaml": "offsets",
    "timers.yaml": "timers",
    "registers.yaml": "registers",
}

#: The file kinds, each with ``schemas/<kind>.schema.json`` in this package.
KINDS = ("robot", "controller", "parameters", "offsets", "timers", "registers", "program")
#: The schemas, and the exact text of each number kind they name as a format.
SCHEMAS = SchemaSet(
    f"{__package__}.schemas",
    KINDS,
    {
        "harl-timer": TIMER_RE,
        "harl-register": REGISTER_RE,
        "harl-offset": OFFSET_RE,
        "harl-code": CODE_RE,
    },
)
#: How the files are read and written: their schemas, format and migrations.
FILES = FileSet(SCHEMAS, FORMAT, MIGRATIONS)

_DIGITS = re.compile(r"[0-9]+")
_PROGRAM_NAME = re.compile(r"(start|(main|sub|hand)-([0-9]{2}))\.yaml")


def program_path(key: ProgramKey) -> str:
    """The program's file, relative to the project: ``programs/main-03.yaml``."""
    ptype, number = key
    if ptype is ProgramType.START:
        return f"{PROGRAMS_DIR}/start.yaml"
    return f"{PROGRAMS_DIR}/{ptype.value.lower()}-{number:02d}.yaml"


def program_key(path: str) -> ProgramKey | None:
    """The program a ``programs/...`` path holds, or ``None`` for another name."""
    folder, _, name = path.rpartition("/")
    match = _PROGRAM_NAME.fullmatch(name)
    if folder != PROGRAMS_DIR or match is None:
        return None
    if match.group(1) == "start":
        return (ProgramType.START, 0)
    return (ProgramType(match.group(2).upper()), int(match.group(3)))


# -- rendering ------------------------------------------------------------------------


def render_robot(robot: Robot) -> str:
    connection = [
        ("port", y.text(robot.port)),
        ("station", y.num(str(int(robot.station)))),
        *serial_items(robot.serial),
    ]
    items: list[tuple[str, Node]] = [("name", y.text(robot.name))]
    if robot.description is not None:
        items.append(("description", y.text(robot.description)))
    items += [
        ("connection", y.mapping(connection)),
        ("maintenance_windows", window_nodes(robot)),
        ("keep_registers", y.boolean(robot.keep_registers)),
    ]
    if "offset_tables" in robot.options:
        items.append(("offset_tables", y.num(str(offset_tables(robot)))))
    pinned = no_such_table(robot)
    if pinned is not None:
        items.append(("no_such_table", y.text(pinned)))
    return FILES.document("robot", "robot.yaml", items)


def render_controller(version: str, config: Config, offset_end: OffsetEnd | None = None) -> str:
    def area(a: ProgramArea) -> MappingNode:
        return y.mapping(
            [("count", y.num(str(a.count))), ("steps", y.num(str(a.steps)))], flow=True
        )

    programs = y.mapping([(t.value.lower(), area(config.area(t))) for t in ProgramType])
    items: list[tuple[str, Node]] = [
        ("version", y.text(version)),
        ("programs", programs),
        ("timers", y.num(str(config.timers))),
        ("memory_bits", y.num(str(config.memory_bits))),
        ("registers", y.num(str(config.registers))),
    ]
    if offset_end is not None:
        end = [("count", y.num(str(offset_end.count))), ("no_such_table", y.text(offset_end.reply))]
        items.append(("offset_tables", y.mapping(end, flow=True)))
    return FILES.document("controller", "controller.yaml", items)


def render_parameters(parameters: Parameters) -> str:
    items = [(name, y.scalar_for(value)) for name, value in parameters.as_dict().items()]
    return FILES.document("parameters", "parameters.yaml", items)


def render_offsets(offsets: Mapping[int, OffsetTable]) -> str:
    def table(t: OffsetTable) -> MappingNode:
        return y.mapping(
            [(name, y.scalar_for(v)) for name, v in zip(OFFSET_FIELDS, t.values)], flow=True
        )

    return FILES.document("offsets", "offsets.yaml", [("tables", numbered(offsets, table))])


def render_timers(timers: Mapping[int, str]) -> str:
    return FILES.document("timers", "timers.yaml", [("timers", numbered(timers, y.scalar_for))])


def render_registers(registers: Mapping[int, str]) -> str:
    return FILES.document(
        "registers", "registers.yaml", [("registers", numbered(registers, y.scalar_for))]
    )


def render_program(key: ProgramKey, steps: Mapping[int, Step]) -> str:
    """One program file: its steps as a list in step order, up to the last step used;
    an empty step before it is ``null``, so that inserting a step renumbers nothing."""
    ptype, number = key
    used = [n for n, s in steps.items() if s.command is not None]  # not s.empty
    last = max(used, default=-1)
    texts: list[str | None] = [None] * (last + 1)
    for n in used:
        if n >= 0:  # as range(last + 1) has them
            texts[n] = steps[n].text
    return FILES.document(
        "program",
        program_path(key),
        [
            ("type", y.text(ptype.value)),
            ("number", y.num(str(number))),
            ("steps", y.texts(texts)),
        ],
    )


def render_files(robot: Robot, data: RobotData) -> dict[str, str]:
    """Every YAML file of the project, by path relative to it, in a fixed order.

    ``registers.yaml`` is there only when the robot keeps registers and the data
    has them.  Values are written as they are: :func:`.analysis.analyse` says whether the
    result is valid.
    """
    out = {
        "robot.yaml": render_robot(robot),
        "controller.yaml": render_controller(data.version, data.config, data.offset_end),
        "parameters.yaml": render_parameters(data.parameters),
        "offsets.yaml": render_offsets(data.offsets),
        "timers.yaml": render_timers(data.timers),
    }
    if robot.keep_registers and data.registers is not None:
        out["registers.yaml"] = render_registers(data.registers)
    for key in sorted(data.programs, key=program_order):
        out[program_path(key)] = render_program(key, data.programs[key])
    return out


def program_order(key: ProgramKey) -> tuple[int, int]:
    """Where a program's file comes in a project: by type (START first), then number."""
    return (list(ProgramType).index(key[0]), key[1])
