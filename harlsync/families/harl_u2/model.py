"""The one data model shared by the codec, the controller API, the project files,
the simulator and the sync engine.

Values the controller holds (timer values, offsets, parameters, step tokens) are
kept as their exact wire text: harlsync stores what the controller returned and
writes exactly that back.  Numbers are parsed only to check ranges, and to name
the one form the controller gives an offset back in (:func:`canonical_offset`,
:func:`canonical_code`): a project must write it so, or a push never converges.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Iterator
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...project.robot import Robot

__all__ = [
    "CODE_RE",
    "MAX_STEP_DATA",
    "OFFSET_FIELDS",
    "OFFSET_RE",
    "OFFSET_TABLE_COUNT",
    "PARAMETER_NAMES",
    "REGISTER_RE",
    "TASK_STATUS_NAMES",
    "TIMER_RE",
    "TOKEN_RE",
    "Config",
    "OffsetEnd",
    "OffsetTable",
    "Parameters",
    "ProgramArea",
    "ProgramKey",
    "ProgramType",
    "RobotData",
    "Status",
    "Step",
    "TaskState",
    "canonical_code",
    "canonical_offset",
    "no_such_table",
    "offset_tables",
]

#: One wire token: printable ASCII, no space (fields never contain SP, STX or ETX).
TOKEN_RE = re.compile(r"[!-~]+")
#: Timer value, 0.00-9.99 (manual 3.1.5 LNT, p. 3-4; 3.2.5 SNT, p. 3-14).
TIMER_RE = re.compile(r"[0-9]\.[0-9]{2}")
#: Register value, 0000-9999, zero padded (manual 3.1.6 LND, p. 3-4; 3.2.6 SND, p. 3-14).
REGISTER_RE = re.compile(r"[0-9]{4}")
#: Offset X Y Z W R C: -9999.99..9999.99 with two decimals (manual 3.1.7 LNL, p. 3-4;
#: 3.2.7 SNL, p. 3-14).
OFFSET_RE = re.compile(r"-?[0-9]{1,4}\.[0-9]{2}")
#: Offset M data and F code: 0-99 (manual 3.1.7 LNL, 3.2.7 SNL).
CODE_RE = re.compile(r"[0-9]{1,2}")

#: At most four data items follow a step's command.
MAX_STEP_DATA = 4
#: A step's tokens joined by NUL when each is one TOKEN_RE and there are at most
#: 1 + MAX_STEP_DATA (and no token holds a NUL): :meth:`Step.problems` in one test.
_SOUND_TOKENS = re.compile(rf"[!-~]+(?:\0[!-~]+){{0,{MAX_STEP_DATA}}}")
#: Offset tables 0-99: the manual's "between 0 and 99 (variable)" (3.1.7 LNL, p. 3-4).
#: LNX does not report how many a controller has: a read goes at most this far by
#: default and finds the real end from the controller's answers (:class:`OffsetEnd`).
OFFSET_TABLE_COUNT = 100


def offset_tables(robot: Robot | None) -> int:
    """How many offset tables a read goes to at most, 0 to N - 1: robot.yaml's
    ``offset_tables``, else the manual's 100.  A controller with fewer is read to
    its end (:class:`OffsetEnd`); table N answering data fails the read."""
    if robot is None:
        return OFFSET_TABLE_COUNT
    return int(robot.options.get("offset_tables", OFFSET_TABLE_COUNT))


def no_such_table(robot: Robot | None) -> str | None:
    """robot.yaml's ``no_such_table``: the only reply (``E`` + status) taken for "no
    such table" past the last offset table; None (absent): the reply the controller
    gives twice at its first pull, then the one that pull recorded."""
    if robot is None:
        return None
    pinned = robot.options.get("no_such_table")
    return None if pinned is None else str(pinned)


class ProgramType(enum.Enum):
    """The four kinds of HARL-U2 program.  START is a single program (number 0)."""

    START = "START"
    MAIN = "MAIN"
    SUB = "SUB"
    HAND = "HAND"

    @property
    def letter(self) -> str:
        """The command letter: LNA/SNA for START, LNM/SNM for MAIN, ..."""
        return {"START": "A", "MAIN": "M", "SUB": "S", "HAND": "H"}[self.value]

    @property
    def numbered(self) -> bool:
        """Whether requests carry a program number (all but START)."""
        return self is not ProgramType.START


#: A program's identity: its type and number (START is always number 0).
ProgramKey = tuple[ProgramType, int]


@dataclass(frozen=True)
class Step:
    """One program step: a command and up to four data items, or nothing.

    The tokens are opaque text, kept exactly as the controller returned them.
    """

    command: str | None = None
    data: tuple[str, ...] = ()

    @classmethod
    def parse(cls, text: str) -> Step:
        """Build a step from its text form, ``"MOVE P010 S50"`` (``""`` is empty)."""
        tokens = text.split(" ") if text else []
        return cls.from_tokens(tokens)

    @classmethod
    def from_tokens(cls, tokens: list[str] | tuple[str, ...]) -> Step:
        if not tokens:
            return cls()
        return cls(tokens[0], tuple(tokens[1:]))

    @property
    def empty(self) -> bool:
        return self.command is None

    @property
    def tokens(self) -> tuple[str, ...]:
        return () if self.command is None else (self.command, *self.data)

    @property
    def text(self) -> str:
        return " ".join(self.tokens)

    def problems(self) -> list[str]:
        """What makes this step unwritable, as short phrases (empty when fine)."""
        if self.command is not None:
            joined = "\0".join((self.command, *self.data))
            # every NUL a separator (none in a token), each token one TOKEN_RE
            if joined.count("\0") == len(self.data) and _SOUND_TOKENS.fullmatch(joined):
                return []  # a command and at most four data items
        out = []
        if self.command is None and self.data:
            out.append("data without a command")
        if len(self.data) > MAX_STEP_DATA:
            out.append(f"{len(self.data)} data items (at most {MAX_STEP_DATA})")
        for token in self.tokens:
            if not TOKEN_RE.fullmatch(token):
                out.append(f"token {token!r} has a space or a control character")
        return out

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class ProgramArea:
    """How many programs of one type exist and how many steps each has."""

    count: int
    steps: int


@dataclass(frozen=True)
class Config:
    """The program configuration (LNX): areas per type, then timers, memory bits, registers.

    SNX writes only the four program areas; the last three are read-only.
    """

    start: ProgramArea
    main: ProgramArea
    sub: ProgramArea
    hand: ProgramArea
    timers: int
    memory_bits: int
    registers: int

    @classmethod
    def from_numbers(cls, n: list[int] | tuple[int, ...]) -> Config:
        """From the 11 LNX numbers: P S for START, MAIN, SUB, HAND, then T M R."""
        if len(n) != 11:
            raise ValueError(f"{len(n)} numbers, expected 11: P S P S P S P S T M R")
        return cls(
            ProgramArea(n[0], n[1]),
            ProgramArea(n[2], n[3]),
            ProgramArea(n[4], n[5]),
            ProgramArea(n[6], n[7]),
            timers=n[8],
            memory_bits=n[9],
            registers=n[10],
        )

    def numbers(self) -> tuple[int, ...]:
        """The 11 LNX numbers (the first 8 are what SNX writes)."""
        areas = (self.area(t) for t in ProgramType)
        return (
            *(n for a in areas for n in (a.count, a.steps)),
            self.timers,
            self.memory_bits,
            self.registers,
        )

    def area(self, ptype: ProgramType) -> ProgramArea:
        return {
            ProgramType.START: self.start,
            ProgramType.MAIN: self.main,
            ProgramType.SUB: self.sub,
            ProgramType.HAND: self.hand,
        }[ptype]

    def programs(self) -> Iterator[ProgramKey]:
        """Every program this configuration holds, in pull/push order."""
        for ptype in ProgramType:
            for number in range(self.area(ptype).count):
                yield (ptype, number)

    def has_step(self, key: ProgramKey, step: int) -> bool:
        ptype, number = key
        area = self.area(ptype)
        return 0 <= number < area.count and 0 <= step < area.steps

    def same_programs(self, other: Config) -> bool:
        """Whether the SNX part (the four program areas) is the same."""
        return all(self.area(t) == other.area(t) for t in ProgramType)

    @property
    def step_count(self) -> int:
        return sum(self.area(t).count * self.area(t).steps for t in ProgramType)


#: Offset table fields in wire order (the manual swaps the Z/W captions of LNL;
#: the order is X Y Z W R C M F as in SNL).
OFFSET_FIELDS = ("x", "y", "z", "w", "r", "c", "m", "f")


@dataclass(frozen=True)
class OffsetTable:
    """One offset table: X..C are ``-9999.99``..``9999.99``, M and F ``0``..``99``."""

    x: str = "0.00"
    y: str = "0.00"
    z: str = "0.00"
    w: str = "0.00"
    r: str = "0.00"
    c: str = "0.00"
    m: str = "0"
    f: str = "0"

    @property
    def values(self) -> tuple[str, ...]:
        return tuple(getattr(self, name) for name in OFFSET_FIELDS)

    @classmethod
    def from_values(cls, values: list[str] | tuple[str, ...]) -> OffsetTable:
        """From the 8 wire fields X Y Z W R C M F.  Raises ValueError for another count."""
        if len(values) != len(OFFSET_FIELDS):
            raise ValueError(
                f"{len(values)} values, expected {len(OFFSET_FIELDS)}: X Y Z W R C M F"
            )
        return cls(*values)

    def problems(self) -> list[str]:
        out = []
        for name in OFFSET_FIELDS:
            value = getattr(self, name)
            pattern = CODE_RE if name in ("m", "f") else OFFSET_RE
            if not pattern.fullmatch(value):
                allowed = "0-99" if name in ("m", "f") else "-9999.99..9999.99, two decimals"
                out.append(f"{name.upper()} {value!r} (allowed: {allowed})")
        return out


@dataclass(frozen=True)
class OffsetEnd:
    """Where a read found the offset tables to end (LNX does not report their count).

    Tables 0 to ``count`` - 1 read normally, and table ``count`` answered ``reply``
    (``E`` + status, as the wire gives it) twice, with table ``count`` - 1 read
    normally again between the two: that reply is the controller's "no such table".
    A pull records both in controller.yaml (``offset_tables``).  ``asked`` is how
    many tables the read was to read at most (robot.yaml's ``offset_tables``),
    for what the read says; ``pinned`` says that robot.yaml's ``no_such_table``
    held the read to ``reply`` (what the project recorded then does not bind it).
    Neither is recorded, and equal ends compare equal whatever was asked.
    """

    count: int
    reply: str
    asked: int = field(default=0, compare=False)
    pinned: bool = field(default=False, compare=False)


def canonical_offset(text: str) -> str:
    """An offset X..C as the controller gives it back: no leading zero, no minus on
    zero (``"0012.50"`` -> ``"12.50"``, ``"-0000.00"`` -> ``"0.00"``).

    The controller keeps a number, not its text: the manual's fields are
    "-9999.99 to 9999.99 (variable)", two decimals, never padded.  Raises
    :class:`ValueError` for text :data:`OFFSET_RE` does not match.
    """
    if not OFFSET_RE.fullmatch(text):
        raise ValueError(f"offset {text!r} (allowed: -9999.99..9999.99, two decimals)")
    whole, _, decimals = text.lstrip("-").partition(".")
    whole = whole.lstrip("0") or "0"
    sign = "-" if text.startswith("-") and (whole, decimals) != ("0", "00") else ""
    return f"{sign}{whole}.{decimals}"


def canonical_code(text: str) -> str:
    """M data or an F code as the controller gives it back: ``"07"`` -> ``"7"``.
    Raises :class:`ValueError` for text :data:`CODE_RE` does not match."""
    if not CODE_RE.fullmatch(text):
        raise ValueError(f"code {text!r} (allowed: 0-99)")
    return str(int(text))


#: The 13 expanded parameters (LNE/SNE), wire order: (YAML key, manual's name).  The
#: manual names them and gives no range, unit or form for any (3.1.11 LNE, p. 3-9;
#: 3.2.10 SNE, p. 3-17): validate refuses what the wire cannot carry or give back
#: (one token, the SNE request and the LNE reply within a frame, PULL LIMIT not
#: read as an error status), and no range it would have to invent.
PARAMETER_NAMES: tuple[tuple[str, str], ...] = (
    ("pull_limit", "PULL LIMIT"),
    ("arch_motion", "ARCH MOTION"),
    ("table_data", "TABLE DATA"),
    ("z_up_dis_1", "Z UP DIS 1"),
    ("z_dn_dis_1", "Z DN DIS 1"),
    ("z_up_dis_2", "Z UP DIS 2"),
    ("z_dn_dis_2", "Z DN DIS 2"),
    ("z_up_dis_3", "Z UP DIS 3"),
    ("z_dn_dis_3", "Z DN DIS 3"),
    ("pull_rate", "PULL RATE"),
    ("io_status", "I/O STATUS"),
    ("z_stop_pos", "Z STOP POS."),
    ("prg_count", "PRG. COUNT"),
)


@dataclass(frozen=True)
class Parameters:
    """The 13 expanded parameters, by name, as wire text."""

    pull_limit: str
    arch_motion: str
    table_data: str
    z_up_dis_1: str
    z_dn_dis_1: str
    z_up_dis_2: str
    z_dn_dis_2: str
    z_up_dis_3: str
    z_dn_dis_3: str
    pull_rate: str
    io_status: str
    z_stop_pos: str
    prg_count: str

    @property
    def values(self) -> tuple[str, ...]:
        return tuple(getattr(self, f.name) for f in fields(self))

    @classmethod
    def from_values(cls, values: list[str] | tuple[str, ...]) -> Parameters:
        """From the 13 wire fields, in order.  Raises ValueError for another count."""
        if len(values) != len(PARAMETER_NAMES):
            raise ValueError(f"{len(values)} values, expected {len(PARAMETER_NAMES)} parameters")
        return cls(*values)

    def as_dict(self) -> dict[str, str]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: LNR task status values as the manual lists them.
TASK_STATUS_NAMES = {0: "stop", 1: "in execution", 2: "suspended", 4: "complete", 8: "error"}
_RUNNING_BITS = 1 | 2  # in execution, suspended


@dataclass(frozen=True)
class TaskState:
    """One task's line of the LNR reply."""

    task: int
    status: int
    program_type: str
    program: int
    step: int

    @property
    def status_name(self) -> str:
        return TASK_STATUS_NAMES.get(self.status, f"unknown status {self.status}")

    @property
    def active(self) -> bool:
        """In execution or suspended, or a status we do not know (fail safe)."""
        return self.status not in TASK_STATUS_NAMES or bool(self.status & _RUNNING_BITS)

    def describe(self) -> str:
        return (
            f"task {self.task} {self.status_name}: "
            f"{self.program_type} program {self.program} step {self.step}"
        )


@dataclass(frozen=True)
class Status:
    """The LNR reply: one state per task (five tasks, 0-4)."""

    tasks: tuple[TaskState, ...]
    expected_tasks: int = 5

    @property
    def active_tasks(self) -> tuple[TaskState, ...]:
        return tuple(t for t in self.tasks if t.active)

    @property
    def idle(self) -> bool:
        """True only when every task is known and none is in execution or suspended."""
        return len(self.tasks) == self.expected_tasks and not self.active_tasks

    def describe(self) -> str:
        if self.idle:
            return "idle"
        if len(self.tasks) != self.expected_tasks:
            return f"LNR reported {len(self.tasks)} tasks, expected {self.expected_tasks}"
        return "; ".join(t.describe() for t in self.active_tasks)


@dataclass
class RobotData:
    """Everything a backup holds: what the controller's memory contains.

    ``programs`` maps each program to its non-empty steps by step number; every
    program the configuration has is present (an empty program maps to ``{}``).
    ``registers`` is ``None`` unless the project keeps registers.  ``offset_end``
    is where the offset tables ended when they were read (None: a project pulled
    before harlsync recorded it).
    """

    version: str
    config: Config
    parameters: Parameters
    programs: dict[ProgramKey, dict[int, Step]] = field(default_factory=dict)
    offsets: dict[int, OffsetTable] = field(default_factory=dict)
    timers: dict[int, str] = field(default_factory=dict)
    registers: dict[int, str] | None = None
    offset_end: OffsetEnd | None = None
