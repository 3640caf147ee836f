"""Reading a HARL-U2 project back: :func:`analyse` turns file contents into a
robot and its data, reporting every issue it meets.

Each file is read with its schema (:data:`.layout.FILES`: format, migrations),
every check the schemas cannot make is :mod:`.checks`', and the data is built
only from a project with no issue.  It works in memory:
:mod:`harlsync.project.store` does the disk I/O.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ...project import yamlio as y
from ...project.files import Flaws, text_of, unique
from ...project.schema import Issue
from ..base import Analysis
from .checks import check_files, check_program_header, top_value, used_steps
from .declared import PROGRAMS_DIR
from .layout import FILES, ROOT_FILES, program_key, program_order
from .model import (
    OFFSET_FIELDS,
    PARAMETER_NAMES,
    Config,
    OffsetEnd,
    OffsetTable,
    Parameters,
    ProgramArea,
    ProgramKey,
    RobotData,
    Step,
)
from .robotfile import build_robot

__all__ = ["analyse", "build_config"]


def analyse(files: Mapping[str, bytes]) -> Analysis:
    """Read and check a project's files (path relative to the project -> content).

    Every file is checked even when others are broken, and a schema error skips the
    deeper checks of its own item only (a step, a table, the parameters): the checks
    against the configuration (program numbers, steps, timers, tables) and of what
    the wire carries run on every other item, with whatever part of controller.yaml
    and robot.yaml is sound.  ``robot`` is set when robot.yaml is valid, ``data``
    only when there is no issue at all.
    """
    read = _Read(files)
    issues = read.issues
    for name, kind in ROOT_FILES.items():
        if name == "registers.yaml":
            continue
        if name not in files:
            issues.append(Issue(name, None, None, "missing", fatal=True))
            continue
        read(name, kind)

    result = Analysis(issues=issues)
    robot_doc = read.docs.get("robot.yaml")
    if robot_doc is not None and read.flaws["robot.yaml"] == Flaws():
        result.robot = build_robot(robot_doc.data)
    # registers.yaml is checked unless robot.yaml soundly says it is not kept
    keep = not (
        robot_doc is not None
        and read.flaws["robot.yaml"].sound("keep_registers")
        and top_value(robot_doc, "keep_registers") in (False, None)
    )
    if keep and "registers.yaml" in files:
        read("registers.yaml", "registers")
    programs = _read_programs(read)
    check_files(read.docs, read.flaws, programs, issues)

    if not issues:
        config = build_config(read.docs["controller.yaml"].data)
        result.data = _build_data(config, read.docs, programs)
    result.issues = unique(issues, list(ROOT_FILES))
    return result


@dataclass
class _Read:
    """The files of a project being read: every one that could be parsed, where
    each has a problem, and every issue so far."""

    files: Mapping[str, bytes]
    issues: list[Issue] = field(default_factory=list)
    docs: dict[str, y.Parsed] = field(default_factory=dict)
    flaws: dict[str, Flaws] = field(default_factory=dict)

    def __call__(self, name: str, kind: str) -> y.Parsed | None:
        """File ``name`` read as a ``kind``, its issues added; None when unparsable."""
        before = len(self.issues)
        doc, _ = FILES.read(name, kind, self.files[name], self.issues)
        if doc is not None:
            self.docs[name] = doc
            self.flaws[name] = Flaws.of(self.issues[before:], name)
        return doc


def _read_programs(read: _Read) -> dict[ProgramKey, y.Parsed | None]:
    """Every file in ``programs/``, by the program its name says (None: unparsable),
    each header checked against its name; a file of another name is an issue."""
    programs: dict[ProgramKey, y.Parsed | None] = {}
    for name in sorted(read.files):
        if not name.startswith(PROGRAMS_DIR + "/"):
            continue
        key = program_key(name)
        if key is None:
            read.issues.append(
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
            check_program_header(name, key, doc, read.issues)
    return programs


def build_config(data: dict[str, Any]) -> Config:
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
    for key in sorted(programs, key=program_order):
        parsed = programs[key]
        assert parsed is not None
        program = steps[key] = {}
        for n, text in used_steps(parsed):
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
