"""robot.yaml as Python: which robot, of which family, how to reach it, when a push
may write to it.  The family reads and writes the file (its connection keys differ);
this is what the engine needs of it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..settings import SerialSettings

if TYPE_CHECKING:
    from datetime import datetime, time

__all__ = ["DAYS", "Robot", "Window", "build_serial", "build_windows", "new_robot"]

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


# -- from robot.yaml's data, as the family's layout read and checked it ----------------


def build_serial(connection: Mapping[str, Any], defaults: SerialSettings) -> SerialSettings:
    """robot.yaml's serial settings, each missing one the family's default."""
    return SerialSettings(
        baudrate=int(connection.get("baudrate", defaults.baudrate)),
        bytesize=int(connection.get("bytesize", defaults.bytesize)),
        parity=str(connection.get("parity", defaults.parity)),
        stopbits=int(connection.get("stopbits", defaults.stopbits)),
        rtscts=bool(connection.get("rtscts", defaults.rtscts)),
        timeout=float(connection.get("timeout", defaults.timeout)),
        retries=int(connection.get("retries", defaults.retries)),
    )


def _time(value: str) -> time:
    from datetime import time  # not at import: most robots have no window

    hours, minutes = value.split(":")
    return time(int(hours), int(minutes))


def build_windows(data: Mapping[str, Any]) -> list[Window]:
    """robot.yaml's maintenance windows (the schema has checked them)."""
    return [
        Window(tuple(w["days"]), _time(w["start"]), _time(w["end"]))
        for w in data.get("maintenance_windows", [])
    ]
