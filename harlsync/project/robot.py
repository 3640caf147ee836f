"""robot.yaml as Python: which robot, of which family, how to reach it, when a push
may write to it.  The family reads and writes the file (its connection keys differ);
this is what the engine needs of it."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, time
from typing import Any

from ..settings import SerialSettings

__all__ = ["DAYS", "Robot", "Window", "new_robot"]

#: Day names as robot.yaml writes them, Monday first (``datetime.weekday()`` order).
DAYS = ("mon", "tue", "wed", "thu", "fri", "sat", "sun")


@dataclass(frozen=True)
class Window:
    """A maintenance window: from ``start`` to ``end`` on each of ``days``.

    A window whose ``end`` is not after its ``start`` crosses midnight: it opens
    on a listed day and closes on the next one (``end == start`` is 24 hours).
    ``start`` is inside the window, ``end`` is not.
    """

    days: tuple[str, ...]
    start: time
    end: time

    def __str__(self) -> str:
        """As robot.yaml says it: ``mon,tue 22:00-06:00``."""
        return f"{','.join(self.days)} {self.start:%H:%M}-{self.end:%H:%M}"

    def contains(self, when: datetime) -> bool:
        """Whether ``when`` (wall-clock time, as the robot's site keeps it) is inside."""
        now = when.time().replace(tzinfo=None)
        today = DAYS[when.weekday()]
        yesterday = DAYS[(when.weekday() - 1) % 7]
        if self.start < self.end:
            return today in self.days and self.start <= now < self.end
        return (today in self.days and now >= self.start) or (
            yesterday in self.days and now < self.end
        )


@dataclass
class Robot:
    """One robot: its name, family, port URL, station and serial settings, and push policy.

    ``windows`` empty means a push may write at any time; ``keep_registers`` keeps
    the registers (the family's runtime data) in the project.
    ``options`` holds the family's own settings (a robot's model and axes).
    """

    name: str
    port: str
    station: int = 1
    serial: SerialSettings = field(default_factory=SerialSettings)
    windows: list[Window] = field(default_factory=list)
    keep_registers: bool = False
    description: str | None = None
    #: the family's name, as robot.yaml says it (empty: the registry's default family)
    family: str = ""
    options: dict[str, Any] = field(default_factory=dict)

    def in_window(self, when: datetime) -> bool:
        """Whether a push may write at ``when``: no windows, or inside one of them."""
        return not self.windows or any(w.contains(when) for w in self.windows)


def new_robot(name: str, port: str, station: int = 1, **options: Any) -> Robot:
    """A robot with the profile's serial settings, for a pull into a new directory.

    ``options`` are :class:`Robot` fields (``description``, ``keep_registers``,
    ``windows``, ``serial``).
    """
    return Robot(name=name, port=port, station=station, **options)
