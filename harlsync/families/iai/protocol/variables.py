"""Requests for the opt-in flags and variables (20DH-20FH, 24BH-24DH)."""

import struct
from collections.abc import Callable, Sequence

from .. import profile
from ..model import (
    INTEGER_MAX,
    INTEGER_MIN,
)
from .frame import _FLAGS_OVERHEAD, _HEX_RE, _VARIABLES_MAX, _VARIABLES_OVERHEAD
from .request import Request, T, _check, _Fields, _no_data

# --- opt-in: flags and variables ----------------------------------------------------


def read_flags(start: int, count: int, program: int = 0) -> Request[tuple[bool, ...]]:
    """20DH: ``count`` flags from ``start`` (program 0: global), bit 0 first.

    ``start`` must be a category's head flag plus a multiple of 8 (p.22).  A reply
    may carry fewer flags than asked (its count says how many): a controller whose
    table ends among them; the value is then that many flags.
    """
    _check(program, 0, 0xFF, "program number")
    _check(start, 0, 0xFFFF, "start flag")
    _check(count, 1, 0xFFFF, "flag count")

    def parse(data: str) -> tuple[bool, ...]:
        f = _Fields(data)
        f.expect(2, program, "program number")
        f.expect(4, start, "start flag")
        got = _at_most(f.hex(4, "number of flags"), count, "flags")
        octets = [f.hex(2, "flag data") for _ in range((got + 7) // 8)]
        f.end()
        return tuple(bool(octets[i // 8] >> (i % 8) & 1) for i in range(got))

    reply = _FLAGS_OVERHEAD + 2 * ((count + 7) // 8)
    return Request(0x20D, f"{program:02X}{start:04X}{count:04X}", False, True, parse, reply)


def _at_most(got: int, count: int, what: str) -> int:
    """A reply's count of ``what``: at most the ``count`` asked for (fewer when the
    controller's table ends among them: the reader decides what that means)."""
    if got > count:
        raise ValueError(f"{got} {what}, asked for {count}")
    return got


def _variable_args(program: int, start: int, count: int) -> str:
    _check(program, 0, 0xFF, "program number")
    _check(start, 0, 0xFFF, "start variable")
    _check(count, 1, _VARIABLES_MAX, "variable count")
    return f"{program:02X}{start:03X}{count:02X}"


def _read_variables(
    message_id: int, width: int, convert: Callable[[str], T], program: int, start: int, count: int
) -> Request[tuple[T, ...]]:
    data = _variable_args(program, start, count)

    def parse(reply: str) -> tuple[T, ...]:
        f = _Fields(reply)
        f.expect(2, program, "program number")
        f.expect(3, start, "start variable")
        got = _at_most(f.hex(2, "number of variables"), count, "variables")
        values = tuple(convert(f.take(width, f"variable {start + i}")) for i in range(got))
        f.end()
        return values

    reply_bytes = _VARIABLES_OVERHEAD + width * count
    return Request(message_id, data, False, True, parse, reply_bytes)


def _int_from_wire(wire: str) -> int:
    if not (len(wire) == 8 and _HEX_RE.fullmatch(wire)):
        raise ValueError("an integer is not 8 hex digits")
    value = int(wire, 16)
    return value - (1 << 32) if value & 0x80000000 else value


def real_from_wire(wire: str, order: str = profile.DEFAULT_REAL_WORD_ORDER) -> float:
    """A real variable's 16 hex digits in the robot's word order (p.24) as its double.

    Raises :class:`ValueError` for anything but 16 hex digits, or an unknown order.
    """
    if not (len(wire) == 16 and _HEX_RE.fullmatch(wire)):
        raise ValueError("a real is not 16 hex digits")
    value: float = struct.unpack(">d", bytes.fromhex(_in_order(wire, order)))[0]
    return value


def real_to_wire(value: float, order: str = profile.DEFAULT_REAL_WORD_ORDER) -> str:
    """A double as a real variable's 16 upper-case hex digits in the robot's word order."""
    return _in_order(struct.pack(">d", value).hex().upper(), order)


def _in_order(digits: str, order: str) -> str:
    """Big-endian hex digits of a double to ``order``'s, or back (a swap is its own inverse)."""
    if order not in profile.REAL_WORD_ORDERS:
        raise ValueError(
            f"real word order {order!r} (allowed: {', '.join(profile.REAL_WORD_ORDERS)})"
        )
    return digits[8:] + digits[:8] if order == "lower-first" else digits


def read_integers(start: int, count: int, program: int = 0) -> Request[tuple[int, ...]]:
    """20EH: ``count`` integer variables from ``start`` (program 0: global).

    32-bit two's complement each (profile: the page is missing; mirrors 24CH).
    """
    return _read_variables(0x20E, 8, _int_from_wire, program, start, count)


def read_reals(
    start: int,
    count: int,
    program: int = 0,
    order: str = profile.DEFAULT_REAL_WORD_ORDER,
) -> Request[tuple[float, ...]]:
    """20FH: ``count`` real variables from ``start``, each an IEEE double in the
    robot's word ``order`` (p.24; a float holds the double exactly)."""
    _in_order("0" * 16, order)  # an unknown order is refused before anything is sent
    return _read_variables(
        0x20F, 16, lambda wire: real_from_wire(wire, order), program, start, count
    )


def read_real_words(start: int, count: int, program: int = 0) -> Request[tuple[str, ...]]:
    """20FH as its words: ``count`` real variables from ``start``, each the 16 hex
    digits the controller sent (upper case), in whatever order it keeps them: the
    reader decides the order (:func:`real_from_wire` then reads them)."""
    return _read_variables(0x20F, 16, _real_digits, program, start, count)


def _real_digits(wire: str) -> str:
    if not (len(wire) == 16 and _HEX_RE.fullmatch(wire)):
        raise ValueError("a real is not 16 hex digits")
    return wire.upper()


def write_flag(number: int, on: bool, program: int = 0) -> Request[None]:
    """24BH: set or clear one flag (program 0: global).  The reply has no data."""
    _check(program, 0, 0xFF, "program number")
    _check(number, 0, 0xFFFF, "flag number")
    return Request(0x24B, f"{program:02X}{number:04X}{int(on):X}", True, False, _no_data, 10)


def _write_variables(message_id: int, start: int, texts: list[str], program: int) -> Request[int]:
    count = len(texts)
    data = _variable_args(program, start, count) + "".join(texts)

    def parse(reply: str) -> int:
        f = _Fields(reply)
        f.expect(2, program, "program number")
        f.expect(3, start, "start variable")
        written = f.hex(2, "number changed")
        f.end()
        if written > count:
            raise ValueError(f"{written} variables changed of {count} sent")
        return written

    return Request(message_id, data, True, False, parse, 17)


def write_integers(start: int, values: Sequence[int], program: int = 0) -> Request[int]:
    """24CH: integer variables from ``start``; the reply gives the number changed.

    Raises :class:`ValueError` for no values, more than 255, or one outside 32 bits.
    """
    for i, value in enumerate(values):
        _check(value, INTEGER_MIN, INTEGER_MAX, f"integer variable {start + i}")
    return _write_variables(0x24C, start, [f"{v & 0xFFFFFFFF:08X}" for v in values], program)


def write_reals(
    start: int,
    values: Sequence[float],
    program: int = 0,
    order: str = profile.DEFAULT_REAL_WORD_ORDER,
) -> Request[int]:
    """24DH: real variables from ``start``, each an IEEE double in the robot's word
    ``order`` (the profile writes in the order 20FH reads)."""
    texts = [real_to_wire(v, order) for v in values]
    return _write_variables(0x24D, start, texts, program)
