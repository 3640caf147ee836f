"""The HARL-U2's items: what one write changes, their keys, names and safe order.

::

    BlockKey("config")  BlockKey("parameters")          LNX / LNE, one write each
    NumberKey("offset", 7)  NumberKey("timer", 3)       one table, timer, register
    NumberKey("register", 1)
    StepKey("step", "MAIN", 2, 3)                       one program step

Push order: configuration, parameters, tables, timers, registers, then programs
(START, MAIN, SUB, HAND, by number and step).  A configuration (SNX) change
destroys every program, so a plan that holds one rewrites every non-empty step
of the project after it.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

from ...alignment import align, spans
from ..base import Catalogue, Change3, PlanShape
from .model import (
    OFFSET_FIELDS,
    Config,
    OffsetEnd,
    OffsetTable,
    Parameters,
    ProgramType,
    RobotData,
    Step,
)

__all__ = [
    "CATALOGUE",
    "BlockKey",
    "HarlU2Catalogue",
    "Key",
    "NumberKey",
    "StepKey",
    "identity_of",
]


class BlockKey(NamedTuple):
    """The program configuration or the expanded parameters: one item each."""

    kind: str  # "config" | "parameters"


class NumberKey(NamedTuple):
    """A numbered item: an offset table, a timer, a register."""

    kind: str  # "offset" | "timer" | "register"
    number: int


class StepKey(NamedTuple):
    """One program step: ``StepKey("step", "MAIN", 2, 3)``; START is program 0."""

    kind: str  # "step"
    program_type: str
    program: int
    step: int


Key = BlockKey | NumberKey | StepKey

_KIND_ORDER = {"config": 0, "parameters": 1, "offset": 2, "timer": 3, "register": 4, "step": 5}
_TYPE_ORDER = {t.value: i for i, t in enumerate(ProgramType)}
_CONFIG_FIELDS = tuple(
    f"{t.value.lower()}.{part}" for t in ProgramType for part in ("count", "steps")
) + ("timers", "memory_bits", "registers")
_PLURAL = {"step": "steps", "offset": "tables", "timer": "timers", "register": "registers"}


class HarlU2Catalogue(Catalogue[Key, RobotData]):
    live_tuning = frozenset({"timer", "offset"})
    """Items ``--allow-live-tuning`` writes while a task runs (the manual allows it).
    Registers are process state the running program counts with: never."""
    group_counts = frozenset({"programs"})
    """:meth:`counts`' programs are the programs whose steps changed: its steps count them."""

    def items(self, data: RobotData, *, registers: bool = True) -> dict[Key, Any]:
        out: dict[Key, Any] = {
            BlockKey("config"): data.config,
            BlockKey("parameters"): data.parameters,
        }
        for n, table in data.offsets.items():
            out[NumberKey("offset", n)] = table
        for n, value in data.timers.items():
            out[NumberKey("timer", n)] = value
        if registers and data.registers is not None:
            for n, value in data.registers.items():
                out[NumberKey("register", n)] = value
        for (ptype, number), steps in data.programs.items():
            name = ptype.value  # once a program, not once a step: 12,544 in a full-size one
            for n, step in steps.items():
                if step.command is not None:  # not step.empty
                    out[StepKey("step", name, number, n)] = step
        return out

    def with_items(self, data: RobotData, values: Mapping[Key, Any]) -> RobotData:
        new = copy.deepcopy(data)
        for key, value in values.items():
            table: dict[int, Any] | None
            if isinstance(key, StepKey):
                table = new.programs.setdefault((ProgramType(key.program_type), key.program), {})
                number = key.step
            elif isinstance(key, NumberKey):
                if key.kind == "register" and new.registers is None:
                    new.registers = {}
                tables: dict[str, dict[int, Any] | None] = {
                    "offset": new.offsets,
                    "timer": new.timers,
                    "register": new.registers,
                }
                table = tables[key.kind]
                number = key.number
            else:
                setattr(new, key.kind, value)
                continue
            assert table is not None
            if value is None:
                table.pop(number, None)
            else:
                table[number] = value
        return new

    def order(self, key: Key) -> tuple[Any, ...]:
        if isinstance(key, StepKey):
            return (_KIND_ORDER["step"], _TYPE_ORDER[key.program_type], key.program, key.step)
        if isinstance(key, NumberKey):
            return (_KIND_ORDER[key.kind], key.number)
        return (_KIND_ORDER[key.kind],)

    def describe(self, key: Key) -> str:
        if isinstance(key, StepKey):
            if key.program_type == "START":
                return f"START program step {key.step}"
            return f"{key.program_type} program {key.program} step {key.step}"
        if isinstance(key, NumberKey):
            return (
                f"offset table {key.number}" if key.kind == "offset" else f"{key.kind} {key.number}"
            )
        return {"config": "program configuration", "parameters": "expanded parameters"}[key.kind]

    def group(self, key: Key) -> str:
        if isinstance(key, StepKey):
            if key.program_type == "START":
                return "START program"
            return f"{key.program_type} program {key.program}"
        return {"timer": "timers", "register": "registers"}.get(key.kind, self.describe(key))

    def position(self, key: Key) -> tuple[str, int] | None:
        """A program is a sequence of steps: diff and plan align it, so that a step
        inserted reads as one step inserted."""
        return (self.group(key), key.step) if isinstance(key, StepKey) else None

    def label(self, key: Key, field: str) -> str:
        if isinstance(key, StepKey):
            return str(key.step)
        if isinstance(key, NumberKey) and key.kind in ("timer", "register"):
            return str(key.number)
        return field

    def fields(self, key: Key, old: Any, new: Any) -> list[tuple[str, str | None, str | None]]:
        if isinstance(key, StepKey):
            return [("", _text(old), _text(new))]
        if isinstance(new, OffsetTable) or isinstance(old, OffsetTable):
            pairs = [(f, _attr(old, f), _attr(new, f)) for f in OFFSET_FIELDS]
        elif isinstance(new, Parameters) or isinstance(old, Parameters):
            names = (new or old).as_dict().keys()
            pairs = [(f, _attr(old, f), _attr(new, f)) for f in names]
        elif isinstance(new, Config) or isinstance(old, Config):
            pairs = [(f, _config_field(old, f), _config_field(new, f)) for f in _CONFIG_FIELDS]
        else:
            pairs = [("", _text(old), _text(new))]
        return [(f, a, b) for f, a, b in pairs if a != b]

    def identity(self, key: Key) -> dict[str, Any]:
        ident: dict[str, Any] = key._asdict()
        return ident

    def counts(self, changes: Iterable[tuple[Any, Any, Any]]) -> dict[str, int]:
        """Programs, steps, tables, timers, registers, parameters, config."""
        changes = list(changes)
        programs = {
            (key.program_type, key.program) for key, _, _ in changes if isinstance(key, StepKey)
        }
        count = {
            "programs": len(programs),
            "steps": 0,
            "tables": 0,
            "timers": 0,
            "registers": 0,
            "parameters": 0,
            "config": 0,
        }
        for key, old, new in changes:
            kind = key.kind
            if kind in _PLURAL:
                count[_PLURAL[kind]] += 1
            else:
                count[kind] += len(self.fields(key, old, new))
        return count

    def summary(self, changes: Iterable[tuple[Any, Any, Any]]) -> str:
        count = self.counts(changes)
        parts = []
        if count["config"]:
            parts.append("program configuration")
        if count["parameters"]:
            parts.append(f"{count['parameters']} parameter{'s' * (count['parameters'] > 1)}")
        if count["programs"]:
            parts.append(
                f"{count['programs']} program{'s' * (count['programs'] > 1)} "
                f"({count['steps']} step{'s' * (count['steps'] > 1)})"
            )
        for name, singular in (("tables", "table"), ("timers", "timer"), ("registers", "register")):
            if count[name]:
                parts.append(f"{count[name]} {singular if count[name] == 1 else name}")
        return ", ".join(parts) or "no change"

    def version(self, data: RobotData) -> str:
        return data.version

    def robot_identity(self, data: RobotData) -> dict[str, str]:
        """The version (LNV) and the program configuration (LNX)."""
        return identity_of(data.version, data.config)

    def other_identity(self, now: Mapping[str, str], project: RobotData) -> str | None:
        """Why the controller that reports ``now`` (:meth:`robot_identity`, from LNX
        and LNV) is not the project's robot, for diff, plan, push and rollback:
        another version, which no command writes.  Another program configuration
        is not: a push writes it (SNX, with ``--allow-reconfigure``), as a restore
        to a controller that lost its memory must."""
        version = now.get("version")
        if version == project.version:
            return None
        said = "none" if version is None else f"'{version}'"
        return (
            f"the controller answers version {said} (LNV), the project is of version "
            f"'{project.version}': another robot's controller, or one replaced or updated. "
            "Check the port and station (a replacement must run the project's version, "
            "docs/restore.md); if this is the robot, updated, take it into the project "
            "with 'harlsync pull DIR --new-robot' first"
        )

    def other_robot(self, live: RobotData, project: RobotData) -> str | None:
        """Another version (:meth:`other_identity`), or a reply past the last offset
        table other than the one the project recorded (controller.yaml
        ``offset_tables``): the controller answers a missing table otherwise now, or
        cannot answer normally, and the tables read may be short.  A read held to
        robot.yaml's ``no_such_table`` is not held to the recorded reply."""
        other = super().other_robot(live, project)
        was, now = project.offset_end, live.offset_end
        if other is not None or was is None or now is None or now.pinned:
            return other
        if now.reply == was.reply:
            return None
        return (
            f"offset table {now.count} answered {now.reply} twice, not {was.reply} (as "
            "the project recorded, controller.yaml offset_tables): the controller now "
            "answers a missing table otherwise, or cannot answer normally (an abnormal "
            "condition), so the tables read may be short; run again when the robot "
            f"answers normally, or, if {now.reply} is what this controller answers for a "
            f"table it does not have, set no_such_table: {now.reply} in robot.yaml"
        )

    def contents(self, data: RobotData, *, registers: bool) -> str:
        """What a live read holds: programs, timers and registers to the sizes LNX
        reports, and the offset tables with the range the read covered and the
        reply that ended it (``Controller.read_offsets``)."""
        steps = sum(not step.empty for steps in data.programs.values() for step in steps.values())
        parts = [
            f"{_many(len(data.programs), 'program')} ({_many(steps, 'step')} used)",
            _tables(len(data.offsets), data.offset_end),
            _many(len(data.timers), "timer"),
        ]
        if registers and data.registers is not None:
            parts.append(_many(len(data.registers), "register"))
        return ", ".join(parts)

    def plan(
        self,
        live: RobotData,
        project: RobotData,
        changes: list[tuple[Any, Any, Any]],
        *,
        registers: bool,
    ) -> PlanShape[Key]:
        # Only a step can be written as "nothing" (cleared); any other item the
        # project lacks cannot be written at all.
        missing = [c for c in changes if c[2] is None and c[0].kind != "step"]
        explained = _explained(live.config, project)
        unwritable = _unwritable(live.config, project, registers) + [
            f"{self.describe(key)}: the project has none"
            for key, _, _ in missing
            if key.kind not in explained
        ]
        reconfigure = not live.config.same_programs(project.config)
        # Without a reconfiguration the config item differs only in what SNX cannot
        # write (unwritable above); with one, every step is rewritten below.
        skip_kind = "step" if reconfigure else "config"
        wanted = [c for c in changes if c not in missing and c[0].kind != skip_kind]
        if reconfigure:
            # SNX wipes every program: rewrite every non-empty step of the project,
            # each written over an empty step.
            wanted += [
                (key, None, value)
                for key, value in self.items(project).items()
                if isinstance(key, StepKey)
            ]
            return _reconfiguring(wanted, unwritable)
        # An insertion or deletion rewrites every step it moves along (each step whose
        # content changed is one SN write, as ever): say so in the program's terms.
        notes = [
            f"{shift.group}: {shift.what}: rewrites {_steps(shift.rewrites)}"
            for shift in align(self, [c for c in wanted if isinstance(c[0], StepKey)])
        ]
        return PlanShape(notes=notes, wanted=wanted, unwritable=unwritable)


def _unwritable(live: Config, project: RobotData, registers: bool) -> list[str]:
    """What differs that no write changes: the configuration's read-only counts
    (SNX writes only the program areas), and registers the project does not keep."""
    unwritable = [
        f"{name}: the robot has {getattr(live, name)}, the project "
        f"{getattr(project.config, name)}; the configuration write (SNX) cannot change it"
        for name in ("timers", "memory_bits", "registers")
        if getattr(live, name) != getattr(project.config, name)
    ]
    if registers and project.registers is None:
        unwritable.append(
            "registers: the project does not keep them; set keep_registers in robot.yaml "
            "and pull, or push without registers"
        )
    return unwritable


def _explained(live: Config, project: RobotData) -> set[str]:
    """The item kinds whose missing items :func:`_unwritable` already explains."""
    return {
        kind
        for kind, count in (("timer", "timers"), ("register", "registers"))
        if getattr(live, count) != getattr(project.config, count)
    } | ({"register"} if project.registers is None else set())


def _reconfiguring(wanted: list[Change3[Key]], unwritable: list[str]) -> PlanShape[Key]:
    """The plan of a push that changes the program configuration (SNX)."""
    return PlanShape(
        notes=[],
        wanted=wanted,
        unwritable=unwritable,
        reconfigure=(
            "the project changes the program configuration (SNX), which destroys every "
            "program on the robot; give --allow-reconfigure to do it and rewrite them all"
        ),
        reconfigure_note=(
            "SNX changes the program configuration: every program is rewritten after it"
        ),
    )


CATALOGUE = HarlU2Catalogue()


def identity_of(version: str, cfg: Config) -> dict[str, str]:
    """The robot's identity (:meth:`HarlU2Catalogue.robot_identity`) from its
    version (LNV) and program configuration (LNX)."""
    areas = ", ".join(f"{t.value} {cfg.area(t).count}x{cfg.area(t).steps}" for t in ProgramType)
    return {
        "version": version,
        "program configuration": (
            f"{areas} (programs x steps), {_many(cfg.timers, 'timer')}, "
            f"{_many(cfg.memory_bits, 'memory bit')}, {_many(cfg.registers, 'register')}"
        ),
    }


def _steps(numbers: list[int]) -> str:
    """``steps 4-17``, ``step 16``."""
    return f"step{'s' * (len(numbers) != 1)} {spans(numbers)}"


def _tables(count: int, end: OffsetEnd | None) -> str:
    """``100 offset tables (0-99, no table 100: E21 twice)``: the range read and the
    reply that ended it; a controller with fewer than robot.yaml's ``offset_tables``
    is said to be so."""
    said = f"{_many(count, 'offset table')} (0-{count - 1}, no table {count}"
    if end is None:
        return said + ")"
    said += f": {end.reply} twice"
    if end.count < end.asked:
        said += f"; fewer than robot.yaml's offset_tables: {end.asked}"
    return said + ")"


def _many(count: int, one: str) -> str:
    return f"{count} {one}{'s' * (count != 1)}"


def _config_field(cfg: Config | None, name: str) -> str | None:
    if cfg is None:
        return None
    if "." in name:
        ptype, part = name.split(".")
        return str(getattr(cfg.area(ProgramType(ptype.upper())), part))
    return str(getattr(cfg, name))


def _attr(obj: Any, name: str) -> str | None:
    return None if obj is None else str(getattr(obj, name))


def _text(value: Any) -> str | None:
    if value is None:
        return None
    return value.text if isinstance(value, Step) else str(value)
