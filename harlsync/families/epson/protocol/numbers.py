"""Numbers on the wire: decimal text <-> thousandths <-> 16-bit words, with
integer arithmetic only."""

from __future__ import annotations

import re

#: Command and response words: up to 8 of each (§4.2).
MAX_WORDS = 8
_WORD = 0xFFFF
#: Real values: a 32-bit count of thousandths.
REAL_MIN = -(2**31)
REAL_MAX = 2**31 - 1
#: Point coordinates and Plane/Local/Base selectors: 0 X ... 5 W.
COORDINATES = ("X", "Y", "Z", "U", "V", "W")
#: Box and XYLim axes: X, Y, Z.
_XYZ = COORDINATES[:3]


# --- numbers: decimal text <-> thousandths <-> words --------------------------------

_REAL_RE = re.compile(r"([+-]?)([0-9]*)(?:\.([0-9]*))?")


def real_units(text: str) -> int:
    """Decimal ``text`` as a whole number of thousandths, exactly (``"-100.003"`` ->
    ``-100003``).

    Raises :class:`ValueError` for anything but plain decimal text, more than three
    significant decimals (the wire carries thousandths: nothing is rounded away
    silently) or a value outside the 32-bit range.
    """
    match = _REAL_RE.fullmatch(text) if isinstance(text, str) else None
    if match is None or not (match[2] or match[3]):
        raise ValueError(f"{text!r} is not a decimal number")
    sign, whole, frac = match[1], match[2] or "0", (match[3] or "").rstrip("0")
    if len(frac) > 3:
        raise ValueError(f"{text!r} has more than three decimals (the wire carries thousandths)")
    units = int(whole) * 1000 + int(frac.ljust(3, "0"))
    if sign == "-":
        units = -units
    if not REAL_MIN <= units <= REAL_MAX:
        raise ValueError(
            f"{text!r} is outside the 32-bit range ({real_text(REAL_MIN)} to {real_text(REAL_MAX)})"
        )
    return units


def real_text(units: int) -> str:
    """Thousandths as decimal text with three decimals (``-100003`` -> ``"-100.003"``)."""
    whole, frac = divmod(abs(units), 1000)
    return f"{'-' if units < 0 else ''}{whole}.{frac:03d}"


def canonical_real(text: str) -> str:
    """``text`` in its one form: three decimals (``"12.5"`` -> ``"12.500"``).

    Raises :class:`ValueError` as :func:`real_units` does.
    """
    return real_text(real_units(text))


def int32_to_words(value: int) -> tuple[int, int]:
    """A 32-bit signed integer as (high word, low word), two's complement.

    Raises :class:`ValueError` outside -2**31 .. 2**31 - 1.
    """
    if not REAL_MIN <= value <= REAL_MAX:
        raise ValueError(f"{value} does not fit 32 bits")
    raw = value & 0xFFFFFFFF
    return raw >> 16, raw & _WORD


def int32_from_words(high: int, low: int) -> int:
    """The signed integer of two words, high word first."""
    raw = (high & _WORD) << 16 | (low & _WORD)
    return raw - (1 << 32) if raw & 0x80000000 else raw


def real_to_words(text: str) -> tuple[int, int]:
    """A real value's two words, high first (``"100.123"`` -> ``(0x0001, 0x871B)``)."""
    return int32_to_words(real_units(text))


def real_from_words(high: int, low: int) -> str:
    """The decimal text of a real value's two words."""
    return real_text(int32_from_words(high, low))
