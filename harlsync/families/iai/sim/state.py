"""What a simulated IAI controller holds: its position table, what it is doing,
and the global flags and variables.

:class:`SimState` is built from positions and the robot's settings (axes, model
for the buffer sizes, position range), or generated from a seed as a realistic
table: 3 or 4 axes and a few hundred positions in runs with gaps.  Beside the
table it holds what only a live controller has: the mode and status that 215H
reports, the axes in use and their current positions that 212H reports.

The interlock of the profile, as this state sees it (:meth:`SimState.not_idle`),
is written from these fields, not from the status bits the client decodes: the
simulator's record of "was it idle?" does not share a bug with the client.
"""

from __future__ import annotations

import random
import struct
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from .. import profile
from ..model import AXIS_COUNT, Position, Version

__all__ = ["AUTO", "DEFAULT_AXES", "DEFAULT_VERSION", "MANUAL", "SimState"]

#: 215H system modes the simulator has.
AUTO = 1
MANUAL = 2

DEFAULT_AXES = (1, 2, 3)
#: What 201H reports for the main CPU application (unit type 0, device 0); the
#: codes mean nothing we know of (the manual does not say).
DEFAULT_VERSION = Version(0, 0, "21", "01", "0106", "2019-03-05 14:07:09")


#: Every number each message names: a controller whose tables have no end of their own.
WIRE_TABLES = {
    "flags": (0, 0xFFFF),
    "integers": (0, 0xFFF),
    "reals": (0, 0xFFF),
    "strings": (0, 0xFFF),
    "work_coordinates": (0, 0xFF),
    "tool_coordinates": (0, 0xFF),
}


def _coordinate(units: int) -> str:
    """0.001 units as coordinate text: ``-1000`` -> ``"-1.000"``."""
    sign = "-" if units < 0 else ""
    return f"{sign}{abs(units) // 1000}.{abs(units) % 1000:03d}"


@dataclass
class SimState:
    """One simulated IAI controller (one station).

    Raises :class:`ValueError` naming every problem for positions the robot
    could not hold, an unknown model, or axes outside 1-8.
    """

    positions: dict[int, Position] = field(default_factory=dict)
    axes: tuple[int, ...] = DEFAULT_AXES
    model: str = profile.DEFAULT_MODEL
    #: the position numbers the table holds (first, last), inclusive
    position_range: tuple[int, int] = profile.DEFAULT_POSITION_RANGE
    #: 201H: (unit type, device) -> what that unit reports
    versions: dict[tuple[int, int], Version] = field(
        default_factory=lambda: {(0, 0): DEFAULT_VERSION}
    )
    # --- what the controller is doing: a restarted controller comes up idle ----------
    mode: int = AUTO
    program_running: bool = False
    flash_writing: bool = False
    emergency_stop: bool = False
    ready: bool = True
    #: positioner mode (215H status byte 3 bit 4): a PLC moves the robot to position numbers
    positioner_mode: bool = False
    #: the drive source cut off on its own (an emergency stop cuts it too)
    drive_cut_off: bool = False
    #: the safety gate open (215H status byte 1 bit 2; the enable switch on a TTA)
    safety_gate_open: bool = False
    axes_in_use: set[int] = field(default_factory=set)
    #: axes 212H leaves out of its reply (driver not connected) though the robot has them
    unreported_axes: set[int] = field(default_factory=set)
    #: each axis's current position (212H), coordinate text
    current: dict[int, str] = field(default_factory=dict)
    critical_error: str = "000"
    latest_error: str = "000"
    # --- global flags and variables (runtime data, read and written when opted in) ---
    flags: set[int] = field(default_factory=set)
    integers: dict[int, int] = field(default_factory=dict)
    reals: dict[int, float] = field(default_factory=dict)
    #: how 20FH and 24DH carry a real's double (robot.yaml's controller.real_word_order)
    real_word_order: str = profile.DEFAULT_REAL_WORD_ORDER
    # --- records (2A0H, 210H): coordinate systems set on the controller only; strings 24EH
    #: coordinate system definitions by number: X, Y, Z, R as coordinate text (0 when absent)
    work_coordinates: dict[int, tuple[str, str, str, str]] = field(default_factory=dict)
    tool_coordinates: dict[int, tuple[str, str, str, str]] = field(default_factory=dict)
    #: global string variable columns: column -> character code (0 when absent)
    strings: dict[int, int] = field(default_factory=dict)
    #: the numbers the controller has of each table but positions (whose table is
    #: :attr:`position_range`), first and last: a query naming one outside answers
    #: as the ``past_table`` variant says.  By default every number its message names.
    tables: dict[str, tuple[int, int]] = field(default_factory=lambda: dict(WIRE_TABLES))

    def __post_init__(self) -> None:
        problems = []
        if self.real_word_order not in profile.REAL_WORD_ORDERS:
            problems.append(
                f"real word order {self.real_word_order!r} "
                f"(allowed: {', '.join(profile.REAL_WORD_ORDERS)})"
            )
        if self.model not in profile.BUFFERS:
            problems.append(f"unknown model {self.model!r} (known: {', '.join(profile.BUFFERS)})")
        if (
            not self.axes
            or list(self.axes) != sorted(set(self.axes))
            or not all(1 <= a <= AXIS_COUNT for a in self.axes)
        ):
            problems.append(f"axes {list(self.axes)}: 1 to {AXIS_COUNT}, ascending, each once")
        first, last = self.position_range
        if not 1 <= first <= last <= 0xFFFF:
            problems.append(f"position range {first}-{last} (allowed: within 1 to {0xFFFF})")
        for number, position in sorted(self.positions.items()):
            problems += [f"position {number}: {p}" for p in self.position_problems(position)]
            if position.number != number:
                problems.append(f"position {position.number} kept as number {number}")
        if problems:
            raise ValueError("; ".join(problems))
        self.positions = {n: p.canonical() for n, p in sorted(self.positions.items())}
        for axis in self.axes:
            self.current.setdefault(axis, "0.000")

    @classmethod
    def from_positions(
        cls,
        positions: Iterable[Position] | Mapping[int, Position],
        *,
        axes: tuple[int, ...] = DEFAULT_AXES,
        model: str = profile.DEFAULT_MODEL,
        position_range: tuple[int, int] = profile.DEFAULT_POSITION_RANGE,
        version: Version = DEFAULT_VERSION,
    ) -> SimState:
        """A controller holding ``positions`` (a list, or a dict by number), idle.

        Raises :class:`ValueError` naming every position it could not hold.
        """
        found = positions.values() if isinstance(positions, Mapping) else positions
        return cls(
            {p.number: p for p in found},
            axes=axes,
            model=model,
            position_range=position_range,
            versions={(version.unit_type, version.device): version},
        )

    @classmethod
    def generate(
        cls,
        seed: int,
        *,
        model: str = profile.DEFAULT_MODEL,
        position_range: tuple[int, int] = profile.DEFAULT_POSITION_RANGE,
    ) -> SimState:
        """A controller with a realistic table drawn from ``seed``: 3 or 4 axes (4 a
        SCARA with arm systems), positions in runs of 2-30 with gaps of 1-60, and
        some global flags and variables set (:meth:`seed_variables`)."""
        rng = random.Random(seed)
        axes = tuple(range(1, rng.choice((3, 4)) + 1))
        scara = len(axes) == 4
        first, last = position_range
        positions: dict[int, Position] = {}
        number = first + rng.randrange(3)
        while number <= last:
            for n in range(number, min(number + rng.randint(2, 30), last + 1)):
                positions[n] = _generate_position(rng, n, axes, scara)
            number = max(positions) + 1 + rng.randint(1, 60)
        state = cls(positions, axes=axes, model=model, position_range=position_range)
        state.current = {a: _coordinate(rng.randint(-100_000, 400_000)) for a in axes}
        state.seed_variables(random.Random(~seed))
        return state

    def seed_variables(self, rng: random.Random) -> None:
        """Global flags and variables as a program leaves them, in the profile's
        default ranges: a few flags on, counters and a few measured reals, the
        rest 0."""
        ranges = profile.DEFAULT_VARIABLE_RANGES
        first, last = ranges["flags"]
        self.flags = set(rng.sample(range(first, last + 1), 12))
        first, last = ranges["integers"]
        numbers = rng.sample(range(first, last + 1), 20)
        self.integers = {n: rng.randint(-5000, 5000) for n in numbers}
        first, last = ranges["reals"]
        self.reals = {
            n: round(rng.uniform(-500, 500), rng.randint(0, 6))
            for n in rng.sample(range(first, last + 1), 10)
        }

    def position_problems(self, position: Position) -> list[str]:
        """Why this robot cannot hold ``position``, one line each; empty if it can."""
        out = position.problems()
        missing = [a for a in position.axes if a not in self.axes]
        if missing:
            out.append(f"axes {missing} not on this robot (it has {list(self.axes)})")
        first, last = self.position_range
        if not first <= position.number <= last:
            out.append(f"number {position.number} outside the position range {first}-{last}")
        return out

    @property
    def buffers(self) -> profile.Buffers:
        return profile.BUFFERS[self.model]

    # --- the interlock and the status bytes ---------------------------------------------

    def not_idle(self) -> list[str]:
        """Every reason the profile's interlock refuses a write now; empty when idle."""
        reasons = (
            (self.mode != AUTO, "MANUAL mode"),
            (self.program_running, "program running"),
            (self.flash_writing, "flash ROM write"),
            (self.emergency_stop, "emergency stop"),
            (not self.ready, "system not ready"),
            (self.critical_error != "000", f"critical error {self.critical_error}"),
            (self.drive_cut_off, "drive source cut off"),
            (self.positioner_mode, "positioner mode"),
            (self.safety_gate_open, "safety gate open"),
        )
        out = [why for applies, why in reasons if applies]
        out += [f"axis {a} in use" for a in sorted(self.axes_in_use)]
        out += [f"axis {a} not reported" for a in sorted(self.unreported_axes)]
        return out

    @property
    def idle(self) -> bool:
        return not self.not_idle()

    def status_bytes(self) -> tuple[int, int, int, int]:
        """215H status bytes 1-4 (p.30-31)."""
        s1 = (
            (0x08 if self.emergency_stop else 0)
            | (0x04 if self.safety_gate_open else 0)
            | (0x01 if self.mode == MANUAL else 0)  # the operation mode switch
        )
        s2 = (0x20 if self.program_running else 0) | (0x01 if self.flash_writing else 0)
        s3 = (
            (0x10 if self.positioner_mode else 0)
            | (0x04 if self.ready else 0)
            | (0x02 if self.program_running else 0)  # operating in AUTO mode
            | (0x01 if self.emergency_stop or self.drive_cut_off else 0)  # drive source cut off
        )
        return s1, s2, s3, 0

    def axis_status(self, axis: int) -> int:
        """212H axis status: home return complete, servo on unless the emergency stop
        cut it, and either in use (bit 0) or the last command completed (bit 4)."""
        servo = 0 if self.emergency_stop else 0x08
        return 0x04 | servo | (0x01 if axis in self.axes_in_use else 0x10)

    # --- mode control ---------------------------------------------------------------------

    def run_program(self) -> None:
        """A program running in AUTO operation, holding every axis."""
        self.program_running = True
        self.axes_in_use = set(self.axes)

    def stop(self) -> None:
        """Idle again: AUTO mode, no program, no flash write, no emergency stop, no
        critical error, drive source on, program mode, the gate closed, every axis
        reported and none in use."""
        self.mode = AUTO
        self.program_running = self.flash_writing = self.emergency_stop = False
        self.drive_cut_off = self.positioner_mode = self.safety_gate_open = False
        self.ready = True
        self.critical_error = self.latest_error = "000"
        self.axes_in_use = set()
        self.unreported_axes = set()

    # --- battery-backed memory ---------------------------------------------------------------

    def memory(self) -> dict[str, object]:
        """What survives a power cycle, as JSON data: the table, the settings, the
        flags and variables (reals as the hex of their IEEE double, exactly)."""
        return {
            "model": self.model,
            "axes": list(self.axes),
            "position_range": list(self.position_range),
            "positions": [
                {
                    "number": p.number,
                    "axes": list(p.axes),
                    "acc": p.acc,
                    "dec": p.dec,
                    "speed": p.speed,
                    "coords": list(p.coords),
                    "arm1": p.arm1,
                    "arm2": p.arm2,
                }
                for p in self.positions.values()
            ],
            "flags": sorted(self.flags),
            "integers": {str(n): v for n, v in sorted(self.integers.items())},
            "reals": {str(n): struct.pack(">d", v).hex() for n, v in sorted(self.reals.items())},
            "real_word_order": self.real_word_order,
            "work_coordinates": {str(n): list(v) for n, v in sorted(self.work_coordinates.items())},
            "tool_coordinates": {str(n): list(v) for n, v in sorted(self.tool_coordinates.items())},
            "strings": {str(n): c for n, c in sorted(self.strings.items())},
            "tables": {name: list(bounds) for name, bounds in sorted(self.tables.items())},
        }

    @classmethod
    def from_memory(
        cls, doc: Mapping[str, object], versions: dict[tuple[int, int], Version]
    ) -> SimState:
        """The controller :meth:`memory` kept, idle.  Raises ValueError, KeyError or
        TypeError for a document that is not one."""
        positions = _memory_positions(_listed(doc, "positions"))
        first, last = (int(str(n)) for n in _listed(doc, "position_range"))
        state = cls(
            {p.number: p for p in positions},
            axes=tuple(int(str(a)) for a in _listed(doc, "axes")),
            model=str(doc["model"]),
            position_range=(first, last),
            versions=dict(versions),
            real_word_order=str(doc.get("real_word_order", profile.DEFAULT_REAL_WORD_ORDER)),
        )
        _memory_records(state, doc)
        state.flags = {int(str(n)) for n in _listed(doc, "flags")}
        state.integers = {int(n): int(str(v)) for n, v in _mapped(doc, "integers").items()}
        state.reals = {
            int(n): struct.unpack(">d", bytes.fromhex(str(v)))[0]
            for n, v in _mapped(doc, "reals").items()
        }
        return state


def _listed(doc: Mapping[str, object], key: str) -> list[object]:
    value = doc[key]
    if not isinstance(value, list):
        raise TypeError(f"{key} is not a list")
    return value


def _mapped(doc: Mapping[str, object], key: str) -> dict[str, object]:
    value = doc[key]
    if not isinstance(value, dict):
        raise TypeError(f"{key} is not a mapping")
    return value


def _memory_positions(items: list[object]) -> list[Position]:
    """The positions :meth:`SimState.memory` kept."""
    positions = []
    for item in items:
        if not isinstance(item, dict):
            raise TypeError("a position is not a mapping")
        positions.append(
            Position(
                int(item["number"]),
                tuple(int(a) for a in item["axes"]),
                str(item["acc"]),
                str(item["dec"]),
                int(item["speed"]),
                tuple(str(c) for c in item["coords"]),
                int(item["arm1"]),
                int(item["arm2"]),
            )
        )
    return positions


def _memory_records(state: SimState, doc: Mapping[str, object]) -> None:
    """The coordinate systems, string variables and table sizes :meth:`SimState.memory`
    kept, into ``state``."""
    for section in ("work_coordinates", "tool_coordinates"):
        table = doc.get(section, {})
        if not isinstance(table, dict):
            raise TypeError(f"{section} is not a mapping")
        setattr(
            state,
            section,
            {int(n): tuple(str(c) for c in v) for n, v in table.items()},
        )
    strings = doc.get("strings", {})
    if not isinstance(strings, dict):
        raise TypeError("strings is not a mapping")
    state.strings = {int(n): int(str(c)) for n, c in strings.items()}
    tables = doc.get("tables", {})
    if not isinstance(tables, dict):
        raise TypeError("tables is not a mapping")
    for name, bounds in tables.items():
        low, high = (int(str(n)) for n in bounds)
        state.tables[str(name)] = (low, high)


def _generate_position(
    rng: random.Random, number: int, axes: tuple[int, ...], scara: bool
) -> Position:
    if rng.random() < 0.75:
        used = axes
    else:
        used = tuple(sorted(rng.sample(axes, rng.randint(1, len(axes) - 1))))
    coords = tuple(
        # a SCARA's 4th axis is its rotation, in 0.001 deg
        _coordinate(
            rng.randint(-180_000, 180_000) if scara and a == 4 else rng.randint(-300_000, 600_000)
        )
        for a in used
    )

    def g() -> str:
        hundredths = 0 if rng.random() < 0.2 else rng.randint(10, 100)
        return f"{hundredths // 100}.{hundredths % 100:02d}"

    speed = 0 if rng.random() < 0.2 else rng.choice((50, 100, 150, 200, 300, 500, 800, 1000))
    arm1 = rng.choice((0, 1, 2)) if scara else 0
    return Position(number, used, g(), g(), speed, coords, arm1, 0)
