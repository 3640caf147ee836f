"""The HARL-U2 as the engine's :class:`~harlsync.families.base.Driver`: read
everything, read or write one item (keys from :mod:`.catalogue`), status (LNR)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..base import Driver, Progress
from ..base import Status as AnyStatus
from ..survey import Extent, Findings, Guess, Survey, surveyed
from .catalogue import Key, NumberKey, StepKey, identity_of
from .controller import Controller
from .model import (
    OFFSET_TABLE_COUNT,
    TASK_STATUS_NAMES,
    Config,
    ProgramType,
    RobotData,
    Status,
    Step,
)
from .protocol import Request, profile
from .protocol import commands as cmd

__all__ = ["HarlU2Driver"]

#: LNR's task status "suspended" (profile: the statuses are bit flags).
_SUSPENDED = 2
#: How far a probe reads offset tables at most: past the manual's 0-99, so that a
#: controller with more is counted rather than refused.
PROBE_TABLES = 1000


class HarlU2Driver(Driver[Key, RobotData]):
    """The HARL-U2 over a :class:`~harlsync.controller.Controller`."""

    def __init__(
        self,
        controller: Controller,
        *,
        offset_tables: int = OFFSET_TABLE_COUNT,
        no_such_table: str | None = None,
    ) -> None:
        self.controller = controller
        #: robot.yaml's ``offset_tables``: how many tables a read of everything reads
        #: at most
        self.offset_tables = offset_tables
        #: robot.yaml's ``no_such_table``: the only reply taken for a missing table
        #: (what a project recorded is compared after the read: ``other_robot``)
        self.no_such_table = no_such_table
        self.label = f"port {controller.port} station {controller.station}"
        self._known: tuple[Config, str] | None = None

    def identity(self) -> dict[str, str]:
        """LNX and LNV, the first two requests of a read: kept for :meth:`read_all`."""
        config = self.controller.config()
        self._known = config, self.controller.version()
        return identity_of(self._known[1], config)

    def survey(self) -> Survey:
        """LNX and LNV (the identity), the offset tables to where the controller says
        they end (:meth:`Controller.read_offsets`, taking whatever reply it gives
        twice), and LNR twice (the interlock): reads only."""

        def explore() -> Findings:
            config = self._known[0] if self._known is not None else self.controller.config()
            _, end = self.controller.read_offsets(
                max(PROBE_TABLES, self.offset_tables), pinned=self.no_such_table
            )
            guessed_reply = profile.ERROR_PREFIX + profile.NO_SUCH_TABLE
            options: dict[str, object] = {"no_such_table": end.reply}
            if end.count > OFFSET_TABLE_COUNT:
                options["offset_tables"] = end.count
            return Findings(
                extents=[
                    Extent(
                        "offset tables",
                        end.count,
                        end.reply,
                        ("offset_tables", "no_such_table"),
                        counted="tables, 0 to count - 1",
                    )
                ],
                guesses=[
                    Guess(
                        "how many offset tables the controller has (at most)",
                        str(OFFSET_TABLE_COUNT),
                        str(end.count),
                        "offset_tables",
                    ),
                    Guess(
                        "the reply to an offset table the controller does not have",
                        guessed_reply,
                        end.reply,
                        "no_such_table",
                    ),
                ],
                options=options,
                # what a pull reads (Controller.read_all): LNX, LNV, LNE, every step, the
                # tables and the three exchanges of their end, the timers
                pull_exchanges=6 + config.step_count + end.count + config.timers,
            )

        return surveyed(self.controller.link.stats, self.identity, explore, self.status)

    def read_all(
        self, *, registers: bool, progress: Progress | None = None, whole: bool = False
    ) -> RobotData:
        known, self._known = self._known, None
        return self.controller.read_all(
            include_registers=registers,
            progress=progress,
            offset_tables=self.offset_tables,
            no_such_table=self.no_such_table,
            known=known,
        )

    def status(self) -> Status:
        """The interlock's reading: LNR twice in a row, both idle (``Controller.idle_status``)."""
        return self.controller.idle_status()

    def advice(self, status: AnyStatus) -> str:
        """By the tasks LNR reports: one in execution, one suspended, a status the
        profile does not know, or not every task reported."""
        if not isinstance(status, Status):
            return super().advice(status)
        if len(status.tasks) != status.expected_tasks:
            return (
                "Check that the station is this robot's (LNR reports every task of the "
                "controller at that station) and the line, then run again"
            )
        states = {t.status for t in status.active_tasks}
        if any(s not in TASK_STATUS_NAMES for s in states):
            return (
                "A task status the profile does not know is taken as running: stop every "
                "task on the controller and run again"
            )
        if states and all(s & _SUSPENDED for s in states):
            return (
                "A suspended task goes on where it stopped: stop it on the controller (a "
                "push never resumes or stops a task), then run again"
            )
        return super().advice(status)

    def _request(self, key: Key, value: Any) -> Request[Any]:
        if isinstance(key, StepKey):
            return cmd.write_step(
                ProgramType(key.program_type), key.program, key.step, value or Step()
            )
        if isinstance(key, NumberKey):
            return _NUMBERED_WRITES[key.kind](key.number, value)
        return cmd.write_parameters(value) if key.kind == "parameters" else cmd.write_config(value)

    def command(self, key: Key, value: Any) -> str:
        return self._request(key, value).payload

    def unsafe(self, key: Key) -> bool:
        return Request(_letters(key)).unsafe

    def read(self, key: Key) -> Any:
        c = self.controller
        if isinstance(key, StepKey):
            value = c.read_step(ProgramType(key.program_type), key.program, key.step)
            return None if value.empty else value
        if isinstance(key, NumberKey):
            read = {"timer": c.read_timer, "register": c.read_register, "offset": c.read_offset}
            return read[key.kind](key.number)
        return c.read_parameters() if key.kind == "parameters" else c.config()

    def write(self, key: Key, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        # Knowing the old value lets the controller decide, after a lost reply,
        # whether the write took, without an extra read before every write.
        c, idle = self.controller, needs_idle
        if isinstance(key, StepKey):
            c.write_step(
                ProgramType(key.program_type),
                key.program,
                key.step,
                value or Step(),
                old=old or Step(),
                needs_idle=idle,
            )
        elif isinstance(key, NumberKey):
            writes: dict[str, Callable[..., None]] = {
                "timer": c.write_timer,
                "register": c.write_register,
                "offset": c.write_offset,
            }
            writes[key.kind](key.number, value, old=old, needs_idle=idle)
        elif key.kind == "parameters":
            c.write_parameters(value, old=old, needs_idle=idle)
        else:
            c.write_config(value, old=old, needs_idle=idle)

    def close(self) -> None:
        self.controller.close()


_LETTERS = {
    "timer": "SNT",
    "register": "SND",
    "offset": "SNL",
    "parameters": "SNE",
    "config": "SNX",
}
_NUMBERED_WRITES: dict[str, Callable[[int, Any], Request[Any]]] = {
    "timer": cmd.write_timer,
    "register": cmd.write_register,
    "offset": cmd.write_offset,
}


def _letters(key: Key) -> str:
    if isinstance(key, StepKey):
        return "SN" + ProgramType(key.program_type).letter
    return _LETTERS[key.kind]
