"""An IAI controller as the engine's :class:`~harlsync.families.base.Driver`: read
everything, read a position or a run, write a run (291H), status (215H + 212H)."""

from __future__ import annotations

from typing import Any

from ..base import Progress
from .catalogue import Key, PositionKey, PositionRun
from .controller import Controller, IaiStatus
from .layout import IaiData
from .protocol import position_fields, write_positions

__all__ = ["IaiDriver"]


class IaiDriver:
    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.label = controller.label

    def read_all(self, *, registers: bool, progress: Progress | None = None) -> IaiData:
        return self.controller.read_all(progress)

    def status(self) -> IaiStatus:
        return self.controller.status()

    def read(self, key: Key) -> Any:
        if isinstance(key, PositionKey):
            return self.controller.read_run(key.number, 1)[0]
        return self.controller.read_run(key.start, key.size)

    def write(self, key: Key, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        if not isinstance(key, PositionRun):
            raise TypeError(f"no write for item {key}: positions are written in runs")
        if old is None:
            old = self.controller.read_run(key.start, key.size)
        self.controller.write_run(key.start, value, old)

    def command(self, key: Key, value: Any) -> str:
        """The 291H a write sends, its fields spaced and its records split by ``|``
        so a person can read it: ``291H 00 0004 0002 | 07 001D 001D 03E8 ... 00 | ...``."""
        if not isinstance(key, PositionRun):
            raise TypeError(f"no write for item {key}: positions are written in runs")
        request = write_positions(key.start, value)  # refuses what the wire cannot carry
        head = f"{request.message_id:03X}H 00 {key.start:04X} {len(value):04X}"
        return " | ".join(
            [head, *(" ".join(position_fields(p, numbered=False)) for p in value)]
        )

    def unsafe(self, key: Key) -> bool:
        return True  # every IAI write needs an idle robot

    def close(self) -> None:
        self.controller.close()
