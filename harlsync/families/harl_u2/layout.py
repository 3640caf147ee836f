"""The project's files: their names, their text, and checking a set of them.

``render_files`` turns a robot and its data into file texts; ``analyse`` turns
file contents back into a robot and its data, reporting every issue it meets.
Both work in memory: :mod:`harlsync.project.store` does the disk I/O.

Every file starts with a ``yaml-language-server`` comment naming its schema
copy in ``.schemas/`` and a ``format:`` number.  A file written in an older
format is migrated on load (:data:`MIGRATIONS`) and written in the current one
on the next save; a newer format is refused.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ...alignment import spans
from ...project import yamlio as y
from ...project.files import (
    HUGE,
    SCHEMAS_DIR,
    FileSet,
    Flaws,
    MigrationError,
    not_canonical,
    numbered,
    numbers,
    serial_items,
    text_of,
    unique,
    window_nodes,
)
from ...project.robot import Robot
from ...project.schema import Issue, SchemaSet, show
from ..base import Analysis
from .declared import FIRST_STATION, LAST_STATION, PROGRAMS_DIR, STATION_ALLOWED
from .model import (
    CODE_RE,
    OFFSET_FIELDS,
    OFFSET_RE,
    OFFSET_TABLE_COUNT,
    PARAMETER_NAMES,
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
    canonical_code,
    canonical_offset,
    no_such_table,
    offset_tables,
)
from .protocol import commands as cmd
from .protocol import profile
from .protocol.frame import MAX_STATION, payload_room
from .robotfile import build_robot

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
    "Analysis",
    "analyse",
    "program_key",
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
MIGRATIONS: dict[int, Callable[[str, dict[str, Any]], dict[str, Any]]] = {}

#: The most steps a program area has (controller.yaml's schema: ``steps`` 0-9999).
MAX_STEPS = 9999
_STEP_NUMBER = re.compile(r"0|[1-9][0-9]{0,3}")


def migrate_1_to_2(kind: str, data: dict[str, Any]) -> dict[str, Any]:
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
    listed: list[Any] = [None] * (max((int(k) for k in steps), default=-1) + 1)
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
    items: list[tuple[str, Any]] = [("name", y.text(robot.name))]
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
    def area(a: ProgramArea) -> Any:
        return y.mapping(
            [("count", y.num(str(a.count))), ("steps", y.num(str(a.steps)))], flow=True
        )

    programs = y.mapping([(t.value.lower(), area(config.area(t))) for t in ProgramType])
    items: list[tuple[str, Any]] = [
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
    def table(t: OffsetTable) -> Any:
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
    has them.  Values are written as they are: :func:`analyse` says whether the
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
    for key in sorted(data.programs, key=_program_order):
        out[program_path(key)] = render_program(key, data.programs[key])
    return out


def _program_order(key: ProgramKey) -> tuple[int, int]:
    return (list(ProgramType).index(key[0]), key[1])


# -- reading and checking ---------------------------------------------------------------


def analyse(files: Mapping[str, bytes]) -> Analysis:
    """Read and check a project's files (path relative to the project -> content).

    Every file is checked even when others are broken, and a schema error skips the
    deeper checks of its own item only (a step, a table, the parameters): the checks
    against the configuration (program numbers, steps, timers, tables) and of what
    the wire carries run on every other item, with whatever part of controller.yaml
    and robot.yaml is sound.  ``robot`` is set when robot.yaml is valid, ``data``
    only when there is no issue at all.
    """
    issues: list[Issue] = []
    docs: dict[str, y.Parsed] = {}  # every file that could be parsed
    flaws: dict[str, Flaws] = {}  # ... and where each has a problem

    def read(name: str, kind: str) -> y.Parsed | None:
        before = len(issues)
        doc, _ = FILES.read(name, kind, files[name], issues)
        if doc is not None:
            docs[name] = doc
            flaws[name] = Flaws.of(issues[before:], name)
        return doc

    for name, kind in ROOT_FILES.items():
        if name == "registers.yaml":
            continue
        if name not in files:
            issues.append(Issue(name, None, None, "missing", fatal=True))
            continue
        read(name, kind)

    result = Analysis(issues=issues)
    robot_doc = docs.get("robot.yaml")
    if robot_doc is not None and flaws["robot.yaml"] == Flaws():
        result.robot = build_robot(robot_doc.data)
    # registers.yaml is checked unless robot.yaml soundly says it is not kept
    keep = not (
        robot_doc is not None
        and flaws["robot.yaml"].sound("keep_registers")
        and _get(robot_doc, "keep_registers") in (False, None)
    )
    if keep and "registers.yaml" in files:
        read("registers.yaml", "registers")

    programs: dict[ProgramKey, y.Parsed | None] = {}
    for name in sorted(files):
        if not name.startswith(PROGRAMS_DIR + "/"):
            continue
        key = program_key(name)
        if key is None:
            issues.append(
                Issue(
                    name,
                    1,
                    None,
                    "not a program file name "
                    "(allowed: start.yaml, main-NN.yaml, sub-NN.yaml, hand-NN.yaml)",
                )
            )
            continue
        programs[key] = doc = read(name, "program")
        if doc is not None:
            _check_program_header(name, key, doc, issues)

    if "controller.yaml" in docs:
        limits = _Limits.of(docs["controller.yaml"], flaws["controller.yaml"])
        tables = _offset_tables(robot_doc, flaws.get("robot.yaml"))
        _check_against_config(limits, docs, programs, issues, _table_limit(tables, limits))
    _check_wire(docs, flaws, programs, issues)

    if not issues:
        config = _build_config(docs["controller.yaml"].data)
        result.data = _build_data(config, docs, programs)
    result.issues = unique(issues, list(ROOT_FILES))
    return result


@dataclass(frozen=True)
class _Limits:
    """What controller.yaml says that the other files are checked against, each part
    None when controller.yaml has a problem there (its checks are then skipped)."""

    counts: Mapping[ProgramType, int | None]
    steps: Mapping[ProgramType, int | None]
    timers: int | None
    registers: int | None
    #: the offset tables' count a pull recorded (0: none recorded, None: unsound)
    tables: int | None = 0

    @classmethod
    def of(cls, doc: y.Parsed, flaws: Flaws) -> _Limits:
        data = doc.data

        def area(ptype: ProgramType, part: str) -> int | None:
            return flaws.number("programs", ptype.value.lower(), part, data=data)

        return cls(
            counts={t: area(t, "count") for t in ProgramType},
            steps={t: area(t, "steps") for t in ProgramType},
            timers=flaws.number("timers", data=data),
            registers=flaws.number("registers", data=data),
            tables=(
                flaws.number("offset_tables", "count", data=data)
                if isinstance(data, dict) and "offset_tables" in data
                else 0
            ),
        )


def _offset_tables(doc: y.Parsed | None, flaws: Flaws | None) -> int | None:
    """How many offset tables robot.yaml gives (:func:`offset_tables`), or None when
    it cannot say: robot.yaml is unreadable, or has a problem at ``offset_tables``."""
    if doc is None or flaws is None or not flaws.sound("offset_tables"):
        return None
    if _get(doc, "offset_tables") is None:
        return OFFSET_TABLE_COUNT
    return flaws.number("offset_tables", data=doc.data)


def _table_limit(asked: int | None, limits: _Limits) -> tuple[int, str] | None:
    """How many offset tables offsets.yaml holds, and what says so: robot.yaml's
    count (:func:`_offset_tables`), or fewer when controller.yaml records that the
    controller has fewer; None when either cannot say."""
    if asked is None or limits.tables is None:
        return None
    if limits.tables and limits.tables < asked:
        return limits.tables, "controller.yaml offset_tables.count"
    return asked, "robot.yaml offset_tables"


def _get(doc: y.Parsed, key: str) -> Any:
    return doc.data.get(key) if isinstance(doc.data, dict) else None


def _steps(doc: y.Parsed) -> list[tuple[int, Any]]:
    """A program's used steps as (step number, what is written); [] when ``steps`` is
    not a list (the schema reports it)."""
    steps = _get(doc, "steps")
    if not isinstance(steps, list):
        return []
    return [(n, step) for n, step in enumerate(steps) if step is not None]


def _check_program_header(name: str, key: ProgramKey, doc: y.Parsed, issues: list[Issue]) -> None:
    ptype, number = key
    found_type, found_number = _get(doc, "type"), _get(doc, "number")
    if isinstance(found_type, str) and found_type != ptype.value:
        issues.append(
            Issue(
                name,
                doc.line(("type",)),
                "type",
                f"{show(found_type)} does not match the file name (allowed: {ptype.value})",
            )
        )
    if isinstance(found_number, y.Number) and found_number != number:
        issues.append(
            Issue(
                name,
                doc.line(("number",)),
                "number",
                f"{show(found_number)} does not match the file name (allowed: {number})",
            )
        )


def _span(count: int) -> str:
    return "none" if count <= 0 else ("0" if count == 1 else f"0-{count - 1}")


def _check_numbered(
    name: str,
    doc: y.Parsed,
    key: str,
    count: int,
    what: str,
    issues: list[Issue],
    source: str = "",
) -> None:
    """Every number 0..count-1 present under ``key``, and no other; ``source`` names
    the setting that gives ``count``, for the message."""
    source = f", {source}" if source else ""
    if not isinstance(_get(doc, key), dict):
        return
    found = numbers(_get(doc, key))
    for text, n in sorted(found, key=lambda item: (item[1], item[0])):
        if n >= count:
            issues.append(
                Issue(
                    name,
                    doc.line((key, text)),
                    f"{key}.{text}",
                    f"{what} {show(y.Number(text))} is outside the configuration "
                    f"(allowed: {_span(count)}{source})",
                )
            )
    missing = set(range(count)) - {n for _, n in found}
    if missing:
        issues.append(
            Issue(
                name,
                doc.line((key,)),
                key,
                f"{what} {spans(missing)} missing (allowed: every {what} {_span(count)}{source})",
            )
        )


def _check_against_config(
    limits: _Limits,
    docs: Mapping[str, y.Parsed],
    programs: Mapping[ProgramKey, y.Parsed | None],
    issues: list[Issue],
    tables: tuple[int, str] | None = (OFFSET_TABLE_COUNT, "robot.yaml offset_tables"),
) -> None:
    """What the schemas cannot say: numbers that depend on controller.yaml (and the
    offset tables' count on robot.yaml, or the fewer controller.yaml records,
    :func:`_table_limit`); a check whose limit is unsound is skipped."""
    if tables is not None and (offsets := docs.get("offsets.yaml")) is not None:
        _check_numbered("offsets.yaml", offsets, "tables", tables[0], "table", issues, tables[1])
    for file, numbered_key, limit, what in (
        ("timers.yaml", "timers", limits.timers, "timer"),
        ("registers.yaml", "registers", limits.registers, "register"),
    ):
        if (numbered_doc := docs.get(file)) is not None and limit is not None:
            _check_numbered(file, numbered_doc, numbered_key, limit, what, issues)

    for key, doc in programs.items():
        ptype, number = key
        count, steps = limits.counts[ptype], limits.steps[ptype]
        if doc is None:
            continue
        name = program_path(key)
        if count is not None and number >= count:
            issues.append(
                Issue(
                    name,
                    doc.line(("number",)),
                    "number",
                    f"{ptype.value} program {number} is outside the configuration "
                    f"(allowed: {_span(count)}, controller.yaml "
                    f"programs.{ptype.value.lower()}.count)",
                )
            )
            continue
        for step, _ in _steps(doc):
            if steps is not None and step >= steps:
                issues.append(
                    Issue(
                        name,
                        doc.line(("steps", step)),
                        f"steps.{step}",
                        f"step {step} is outside the configuration "
                        f"(allowed: {_span(steps)}, controller.yaml "
                        f"programs.{ptype.value.lower()}.steps)",
                    )
                )
    controller = docs["controller.yaml"]
    for kind, configured in limits.counts.items():
        for wanted in [(kind, n) for n in range(configured or 0)]:
            if wanted not in programs:
                field_path = ("programs", kind.value.lower(), "count")
                issues.append(
                    Issue(
                        "controller.yaml",
                        controller.line(field_path),
                        ".".join(field_path),
                        f"{configured} {kind.value} programs configured, but "
                        f"{program_path(wanted)} is missing (an empty program is written "
                        "`steps: []`)",
                    )
                )


def _check_wire(
    docs: Mapping[str, y.Parsed],
    flaws: Mapping[str, Flaws],
    programs: Mapping[ProgramKey, y.Parsed | None],
    issues: list[Issue],
) -> None:
    """What the schemas cannot say about a value: that the controller would give it
    back in another form (a push would never converge), or that the wire cannot
    carry it or give it back (:func:`.protocol.commands.read_back`).  Each item the
    schema passed is checked (a table, the parameters, a step), whatever is wrong
    with the others.

    Timers and registers have one form each (``d.dd``, ``dddd``) and a fixed
    length, so only offsets, parameters and steps can break these.
    """
    if "offsets.yaml" in docs:
        _check_offsets(docs["offsets.yaml"], flaws["offsets.yaml"], issues)
    if "parameters.yaml" in docs:
        _check_parameters(docs["parameters.yaml"], flaws["parameters.yaml"], issues)
    for key, doc in programs.items():
        if doc is not None:
            _check_steps(key, doc, flaws[program_path(key)], issues)


def _check_offsets(doc: y.Parsed, flaws: Flaws, issues: list[Issue]) -> None:
    tables = _get(doc, "tables")
    for key, _ in numbers(tables):
        if not flaws.sound("tables", key):
            continue
        for field in OFFSET_FIELDS:
            text = text_of(tables[key][field])
            one = canonical_code(text) if field in ("m", "f") else canonical_offset(text)
            if one != text:
                issues.append(
                    Issue(
                        "offsets.yaml",
                        doc.line(("tables", key, field)),
                        f"tables.{key}.{field}",
                        not_canonical(text, one),
                    )
                )


def _check_parameters(doc: y.Parsed, flaws: Flaws, issues: list[Issue]) -> None:
    """The 13 parameters are one write (SNE): checked when the schema passed each."""
    if not all(flaws.sound(name) for name, _ in PARAMETER_NAMES):
        return
    data = doc.data
    values = {name: text_of(data[name]) for name, _ in PARAMETER_NAMES}
    write = cmd.write_parameters(Parameters(**values))
    back = cmd.read_back(write)
    if back.misread is not None:
        first = PARAMETER_NAMES[0][0]  # the LNE reply is the values in order: it leads
        issues.append(
            Issue(
                "parameters.yaml",
                doc.line((first,)),
                first,
                f"{show(data[first])} {back.misread}: the robot could not be read again "
                f"(allowed: one token not beginning with {profile.ERROR_PREFIX!r})",
            )
        )
    if back.excess:
        longest = max(values, key=lambda name: len(values[name]))
        total = len(" ".join(values.values()))
        issues.append(
            Issue(
                "parameters.yaml",
                doc.line((longest,)),
                longest,
                f"the {len(values)} parameters are {total} characters with their spaces, more "
                f"than a frame carries (allowed: at most {total - back.excess} together, "
                f"{_both_fit(write, back)})",
            )
        )


#: What an SN step write holds besides the step, at most (two-digit program, a step
#: number as long as :func:`numbers` gives one).
_STEP_WRITE_PREFIX = len(f"SNM 99 {HUGE} ")


def _check_steps(key: ProgramKey, doc: y.Parsed, flaws: Flaws, issues: list[Issue]) -> None:
    ptype, number = key
    # A step this short fits a frame in its write, and in the reply that reads it back
    # (the step number, then the step: shorter than the write); that reply begins with
    # the step number, never with the error prefix.  Only longer steps are worked out.
    surely_fits = payload_room(MAX_STATION) - _STEP_WRITE_PREFIX
    for n, step in _steps(doc):
        if not flaws.sound("steps", n) or len(step) <= surely_fits:
            continue
        write = cmd.write_step(ptype, number, n, Step.parse(step))
        back = cmd.read_back(write)
        if not back.excess and back.misread is None:
            continue
        where = (program_path(key), doc.line(("steps", n)), f"steps.{n}")
        if back.excess:
            issues.append(
                Issue(
                    *where,
                    f"{len(step)} characters are more than a frame carries (allowed: at most "
                    f"{len(step) - back.excess} in this step, {_both_fit(write, back, 'its ')})",
                )
            )
        if back.misread is not None:  # the reply begins with the step number: never so far
            issues.append(
                Issue(
                    *where,
                    f"{show(step)} {back.misread} (allowed: a step the "
                    f"{back.read.letters} reply gives back as written)",
                )
            )


def _both_fit(write: cmd.Request[cmd.Ack], back: cmd.ReadBack, its: str = "") -> str:
    return (
        f"so that {its or 'the '}{write.letters} request and the {back.read.letters} reply "
        f"fit the frame limit of {profile.MAX_FRAME} bytes"
    )


# -- building the model from valid documents ---------------------------------------------


def _build_config(data: dict[str, Any]) -> Config:
    def area(name: str) -> ProgramArea:
        entry = data["programs"][name]
        return ProgramArea(int(entry["count"]), int(entry["steps"]))

    return Config(
        start=area("start"),
        main=area("main"),
        sub=area("sub"),
        hand=area("hand"),
        timers=int(data["timers"]),
        memory_bits=int(data["memory_bits"]),
        registers=int(data["registers"]),
    )


def _build_data(
    config: Config,
    docs: Mapping[str, y.Parsed],
    programs: Mapping[ProgramKey, y.Parsed | None],
) -> RobotData:
    """The data of a project whose every file is valid."""

    def doc(name: str) -> dict[str, Any]:
        data: dict[str, Any] = docs[name].data
        return data

    params = doc("parameters.yaml")
    tables = doc("offsets.yaml")["tables"]
    registers = None
    if "registers.yaml" in docs:
        registers = {int(n): text_of(v) for n, v in doc("registers.yaml")["registers"].items()}
    steps: dict[ProgramKey, dict[int, Step]] = {}
    # A Step is immutable: each text is parsed once, however often a robot repeats it
    made: dict[str, Step] = {}
    for key in sorted(programs, key=_program_order):
        parsed = programs[key]
        assert parsed is not None
        program = steps[key] = {}
        for n, text in _steps(parsed):
            step = made.get(text)
            if step is None:
                step = made[text] = Step.parse(text)
            program[n] = step
    return RobotData(
        version=doc("controller.yaml")["version"],
        config=config,
        parameters=Parameters(**{k: text_of(params[k]) for k, _ in PARAMETER_NAMES}),
        programs=steps,
        offsets={
            int(n): OffsetTable(**{f: text_of(t[f]) for f in OFFSET_FIELDS})
            for n, t in tables.items()
        },
        timers={int(n): text_of(v) for n, v in doc("timers.yaml")["timers"].items()},
        registers=registers,
        offset_end=_offset_end(doc("controller.yaml")),
    )


def _offset_end(controller: Mapping[str, Any]) -> OffsetEnd | None:
    """The end of the offset tables controller.yaml records, or None when it records none."""
    end = controller.get("offset_tables")
    if end is None:
        return None
    count = int(end["count"])
    return OffsetEnd(count, text_of(end["no_such_table"]), asked=count)
