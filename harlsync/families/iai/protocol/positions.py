"""Requests for the position table (22DH, 291H) and how many fit a frame."""

from collections.abc import Sequence

from .. import profile
from ..model import (
    Position,
    arms_from_extended,
    axes_from_pattern,
    coord_from_wire,
    coord_from_word,
    coord_to_wire,
    extended_from_arms,
    g_from_units,
    g_from_wire,
    g_to_wire,
    pattern_from_axes,
    speed_from_wire,
    speed_to_wire,
)
from .frame import (
    _FLAGS_OVERHEAD,
    _HEX_RE,
    _READ_OVERHEAD,
    _VARIABLE_WIDTH,
    _VARIABLES_MAX,
    _VARIABLES_OVERHEAD,
    _WRITE_OVERHEAD,
)
from .request import Request, _check, _Fields

# --- 22DH, 291H: positions ----------------------------------------------------------


def _buffers(model: str) -> profile.Buffers:
    buffers = profile.BUFFERS.get(model)
    if buffers is None:
        raise ValueError(f"unknown IAI model {model!r} (known: {', '.join(profile.BUFFERS)})")
    return buffers


def max_positions_per_read(model: str) -> int:
    """How many position numbers one 22DH may ask for on ``model``: as many as fit
    the send buffer if every one held 8 axes.

    Raises :class:`ValueError` for a model the profile does not know (so do the
    other ``max_*`` functions).
    """
    return (_buffers(model).send - _READ_OVERHEAD) // profile.READ_RECORD_MAX


def max_positions_per_write(model: str) -> int:
    """The most positions one 291H may carry to ``model``'s receive buffer, if every
    one held 8 axes."""
    return (_buffers(model).receive - _WRITE_OVERHEAD) // profile.WRITE_RECORD_MAX


def max_flags_per_read(model: str) -> int:
    """How many flags one 20DH may ask for on ``model``: the whole bytes of 8 flags
    its reply can carry in the send buffer (a multiple of 8, so that queries which
    follow one another stay aligned)."""
    return (_buffers(model).send - _FLAGS_OVERHEAD) // 2 * 8


def max_variables_per_read(model: str, kind: str) -> int:
    """How many ``kind`` (``"integers"`` or ``"reals"``) variables one 20EH/20FH
    reply can carry in ``model``'s send buffer (at most 255)."""
    room = _buffers(model).send - _VARIABLES_OVERHEAD
    return min(_VARIABLES_MAX, room // _VARIABLE_WIDTH[kind])


def max_variables_per_write(model: str, kind: str) -> int:
    """How many ``kind`` (``"integers"`` or ``"reals"``) variables one 24CH/24DH may
    carry to ``model``'s receive buffer (at most 255)."""
    room = _buffers(model).receive - _VARIABLES_OVERHEAD
    return min(_VARIABLES_MAX, room // _VARIABLE_WIDTH[kind])


def position_fields(position: Position, *, numbered: bool) -> list[str]:
    """One position's record, field by field (pattern, acc, dec, speed, coordinates,
    extended; the number first when ``numbered``).

    Raises :class:`ValueError` naming every problem of a position the wire cannot carry.
    """
    problems = position.problems()
    if problems:
        raise ValueError(f"position {position.number}: {'; '.join(problems)}")
    return [
        *([f"{position.number:04X}"] if numbered else []),
        f"{pattern_from_axes(position.axes):02X}",
        g_to_wire(position.acc, "acceleration"),
        g_to_wire(position.dec, "deceleration"),
        speed_to_wire(position.speed),
        *(coord_to_wire(c) for c in position.coords),
        f"{extended_from_arms(position.arm1, position.arm2):02X}",
    ]


def position_record(position: Position, *, numbered: bool) -> str:
    """One position as record text: 22DH's form with the number in front
    (``numbered``), 291H's without.

    Raises :class:`ValueError` naming every problem of a position the wire cannot carry.
    """
    return "".join(position_fields(position, numbered=numbered))


def _take_position(f: _Fields, number: int | None) -> Position:
    if number is None:
        number = f.hex(4, "position number")
    what = f"position {number}"
    axes = axes_from_pattern(f.hex(2, f"{what} axis pattern"))
    acc = g_from_wire(f.take(4, f"{what} acceleration"))
    dec = g_from_wire(f.take(4, f"{what} deceleration"))
    speed = speed_from_wire(f.take(4, f"{what} speed"))
    coords = tuple(coord_from_wire(f.take(8, f"{what} axis {a}")) for a in axes)
    arm1, arm2 = arms_from_extended(f.hex(2, f"{what} extended data"))
    return Position(number, axes, acc, dec, speed, coords, arm1, arm2)


#: Each axis pattern's axes, lowest first, for the 22DH reply's records.
_PATTERN_AXES = tuple(axes_from_pattern(pattern) for pattern in range(0x100))
#: A 22DH record: number, pattern, acc, dec, speed (18 characters), then 8 per
#: coordinate, then the extended data (2).
_RECORD_HEAD = 18


def _positions_in(data: str, head: int, count: int) -> tuple[Position, ...] | None:
    """The positions of a 22DH reply that reads as one, records in ascending number
    order as controllers send them, in one pass over the data (hex checked once for
    all of it); None for anything else, which :func:`read_positions`'s field-by-field
    reading then takes, and names what is wrong with.  The same positions either way
    (tests/families/iai/test_protocol.py proves it on random replies)."""
    if data[:2] != "00" or not _HEX_RE.fullmatch(data):
        return None
    records = int(data[2:6], 16)
    if records > count:
        return None
    size, at, previous, out = len(data), 6, head - 1, []
    for _ in range(records):
        coords_at = at + _RECORD_HEAD
        if coords_at > size:
            return None
        number = int(data[at : at + 4], 16)
        if not previous < number:
            return None
        axes = _PATTERN_AXES[int(data[at + 4 : at + 6], 16)]
        end = coords_at + 8 * len(axes) + 2
        if end > size:
            return None
        extended = int(data[end - 2 : end], 16)
        if extended & 0x0F:
            return None
        out.append(
            Position(
                number,
                axes,
                g_from_units(int(data[at + 6 : at + 10], 16)),
                g_from_units(int(data[at + 10 : at + 14], 16)),
                int(data[at + 14 : coords_at], 16),
                tuple(
                    coord_from_word(int(data[i : i + 8], 16)) for i in range(coords_at, end - 2, 8)
                ),
                extended >> 4 & 3,
                extended >> 6 & 3,
            )
        )
        previous, at = number, end
    return tuple(out) if at == size else None


def read_positions(
    head: int, count: int, send_buffer: int | None = None
) -> Request[tuple[Position, ...]]:
    """22DH: the defined positions among ``count`` numbers from ``head``, by number.

    An undefined position is absent from the reply.  Size ``count`` with
    :func:`max_positions_per_read` so that a reply is never cut; a probe that
    asks for more gives the model's ``send_buffer``, the longest reply it can get.
    Whether ``count`` counts the numbers scanned or the records returned is not
    said (digest 7.7): a controller that counts records may answer positions past
    the ``count`` numbers, in ascending order; they are returned too, and the
    reader keeps those it asked for.
    """
    _check(head, 1, 0xFFFF, "head position")
    _check(count, 1, 0xFFFF - head + 1, "position count")

    def parse(data: str) -> tuple[Position, ...]:
        quick = _positions_in(data, head, count)
        if quick is not None:
            return quick
        f = _Fields(data)
        f.expect(2, 0, "reserved field")
        records = f.hex(4, "number of records")
        if records > count:
            raise ValueError(f"{records} records, asked for {count} positions")
        out: dict[int, Position] = {}
        for _ in range(records):
            position = _take_position(f, None)
            if position.number < head:
                raise ValueError(f"position {position.number} was not asked for")
            if position.number in out:
                raise ValueError(f"position {position.number} twice")
            out[position.number] = position
        f.end()
        return tuple(out[n] for n in sorted(out))

    reply = _READ_OVERHEAD + profile.READ_RECORD_MAX * count
    if send_buffer is not None:
        reply = min(reply, send_buffer)
    return Request(0x22D, f"00{head:04X}{count:04X}", False, False, parse, reply)


def write_positions(start: int, positions: Sequence[Position]) -> Request[int]:
    """291H: write consecutive positions ``start``, ``start + 1`` ...

    The reply gives the number of positions written.  Raises :class:`ValueError`
    for no positions, numbers that do not run on from ``start``, or a position
    the wire cannot carry.  Check :attr:`Request.frame_size` against the model's
    receive buffer.
    """
    count = len(positions)
    _check(start, 1, 0xFFFF, "start position")
    _check(count, 1, 0xFFFF - start + 1, "position count")
    for offset, position in enumerate(positions):
        if position.number != start + offset:
            raise ValueError(
                f"position {position.number} where {start + offset} was due: "
                "291H writes consecutive positions"
            )
    records = "".join(position_record(p, numbered=False) for p in positions)

    def parse(data: str) -> int:
        f = _Fields(data)
        f.expect(2, 0, "reserved field")
        written = f.hex(4, "number written")
        f.end()
        if written > count:
            raise ValueError(f"{written} positions written of {count} sent")
        return written

    return Request(0x291, f"00{start:04X}{count:04X}{records}", True, False, parse, 16)


def parse_write_positions(data: str) -> tuple[int, tuple[Position, ...]]:
    """The controller's side of 291H: (start, positions) from the command data.

    Raises :class:`ValueError` for data that is not a 291H command.
    """
    f = _Fields(data)
    f.expect(2, 0, "reserved field")
    start = f.hex(4, "start position")
    count = f.hex(4, "position count")
    positions = tuple(_take_position(f, start + i) for i in range(count))
    f.end()
    return start, positions
