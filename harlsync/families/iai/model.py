"""The IAI data model: positions, the version, and the numbers they hold.

Numbers the controller holds are kept as exact decimal text (coordinates with
three decimals, ``"-1.000"``; acceleration and deceleration with two, ``"0.30"``)
and converted to and from the wire with integer arithmetic only, never a float:

======================  ===============  ==================================
value                   wire             text
======================  ===============  ==================================
coordinate, 0.001 mm    ``FFFFFC18``     ``-1.000`` (32-bit two's complement)
acc / dec, 0.01 G       ``001E``         ``0.30`` (0.00 = the parameter's value)
speed, mm/s             ``0064``         ``100`` (an int; 0 = the parameter's)
axis pattern            ``05``           axes ``(1, 3)`` (bit n = axis n+1)
extended data           ``90``           arm1 1, arm2 2 (bits 4-5, 6-7)
integer variable        ``FFFFFC18``     ``-1000`` (an int, 32-bit two's complement)
real variable           ``3FB99999...``  ``0.1`` (the shortest text that reads back
                                         as the same IEEE double, Python's repr)
flag                    a bit of 20DH    ``True`` / ``False``
======================  ===============  ==================================

A value the wire cannot carry is a :class:`ValueError` from the conversion, or a
line of :meth:`Position.problems` for the project validator.  What the status
queries report is in :mod:`~harlsync.families.iai.interlock`.
"""

from __future__ import annotations

import math
import re
import struct
import sys
from collections.abc import Iterable
from dataclasses import dataclass

__all__ = [
    "ARM_NAMES",
    "AXIS_COUNT",
    "COORD_MAX",
    "COORD_MIN",
    "G_MAX",
    "INTEGER_MAX",
    "INTEGER_MIN",
    "PLAUSIBLE_REAL",
    "POSITION_NUMBER_MAX",
    "REAL_MAX",
    "SPEED_MAX",
    "TELLING",
    "VARIABLE_SECTIONS",
    "Position",
    "Version",
    "arms_from_extended",
    "axes_from_pattern",
    "canonical_coord",
    "canonical_g",
    "canonical_integer",
    "canonical_real",
    "coord_from_wire",
    "coord_from_word",
    "coord_to_wire",
    "extended_from_arms",
    "g_from_units",
    "g_from_wire",
    "g_to_wire",
    "pattern_from_axes",
    "real_text",
    "real_value",
    "real_word_order_of",
    "speed_from_wire",
    "speed_to_wire",
    "variable_problem",
]

#: Axes 1-8: one bit each in an axis pattern.
AXIS_COUNT = 8
#: The 32-bit coordinate range, in 0.001 units.
COORD_MIN = -(2**31)
COORD_MAX = 2**31 - 1
#: Acceleration and deceleration: 4 hex digits of 0.01 G.
G_MAX = 0xFFFF
#: Speed: 4 hex digits of mm/s.
SPEED_MAX = 0xFFFF
#: Position numbers: 4 hex digits (the robot's own range is a per-robot setting).
POSITION_NUMBER_MAX = 0xFFFF

#: Integer variables: 32-bit two's complement (profile: 20EH's page is missing; 24CH's).
INTEGER_MIN = -(2**31)
INTEGER_MAX = 2**31 - 1
#: Real variables: IEEE doubles, finite only (a NaN never equals itself).
REAL_MAX = sys.float_info.max
#: The opt-in runtime data, as robot.yaml and variables.yaml name its sections,
#: and what one of each is called: global flags, integer and real variables.
VARIABLE_SECTIONS = {"flags": "flag", "integers": "integer variable", "reals": "real variable"}

#: SCARA arm system codes in the extended data.
ARM_NAMES = {0: "none", 1: "right", 2: "left"}

_DECIMAL_RE = re.compile(r"([+-]?)([0-9]*)(?:\.([0-9]*))?")
_HEX_RE = re.compile(r"[0-9A-Fa-f]+")
_INTEGER_RE = re.compile(r"[-+]?[0-9]+")
_REAL_RE = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
_NOT_FINITE_RE = re.compile(r"[-+]?\.?(nan|inf|infinity)", re.IGNORECASE)
#: Decimal text with exactly that many decimals (the form the project keeps): its
#: units are its digits, read as one integer.  Anything else takes the general way.
_EXACT_RE = {decimals: re.compile(rf"-?[0-9]+\.[0-9]{{{decimals}}}") for decimals in (2, 3)}


# --- numbers: text <-> units <-> wire ------------------------------------------------


def _units(text: str, decimals: int, what: str) -> int:
    """Decimal ``text`` as an integer count of 10**-decimals, exactly.

    Raises :class:`ValueError` for anything but plain decimal text, or for more
    significant decimals than the unit carries.
    """
    exact = _EXACT_RE.get(decimals)
    if exact is not None and exact.fullmatch(text):  # "-12.345": the units are -12345
        return int(text.replace(".", "", 1))
    match = _DECIMAL_RE.fullmatch(text)
    if match is None or not (match[2] or match[3]):
        raise ValueError(f"{what} {text!r} is not a decimal number")
    sign, whole, frac = match[1], match[2] or "0", (match[3] or "").rstrip("0")
    if len(frac) > decimals:
        raise ValueError(f"{what} {text!r} has more than {decimals} decimals")
    scale: int = 10**decimals
    units = int(whole) * scale + int(frac.ljust(decimals, "0") or "0")
    return -units if sign == "-" else units


def _text(units: int, decimals: int) -> str:
    """``units`` of 10**-decimals as decimal text: ``(-1000, 3)`` -> ``"-1.000"``.
    (Cut from the digits: a 22DH reply has a hundred of these.)"""
    if units < 0:
        digits = str(-units).zfill(decimals + 1)
        return f"-{digits[:-decimals]}.{digits[-decimals:]}"
    digits = str(units).zfill(decimals + 1)
    return f"{digits[:-decimals]}.{digits[-decimals:]}"


def _hex_value(wire: str, digits: int, what: str) -> int:
    if len(wire) != digits or not _HEX_RE.fullmatch(wire):
        raise ValueError(f"{what} {wire!r} is not {digits} hex digits")
    return int(wire, 16)


#: Coordinate text surely in its one form: three decimals, no leading zero, at most
#: six digits before the point (the range has seven): canonical_coord gives it back.
_ONE_FORM_COORD = re.compile(r"-?(?:0|[1-9][0-9]{0,5})\.[0-9]{3}")
#: Acceleration text surely in its one form: 0.00-99.99 (the range goes to 655.35).
_ONE_FORM_G = re.compile(r"(?:0|[1-9][0-9]?)\.[0-9]{2}")


def coord_in_one_form(text: str) -> bool:
    """Whether ``text`` is surely in its one form (``canonical_coord(text) == text``)
    without working that out: False says nothing (ask :func:`canonical_coord`)."""
    return _ONE_FORM_COORD.fullmatch(text) is not None and text != "-0.000"


def g_in_one_form(text: str) -> bool:
    """As :func:`coord_in_one_form`, of :func:`canonical_g`."""
    return _ONE_FORM_G.fullmatch(text) is not None


def canonical_coord(text: str) -> str:
    """Coordinate text in its one form: three decimals (``"0012.5"`` -> ``"12.500"``).

    Raises :class:`ValueError` when the text is not a decimal, has more than three
    significant decimals, or lies outside the 32-bit range.
    """
    return _text(_coord_units(text), 3)


def _coord_units(text: str) -> int:
    units = _units(text, 3, "coordinate")
    if not COORD_MIN <= units <= COORD_MAX:
        raise ValueError(
            f"coordinate {text!r} out of range "
            f"(allowed: {_text(COORD_MIN, 3)} to {_text(COORD_MAX, 3)})"
        )
    return units


def coord_to_wire(text: str) -> str:
    """``"-1.000"`` -> ``"FFFFFC18"``: 8 hex digits, two's complement, 0.001 units."""
    return f"{_coord_units(text) & 0xFFFFFFFF:08X}"


def coord_from_wire(wire: str) -> str:
    """``"FFFFFC18"`` -> ``"-1.000"``; either hex case.  Raises :class:`ValueError`."""
    return coord_from_word(_hex_value(wire, 8, "coordinate"))


def coord_from_word(word: int) -> str:
    """A 32-bit coordinate word, 0.001 units in two's complement, as text:
    ``0xFFFFFC18`` -> ``"-1.000"``."""
    return _text(word - (1 << 32) if word & 0x80000000 else word, 3)


def canonical_g(text: str, what: str = "acceleration") -> str:
    """Acceleration or deceleration text in its one form: ``"0.3"`` -> ``"0.30"``.

    Raises :class:`ValueError` (naming ``what``) when the text is not a decimal, is
    negative, has more than two significant decimals or is above 655.35 G.
    """
    return _text(_g_units(text, what), 2)


def _g_units(text: str, what: str) -> int:
    units = _units(text, 2, what)
    if text.startswith("-") or not 0 <= units <= G_MAX:
        raise ValueError(f"{what} {text!r} out of range (allowed: 0.00 to {_text(G_MAX, 2)})")
    return units


def g_to_wire(text: str, what: str = "acceleration") -> str:
    """``"0.30"`` -> ``"001E"``: 4 hex digits of 0.01 G."""
    return f"{_g_units(text, what):04X}"


def g_from_wire(wire: str) -> str:
    """``"001E"`` -> ``"0.30"``.  Raises :class:`ValueError`."""
    return g_from_units(_hex_value(wire, 4, "acceleration"))


def g_from_units(units: int) -> str:
    """A count of 0.01 G as text: ``30`` -> ``"0.30"``."""
    return _text(units, 2)


def speed_to_wire(speed: int) -> str:
    """Speed in mm/s as 4 hex digits.  Raises :class:`ValueError` outside 0-65535."""
    if not 0 <= speed <= SPEED_MAX:
        raise ValueError(f"speed {speed} out of range (allowed: 0 to {SPEED_MAX})")
    return f"{speed:04X}"


def speed_from_wire(wire: str) -> int:
    return _hex_value(wire, 4, "speed")


def axes_from_pattern(pattern: int) -> tuple[int, ...]:
    """The axes whose bits are set, lowest first: ``0b101`` -> ``(1, 3)``."""
    if not 0 <= pattern <= 0xFF:
        raise ValueError(f"axis pattern {pattern:#x} is not 8 bits")
    return tuple(n + 1 for n in range(AXIS_COUNT) if pattern >> n & 1)


def pattern_from_axes(axes: tuple[int, ...]) -> int:
    """The axis pattern of ``axes``.  Raises :class:`ValueError` for an axis outside 1-8."""
    pattern = 0
    for axis in axes:
        if not 1 <= axis <= AXIS_COUNT:
            raise ValueError(f"axis {axis} out of range (allowed: 1 to {AXIS_COUNT})")
        pattern |= 1 << (axis - 1)
    return pattern


def extended_from_arms(arm1: int, arm2: int) -> int:
    """The extended-data byte: arm1 in bits 4-5, arm2 in bits 6-7, bits 0-3 zero."""
    for name, arm in (("arm1", arm1), ("arm2", arm2)):
        if not 0 <= arm <= 3:
            raise ValueError(f"{name} {arm} does not fit 2 bits")
    return arm1 << 4 | arm2 << 6


def arms_from_extended(extended: int) -> tuple[int, int]:
    """(arm1, arm2) from the extended-data byte.

    Raises :class:`ValueError` when a spare bit 0-3 is set.
    """
    if extended & 0x0F:
        raise ValueError(f"extended data {extended:02X}h has spare bits 0-3 set")
    return extended >> 4 & 3, extended >> 6 & 3


# --- global flags and variables -------------------------------------------------------


def canonical_integer(text: str) -> str:
    """Integer variable text in its one form: ``"+007"`` -> ``"7"``.

    Raises :class:`ValueError` for anything but an integer within 32 bits.
    """
    if not _INTEGER_RE.fullmatch(text):
        raise ValueError(f"integer {text!r} is not a whole number")
    value = int(text)
    if not INTEGER_MIN <= value <= INTEGER_MAX:
        raise ValueError(f"integer {text} out of range (allowed: {INTEGER_MIN} to {INTEGER_MAX})")
    return str(value)


def canonical_real(text: str) -> str:
    """Real variable text in its one form: the shortest text that reads back as the
    same double (``"0.10"`` -> ``"0.1"``, ``"3"`` -> ``"3.0"``, ``"1e16"`` -> ``"1e+16"``).

    Raises :class:`ValueError` for NaN, an infinity, a number beyond the double's
    range, or anything but decimal text.
    """
    finite = f"allowed: a finite real, -{REAL_MAX!r} to {REAL_MAX!r}"
    if _NOT_FINITE_RE.fullmatch(text):
        raise ValueError(
            f"{text} is not kept: a NaN never equals itself and an infinity "
            f"is no number to compare, so a diff of it never converges ({finite})"
        )
    if not _REAL_RE.fullmatch(text):
        raise ValueError(f"real {text!r} is not a decimal number")
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"real {text} out of range ({finite})")
    return repr(value)


def real_text(value: float) -> str:
    """A double as its shortest round-trip text, as the project keeps it: ``0.1``.
    NaN and the infinities come out as ``nan``, ``inf``, ``-inf``, which
    :func:`canonical_real` refuses."""
    return repr(value)


def real_value(text: str) -> float:
    """The double of real variable text.  Raises :class:`ValueError` as
    :func:`canonical_real` does."""
    return float(canonical_real(text))


#: The magnitudes a real variable a SEL program keeps plausibly has (besides 0): a
#: double read in the wrong word order (p.24) has its exponent from the other word,
#: nearly always far outside (a denormal, 1e-180, 1e+250, or NaN).
PLAUSIBLE_REAL = (1e-15, 1e15)
#: How many values (besides zeros) must all read as plausible in one word order
#: only before harlsync says robot.yaml's order is wrong: a value in the wrong order
#: reads plausible about one time in twenty.
TELLING = 3


def _swapped(words: str) -> str:
    return words[8:] + words[:8]


def _plausible(words: str) -> bool:
    """Whether 16 big-endian hex digits are a double a program plausibly keeps."""
    value: float = struct.unpack(">d", bytes.fromhex(words))[0]
    low, high = PLAUSIBLE_REAL
    return value == 0.0 or (math.isfinite(value) and low <= abs(value) < high)


def real_word_order_of(words: Iterable[str], *, every: bool = False) -> str | None:
    """The word order (``upper-first`` or ``lower-first``, p.24) the values ``words``
    (16 hex digits each, as 20FH sent them) show: the one in which more of them are
    plausible values, and at least half of them; with ``every``, the one in which
    every one of at least :data:`TELLING` is and not every one in the other.  None
    when they do not tell (all zero, or words alike, or as many either way)."""
    telling = [w.upper() for w in words if w[:8] != w[8:]]
    if not telling or (every and len(telling) < TELLING):
        return None
    upper = sum(_plausible(w) for w in telling)
    lower = sum(_plausible(_swapped(w)) for w in telling)
    if every:
        fits = [o for o, n in (("upper-first", upper), ("lower-first", lower)) if n == len(telling)]
        return fits[0] if len(fits) == 1 else None
    if upper != lower and 2 * max(upper, lower) >= len(telling):
        return "upper-first" if upper > lower else "lower-first"
    return None


def variable_problem(section: str, value: object) -> str | None:
    """Why ``value`` cannot be a value of ``section`` (flags, integers, reals) or be
    kept as it is; None when it can."""
    if section == "flags":
        return None if isinstance(value, bool) else f"{value!r} is not true or false"
    if section == "integers":
        if isinstance(value, bool) or not isinstance(value, int):
            return f"{value!r} is not an integer"
        if not INTEGER_MIN <= value <= INTEGER_MAX:
            return f"{value} out of range (allowed: {INTEGER_MIN} to {INTEGER_MAX})"
        return None
    if not isinstance(value, str):
        return f"{value!r} is not real text"
    try:
        one = canonical_real(value)
    except ValueError as exc:
        return str(exc)
    return None if one == value else f"{value} is not in its one form ({one})"


# --- positions ----------------------------------------------------------------------


@dataclass(frozen=True)
class Position:
    """One position of the table, as exact text.

    ``axes`` are the axes that carry a coordinate (1-8, ascending), ``coords``
    one coordinate each.  ``acc``/``dec`` ``"0.00"`` and ``speed`` 0 mean "use the
    parameter's value".  ``arm1``/``arm2``: SCARA arm system, 0 none, 1 right, 2 left.
    """

    number: int
    axes: tuple[int, ...]
    acc: str
    dec: str
    speed: int
    coords: tuple[str, ...]
    arm1: int = 0
    arm2: int = 0

    def problems(self) -> list[str]:
        """Every reason this position cannot be written, one line each; empty if none."""
        out: list[str] = []
        if not 1 <= self.number <= POSITION_NUMBER_MAX:
            out.append(
                f"position number {self.number} out of range (allowed: 1 to {POSITION_NUMBER_MAX})"
            )
        if not self.axes:
            out.append("no axis: a position needs at least one coordinate")
        elif any(not 1 <= a <= AXIS_COUNT for a in self.axes):
            out.append(f"axes {list(self.axes)} out of range (allowed: 1 to {AXIS_COUNT})")
        elif list(self.axes) != sorted(set(self.axes)):
            out.append(f"axes {list(self.axes)} must be ascending and each once")
        if len(self.coords) != len(self.axes):
            out.append(f"{len(self.coords)} coordinates for {len(self.axes)} axes")
        for axis, coord in zip(self.axes, self.coords):
            if isinstance(coord, str) and coord_in_one_form(coord):
                continue  # surely a coordinate in range
            try:
                _coord_units(coord)
            except ValueError as exc:
                out.append(f"axis {axis}: {exc}")
        for what, value in (("acceleration", self.acc), ("deceleration", self.dec)):
            if isinstance(value, str) and g_in_one_form(value):
                continue
            try:
                _g_units(value, what)
            except ValueError as exc:
                out.append(str(exc))
        if not 0 <= self.speed <= SPEED_MAX:
            out.append(f"speed {self.speed} out of range (allowed: 0 to {SPEED_MAX})")
        for name, arm in (("arm1", self.arm1), ("arm2", self.arm2)):
            if arm not in ARM_NAMES:
                out.append(f"{name} {arm} out of range (allowed: 0 none, 1 right, 2 left)")
        return out

    def canonical(self) -> Position:
        """The same position with every text in its one form.

        Raises :class:`ValueError` naming every problem when it has any.
        """
        problems = self.problems()
        if problems:
            raise ValueError(f"position {self.number}: {'; '.join(problems)}")
        return Position(
            self.number,
            self.axes,
            canonical_g(self.acc, "acceleration"),
            canonical_g(self.dec, "deceleration"),
            self.speed,
            tuple(canonical_coord(c) for c in self.coords),
            self.arm1,
            self.arm2,
        )


# --- what the queries report --------------------------------------------------------


@dataclass(frozen=True)
class Version:
    """201H: what the unit reports about itself.

    The codes are kept as upper-case hex text: their meaning is not in the
    manual pages we have.  ``built`` is ``YYYY-MM-DD hh:mm:ss``.
    """

    unit_type: int
    device: int
    model_code: str
    unit_code: str
    version: str
    built: str
