"""Requests for the six tables and Weight, Inertia, Arch, Fine and Tool
(§10.1-10.11)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

from .numbers import _WORD, MAX_WORDS, real_to_words
from .request import (
    Request,
    T,
    WriteSequence,
    _check,
    _echo_read,
    _fit,
    _read,
    _table,
    _Words,
    _write,
)

# --- the six tables (§10.1-10.6) -------------------------------------------------------


class AccelPercent(NamedTuple):
    """An Accel table entry: % of the maximum acceleration and deceleration."""

    accel: int
    decel: int


class AccelReal(NamedTuple):
    """An AccelS (mm/s², x1000) or AccelR (deg/s², x1000) table entry."""

    accel: str
    decel: str


class SpeedPercent(NamedTuple):
    """A Speed table entry: speed, depart and approach speed, % 1-100."""

    speed: int
    depart: int
    approach: int


class SpeedReal(NamedTuple):
    """A SpeedS table entry: speed, depart and approach speed, mm/s."""

    speed: str
    depart: str
    approach: str


def _table_read(
    number: int, table: int, what: str, data_words: int, rest: Callable[[_Words], T]
) -> Request[T]:
    table = _table(table)
    return _echo_read(number, ((table, "table number"),), f"{what} table {table}", data_words, rest)


def read_accel(table: int) -> Request[AccelPercent]:
    """3: an Accel table entry.  Unregistered: error 2006 (the profile)."""
    return _table_read(
        3, table, "Accel", 3, lambda w: AccelPercent(w.word("accel"), w.word("decel"))
    )


def _accel_real(w: _Words) -> AccelReal:
    return AccelReal(w.real("accel"), w.real("decel"))


def read_accel_s(table: int) -> Request[AccelReal]:
    """59: an AccelS table entry (both halves; 6 response words)."""
    return _table_read(59, table, "AccelS", 5, _accel_real)


def read_accel_s_accel(table: int) -> Request[str]:
    """60: an AccelS table entry's accel (4 response words)."""
    return _table_read(60, table, "AccelS accel", 3, lambda w: w.real("accel"))


def read_accel_s_decel(table: int) -> Request[str]:
    """61: an AccelS table entry's decel (4 response words)."""
    return _table_read(61, table, "AccelS decel", 3, lambda w: w.real("decel"))


def read_accel_r(table: int) -> Request[AccelReal]:
    """109: an AccelR table entry (both halves; 6 response words)."""
    return _table_read(109, table, "AccelR", 5, _accel_real)


def read_accel_r_accel(table: int) -> Request[str]:
    """110: an AccelR table entry's accel."""
    return _table_read(110, table, "AccelR accel", 3, lambda w: w.real("accel"))


def read_accel_r_decel(table: int) -> Request[str]:
    """111: an AccelR table entry's decel."""
    return _table_read(111, table, "AccelR decel", 3, lambda w: w.real("decel"))


def read_speed(table: int) -> Request[SpeedPercent]:
    """153: a Speed table entry."""
    return _table_read(
        153,
        table,
        "Speed",
        4,
        lambda w: SpeedPercent(w.word("speed"), w.word("depart speed"), w.word("approach speed")),
    )


def read_speed_s(table: int) -> Request[SpeedReal]:
    """209: a SpeedS table entry (all three; 8 response words)."""
    return _table_read(
        209,
        table,
        "SpeedS",
        7,
        lambda w: SpeedReal(w.real("speed"), w.real("depart speed"), w.real("approach speed")),
    )


def read_speed_s_speed_depart(table: int) -> Request[tuple[str, str]]:
    """210: a SpeedS table entry's speed and depart speed (6 response words; the
    manual's list and heading call it a register command, its body an acquire)."""
    return _table_read(
        210,
        table,
        "SpeedS speed and depart",
        5,
        lambda w: (w.real("speed"), w.real("depart speed")),
    )


def read_speed_s_approach(table: int) -> Request[str]:
    """211: a SpeedS table entry's approach speed."""
    return _table_read(211, table, "SpeedS approach", 3, lambda w: w.real("approach speed"))


def read_speed_r(table: int) -> Request[str]:
    """253: a SpeedR table entry (deg/s)."""
    return _table_read(253, table, "SpeedR", 3, lambda w: w.real("speed"))


def register_accel(table: int, accel: int, decel: int) -> WriteSequence:
    """1: register an Accel table entry (% of the maximum, 1 or more)."""
    table = _table(table)
    words = (table, _check(accel, 1, _WORD, "accel"), _check(decel, 1, _WORD, "decel"))
    what = f"Accel table {table}"
    return WriteSequence(what, (_write(1, words, what),))


def _register_accel_real(
    numbers: tuple[int, int, int], item: str, table: int, value: AccelReal, command_words: int
) -> WriteSequence:
    full, first, second = numbers
    table = _table(table)
    accel, decel = real_to_words(value.accel), real_to_words(value.decel)
    what = f"{item} table {table}"
    return _fit(
        what,
        command_words,
        (_write(full, (table, *accel, *decel), what),),
        (_write(first, (table, *accel), what), _write(second, (table, *decel), what)),
    )


def register_accel_s(
    table: int, value: AccelReal, *, command_words: int = MAX_WORDS
) -> WriteSequence:
    """53, or 54 then 55 when the map has fewer than 6 command words."""
    return _register_accel_real((53, 54, 55), "AccelS", table, value, command_words)


def register_accel_r(
    table: int, value: AccelReal, *, command_words: int = MAX_WORDS
) -> WriteSequence:
    """103, or 104 then 105 when the map has fewer than 6 command words."""
    return _register_accel_real((103, 104, 105), "AccelR", table, value, command_words)


def register_speed(table: int, value: SpeedPercent) -> WriteSequence:
    """151: register a Speed table entry (each 1-100 %)."""
    table = _table(table)
    words = (
        table,
        _check(value.speed, 1, 100, "speed"),
        _check(value.depart, 1, 100, "depart speed"),
        _check(value.approach, 1, 100, "approach speed"),
    )
    what = f"Speed table {table}"
    return WriteSequence(what, (_write(151, words, what),))


def register_speed_s(
    table: int, value: SpeedReal, *, command_words: int = MAX_WORDS
) -> WriteSequence:
    """203, or 204 then 205 when the map has fewer than 8 command words."""
    table = _table(table)
    speed, depart, approach = (real_to_words(v) for v in value)
    what = f"SpeedS table {table}"
    return _fit(
        what,
        command_words,
        (_write(203, (table, *speed, *depart, *approach), what),),
        (_write(204, (table, *speed, *depart), what), _write(205, (table, *approach), what)),
    )


def register_speed_r(table: int, speed: str) -> WriteSequence:
    """251: register a SpeedR table entry (deg/s)."""
    table = _table(table)
    what = f"SpeedR table {table}"
    return WriteSequence(what, (_write(251, (table, *real_to_words(speed)), what),))


# --- Weight, Inertia, Arch, Fine, Tool (§10.7-10.11) --------------------------------


class Weight(NamedTuple):
    """Weight: the hand weight and the arm length (mm; SCARA only), x1000."""

    weight: str
    arm_length: str


class Inertia(NamedTuple):
    """Inertia: the load inertia (kg·m²) and the eccentricity, x1000."""

    inertia: str
    eccentricity: str


class Distances(NamedTuple):
    """An Arch entry: depart and approach distance, mm."""

    depart: str
    approach: str


def read_weight() -> Request[Weight]:
    """302: the hand weight and arm length."""
    return _read(302, (), "Weight", 4, lambda w: Weight(w.real("weight"), w.real("arm length")))


def set_weight(weight: str, arm_length: str | None = None) -> WriteSequence:
    """300 (weight and arm length), or 301 (weight alone) when ``arm_length`` is None.

    Written to the controller's memory card.
    """
    if arm_length is None:
        return WriteSequence("Weight", (_write(301, real_to_words(weight), "Weight"),))
    words = (*real_to_words(weight), *real_to_words(arm_length))
    return WriteSequence("Weight", (_write(300, words, "Weight"),))


def read_inertia() -> Request[Inertia]:
    """353: the load inertia and eccentricity."""
    return _read(
        353, (), "Inertia", 4, lambda w: Inertia(w.real("load inertia"), w.real("eccentricity"))
    )


def read_inertia_load() -> Request[str]:
    """354: the load inertia alone (the manual heads it "Command 353")."""
    return _read(354, (), "Inertia load inertia", 2, lambda w: w.real("load inertia"))


def read_inertia_eccentricity() -> Request[str]:
    """355: the eccentricity alone."""
    return _read(355, (), "Inertia eccentricity", 2, lambda w: w.real("eccentricity"))


def set_inertia(value: Inertia, *, command_words: int = MAX_WORDS) -> WriteSequence:
    """350 (5 words: its body, not the 3 of the §8 list), or 351 then 352.

    Written to the controller's memory card.
    """
    inertia, eccentricity = real_to_words(value.inertia), real_to_words(value.eccentricity)
    return _fit(
        "Inertia",
        command_words,
        (_write(350, (*inertia, *eccentricity), "Inertia"),),
        (_write(351, inertia, "Inertia"), _write(352, eccentricity, "Inertia")),
    )


def _arch(arch: int) -> int:
    return _check(arch, 0, 6, "arch number")


def _arch_read(
    number: int, arch: int, what: str, data_words: int, rest: Callable[[_Words], T]
) -> Request[T]:
    arch = _arch(arch)
    return _echo_read(number, ((arch, "arch number"),), f"Arch {arch}{what}", data_words, rest)


def read_arch(arch: int) -> Request[Distances]:
    """403: an Arch entry (0-6)."""
    return _arch_read(
        403,
        arch,
        "",
        5,
        lambda w: Distances(w.real("depart distance"), w.real("approach distance")),
    )


def read_arch_depart(arch: int) -> Request[str]:
    """404: an Arch entry's depart distance."""
    return _arch_read(404, arch, " depart", 3, lambda w: w.real("depart distance"))


def read_arch_approach(arch: int) -> Request[str]:
    """405: an Arch entry's approach distance."""
    return _arch_read(405, arch, " approach", 3, lambda w: w.real("approach distance"))


def set_arch(arch: int, value: Distances, *, command_words: int = MAX_WORDS) -> WriteSequence:
    """400 (6 words: its body, not the 4 of the §8 list), or 401 then 402."""
    arch = _arch(arch)
    depart, approach = real_to_words(value.depart), real_to_words(value.approach)
    what = f"Arch {arch}"
    return _fit(
        what,
        command_words,
        (_write(400, (arch, *depart, *approach), what),),
        (_write(401, (arch, *depart), what), _write(402, (arch, *approach), what)),
    )


def _axes(axes: int) -> int:
    if axes not in (4, 6):
        raise ValueError(f"axes {axes!r}: a robot has 4 or 6 axes")
    return axes


def _fine_values(words: _Words, count: int, first: int = 1) -> tuple[int, ...]:
    return tuple(words.word(f"joint {first + i}") for i in range(count))


def read_fine(axes: int) -> Request[tuple[int, ...]]:
    """453: Fine of every joint (a 4-axis robot answers joints 1-4 only)."""
    count = _axes(axes)
    return _read(453, (), "Fine", count, lambda w: _fine_values(w, count))


def read_fine_123() -> Request[tuple[int, ...]]:
    """454: Fine of joints 1-3."""
    return _read(454, (), "Fine joints 1-3", 3, lambda w: _fine_values(w, 3))


def read_fine_456(axes: int) -> Request[tuple[int, ...]]:
    """455: Fine of joints 4-6 (joint 4 alone on a 4-axis robot)."""
    count = _axes(axes) - 3
    return _read(455, (), "Fine joints 4-6", count, lambda w: _fine_values(w, count, 4))


def set_fine(values: Sequence[int], *, command_words: int = MAX_WORDS) -> WriteSequence:
    """450 with 4 or 6 joints, or 451 (joints 1-3) then 452 (the rest)."""
    _axes(len(values))
    words = tuple(_check(v, 0, _WORD, f"Fine joint {i}") for i, v in enumerate(values, 1))
    return _fit(
        "Fine",
        command_words,
        (_write(450, words, "Fine"),),
        (_write(451, words[:3], "Fine"), _write(452, words[3:], "Fine")),
    )


def read_tool() -> Request[int]:
    """501: the tool selected (0-15).  No command reads a tool's offset."""
    return _read(501, (), "Tool", 1, lambda w: w.number(0, 15, "tool number"))


def select_tool(tool: int) -> WriteSequence:
    """500: select tool 0-15 (written to the controller's memory card)."""
    tool = _check(tool, 0, 15, "tool number")
    return WriteSequence("Tool", (_write(500, (tool,), "Tool"),))
