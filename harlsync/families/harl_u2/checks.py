"""What the schemas cannot say about a HARL-U2 project, checked file by file.

:func:`check_files` runs, after every file is read, the checks against the
configuration (program numbers and steps within controller.yaml's areas, timers
and registers within its counts, the offset tables within robot.yaml's count or
the fewer controller.yaml records) and the checks of what the wire carries (a
value the controller would give back otherwise, or a write or its read-back
that no frame holds).  A check whose limit, or whose item, has a problem of its
own (:class:`~harlsync.project.files.Flaws`) is skipped: one run lists every
other problem.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ...alignment import spans
from ...project import yamlio as y
from ...project.files import HUGE, Flaws, not_canonical, numbers, text_of
from ...project.schema import Issue, show
from .layout import program_path
from .model import (
    OFFSET_FIELDS,
    OFFSET_TABLE_COUNT,
    PARAMETER_NAMES,
    Parameters,
    ProgramKey,
    ProgramType,
    Step,
    canonical_code,
    canonical_offset,
)
from .protocol import commands as cmd
from .protocol import profile
from .protocol.frame import MAX_STATION, payload_room
from .protocol.readback import ReadBack, read_back

__all__ = [
    "Limits",
    "check_against_config",
    "check_files",
    "check_program_header",
    "top_value",
    "used_steps",
]


def check_files(
    docs: Mapping[str, y.Parsed],
    flaws: Mapping[str, Flaws],
    programs: Mapping[ProgramKey, y.Parsed | None],
    issues: list[Issue],
) -> None:
    """Every check of the files read (``docs``, each with its ``flaws``; ``programs``
    by key, None for one unreadable), against the sound parts of controller.yaml and
    robot.yaml, and of what the wire carries; each problem is added to ``issues``."""
    if "controller.yaml" in docs:
        limits = Limits.of(docs["controller.yaml"], flaws["controller.yaml"])
        tables = _offset_tables(docs.get("robot.yaml"), flaws.get("robot.yaml"))
        check_against_config(limits, docs, programs, issues, _table_limit(tables, limits))
    _check_wire(docs, flaws, programs, issues)


@dataclass(frozen=True)
class Limits:
    """What controller.yaml says that the other files are checked against, each part
    None when controller.yaml has a problem there (its checks are then skipped)."""

    counts: Mapping[ProgramType, int | None]
    steps: Mapping[ProgramType, int | None]
    timers: int | None
    registers: int | None
    #: the offset tables' count a pull recorded (0: none recorded, None: unsound)
    tables: int | None = 0

    @classmethod
    def of(cls, doc: y.Parsed, flaws: Flaws) -> Limits:
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
    if top_value(doc, "offset_tables") is None:
        return OFFSET_TABLE_COUNT
    return flaws.number("offset_tables", data=doc.data)


def _table_limit(asked: int | None, limits: Limits) -> tuple[int, str] | None:
    """How many offset tables offsets.yaml holds, and what says so: robot.yaml's
    count (:func:`_offset_tables`), or fewer when controller.yaml records that the
    controller has fewer; None when either cannot say."""
    if asked is None or limits.tables is None:
        return None
    if limits.tables and limits.tables < asked:
        return limits.tables, "controller.yaml offset_tables.count"
    return asked, "robot.yaml offset_tables"


def top_value(doc: y.Parsed, key: str) -> object:
    return doc.data.get(key) if isinstance(doc.data, dict) else None


def used_steps(doc: y.Parsed) -> list[tuple[int, Any]]:
    """A program's used steps as (step number, what is written); [] when ``steps`` is
    not a list (the schema reports it)."""
    steps = top_value(doc, "steps")
    if not isinstance(steps, list):
        return []
    return [(n, step) for n, step in enumerate(steps) if step is not None]


def check_program_header(name: str, key: ProgramKey, doc: y.Parsed, issues: list[Issue]) -> None:
    ptype, number = key
    found_type, found_number = top_value(doc, "type"), top_value(doc, "number")
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
    if not isinstance(top_value(doc, key), dict):
        return
    found = numbers(top_value(doc, key))
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


def check_against_config(
    limits: Limits,
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
        if doc is not None:
            _check_program(key, doc, limits, issues)
    _check_programs_present(limits, docs["controller.yaml"], programs, issues)


def _check_program(key: ProgramKey, doc: y.Parsed, limits: Limits, issues: list[Issue]) -> None:
    """The program's number within its type's count, then each step within its steps."""
    ptype, number = key
    count, steps = limits.counts[ptype], limits.steps[ptype]
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
        return
    for step, _ in used_steps(doc):
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


def _check_programs_present(
    limits: Limits,
    controller: y.Parsed,
    programs: Mapping[ProgramKey, y.Parsed | None],
    issues: list[Issue],
) -> None:
    """A file for every program controller.yaml configures."""
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
    carry it or give it back (:func:`.protocol.readback.read_back`).  Each item the
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
    tables = top_value(doc, "tables")
    if not isinstance(tables, dict):
        return  # the schema reports it
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
    back = read_back(write)
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
    for n, step in used_steps(doc):
        if not flaws.sound("steps", n) or len(step) <= surely_fits:
            continue
        write = cmd.write_step(ptype, number, n, Step.parse(step))
        back = read_back(write)
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


def _both_fit(write: cmd.Request[cmd.Ack], back: ReadBack, its: str = "") -> str:
    return (
        f"so that {its or 'the '}{write.letters} request and the {back.read.letters} reply "
        f"fit the frame limit of {profile.MAX_FRAME} bytes"
    )
