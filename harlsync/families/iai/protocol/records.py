"""Requests for the records: coordinate systems (2A0H, read only) and string
variables (210H, and 24EH to write them back)."""

from collections.abc import Sequence

from ..model import (
    coord_from_wire,
)
from .frame import _FRAME_OVERHEAD, _HEX_RE, _VARIABLES_MAX, _VARIABLES_OVERHEAD
from .positions import _buffers
from .request import Request, _check, _Fields, _no_data
from .variables import _at_most, _read_variables, _variable_args

# --- read-only records: coordinate systems and string variables ---------------------

#: A 2A0H reply around its records: the frame, type, start number and count.
_COORDINATES_OVERHEAD = _FRAME_OVERHEAD + 1 + 2 + 2
#: One 2A0H record: X, Y, Z offsets (0.001 mm) and R (0.001 deg), 8 hex digits each.
_COORDINATE_RECORD = 4 * 8


def max_coordinate_systems_per_read(model: str) -> int:
    """How many coordinate system definitions one 2A0H reply carries in ``model``'s
    send buffer (at most 255: the count is 2 hex digits)."""
    return min(0xFF, (_buffers(model).send - _COORDINATES_OVERHEAD) // _COORDINATE_RECORD)


def max_string_columns_per_read(model: str) -> int:
    """How many string variable columns (one character each) one 210H reply carries
    in ``model``'s send buffer (at most 255)."""
    return min(_VARIABLES_MAX, (_buffers(model).send - _VARIABLES_OVERHEAD) // 2)


def read_coordinate_systems(
    kind: int, head: int, count: int
) -> Request[tuple[tuple[str, str, str, str], ...]]:
    """2A0H (p.65): ``count`` coordinate system definitions from number ``head``,
    work (``kind`` 0) or tool (1); each the X, Y, Z offsets and R, as coordinate text
    (fewer when the reply's count says so: the controller's table ends among them)."""
    _check(kind, 0, 1, "coordinate system type")
    _check(head, 0, 0xFF, "head definition number")
    _check(count, 1, 0xFF - head + 1, "number of records")

    def parse(data: str) -> tuple[tuple[str, str, str, str], ...]:
        f = _Fields(data)
        f.expect(1, kind, "coordinate system type")
        f.expect(2, head, "start number")
        got = _at_most(f.hex(2, "number of records"), count, "records")
        out = []
        for n in range(head, head + got):
            x, y, z, r = (coord_from_wire(f.take(8, f"definition {n} {a}")) for a in "XYZR")
            out.append((x, y, z, r))
        f.end()
        return tuple(out)

    reply = _COORDINATES_OVERHEAD + _COORDINATE_RECORD * count
    return Request(0x2A0, f"{kind:X}{head:02X}{count:02X}", False, False, parse, reply)


def read_strings(start: int, count: int, program: int = 0) -> Request[tuple[int, ...]]:
    """210H (p.26): ``count`` string variable columns from ``start`` (program 0:
    global), each one character as its code ('XX', hex ASCII)."""
    return _read_variables(0x210, 2, _code_from_wire, program, start, count)


def _code_from_wire(wire: str) -> int:
    if not (len(wire) == 2 and _HEX_RE.fullmatch(wire)):
        raise ValueError("a character code is not 2 hex digits")
    return int(wire, 16)


def write_strings(start: int, codes: Sequence[int], program: int = 0) -> Request[None]:
    """24EH (p.51): string variable columns from ``start`` (program 0: global), each
    one character's code; the normal reply has no data (10 bytes).

    Raises :class:`ValueError` for no code, more than 255, or one outside 00-FF.
    Check :attr:`Request.frame_size` against the model's receive buffer.
    """
    for i, code in enumerate(codes):
        _check(code, 0, 0xFF, f"string variable column {start + i}")
    data = _variable_args(program, start, len(codes)) + "".join(f"{c:02X}" for c in codes)
    return Request(0x24E, data, True, False, _no_data, _FRAME_OVERHEAD)
