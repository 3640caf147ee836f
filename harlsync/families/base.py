"""What a controller family gives the engine, and nothing more.

The engine (pull, diff, plan, push, rollback, backup) and the project store
know a robot as *items*: the smallest things one write changes, each keyed by a
typed, hashable key with a ``kind`` (``StepKey("step", "MAIN", 2, 3)``,
``PositionKey("position", 12)``).  What the items are, how they are read and
written, in which order a push writes them, which need an idle robot and how
they sit in files is the family's; the engine never branches on which family
it is::

    engine                       family (harlsync/families/<name>/)
    ------                       -----------------------------------
    load / save a project   -->  Family.analyse / render_files / project_files
    connect                 -->  Family.connect -> Driver (read_all, read, write, status)
    diff / plan             -->  Catalogue (items, order, names, fields, plan_writes)
    interlock               -->  Driver.status() -> Status (idle? which signal says no)

A family's *data* (what a backup holds: the HARL-U2's ``RobotData``, IAI's
position table) is opaque to the engine: it hands it back to the family.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from ..project.robot import Robot
    from ..project.schema import Issue

__all__ = [
    "Analysis",
    "Catalogue",
    "Driver",
    "Family",
    "ItemKey",
    "PlanShape",
    "Progress",
    "Status",
]

#: ``progress(done, total)`` while reading everything (exchanges with the controller).
Progress = Callable[[int, int], None]


class ItemKey(Hashable, Protocol):
    """An item's identity.  Families use NamedTuples whose first field is ``kind``,
    so a key is typed, hashable, ordered and JSON-able as a list."""

    @property
    def kind(self) -> str: ...


class Status(Protocol):
    """The interlock's answer: may a write go now, and if not, which signal says no."""

    @property
    def idle(self) -> bool: ...

    def describe(self) -> str:
        """``"idle"``, or what forbids a write (``task 0 in execution``, ``MANUAL mode``)."""
        ...


class Driver(Protocol):
    """One open robot, as the engine uses it."""

    #: Where the robot is, for messages: ``"port /dev/ttyUSB0 station 1"``.
    label: str

    def read_all(self, *, registers: bool, progress: Progress | None = None) -> Any:
        """Everything the controller holds, as the family's data (runtime data only
        when ``registers``)."""
        ...

    def status(self) -> Status:
        """The interlock state; ``Status.idle`` says whether writing is allowed."""
        ...

    def read(self, key: Any) -> Any:
        """The item's current value (``None`` for an empty one)."""
        ...

    def write(self, key: Any, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        """Write one item; ``old`` is what it holds now, if known.

        With ``needs_idle`` the write is never sent again (after a lost reply)
        unless the robot is then found idle; raises InterlockError instead.
        """
        ...

    def command(self, key: Any, value: Any) -> str:
        """The exact wire command that :meth:`write` sends, for plans and audits."""
        ...

    def unsafe(self, key: Any) -> bool:
        """Whether writing this item is forbidden while the robot runs."""
        ...

    def close(self) -> None: ...


@dataclass
class PlanShape:
    """What the family decides about a plan: the writes wanted (key, old, new),
    unsorted, and why the rest cannot be written."""

    wanted: list[tuple[Any, Any, Any]]
    #: differences no write can fix, each as a sentence
    unwritable: list[str] = field(default_factory=list)
    #: set when the plan holds a destructive reconfiguration: the refusal a push
    #: without --allow-reconfigure gives
    reconfigure: str | None = None
    #: ... and the line a printed plan starts with
    reconfigure_note: str | None = None
    #: what a printed plan, a push's result and its audit record must tell about
    #: these writes (Epson: the persistent items it writes to the memory card)
    notes: list[str] = field(default_factory=list)


class Catalogue(Protocol):
    """The family's items: what they are, their names, their order, their fields."""

    #: Item kinds that ``--allow-live-tuning`` may write while the robot runs.
    live_tuning: frozenset[str]

    def items(self, data: Any, *, registers: bool) -> dict[Any, Any]:
        """Every item of ``data`` by key (empty items left out)."""
        ...

    def order(self, key: Any) -> tuple[Any, ...]:
        """Sort key: the safe order of a push."""
        ...

    def describe(self, key: Any) -> str:
        """A person's name for an item: ``MAIN program 2 step 3``, ``position 12``."""
        ...

    def group(self, key: Any) -> str:
        """The ``@@ group @@`` an item is shown under in a text diff."""
        ...

    def label(self, key: Any, field: str) -> str:
        """The line label of one field of an item in a text diff."""
        ...

    def fields(self, key: Any, old: Any, new: Any) -> list[tuple[str, str | None, str | None]]:
        """The change field by field, ``(field, old text, new text)``, only what differs."""
        ...

    def identity(self, key: Any) -> dict[str, Any]:
        """The key as JSON fields (``kind`` and the rest by name)."""
        ...

    def counts(self, changes: Iterable[tuple[Any, Any, Any]]) -> dict[str, int]:
        """How much changed, by the family's own units (programs, steps, positions...)."""
        ...

    def summary(self, changes: Iterable[tuple[Any, Any, Any]]) -> str:
        """``"2 programs (5 steps), 1 table"``, or ``"no change"``."""
        ...

    def version(self, data: Any) -> str:
        """The controller's version text (fingerprinted, never compared)."""
        ...

    def robot_identity(self, data: Any) -> dict[str, str]:
        """What tells this robot from another of its family, by a person's name for
        each part (``{"version": "5.00", "program configuration": "..."}``): a pull
        whose controller answers otherwise than the backup refuses (another robot on
        the line, a wrong port or station) until told it is a new robot."""
        ...

    def contents(self, data: Any, *, registers: bool) -> str:
        """What ``data`` holds, in the family's words, for the line a pull or diff
        ends with: ``"7 programs (120 steps used), 10 offset tables, 8 timers"``."""
        ...

    def plan(
        self, live: Any, project: Any, changes: list[tuple[Any, Any, Any]], *, registers: bool
    ) -> PlanShape:
        """The writes that turn ``live`` into ``project`` given their differences."""
        ...


@dataclass
class Analysis:
    """What :meth:`Family.analyse` found: the robot and data when valid, and every issue."""

    robot: Robot | None = None
    data: Any = None
    issues: list[Issue] = field(default_factory=list)


class Family(Protocol):
    """One controller family, as the registry hands it out."""

    #: the name robot.yaml and ``--family`` use: ``harl-u2``, ``iai``
    name: str
    #: for people: ``Hirata HARL-U2``
    title: str
    catalogue: Catalogue
    #: the project format version this harlsync reads and writes for the family
    format: int
    #: sub-directories of a project whose files the family manages
    directories: tuple[str, ...]
    #: what a push's result and audit record must tell (e.g. positions not in flash)
    deploy_notes: tuple[str, ...]
    #: the options :meth:`connect` takes beyond port and station (Epson:
    #: ``reset_function``); the engine refuses any other before connecting
    connect_options: frozenset[str]
    # Optional, read with getattr (a family without it has none):
    #   port_schemes: tuple[str, ...]  the port URL schemes only this family reads
    #   (Epson: ``modbus``): a first pull with such a port needs no --family

    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        """Read and check a project's files (path relative to the project -> content)."""
        ...

    def render_files(self, robot: Robot, data: Any) -> dict[str, str]:
        """Every file of the project, by relative path, in a fixed order."""
        ...

    def data_problems(self, data: Any) -> list[str]:
        """What is wrong with ``data`` that its files cannot show (checked before a save)."""
        ...

    def project_files(self, root: Path) -> list[str]:
        """The relative paths under ``root`` that hold the project (robot.yaml first)."""
        ...

    def stale_files(
        self, root: Path, texts: Mapping[str, str], robot: Robot, data: Any
    ) -> list[str]:
        """Managed files on disk that a save of ``texts`` must remove."""
        ...

    def schemas(self) -> dict[str, str]:
        """Schema file name -> text, copied into each project's ``.schemas/``."""
        ...

    def new_robot(self, name: str, port: str, station: int | None, **options: Any) -> Robot:
        """The robot.yaml of a first pull (the family's defaults)."""
        ...

    def parse_station(self, text: str) -> int:
        """A station as a person gives it (``--station``).  Raises ValueError with the range."""
        ...

    def format_station(self, station: int) -> str:
        """A station as the family's people write it (decimal, or hex for IAI)."""
        ...

    def connect(
        self,
        robot: Robot,
        port: str | None,
        station: int | None,
        *,
        lock_timeout: float,
        **options: Any,
    ) -> Driver:
        """Open the robot's line (``port``/``station`` override robot.yaml); ``options``
        are some of :attr:`connect_options`."""
        ...
