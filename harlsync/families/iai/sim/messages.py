"""What the simulated IAI controller answers to each allow-listed message (protocol
B): the reply data to one command's data, or :class:`~harlsync.sim.Refused` with
a placeholder code of :mod:`.codes`.  :meth:`.device.Simulator.handle` checks
the allow-list, the buffers and the interlock, then calls the message's handler
in :data:`HANDLERS`; the variants chosen (:data:`.device.VARIANTS`) say how it
fills the manual's silences.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Protocol

from ....sim.device import Refused
from .. import profile
from ..model import axes_from_pattern, coord_to_wire, pattern_from_axes
from ..protocol import max_positions_per_read, parse_write_positions, position_record
from ..protocol.frame import _FRAME_OVERHEAD
from ..protocol.request import _Fields
from . import codes
from .state import SimState

__all__ = ["HANDLERS", "Handler", "Line"]


class Line(Protocol):
    """What a handler asks of the simulator: the variants chosen, and to count a
    write carried out (:meth:`~harlsync.sim.device.Device.wrote`)."""

    variant: dict[str, str]

    def wrote(self, state: SimState) -> None: ...


#: A message's handler: the simulator, the station's state and the command's
#: data -> the reply's data.
Handler = Callable[[Line, SimState, str], str]


def _not_there(sim: Line) -> str | None:
    """The code of the ``&`` a number a table lacks answers, None: an empty reply."""
    chosen = sim.variant["past_table"]
    return chosen.split("-", 1)[1] if chosen.startswith("refused-") else None


def _within(sim: Line, state: SimState, section: str, start: int, count: int) -> int:
    """How many of ``count`` numbers from ``start`` the reply answers for: all,
    or those up to the table's end (an empty reply past it); raises Refused when
    the controller refuses numbers its table lacks."""
    low, high = state.tables[section]
    code = _not_there(sim)
    inside = low <= start <= high
    if inside and start + count - 1 <= high:
        return count
    if code is not None:
        raise Refused(code)
    return high - start + 1 if inside else 0


def _version(sim: Line, state: SimState, data: str) -> str:
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


def _system_status(sim: Line, state: SimState, data: str) -> str:
    _Fields(data).end()
    status = "".join(f"{b:02X}" for b in state.status_bytes())
    return f"{state.mode:X}{state.critical_error}{state.latest_error}{status}"


def _axis_status(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    pattern = f.hex(2, "axis pattern")
    f.end()
    if not pattern:
        raise Refused(codes.PATTERN_ZERO)
    # An axis the robot does not have is left out: "driver not connected" (p.27);
    # so is one unplugged (the ``unplug`` verb).
    reported = tuple(
        a for a in axes_from_pattern(pattern) if a in state.axes and a not in state.unreported_axes
    )
    sensors, error, encoder = 0, "000", 0
    return f"{pattern_from_axes(reported):02X}" + "".join(
        f"{state.axis_status(a):02X}{sensors:X}{error}{encoder:02X}"
        f"{coord_to_wire(state.current[a])}"
        for a in reported
    )


def _read_positions(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    f.expect(2, 0, "reserved field")
    head, count = f.hex(4, "head position"), f.hex(4, "position count")
    f.end()
    if not count:
        raise ValueError("no position")
    low, high = state.position_range
    if not low <= head <= high:
        code = _not_there(sim)
        if code is not None:
            raise Refused(code)
        return "000000"
    limit = max_positions_per_read(state.model)
    if count > limit and sim.variant["wide_query"] == "refused":
        raise Refused(codes.TOO_LONG)
    if count > limit and sim.variant["wide_query"] == "scans-less":
        count = limit
    defined = sorted(n for n in state.positions if head <= n <= high)
    if sim.variant["count_means"] == "records":
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


def _write_positions(sim: Line, state: SimState, data: str) -> str:
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
    sim.wrote(state)
    return f"00{len(positions):04X}"


def _read_flags(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    program, start, count = f.hex(2, "program"), f.hex(4, "start flag"), f.hex(4, "count")
    f.end()
    _global(program, count)
    if start % profile.FLAG_QUERY_ALIGNMENT:
        raise ValueError("20DH starts at a category's head flag + a multiple of 8 (p.22)")
    count = _within(sim, state, "flags", start, count)
    octets = (
        sum(1 << i for i in range(8) if k + i < count and start + k + i in state.flags)
        for k in range(0, count, 8)
    )
    return f"{program:02X}{start:04X}{count:04X}" + "".join(f"{o:02X}" for o in octets)


def _read_integers(sim: Line, state: SimState, data: str) -> str:
    program, start, count = _variables(_Fields(data), end=True)
    count = _within(sim, state, "integers", start, count)
    values = (state.integers.get(n, 0) & 0xFFFFFFFF for n in range(start, start + count))
    return f"{program:02X}{start:03X}{count:02X}" + "".join(f"{v:08X}" for v in values)


def _read_reals(sim: Line, state: SimState, data: str) -> str:
    program, start, count = _variables(_Fields(data), end=True)
    count = _within(sim, state, "reals", start, count)
    values = (state.reals.get(n, 0.0) for n in range(start, start + count))
    return f"{program:02X}{start:03X}{count:02X}" + "".join(
        _real_wire(v, state.real_word_order) for v in values
    )


def _read_coordinate_systems(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    kind, head, count = f.hex(1, "type"), f.hex(2, "head number"), f.hex(2, "count")
    f.end()
    if kind not in (0, 1) or not count or head + count > 0x100:
        raise ValueError("type 0 (work) or 1 (tool), at least one, numbers 00-FF")
    count = _within(sim, state, ("work_coordinates", "tool_coordinates")[kind], head, count)
    table = state.work_coordinates if kind == 0 else state.tool_coordinates
    records = "".join(
        "".join(coord_to_wire(c) for c in table.get(n, ("0.000",) * 4))
        for n in range(head, head + count)
    )
    return f"{kind:X}{head:02X}{count:02X}{records}"


def _read_strings(sim: Line, state: SimState, data: str) -> str:
    program, start, count = _variables(_Fields(data), end=True)
    count = _within(sim, state, "strings", start, count)
    codes = "".join(f"{state.strings.get(n, 0):02X}" for n in range(start, start + count))
    return f"{program:02X}{start:03X}{count:02X}{codes}"


def _write_flag(sim: Line, state: SimState, data: str) -> str:
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
    sim.wrote(state)
    return ""


def _write_strings(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    _, start, count = _variables(f)
    values = [f.hex(2, f"column {start + i}") for i in range(count)]
    f.end()
    _inside(state, "strings", start, count)
    state.strings.update((start + i, code) for i, code in enumerate(values))
    sim.wrote(state)
    return ""


def _write_integers(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    program, start, count = _variables(f)
    values = [f.hex(8, f"variable {start + i}") for i in range(count)]
    f.end()
    _inside(state, "integers", start, count)
    state.integers.update(
        (start + i, v - (1 << 32) if v & 0x80000000 else v) for i, v in enumerate(values)
    )
    sim.wrote(state)
    return f"{program:02X}{start:03X}{count:02X}"


def _write_reals(sim: Line, state: SimState, data: str) -> str:
    f = _Fields(data)
    program, start, count = _variables(f)
    values = [
        _real_value(f.take(16, f"variable {start + i}"), state.real_word_order)
        for i in range(count)
    ]
    f.end()
    _inside(state, "reals", start, count)
    state.reals.update((start + i, v) for i, v in enumerate(values))
    sim.wrote(state)
    return f"{program:02X}{start:03X}{count:02X}"


def _real_wire(value: float, order: str) -> str:
    """A double as 20FH sends it (p.24), written here from the manual's words, not
    with the client's codec: big endian, or its lower 4 bytes first."""
    digits = struct.pack(">d", value).hex().upper()
    return digits[8:] + digits[:8] if order == "lower-first" else digits


def _real_value(wire: str, order: str) -> float:
    digits = wire[8:] + wire[:8] if order == "lower-first" else wire
    value: float = struct.unpack(">d", bytes.fromhex(digits))[0]
    return value


def _inside(state: SimState, section: str, start: int, count: int) -> None:
    """A write to numbers the table lacks is refused (nothing of it written)."""
    low, high = state.tables[section]
    if not low <= start <= start + count - 1 <= high:
        raise Refused(codes.OUT_OF_RANGE)


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


#: Each allow-listed message's handler.
HANDLERS: dict[int, Handler] = {
    0x201: _version,
    0x215: _system_status,
    0x212: _axis_status,
    0x22D: _read_positions,
    0x291: _write_positions,
    0x20D: _read_flags,
    0x20E: _read_integers,
    0x20F: _read_reals,
    0x24B: _write_flag,
    0x24C: _write_integers,
    0x24D: _write_reals,
    0x2A0: _read_coordinate_systems,
    0x210: _read_strings,
    0x24E: _write_strings,
}
