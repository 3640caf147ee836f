"""Diff and plan: the live robot against the project, item by item, and the
writes a push would make of it (no write is sent)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic

from ..errors import ProjectError
from ..families.base import D, Driver, K, Progress
from ..project import Project, load_project
from .items import Change, Differences, diff
from .live import Station, read_live, station_number
from .plan import Plan, make_plan, policy_refusals

__all__ = ["Comparison", "compare", "plan"]


@dataclass
class Comparison(Generic[K, D]):
    """The live robot against the project.  ``driver`` is closed; it still names
    the robot and builds its commands."""

    project: Project
    driver: Driver[K, D]
    live: D
    changes: list[Change[K]]
    #: Earlier pushes to this robot that never finished (see :mod:`.audit`).
    warnings: list[str] = field(default_factory=list)
    #: With ``idle_check``, when the robot is not idle: why a push would be refused now.
    busy: str | None = None
    #: What was read, in the family's words (Catalogue.contents).
    contents: str = ""
    #: Whether runtime data was compared.
    registers: bool = False

    @property
    def target(self) -> str:
        return self.driver.label

    def differences(self) -> Differences:
        """What ``diff`` prints of it: ``-`` the robot, ``+`` the project."""
        about = {"robot": self.project.robot.name, "target": self.target}
        return Differences(
            self.changes,
            f"robot {self.target}",
            f"project {self.project.path}",
            {**about, "project": str(self.project.path)},
        )

    def refusals(self) -> list[str]:
        """Every reason a push would be refused now, not only the first it would meet:
        the project's policy (:func:`policy_refusals`) and, with ``idle_check``, a
        robot that is not idle (a push reads its state before anything else)."""
        reasons = policy_refusals(self.project.path, self.project.robot)
        if self.busy is not None:
            robot = self.project.robot.name
            reasons.append(f"robot {robot} ({self.target}) is not idle: {self.busy}")
        return reasons

    def plan(self) -> Plan[K]:
        """The plan a push would carry out, from this comparison, each write that
        reverts a change made on the robot named (:attr:`Plan.reverts`)."""
        from .states import mark_reverts

        return mark_reverts(
            self.project.path,
            self.live,
            make_plan(
                self.project.family.catalogue,
                self.live,
                self.project.data,
                self.driver,
                robot=self.project.robot.name,
                registers=self.registers,
            ),
        )


def compare(
    path: str | Path,
    *,
    port: str | None = None,
    station: Station = None,
    progress: Progress | None = None,
    registers: bool = False,
    lock_timeout: float = 10.0,
    idle_check: bool = False,
    connect_options: Mapping[str, bool] | None = None,
    command: str = "diff",
) -> Comparison[Any, Any]:
    """Read the live robot and compare it with the project, item by item; with
    ``idle_check`` also say whether a push would be refused now (robot not idle).
    ``command`` is the harlsync command it serves (``diff``, ``plan``), for advice."""
    project = load_project(path)
    station = station_number(project.family, station)
    things = project.family.catalogue

    def not_another_robot(now: Mapping[str, str], where: str) -> None:
        why = things.other_identity(now, project.data)
        if why is not None:  # at its first exchanges, not after a whole read
            raise ProjectError(f"{project.path}: not compared: {why}")

    read = read_live(
        project.family,
        project.robot,
        port,
        station,
        registers=registers,
        progress=progress,
        lock_timeout=lock_timeout,
        idle_check=idle_check,
        options=connect_options,
        identified=not_another_robot,
        command=command,
    )
    why = things.other_robot(read.live, project.data)
    if why is not None:
        raise ProjectError(f"{project.path}: not compared: {why}")
    changes = diff(things, read.live, project.data, registers=registers)
    return Comparison(
        project,
        read.driver,
        read.live,
        changes,
        read.warnings,
        read.busy,
        things.contents(read.live, registers=registers),
        registers,
    )


def plan(
    path: str | Path,
    *,
    port: str | None = None,
    station: Station = None,
    progress: Progress | None = None,
    registers: bool = False,
    lock_timeout: float = 10.0,
    connect_options: Mapping[str, bool] | None = None,
) -> Plan[Any]:
    """The plan a push would carry out now; sends no write."""
    return compare(
        path,
        port=port,
        station=station,
        progress=progress,
        registers=registers,
        lock_timeout=lock_timeout,
        connect_options=connect_options,
        command="plan",
    ).plan()
