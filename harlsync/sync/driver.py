"""The driver interface between the sync engine and a controller family.

The engine (pull, diff, plan, push, rollback) knows robots as items keyed by
identity (see :mod:`harlsync.sync.items`) and talks to the controller only
through a :class:`Driver`: read everything, read or write one item, status.
Another controller family is added by writing one more driver; pull, diff and
push do not change.  :class:`HarlU2Driver` is the first.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from ..families.harl_u2.controller import Controller
from ..families.harl_u2.model import ProgramType, RobotData, Status, Step
from ..families.harl_u2.protocol import Request
from ..families.harl_u2.protocol import commands as cmd
from .items import Key

__all__ = ["Driver", "HarlU2Driver", "Progress"]

#: ``progress(done, total)`` while reading everything.
Progress = Callable[[int, int], None]


class Driver(Protocol):
    """What the engine needs from a controller."""

    #: Where the robot is, for messages: ``"port /dev/ttyUSB0 station 1"``.
    label: str

    def read_all(self, *, registers: bool, progress: Progress | None = None) -> RobotData:
        """Everything the controller holds (registers only when asked)."""

    def status(self) -> Status:
        """The task states; ``Status.idle`` says whether writing is allowed."""

    def read(self, key: Key) -> Any:
        """The item's current value (``None`` for an empty step)."""

    def write(self, key: Key, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        """Write one item (``None`` clears a step); ``old`` is what it holds now, if known.

        With ``needs_idle`` the write is never sent again (after a lost reply)
        unless the robot is then found idle; raises InterlockError instead.
        """

    def command(self, key: Key, value: Any) -> str:
        """The exact wire command that :meth:`write` sends, for plans and audits."""

    def unsafe(self, key: Key) -> bool:
        """Whether writing this item is forbidden during automatic operation."""

    def close(self) -> None: ...


class HarlU2Driver:
    """The HARL-U2 over a :class:`~harlsync.controller.Controller`."""

    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.label = f"port {controller.port} station {controller.station}"

    def read_all(self, *, registers: bool, progress: Progress | None = None) -> RobotData:
        return self.controller.read_all(include_registers=registers, progress=progress)

    def status(self) -> Status:
        return self.controller.status()

    def _request(self, key: Key, value: Any) -> Request:
        kind = key[0]
        if kind == "step":
            _, ptype, number, step = key
            return cmd.write_step(ProgramType(ptype), number, step, value or Step())
        if kind == "timer":
            return cmd.write_timer(key[1], value)
        if kind == "register":
            return cmd.write_register(key[1], value)
        if kind == "offset":
            return cmd.write_offset(key[1], value)
        if kind == "parameters":
            return cmd.write_parameters(value)
        if kind == "config":
            return cmd.write_config(value)
        raise ValueError(f"no write for item {key}")

    def command(self, key: Key, value: Any) -> str:
        return self._request(key, value).payload

    def unsafe(self, key: Key) -> bool:
        return Request(_letters(key)).unsafe

    def read(self, key: Key) -> Any:
        c, kind = self.controller, key[0]
        if kind == "step":
            _, ptype, number, step = key
            value = c.read_step(ProgramType(ptype), number, step)
            return None if value.empty else value
        if kind == "timer":
            return c.read_timer(key[1])
        if kind == "register":
            return c.read_register(key[1])
        if kind == "offset":
            return c.read_offset(key[1])
        if kind == "parameters":
            return c.read_parameters()
        if kind == "config":
            return c.config()
        raise ValueError(f"no read for item {key}")

    def write(self, key: Key, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        # Knowing the old value lets the controller decide, after a lost reply,
        # whether the write took, without an extra read before every write.
        c, kind, idle = self.controller, key[0], needs_idle
        if kind == "step":
            _, ptype, number, step = key
            c.write_step(ProgramType(ptype), number, step, value or Step(), old=old or Step(),
                         needs_idle=idle)
        elif kind == "timer":
            c.write_timer(key[1], value, old=old, needs_idle=idle)
        elif kind == "register":
            c.write_register(key[1], value, old=old, needs_idle=idle)
        elif kind == "offset":
            c.write_offset(key[1], value, old=old, needs_idle=idle)
        elif kind == "parameters":
            c.write_parameters(value, old=old, needs_idle=idle)
        elif kind == "config":
            c.write_config(value, old=old, needs_idle=idle)
        else:
            raise ValueError(f"no write for item {key}")

    def close(self) -> None:
        self.controller.close()


_LETTERS = {"timer": "SNT", "register": "SND", "offset": "SNL", "parameters": "SNE", "config": "SNX"}


def _letters(key: Key) -> str:
    if key[0] == "step":
        return "SN" + ProgramType(key[1]).letter
    return _LETTERS[key[0]]
