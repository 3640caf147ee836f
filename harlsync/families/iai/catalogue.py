"""An IAI robot's items: its positions, their keys, names and how a plan writes them.

::

    PositionKey("position", 12)          one position of the table (diff, read, verify)
    PositionRun("positions", 12, 4)      positions 12-15 written by one 291H (plans only)

A diff compares positions one by one.  A plan writes each run of consecutive
changed positions with one 291H, as long as the controller's receive buffer
takes it, and never a position that did not change.  A position the robot has
and the project lacks cannot be written: no message of protocol B clears a
position, so such a plan is refused with what to do.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, NamedTuple

from ..base import PlanShape
from . import profile
from .layout import IaiData
from .model import ARM_NAMES, Position

__all__ = ["CATALOGUE", "IaiCatalogue", "Key", "PositionKey", "PositionRun", "max_run"]

#: Bytes of a 291H frame around its records: ! station id, 00 start count, SC CR LF.
_WRITE_OVERHEAD = 1 + 2 + 3 + 2 + 4 + 4 + 2 + 2


class PositionKey(NamedTuple):
    """One position of the table."""

    kind: str  # "position"
    number: int


class PositionRun(NamedTuple):
    """Consecutive positions ``start`` .. ``start + count - 1``, written by one 291H."""

    kind: str  # "positions"
    start: int
    size: int

    @property
    def numbers(self) -> range:
        return range(self.start, self.start + self.size)


Key = PositionKey | PositionRun


def max_run(model: str) -> int:
    """The most positions one 291H may carry to a controller of ``model``."""
    receive = profile.BUFFERS[model].receive
    return (receive - _WRITE_OVERHEAD) // profile.WRITE_RECORD_MAX


def position_text(position: Position | None) -> str | None:
    """A position on one line, as a diff shows it."""
    if position is None:
        return None
    text = (
        f"axes [{', '.join(map(str, position.axes))}] "
        f"coords [{', '.join(position.coords)}] "
        f"acc {position.acc} dec {position.dec} speed {position.speed}"
    )
    for name, arm in (("arm1", position.arm1), ("arm2", position.arm2)):
        if arm:
            text += f" {name} {ARM_NAMES.get(arm, arm)}"
    return text


class IaiCatalogue:
    #: No IAI write is allowed while a program runs.
    live_tuning: frozenset[str] = frozenset()

    def items(self, data: IaiData, *, registers: bool = False) -> dict[Key, Any]:
        return {PositionKey("position", n): p for n, p in data.positions.items()}

    def order(self, key: Key) -> tuple[Any, ...]:
        return (key.number,) if isinstance(key, PositionKey) else (key.start,)

    def describe(self, key: Key) -> str:
        if isinstance(key, PositionKey):
            return f"position {key.number}"
        if key.size == 1:
            return f"position {key.start}"
        return f"positions {key.start}-{key.start + key.size - 1}"

    def group(self, key: Key) -> str:
        return "positions"

    def label(self, key: Key, field: str) -> str:
        return str(key.number if isinstance(key, PositionKey) else key.start)

    def fields(self, key: Key, old: Any, new: Any) -> list[tuple[str, str | None, str | None]]:
        a, b = position_text(old), position_text(new)
        return [] if a == b else [("", a, b)]

    def identity(self, key: Key) -> dict[str, Any]:
        ident: dict[str, Any] = key._asdict()
        return ident

    def counts(self, changes: Iterable[tuple[Any, Any, Any]]) -> dict[str, int]:
        return {"positions": sum(1 for _ in changes)}

    def summary(self, changes: Iterable[tuple[Any, Any, Any]]) -> str:
        n = self.counts(changes)["positions"]
        return f"{n} position{'s' * (n != 1)}" if n else "no change"

    def version(self, data: IaiData) -> str:
        v = data.version
        return f"model {v.model_code} unit {v.unit_code} version {v.version} built {v.built}"

    def plan(self, live: IaiData, project: IaiData, changes: list[tuple[Any, Any, Any]], *,
             registers: bool) -> PlanShape:
        unwritable = [
            f"{self.describe(key)}: defined on the robot but not in the project, and no IAI "
            "protocol B message clears a position; clear it with the controller's own tools "
            "(or add it to the project) and run again"
            for key, _, new in changes if new is None
        ]
        changed = sorted(key.number for key, _, new in changes if new is not None)
        limit = max_run(project.model)
        runs: list[list[int]] = []
        for n in changed:
            if runs and runs[-1][-1] == n - 1 and len(runs[-1]) < limit:
                runs[-1].append(n)
            else:
                runs.append([n])
        wanted = [
            (
                PositionRun("positions", run[0], len(run)),
                tuple(live.positions.get(n) for n in run),
                tuple(project.positions[n] for n in run),
            )
            for run in runs
        ]
        return PlanShape(wanted=wanted, unwritable=unwritable)


CATALOGUE = IaiCatalogue()
