"""The simulated IAI controller (protocol B): the controller's side of every
allow-listed message, exactly as the profile says, on the shared simulated line
(:mod:`harlsync.sim`).

How this works::

    '!' frame for one of our stations --> handle(state, frame) --> reply data --> '#' frame
    ('#' or '&' frame: silence)               |
                                      refused: '&' station code SC CR LF  (codes.py)

The line does the decoding: a bad SC, a foreign station, a bad header or a
missing LF never reach :meth:`Simulator.handle`, and get no reply (p.9).  A
well-formed command that cannot be carried out gets an ``&`` reply with one of
the placeholder codes of :mod:`~harlsync.families.iai.sim.codes`:

- any message off the allow-list (motion, servo, program control, resets ...):
  refused and recorded, so a test can assert it was never sent (:meth:`Simulator.off_list`);
- a write (291H, 24BH-24EH) while the controller is not idle by the profile's
  interlock: refused before its data is looked at;
- 291H with a record of axis pattern 00, a coordinate for an axis the robot does
  not have, extended bits 0-3 set, or a number outside the position range:
  nothing of it is written (a 291H is applied whole or not at all);
- a 20DH whose start flag is not a multiple of 8 (the profile's reading of
  "a category's head flag + a multiple of 8", p.22);
- a command larger than the model's receive buffer, or a read whose reply would
  not fit its send buffer; a 22DH reply is cut to the whole records that fit
  instead, its count saying how many.

**(simulator)** The manual does not say what a controller in MANUAL mode does
with a command (p.7 says the protocol runs in AUTO).  This simulator answers
reads in MANUAL mode, reporting mode 2 in 215H, and refuses writes; a real
controller that stays silent instead looks to the client like one that does not
answer, which its interlock also treats as not idle (``manual_mode=silent``).

Where the manual is silent, :data:`VARIANTS` (issue 29) are the other ways a
controller may answer, each read where it answers (:attr:`Simulator.variant`):

- ``past_table``: a query naming a number its table lacks (22DH: a head past or
  before the table; 20DH-20FH, 210H, 2A0H: any number outside) is refused with
  ``&`` and that code, or answered normally with nothing for it: no records, a
  count that stops at the table's end (``empty``).  A 22DH whose head is in the
  table scans to its end either way;
- ``wide_query``: a 22DH asking for more numbers than a read of 8-axis records
  carries scans every one (its reply cut to the whole records that fit), scans
  only that many (``scans-less``: zero records when none is defined there), or is
  refused (``refused``, code 0A3);
- ``count_means``: 22DH's count is the numbers scanned, or the defined records
  returned (``records``: positions past the count's numbers come too);
- ``tables``: the tables' sizes (:func:`resize`): each controller's own
  (``ranges``: positions its range, flags and variables every number their
  message names), exactly the profile's default ranges, smaller or larger;
- ``real_word_order``: how 20FH and 24DH carry a real (p.24);
- ``reply_case``: its replies' hex digits in upper or lower case;
- ``manual_mode``: in MANUAL mode, answer (reads, refusing writes) or stay silent.
"""

from __future__ import annotations

import json
import logging
import os
import struct
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from ....errors import ProjectError, ProjectFormatError
from ....sim import device
from ....sim.device import Refused
from ....sim.family import Verb
from ....sim.variants import Variant
from .. import profile
from ..model import axes_from_pattern, coord_to_wire, pattern_from_axes, real_value
from ..protocol import (
    Frame,
    FrameDecoder,
    max_positions_per_read,
    parse_write_positions,
    position_record,
)
from ..protocol.frame import _FRAME_OVERHEAD, sc
from ..protocol.request import _Fields
from . import codes
from .state import DEFAULT_AXES, MANUAL, SimState

__all__ = ["SIM_FAMILY", "VARIANTS", "IaiSimFamily", "Simulator", "resize"]

#: How a controller may fill the manual's silences, the profile's own way first
#: (:mod:`harlsync.sim.variants`; docs/profile.md lists them).
VARIANTS = (
    Variant(
        "past_table",
        ("refused-0A3", "empty", "refused-0B4"),
        "a query for a number a table lacks: refused with & and that code, or answered empty",
    ),
    Variant(
        "wide_query",
        ("scans-all", "scans-less", "refused"),
        "a 22DH for more numbers than a read of 8-axis records carries: scans them all, "
        "scans only that many, or is refused (& 0A3)",
    ),
    Variant(
        "count_means",
        ("numbers", "records"),
        "22DH's count: the numbers it scans, or the defined records it returns",
    ),
    Variant(
        "tables",
        ("ranges", "exact", "smaller", "larger"),
        "the tables' sizes: the robot's position range and every flag and variable "
        "number, exactly the profile's ranges, smaller than them, or larger",
    ),
    Variant(
        "real_word_order",
        ("upper-first", "lower-first"),
        "how 20FH and 24DH carry a real variable's double (p.24)",
    ),
    Variant("reply_case", ("upper", "lower"), "the case of the hex digits of its replies"),
    Variant(
        "manual_mode",
        ("answers", "silent"),
        "in MANUAL mode: answers reads and refuses writes, or answers nothing",
    ),
)

log = logging.getLogger(__name__)

#: The file a station's battery-backed memory is kept in, in its state directory.
MEMORY_FILE = "memory.json"


class IaiSimFamily:
    """The IAI side of the simulator framework (a :class:`~harlsync.sim.SimFamily`)."""

    name = "iai"
    verbs = (
        Verb("run", "[STATION]", "a program running, holding every axis"),
        Verb("manual", "[STATION]", "MANUAL mode"),
        Verb("estop", "[STATION]", "emergency stop"),
        Verb("flash", "[STATION]", "a flash ROM write in progress"),
        Verb("hold", "[STATION [AXIS]]", "an axis in use (default: the first)"),
        Verb("positioner", "[STATION]", "positioner mode (a PLC moves to position numbers)"),
        Verb("error", "[STATION [CODE]]", "a critical error (default code 0E1)"),
        Verb("cutoff", "[STATION]", "the drive source cut off"),
        Verb("gate", "[STATION]", "the safety gate open (a TTA: the enable switch)"),
        Verb("unplug", "[STATION [AXIS]]", "212H leaves an axis out (default: the first)"),
        Verb("stop", "[STATION]", "idle: AUTO mode, no program, nothing held"),
    )
    busy_verb = "run"
    default_station = profile.DEFAULT_STATION
    #: how it may fill its manual's silences (harlsync.sim.variants); the profile's first
    variants: tuple[Variant, ...] = VARIANTS

    def decoder(self) -> FrameDecoder:
        return FrameDecoder()

    def generate(self, seed: int, stations: Sequence[int]) -> Simulator:
        return Simulator({n: SimState.generate(seed + i) for i, n in enumerate(stations)})

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Simulator:
        """The robot of an IAI project: its table, axes (robot.yaml's, else the
        default), model, position range and version."""
        from ....project import load_project
        from ..layout import position_range

        loaded = load_project(project)
        robot, data = loaded.robot, loaded.data
        try:
            states = {
                number: SimState.from_positions(
                    data.positions,
                    axes=robot.options.get("axes") or DEFAULT_AXES,
                    model=data.model,
                    position_range=position_range(robot),
                    version=data.version,
                )
                for number in stations or [robot.station]
            }
            for state in states.values():  # the flags and variables, when the project keeps them
                state.work_coordinates = dict(data.work_coordinates or {})
                state.tool_coordinates = dict(data.tool_coordinates or {})
                state.strings = {
                    start + i: int(row[2 * i : 2 * i + 2], 16)
                    for start, row in (data.strings or {}).items()
                    for i in range(len(row) // 2)
                }
                state.real_word_order = str(
                    robot.options.get("real_word_order", profile.DEFAULT_REAL_WORD_ORDER)
                )
                state.flags = {n for n, on in (data.flags or {}).items() if on}
                state.integers = dict(data.integers or {})
                state.reals = {n: real_value(text) for n, text in (data.reals or {}).items()}
        except ValueError as exc:
            raise ProjectError(f"{project}: the simulator cannot hold this robot: {exc}") from exc
        return Simulator(states)


SIM_FAMILY = IaiSimFamily()

Handler = Callable[["Simulator", SimState, str], str]

#: The control verbs that switch one condition of the controller on, and its field.
_SWITCHES = {
    "estop": "emergency_stop",
    "flash": "flash_writing",
    "positioner": "positioner_mode",
    "cutoff": "drive_cut_off",
    "gate": "safety_gate_open",
}

#: The critical error the ``error`` verb sets when given no code: a placeholder (the
#: manual's error list is not in our pages), like the codes of :mod:`.codes`.
CRITICAL_ERROR = "0E1"


class Simulator(device.Simulator[SimState, Frame]):
    """A simulated IAI controller: one serial line and the controllers (stations) on it.

    ``busy_after_writes`` starts a program on the written station once that many
    writes have been carried out.
    """

    family = SIM_FAMILY

    # --- the line's hooks -----------------------------------------------------------------

    def respond(self, station: int, state: SimState, frame: Frame) -> bytes | None:
        if frame.kind != "!":
            return None  # a reply or an error is no command: a bad header (p.9)
        if state.mode == MANUAL and self.variant["manual_mode"] == "silent":
            return None
        try:
            reply = Frame("#", station, frame.message_id, self.handle(state, frame))
        except Refused as refusal:
            reply = Frame("&", station, None, refusal.code)
        encoded = reply.encode()
        return _lower_case(encoded) if self.variant["reply_case"] == "lower" else encoded

    def vary(self, chosen: Mapping[str, str]) -> None:
        """As :meth:`~harlsync.sim.device.Device.vary`; a ``tables`` or
        ``real_word_order`` chosen reshapes every station's state now (their tables,
        and what lies outside them dropped; the order its reals are kept in)."""
        super().vary(chosen)
        given = {name.strip().replace("-", "_") for name in chosen}
        for state in self.stations.values():
            if "tables" in given:
                resize(state, self.variant["tables"])
            if "real_word_order" in given:
                state.real_word_order = self.variant["real_word_order"]

    def _not_there(self) -> str | None:
        """The code of the ``&`` a number a table lacks answers, None: an empty reply."""
        chosen = self.variant["past_table"]
        return chosen.split("-", 1)[1] if chosen.startswith("refused-") else None

    def _within(self, state: SimState, section: str, start: int, count: int) -> int:
        """How many of ``count`` numbers from ``start`` the reply answers for: all,
        or those up to the table's end (an empty reply past it); raises Refused when
        the controller refuses numbers its table lacks."""
        low, high = state.tables[section]
        code = self._not_there()
        inside = low <= start <= high
        if inside and start + count - 1 <= high:
            return count
        if code is not None:
            raise Refused(code)
        return high - start + 1 if inside else 0

    def command(self, frame: Frame) -> str:
        return frame.payload[:3]

    def is_write(self, frame: Frame) -> bool:
        return frame.message_id in profile.WRITE_MESSAGE_IDS

    def busy(self, state: SimState) -> bool:
        return not state.idle

    def corrupt_checksum(self, frame: bytes) -> bytes:
        wrong = int(frame[-4:-2], 16) ^ 0x5A  # the SC: two hex digits before CR LF
        return frame[:-4] + f"{wrong:02X}".encode("ascii") + frame[-2:]

    def control(self, verb: str, state: SimState, args: Sequence[str]) -> None:
        if verb in ("hold", "unplug"):
            axis = int(args[0]) if args else state.axes[0]
            if axis not in state.axes:
                raise ValueError(f"no axis {axis} (the robot has {list(state.axes)})")
            (state.axes_in_use if verb == "hold" else state.unreported_axes).add(axis)
        elif verb == "error":
            code = (args[0] if args else CRITICAL_ERROR).upper()
            if len(code) != 3 or not all(c in "0123456789ABCDEF" for c in code) or code == "000":
                raise ValueError(f"error code {code!r}: three hex digits, not 000")
            state.critical_error = state.latest_error = code
        elif args:
            raise ValueError(f"{verb} takes only a station")
        elif verb == "run":
            state.run_program()
        elif verb == "manual":
            state.mode = MANUAL
        elif verb in _SWITCHES:
            setattr(state, _SWITCHES[verb], True)
        elif verb == "stop":
            state.stop()
        else:
            raise ValueError(f"unknown command {verb!r}")

    def describe(self, state: SimState) -> str:
        return ", ".join(state.not_idle()) or "idle"

    def save_station(self, station: int, directory: Path) -> None:
        """Write the station's table, flags and variables to ``directory/memory.json``
        (a new file renamed over the old one: a kill never leaves half of it)."""
        directory.mkdir(parents=True, exist_ok=True)
        target = directory / MEMORY_FILE
        temp = directory / f".{MEMORY_FILE}.{os.getpid()}"
        temp.write_text(json.dumps(self.stations[station].memory(), indent=1) + "\n")
        os.replace(temp, target)

    def load_station(self, station: int, directory: Path) -> bool:
        path = directory / MEMORY_FILE
        if not path.exists():
            return False
        old = self.stations[station]
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
            self.stations[station] = SimState.from_memory(doc, old.versions)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ProjectFormatError(f"{path}: not a simulator memory: {exc}") from exc
        return True

    # --- the controller ---------------------------------------------------------------------

    def handle(self, state: SimState, frame: Frame) -> str:
        """The reply data to one command for one controller.  Raises :class:`~harlsync.sim.Refused`."""
        assert frame.message_id is not None  # a '!' frame always has one
        handler = _HANDLERS.get(frame.message_id)
        if handler is None or frame.message_id not in profile.ALLOWED_MESSAGE_IDS:
            log.warning(
                "sim: station %02X got message %03XH, which is off the allow-list",
                frame.station,
                frame.message_id,
            )
            raise Refused(codes.NOT_SUPPORTED)
        if _FRAME_OVERHEAD + len(frame.data) > state.buffers.receive:
            raise Refused(codes.TOO_LONG)
        if frame.message_id in profile.WRITE_MESSAGE_IDS and not state.idle:
            raise Refused(codes.NOT_IDLE)
        try:
            reply = handler(self, state, frame.data)
        except ValueError:
            raise Refused(codes.BAD_DATA) from None
        if _FRAME_OVERHEAD + len(reply) > state.buffers.send:
            raise Refused(codes.TOO_LONG)
        return reply

    def _version(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        unit, number = f.hex(2, "unit type"), f.hex(1, "device number")
        f.end()
        found = state.versions.get((unit, number))
        if found is None:
            raise Refused(codes.BAD_DATA)
        day, clock = found.built.split(" ")
        year, month, mday = (int(x) for x in day.split("-"))
        hour, minute, second = (int(x) for x in clock.split(":"))
        built = f"{year:04X}" + "".join(f"{n:02X}" for n in (month, mday, hour, minute, second))
        return f"{unit:02X}{number:X}{found.model_code}{found.unit_code}{found.version}{built}"

    def _system_status(self, state: SimState, data: str) -> str:
        _Fields(data).end()
        status = "".join(f"{b:02X}" for b in state.status_bytes())
        return f"{state.mode:X}{state.critical_error}{state.latest_error}{status}"

    def _axis_status(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        pattern = f.hex(2, "axis pattern")
        f.end()
        if not pattern:
            raise Refused(codes.PATTERN_ZERO)
        # An axis the robot does not have is left out: "driver not connected" (p.27);
        # so is one unplugged (the ``unplug`` verb).
        reported = tuple(
            a
            for a in axes_from_pattern(pattern)
            if a in state.axes and a not in state.unreported_axes
        )
        sensors, error, encoder = 0, "000", 0
        return f"{pattern_from_axes(reported):02X}" + "".join(
            f"{state.axis_status(a):02X}{sensors:X}{error}{encoder:02X}"
            f"{coord_to_wire(state.current[a])}"
            for a in reported
        )

    def _read_positions(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        f.expect(2, 0, "reserved field")
        head, count = f.hex(4, "head position"), f.hex(4, "position count")
        f.end()
        if not count:
            raise ValueError("no position")
        low, high = state.position_range
        if not low <= head <= high:
            code = self._not_there()
            if code is not None:
                raise Refused(code)
            return "000000"
        limit = max_positions_per_read(state.model)
        if count > limit and self.variant["wide_query"] == "refused":
            raise Refused(codes.TOO_LONG)
        if count > limit and self.variant["wide_query"] == "scans-less":
            count = limit
        defined = sorted(n for n in state.positions if head <= n <= high)
        if self.variant["count_means"] == "records":
            wanted = defined[:count]
        else:
            wanted = [n for n in defined if n < head + count]
        room = state.buffers.send - _FRAME_OVERHEAD - len("00") - len("0000")
        records = []
        for number in wanted:
            record = position_record(state.positions[number], numbered=True)
            if len(record) > room:
                break  # only whole records that fit: the count says how many
            room -= len(record)
            records.append(record)
        return f"00{len(records):04X}" + "".join(records)

    def _write_positions(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        f.expect(2, 0, "reserved field")
        f.hex(4, "start position")
        count = f.hex(4, "position count")
        if not count:
            raise ValueError("no position")
        for i in range(count):  # each record checked before any is written
            axes = axes_from_pattern(f.hex(2, f"record {i} axis pattern"))
            if not axes:
                raise Refused(codes.PATTERN_ZERO)
            if not set(axes) <= set(state.axes):
                raise Refused(codes.NO_AXIS)
            f.take(12 + 8 * len(axes), f"record {i} values")
            if f.hex(2, f"record {i} extended data") & 0x0F:
                raise Refused(codes.EXTENDED_BITS)
        _, positions = parse_write_positions(data)
        first, last = state.position_range
        if not all(first <= p.number <= last for p in positions):
            raise Refused(codes.OUT_OF_RANGE)
        state.positions.update((p.number, p) for p in positions)
        self.wrote(state)
        return f"00{len(positions):04X}"

    def _read_flags(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        program, start, count = f.hex(2, "program"), f.hex(4, "start flag"), f.hex(4, "count")
        f.end()
        _global(program, count)
        if start % profile.FLAG_QUERY_ALIGNMENT:
            raise ValueError("20DH starts at a category's head flag + a multiple of 8 (p.22)")
        count = self._within(state, "flags", start, count)
        octets = (
            sum(1 << i for i in range(8) if k + i < count and start + k + i in state.flags)
            for k in range(0, count, 8)
        )
        return f"{program:02X}{start:04X}{count:04X}" + "".join(f"{o:02X}" for o in octets)

    def _read_integers(self, state: SimState, data: str) -> str:
        program, start, count = _variables(_Fields(data), end=True)
        count = self._within(state, "integers", start, count)
        values = (state.integers.get(n, 0) & 0xFFFFFFFF for n in range(start, start + count))
        return f"{program:02X}{start:03X}{count:02X}" + "".join(f"{v:08X}" for v in values)

    def _read_reals(self, state: SimState, data: str) -> str:
        program, start, count = _variables(_Fields(data), end=True)
        count = self._within(state, "reals", start, count)
        values = (state.reals.get(n, 0.0) for n in range(start, start + count))
        return f"{program:02X}{start:03X}{count:02X}" + "".join(
            _real_wire(v, state.real_word_order) for v in values
        )

    def _read_coordinate_systems(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        kind, head, count = f.hex(1, "type"), f.hex(2, "head number"), f.hex(2, "count")
        f.end()
        if kind not in (0, 1) or not count or head + count > 0x100:
            raise ValueError("type 0 (work) or 1 (tool), at least one, numbers 00-FF")
        count = self._within(state, ("work_coordinates", "tool_coordinates")[kind], head, count)
        table = state.work_coordinates if kind == 0 else state.tool_coordinates
        records = "".join(
            "".join(coord_to_wire(c) for c in table.get(n, ("0.000",) * 4))
            for n in range(head, head + count)
        )
        return f"{kind:X}{head:02X}{count:02X}{records}"

    def _read_strings(self, state: SimState, data: str) -> str:
        program, start, count = _variables(_Fields(data), end=True)
        count = self._within(state, "strings", start, count)
        codes = "".join(f"{state.strings.get(n, 0):02X}" for n in range(start, start + count))
        return f"{program:02X}{start:03X}{count:02X}{codes}"

    def _write_flag(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        program, number, change = f.hex(2, "program"), f.hex(4, "flag"), f.hex(1, "change")
        f.end()
        _global(program, 1)
        if change & 0x0E:
            raise ValueError("change type bits 1-3 are reserved")
        _inside(state, "flags", number, 1)
        if change & 1:
            state.flags.add(number)
        else:
            state.flags.discard(number)
        self.wrote(state)
        return ""

    def _write_strings(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        _, start, count = _variables(f)
        values = [f.hex(2, f"column {start + i}") for i in range(count)]
        f.end()
        _inside(state, "strings", start, count)
        state.strings.update((start + i, code) for i, code in enumerate(values))
        self.wrote(state)
        return ""

    def _write_integers(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        program, start, count = _variables(f)
        values = [f.hex(8, f"variable {start + i}") for i in range(count)]
        f.end()
        _inside(state, "integers", start, count)
        state.integers.update(
            (start + i, v - (1 << 32) if v & 0x80000000 else v) for i, v in enumerate(values)
        )
        self.wrote(state)
        return f"{program:02X}{start:03X}{count:02X}"

    def _write_reals(self, state: SimState, data: str) -> str:
        f = _Fields(data)
        program, start, count = _variables(f)
        values = [
            _real_value(f.take(16, f"variable {start + i}"), state.real_word_order)
            for i in range(count)
        ]
        f.end()
        _inside(state, "reals", start, count)
        state.reals.update((start + i, v) for i, v in enumerate(values))
        self.wrote(state)
        return f"{program:02X}{start:03X}{count:02X}"

    # --- for tests -----------------------------------------------------------------------------

    def off_list(self) -> list[device.Received]:
        """Every request received whose message is off the profile's allow-list."""
        with self.lock:
            return [
                r for r in self.received if int(r.command, 16) not in profile.ALLOWED_MESSAGE_IDS
            ]

    def writes_while_busy(self) -> list[device.Received]:
        """Every write received while the controller was not idle (each one refused)."""
        return [r for r in self.writes_received() if r.busy]


def _real_wire(value: float, order: str) -> str:
    """A double as 20FH sends it (p.24), written here from the manual's words, not
    with the client's codec: big endian, or its lower 4 bytes first."""
    digits = struct.pack(">d", value).hex().upper()
    return digits[8:] + digits[:8] if order == "lower-first" else digits


def _real_value(wire: str, order: str) -> float:
    digits = wire[8:] + wire[:8] if order == "lower-first" else wire
    value: float = struct.unpack(">d", bytes.fromhex(digits))[0]
    return value


def _lower_case(frame: bytes) -> bytes:
    """A reply frame with its hex digits in lower case, and its SC summed over them."""
    body = frame[:-4].lower()
    return body + f"{sc(body):02x}".encode("ascii") + b"\r\n"


def _inside(state: SimState, section: str, start: int, count: int) -> None:
    """A write to numbers the table lacks is refused (nothing of it written)."""
    low, high = state.tables[section]
    if not low <= start <= start + count - 1 <= high:
        raise Refused(codes.OUT_OF_RANGE)


#: The flag and variable tables of ``tables=smaller`` and ``tables=larger``.
_SMALLER = {"flags": (600, 799), "integers": (200, 265), "reals": (300, 365)}
_LARGER = {"flags": (0, 1199), "integers": (1, 1299), "reals": (1, 1399)}


def resize(state: SimState, size: str) -> None:
    """Give ``state`` the tables of the ``tables`` variant ``size`` and drop what
    lies outside them: ``ranges`` leaves it as it is; ``exact`` makes flags and
    integer and real variables the profile's default ranges; ``smaller`` makes
    each table smaller than the profile's (its position range three fifths as
    long); ``larger`` larger (twice as long).  Raises ValueError for another size."""
    first, last = state.position_range
    length = last - first + 1
    if size == "ranges":
        return
    if size == "exact":
        state.tables.update(profile.DEFAULT_VARIABLE_RANGES)
    elif size == "smaller":
        state.tables.update(_SMALLER)
        state.position_range = (first, first + max(1, length * 3 // 5) - 1)
    elif size == "larger":
        state.tables.update(_LARGER)
        state.position_range = (first, min(0xFFFF, first + 2 * length - 1))
    else:
        raise ValueError(f"tables {size}: one of ranges, exact, smaller, larger")
    low, high = state.position_range
    state.positions = {n: p for n, p in state.positions.items() if low <= n <= high}

    def inside(section: str, n: int) -> bool:
        low, high = state.tables[section]
        return low <= n <= high

    state.flags = {n for n in state.flags if inside("flags", n)}
    state.integers = {n: v for n, v in state.integers.items() if inside("integers", n)}
    state.reals = {n: v for n, v in state.reals.items() if inside("reals", n)}


def _global(program: int, count: int) -> None:
    """Only the global flags and variables (program 00), at least one of them."""
    if program or not count:
        raise ValueError(f"program {program:02X}, count {count}: global and at least one")


def _variables(f: _Fields, *, end: bool = False) -> tuple[int, int, int]:
    """Program, start and count of a variable query or change (20EH, 20FH, 24CH, 24DH)."""
    program, start, count = f.hex(2, "program"), f.hex(3, "start"), f.hex(2, "count")
    if end:
        f.end()
    _global(program, count)
    return program, start, count


_HANDLERS: dict[int, Handler] = {
    0x201: Simulator._version,
    0x215: Simulator._system_status,
    0x212: Simulator._axis_status,
    0x22D: Simulator._read_positions,
    0x291: Simulator._write_positions,
    0x20D: Simulator._read_flags,
    0x20E: Simulator._read_integers,
    0x20F: Simulator._read_reals,
    0x24B: Simulator._write_flag,
    0x24C: Simulator._write_integers,
    0x24D: Simulator._write_reals,
    0x2A0: Simulator._read_coordinate_systems,
    0x210: Simulator._read_strings,
    0x24E: Simulator._write_strings,
}
