"""A push plan: the exact writes that would make the robot equal the project.

A plan is computed from the live robot and the project, in the safe order
(configuration, parameters, tables, timers, registers, programs).  It carries a
fingerprint of the live state and of the project it was computed from, so a
saved plan can be refused when either changed since (a stale plan).

A configuration (SNX) change destroys every program, so a plan that holds one
rewrites every non-empty step of the project after it.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ProjectFormatError
from ..families.harl_u2.model import RobotData
from .driver import Driver
from .items import Change, Key, describe, diff, items, push_order

__all__ = ["PLAN_FORMAT", "Plan", "PlannedWrite", "fingerprint", "make_plan"]

PLAN_FORMAT = 1


@dataclass(frozen=True)
class PlannedWrite:
    """One write: the item, what the robot holds, what it will hold, the wire command."""

    key: Key
    old: Any
    new: Any
    command: str
    unsafe: bool

    @property
    def name(self) -> str:
        return describe(self.key)


@dataclass
class Plan:
    """What a push would do to one robot."""

    robot: str
    target: str
    live_fingerprint: str
    project_fingerprint: str
    changes: list[Change]
    writes: list[PlannedWrite]
    reconfigure: bool = False
    #: Differences no write can fix (timer, memory bit, register counts).
    unwritable: list[str] = field(default_factory=list)

    @property
    def empty(self) -> bool:
        return not self.writes

    @property
    def commands(self) -> list[str]:
        return [w.command for w in self.writes]

    def to_json(self) -> dict[str, Any]:
        return {
            "format": PLAN_FORMAT,
            "robot": self.robot,
            "target": self.target,
            "live_fingerprint": self.live_fingerprint,
            "project_fingerprint": self.project_fingerprint,
            "reconfigure": self.reconfigure,
            "unwritable": self.unwritable,
            "commands": self.commands,
        }

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n", encoding="utf-8")

    @staticmethod
    def load_saved(path: str | Path) -> dict[str, Any]:
        """A saved plan's data.  Raises ProjectFormatError when unreadable."""
        try:
            data = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ProjectFormatError(f"{path}: cannot read plan: {exc}") from exc
        if not isinstance(data, dict) or data.get("format") != PLAN_FORMAT:
            raise ProjectFormatError(f"{path}: not a harlsync plan of format {PLAN_FORMAT}")
        return data


def _canonical(value: Any) -> Any:
    if hasattr(value, "__dataclass_fields__"):
        return {k: _canonical(getattr(value, k)) for k in value.__dataclass_fields__}
    if isinstance(value, tuple | list):
        return [_canonical(v) for v in value]
    return value


def fingerprint(data: RobotData, *, registers: bool = False) -> str:
    """A hash of every item (and the version), stable across runs and machines."""
    flat = sorted(
        (json.dumps(list(k)), _canonical(v)) for k, v in items(data, registers=registers).items()
    )
    text = json.dumps([data.version, flat], sort_keys=True, separators=(",", ":"))
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def make_plan(
    live: RobotData,
    project: RobotData,
    driver: Driver,
    *,
    robot: str,
    registers: bool = False,
) -> Plan:
    """The writes that turn ``live`` into ``project``, in the safe order."""
    changes = diff(live, project, registers=registers)
    unwritable = [
        f"{name}: the robot has {getattr(live.config, name)}, the project "
        f"{getattr(project.config, name)}; the configuration write (SNX) cannot change it"
        for name in ("timers", "memory_bits", "registers")
        if getattr(live.config, name) != getattr(project.config, name)
    ]
    if registers and project.registers is None:
        unwritable.append(
            "registers: the project does not keep them; set keep_registers in robot.yaml "
            "and pull, or push without registers"
        )
    explained = {
        kind for kind, count in (("timer", "timers"), ("register", "registers"))
        if getattr(live.config, count) != getattr(project.config, count)
    } | ({"register"} if project.registers is None else set())
    # Only a step can be written as "nothing" (cleared); any other item the
    # project lacks cannot be written at all.
    missing = [c for c in changes if c.new is None and c.key[0] != "step"]
    unwritable += [
        f"{c.name}: the project has none" for c in missing if c.key[0] not in explained
    ]
    reconfigure = not live.config.same_programs(project.config)
    # Without a reconfiguration the config item differs only in what SNX cannot
    # write (unwritable above); with one, every step is rewritten below.
    skip_kind = "step" if reconfigure else "config"
    wanted: list[tuple[Key, Any, Any]] = [
        (c.key, c.old, c.new) for c in changes if c not in missing and c.key[0] != skip_kind
    ]
    if reconfigure:
        # SNX wipes every program: rewrite every non-empty step of the project,
        # each written over an empty step.
        wanted += [(key, None, value) for key, value in items(project).items() if key[0] == "step"]
    wanted.sort(key=lambda w: push_order(w[0]))
    writes = [
        PlannedWrite(key, old, new, driver.command(key, new), driver.unsafe(key))
        for key, old, new in wanted
    ]
    return Plan(
        robot=robot,
        target=driver.label,
        live_fingerprint=fingerprint(live, registers=registers),
        project_fingerprint=fingerprint(project, registers=registers),
        changes=changes,
        writes=writes,
        reconfigure=reconfigure,
        unwritable=unwritable,
    )
