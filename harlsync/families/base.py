"""What a controller family gives the engine, and nothing more.

The engine (pull, diff, plan, push, rollback, backup) and the project store
know a robot as *items*: the smallest things one write changes, each keyed by a
typed, hashable key with a ``kind`` (``TableKey("table", 3)``, say).  What the items are, how they are read and
written, in which order a push writes them, which need an idle robot and how
they sit in files is the family's; the engine never branches on which family
it is::

    engine                       family (harlsync/families/<name>/)
    ------                       -----------------------------------
    load / save a project   -->  Family.analyse / render_files / project_files
    connect                 -->  Family.connect -> Driver (read_all, read, write, status)
    diff / plan             -->  Catalogue (items, order, names, fields, plan)
    interlock               -->  Driver.status() -> Status (idle? which signal says no)
    command line, locks     -->  Family.options, schemes, words (what only it knows)

Three generic base classes, python-can ``BusABC`` style: a family implements a
few abstract members and inherits a default for the rest.  Each is generic over
the family's key type ``K`` (a NamedTuple, or a union of them) and its data
type ``D`` (what a backup holds: the robot's data as the family models it),
which the engine never looks into: it hands data back to the family it
came from.  An item's *value* is ``object`` to the engine: it compares values
and hands them back, nothing more.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, Protocol, TypeAlias, TypeVar, cast

from ..alignment import text_of
from .declare import Help, Option, Scheme, Words
from .survey import Survey

if TYPE_CHECKING:
    from ..project.robot import Robot
    from ..project.schema import Issue

__all__ = [
    "Analysis",
    "AnyFamily",
    "Catalogue",
    "Change3",
    "D",
    "Driver",
    "Family",
    "Help",
    "ItemKey",
    "K",
    "Option",
    "PlanShape",
    "Progress",
    "Scheme",
    "Status",
    "Survey",
    "Words",
]

#: ``progress(done, total)`` while reading everything (exchanges with the controller).
Progress = Callable[[int, int], None]


class ItemKey(Hashable, Protocol):
    """An item's identity.  Families use NamedTuples whose first field is ``kind``,
    so a key is typed, hashable, ordered and JSON-able as a list."""

    @property
    def kind(self) -> str: ...


#: The family's key type.
K = TypeVar("K", bound=ItemKey)
#: The family's data type (what a backup of one robot holds).
D = TypeVar("D")

#: One difference as the family is asked about it: ``(key, old, new)``, ``None``
#: standing for an item one side does not have.
Change3: TypeAlias = tuple[K, object, object]


class Status(Protocol):
    """The interlock's answer: may a write go now, and if not, which signal says no."""

    @property
    def idle(self) -> bool: ...

    def describe(self) -> str:
        """``"idle"``, or what forbids a write (``task 0 in execution``, ``MANUAL mode``)."""
        ...


class Driver(ABC, Generic[K, D]):
    """One open robot, as the engine uses it.

    To implement: :meth:`read_all`, :meth:`status`, :meth:`read`, :meth:`write`
    and :meth:`command`.  :meth:`unsafe` says True for every item unless told
    otherwise (the safe default); :meth:`close` does nothing.
    """

    #: Where the robot is, for messages: ``"port /dev/ttyUSB0 station 1"``.
    label: str = "the robot"
    #: The harlsync command the connection serves (``"push"``), set by the engine once
    #: connected, for advice that names the command to run again (``harlsync push DIR``
    #: with the family's option, never a pull that would overwrite the project).
    serves: str = ""

    @property
    def notes(self) -> Sequence[str]:
        """What the driver did on its own to reach the robot, one sentence each (a
        remote function left in use by a harlsync that is gone, reset): the
        pull says it and the audit log records it.  Default: nothing."""
        return ()

    @abstractmethod
    def read_all(
        self, *, registers: bool, progress: Progress | None = None, whole: bool = False
    ) -> D:
        """Everything the controller holds, as the family's data (runtime data only
        when ``registers``).  ``whole`` (a pull, a backup): also find out how far
        each table really goes past the configured range, and raise rather than
        return a backup that would leave part of one out."""

    @abstractmethod
    def status(self) -> Status:
        """The interlock state; ``Status.idle`` says whether writing is allowed."""

    def identity(self) -> Mapping[str, str] | None:
        """What the robot says it is, by the names :meth:`Catalogue.robot_identity`
        gives (``{"version": "5.00", ...}``), read with only the requests that tell
        it, so that a swapped controller is refused at its first exchanges rather
        than after a whole read; the next :meth:`read_all` uses what it read and
        asks nothing twice.  None when the family cannot tell before a whole read
        (the default): the engine then checks the data a read returns."""
        return None

    def survey(self) -> Survey:
        """What ``harlsync probe`` reports of the controller, read with read requests
        only (the probe refuses any write on the line: :mod:`harlsync.link.readonly`):
        its identity, each table's real extent and "not there" reply, the interlock
        now, the profile's guesses it confirmed or contradicted, and what a full pull
        costs.  Default: :meth:`identity` (else nothing) and :meth:`status`."""
        status = self.status()
        return Survey(
            identity=dict(self.identity() or {}), status=status.describe(), idle=status.idle
        )

    def advice(self, status: Status) -> str:
        """What a person does about a ``status`` that is not idle, one sentence in the
        family's words (``Release the emergency stop ...``), for the interlock's
        refusal and the plan's warning; empty when :meth:`Status.describe` says it
        already.  Default: stop the robot."""
        return "Stop the robot (or wait for the cycle to end) and run again"

    @abstractmethod
    def read(self, key: K) -> object:
        """The item's current value (``None`` for an empty one)."""

    @abstractmethod
    def write(self, key: K, value: object, old: object = None, *, needs_idle: bool = True) -> None:
        """Write one item; ``old`` is what it holds now, if known.

        With ``needs_idle`` the write is never sent again (after a lost reply)
        unless the robot is then found idle; raises InterlockError instead.
        """

    @abstractmethod
    def command(self, key: K, value: object) -> str:
        """The exact wire command that :meth:`write` sends, for plans and audits."""

    def unsafe(self, key: K) -> bool:
        """Whether writing this item is forbidden while the robot runs (default: yes)."""
        return True

    def close(self) -> None:
        """Close the line (default: nothing to close)."""


@dataclass
class PlanShape(Generic[K]):
    """What the family decides about a plan: the writes wanted (key, old, new),
    unsorted, and why the rest cannot be written."""

    wanted: list[Change3[K]]
    #: differences no write can fix, each as a sentence
    unwritable: list[str] = field(default_factory=list)
    #: set when the plan holds a destructive reconfiguration: the refusal a push
    #: without --allow-reconfigure gives
    reconfigure: str | None = None
    #: ... and the line a printed plan starts with
    reconfigure_note: str | None = None
    #: what a printed plan, a push's result and its audit record must tell about
    #: these writes (items a write keeps only until the controller saves them, say)
    notes: list[str] = field(default_factory=list)


class Catalogue(ABC, Generic[K, D]):
    """The family's items: what they are, their names, their order, their fields.

    To implement: :meth:`items`, :meth:`order` and :meth:`describe`.  The rest
    has a default that speaks of items by their ``kind``; a family overrides
    what it has better words for.
    """

    #: Item kinds that ``--allow-live-tuning`` may write while the robot runs.
    live_tuning: frozenset[str] = frozenset()
    #: The keys of :meth:`counts` that count groups of items (a sequence whose items
    #: another key counts), not items: left out of the number of items changed.
    group_counts: frozenset[str] = frozenset()

    @abstractmethod
    def items(self, data: D, *, registers: bool) -> Mapping[K, object]:
        """Every item of ``data`` by key (empty items left out)."""

    def with_items(self, data: D, values: Mapping[K, object]) -> D:
        """A copy of ``data`` with each item of ``values`` set to its value, as
        :meth:`items` gives one (None: the item emptied): what ``harlsync adopt``
        writes into a project.  ``data`` itself is left as it is.  Default: raises
        NotImplementedError, which adopt says in words (the family cannot)."""
        raise NotImplementedError

    @abstractmethod
    def order(self, key: K) -> tuple[int | str, ...]:
        """Sort key: the safe order of a push."""

    @abstractmethod
    def describe(self, key: K) -> str:
        """A person's name for an item: ``MAIN program 2 step 3``, ``position 12``."""

    def group(self, key: K) -> str:
        """The ``@@ group @@`` an item is shown under in a text diff (default: its kind)."""
        return key.kind

    def label(self, key: K, field: str) -> str:
        """The line label of one field of an item in a text diff (default: the
        field, or the item's name for a value of one field)."""
        return field or self.describe(key)

    def fields(self, key: K, old: object, new: object) -> list[tuple[str, str | None, str | None]]:
        """The change field by field, ``(field, old text, new text)``, only what
        differs (default: the value as one field, as its ``.text`` or str())."""
        before, after = text_of(old), text_of(new)
        return [] if before == after else [("", before, after)]

    def identity(self, key: K) -> dict[str, object]:
        """The key as JSON fields (``kind`` and the rest by name)."""
        as_dict = getattr(key, "_asdict", None)
        fields: dict[str, object] = dict(as_dict()) if callable(as_dict) else {}
        fields.setdefault("kind", key.kind)
        return fields

    def position(self, key: K) -> tuple[str, int] | None:
        """Where the item sits in a sequence a person inserts into and deletes from (a
        program's steps): the sequence's :meth:`group` and the item's number in it, so
        that diff and plan align the sequence (:func:`~harlsync.alignment.align`).  Default None: items
        keyed by number for good (a position, a point: a PLC and the programs refer to
        them by number, and an insertion among them is no edit anyone makes)."""
        return None

    def counts(self, changes: Iterable[Change3[K]]) -> dict[str, int]:
        """How much changed, by the family's own units (default: items by kind)."""
        return dict(Counter(key.kind for key, _, _ in changes))

    def summary(self, changes: Iterable[Change3[K]]) -> str:
        """``"2 programs (5 steps), 1 table"``, or ``"no change"``."""
        counted = self.counts(changes)
        return ", ".join(f"{n} {kind}{'s' * (n != 1)}" for kind, n in counted.items() if n) or (
            "no change"
        )

    def version(self, data: D) -> str:
        """The controller's version text (fingerprinted, never compared; default none)."""
        return ""

    def robot_identity(self, data: D) -> dict[str, str]:
        """What tells this robot from another of its family, by a person's name for
        each part (``{"version": "5.00", "program configuration": "..."}``): a pull
        whose controller answers otherwise than the backup refuses (another robot on
        the line, a wrong port or station) until told it is a new robot.  Default:
        the version, when there is one."""
        version = self.version(data)
        return {"version": version} if version else {}

    def other_robot(self, live: D, project: D) -> str | None:
        """Why the controller read (``live``) is not the robot its project recorded
        (``project``: the backup, or the state a push or rollback deploys), for pull,
        diff, plan, push and rollback once the read is over (a pull with
        ``--new-robot`` does not ask): the one place where what a read found out of
        the controller (HARL-U2: the reply past its last offset table; IAI: a
        table's "not there" replies; Epson: what a point not defined answers) is
        compared with what the project recorded, in one sentence naming both and
        what to change; None when it is the robot.  Nothing is saved or written
        before it is asked.  Default: what :meth:`other_identity` says of its
        identity."""
        return self.other_identity(self.robot_identity(live), project)

    def other_identity(self, now: Mapping[str, str], project: D) -> str | None:
        """Why a controller whose identity is ``now`` (:meth:`robot_identity`'s names,
        from :meth:`Driver.identity` or a read) is not the project's robot, for diff,
        plan and push; None when it may be.  Default: None (nothing more to tell than
        a pull checks)."""
        return None

    def contents(self, data: D, *, registers: bool) -> str:
        """What ``data`` holds, in the family's words, for the line a pull or diff
        ends with: ``"7 programs (120 steps used), 10 offset tables, 8 timers"``.
        Default: the items by kind."""
        held = Counter(key.kind for key in self.items(data, registers=registers))
        return ", ".join(f"{n} {kind}{'s' * (n != 1)}" for kind, n in held.items()) or "nothing"

    def plan(
        self, live: D, project: D, changes: list[Change3[K]], *, registers: bool
    ) -> PlanShape[K]:
        """The writes that turn ``live`` into ``project`` given their differences
        (default: every difference is one write of the project's value)."""
        return PlanShape(wanted=list(changes))


@dataclass
class Analysis:
    """What :meth:`Family.analyse` found: the robot and data when valid (the
    family's data, handed back to it), and every issue."""

    robot: Robot | None = None
    data: object = None
    issues: list[Issue] = field(default_factory=list)
    #: what ``validate`` tells of a valid project without failing it (a setting that
    #: works but is unusual), one sentence each
    notes: list[str] = field(default_factory=list)


class Family(ABC, Generic[K, D]):
    """One controller family, as the registry hands it out.

    To implement: :attr:`name`, :attr:`title`, :attr:`catalogue`, :meth:`analyse`,
    :meth:`render_files`, :meth:`schemas` and :meth:`connect`; the rest has
    defaults (no options, schemes or reconfiguration; decimal stations in
    :attr:`stations`; the project's ``*.yaml`` files at its top).
    """

    #: the name robot.yaml and ``--family`` use: ``harl-u2``, ``iai``
    name: str
    #: for people: the maker and the controller's model
    title: str
    #: sub-directories of a project whose files the family manages
    directories: tuple[str, ...] = ()
    #: what a push's result and audit record must tell (e.g. positions not in flash)
    deploy_notes: tuple[str, ...] = ()
    #: its options on the command line (see :class:`Option`)
    options: tuple[Option, ...] = ()
    #: options the engine itself gives :meth:`connect`, never a person: ``unattended``
    #: (a nightly backup: the family may recover on its own what it would otherwise
    #: ask a person to, and say so in :attr:`Driver.notes`)
    engine_options: frozenset[str] = frozenset()
    #: its own URL schemes (see :class:`Scheme`)
    schemes: tuple[Scheme, ...] = ()
    #: its words for the interlock
    words: Words = Words()
    #: what ``--help`` says of it
    help: Help = Help()
    #: loggers of the libraries it uses, quiet below ``-vv`` (their lines repeat ours)
    loggers: tuple[str, ...] = ()
    #: the stations robot.yaml and ``--station`` allow, and the one a first pull takes
    stations: range = range(1, 100)
    default_station: int = 1
    #: whether :meth:`connect` (or what a read does before the robot's identity) may
    #: write to the controller (a handshake that drives its input signals when it
    #: starts).  The engine then refuses a project with uncommitted edits before it
    #: connects; a family whose connection only reads says False, and a pull asks git
    #: while its first requests are on the line (issue 24).
    connect_writes: bool = True
    #: the stations ``harlsync probe`` tries, in order, when none is given (default:
    #: :attr:`default_station` alone)
    probe_stations: tuple[int, ...] = ()
    #: the baud rates its manual lists, which ``harlsync probe --baud auto`` tries on
    #: a local serial port, the profile's first (default: none; the profile's rate)
    probe_bauds: tuple[int, ...] = ()

    @property
    @abstractmethod
    def catalogue(self) -> Catalogue[K, D]:
        """Its items and how to plan writes of them.  A property, so that a family
        may import its catalogue when it is first used: ``--help`` and the look-ups
        of the registry need only the declarations above."""

    @property
    def format(self) -> int:
        """The project format version this harlsync reads and writes for the family
        (default 1; a property, for the same reason as :attr:`catalogue`)."""
        return 1

    @property
    def connect_options(self) -> frozenset[str]:
        """What :meth:`connect` takes beyond port and station: the names of
        :attr:`options`, and :attr:`engine_options`."""
        return frozenset(option.name for option in self.options) | self.engine_options

    @abstractmethod
    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        """Read and check a project's files (path relative to the project -> content)."""

    @abstractmethod
    def render_files(self, robot: Robot, data: D) -> dict[str, str]:
        """Every file of the project, by relative path, in a fixed order."""

    @abstractmethod
    def schemas(self) -> dict[str, str]:
        """Schema file name -> text, copied into each project's ``.schemas/``."""

    @abstractmethod
    def connect(
        self,
        robot: Robot,
        port: str | None,
        station: int | None,
        *,
        lock_timeout: float,
        **options: bool,
    ) -> Driver[K, D]:
        """Open the robot's line (``port``/``station`` override robot.yaml); ``options``
        are some of :attr:`connect_options`, each given when set."""

    def survey(self, robot: Robot, *, lock_timeout: float) -> Survey:
        """Probe ``robot``'s controller with reads only and close the line.  Default:
        :meth:`connect`, :meth:`Driver.survey`.  A family whose connection writes (a
        handshake) overrides it, or the probe's read-only line refuses the write."""
        driver = self.connect(robot, None, None, lock_timeout=lock_timeout)
        try:
            return driver.survey()
        finally:
            driver.close()

    def robot_text(self, robot: Robot) -> str | None:
        """robot.yaml for ``robot`` alone, before any data is read (what ``harlsync
        probe --write`` creates); None (the default) when the family cannot."""
        return None

    def data_problems(self, data: D) -> list[str]:
        """What is wrong with ``data`` that its files cannot show (checked before a save)."""
        return []

    def project_files(self, root: Path) -> list[str]:
        """The relative paths under ``root`` that hold the project (robot.yaml
        first).  Default: the ``*.yaml`` files at the top and in :attr:`directories`."""
        names = ["robot.yaml"] if (root / "robot.yaml").is_file() else []
        for folder in ("", *self.directories):
            where = root / folder
            if where.is_dir():
                names += sorted(
                    f"{folder}/{p.name}" if folder else p.name
                    for p in where.iterdir()
                    if p.is_file() and p.suffix == ".yaml" and p.name != "robot.yaml"
                )
        return names

    def stale_files(self, root: Path, texts: Mapping[str, str], robot: Robot, data: D) -> list[str]:
        """Managed files on disk that a save of ``texts`` must remove (default: none)."""
        return []

    def new_robot(self, name: str, port: str, station: int | None, **fields: object) -> Robot:
        """The robot.yaml of a first pull: the family's defaults, then ``fields``
        (:class:`~harlsync.project.robot.Robot` fields)."""
        from ..project.robot import Robot

        robot = Robot(
            family=self.name,
            name=name,
            port=port,
            station=self.default_station if station is None else station,
        )
        return replace(robot, **cast(dict[str, Any], fields))

    def parse_station(self, text: str) -> int:
        """A station as a person gives it (``--station``).  Raises ValueError with
        the range (default: decimal, in :attr:`stations`)."""
        allowed = f"{self.stations.start}-{self.stations.stop - 1}"
        if not (text.isascii() and text.isdigit()) or int(text) not in self.stations:
            raise ValueError(f"{text!r} is not a station (allowed: {allowed})")
        return int(text)

    def format_station(self, station: int) -> str:
        """A station as the family's people write it (default: decimal)."""
        return str(station)


#: A family whose key and data types are its own, as the registry hands it out.
#: Python's typing has no existential type: this is the one place the family's
#: types are let go, and the engine's functions are generic over them again.
AnyFamily: TypeAlias = "Family[Any, Any]"
