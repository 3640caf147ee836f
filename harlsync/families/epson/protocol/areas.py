"""Requests for Box, Plane, Local, XYLim, JRange, Base and LimZ (§10.13-10.18,
§10.26)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

from .numbers import _XYZ, COORDINATES, MAX_WORDS, int32_to_words, real_to_words
from .request import Request, T, WriteSequence, _check, _echo_read, _fit, _read, _Words, _write

# --- Box, Plane, Local, XYLim, JRange, Base (§10.13-10.18) ---------------------------


class Limits(NamedTuple):
    """The lower and upper limit of one axis of a Box area or of XYLim, x1000."""

    lower: str
    upper: str


class PulseLimits(NamedTuple):
    """One joint's JRange: lower and upper limit in encoder pulses (not x1000)."""

    lower: int
    upper: int


def _number15(value: int, what: str) -> int:
    return _check(value, 1, 15, what)


def _box_read(
    number: int, area: int, axis: int, what: str, data_words: int, rest: Callable[[_Words], T]
) -> Request[T]:
    area, axis = _number15(area, "Box area"), _check(axis, 0, 2, "Box axis")
    return _echo_read(
        number,
        ((area, "area number"), (axis, "axis")),
        f"Box {area} {_XYZ[axis]}{what}",
        data_words,
        rest,
    )


def read_box(area: int, axis: int) -> Request[Limits]:
    """603: one axis (0 X, 1 Y, 2 Z) of Box area 1-15."""
    return _box_read(603, area, axis, "", 6, lambda w: Limits(w.real("lower"), w.real("upper")))


def read_box_lower(area: int, axis: int) -> Request[str]:
    """604: one axis's lower limit of a Box area."""
    return _box_read(604, area, axis, " lower", 4, lambda w: w.real("lower"))


def read_box_upper(area: int, axis: int) -> Request[str]:
    """605: one axis's upper limit of a Box area."""
    return _box_read(605, area, axis, " upper", 4, lambda w: w.real("upper"))


_Pair = tuple[int, int]


def _xyz_limits(limits: Sequence[Limits], what: str) -> list[tuple[_Pair, _Pair]]:
    if len(limits) != 3:
        raise ValueError(f"{what}: {len(limits)} axes given, X, Y and Z needed")
    return [(real_to_words(lim.lower), real_to_words(lim.upper)) for lim in limits]


def set_box(
    area: int, limits: Sequence[Limits], *, command_words: int = MAX_WORDS
) -> WriteSequence:
    """600 for X, Y, Z (Rn), or 601 for X, Y, Z then 602 for X, Y, Z.

    Written to the controller's memory card.  All limits 0: the area is off.
    """
    area = _number15(area, "Box area")
    what = f"Box {area}"
    words = _xyz_limits(limits, what)
    return _fit(
        what,
        command_words,
        tuple(
            _write(600, (area, axis, *low, *high), what) for axis, (low, high) in enumerate(words)
        ),
        tuple(_write(601, (area, axis, *low), what) for axis, (low, _) in enumerate(words))
        + tuple(_write(602, (area, axis, *high), what) for axis, (_, high) in enumerate(words)),
    )


def _frame_read(number: int, item: str, frame: int, coord: int) -> Request[str]:
    frame, coord = _number15(frame, f"{item} number"), _check(coord, 0, 5, "coordinate")
    return _echo_read(
        number,
        ((frame, f"{item} number"), (coord, "coordinate")),
        f"{item} {frame} {COORDINATES[coord]}",
        4,
        lambda w: w.real(COORDINATES[coord]),
    )


def read_plane(plane: int, coord: int) -> Request[str]:
    """651: one coordinate (0 X ... 5 W) of approach check plane 1-15."""
    return _frame_read(651, "Plane", plane, coord)


def read_local(local: int, coord: int) -> Request[str]:
    """701: one coordinate (0 X ... 5 W) of local coordinate system 1-15."""
    return _frame_read(701, "Local", local, coord)


def _coords(coords: Sequence[str], what: str) -> list[tuple[int, int]]:
    if len(coords) not in (4, 6):
        raise ValueError(
            f"{what}: {len(coords)} coordinates given, X to U (4-axis) or X to W (6-axis) needed"
        )
    return [real_to_words(c) for c in coords]


def _frame_write(number: int, item: str, frame: int, coords: Sequence[str]) -> WriteSequence:
    frame = _number15(frame, f"{item} number")
    what = f"{item} {frame}"
    return WriteSequence(
        what,
        tuple(
            _write(number, (frame, coord, *words), what)
            for coord, words in enumerate(_coords(coords, what))
        ),
    )


def set_plane(plane: int, coords: Sequence[str]) -> WriteSequence:
    """650 for X, Y, Z, U (and V, W on a 6-axis robot), in order (Rn).

    Written to the controller's memory card.
    """
    return _frame_write(650, "Plane", plane, coords)


def set_local(local: int, coords: Sequence[str]) -> WriteSequence:
    """700 for X, Y, Z, U (and V, W on a 6-axis robot), in order (Rn)."""
    return _frame_write(700, "Local", local, coords)


def _xylim_read(
    number: int, axis: int, what: str, data_words: int, rest: Callable[[_Words], T]
) -> Request[T]:
    axis = _check(axis, 0, 2, "XYLim axis")
    return _echo_read(number, ((axis, "axis"),), f"XYLim {_XYZ[axis]}{what}", data_words, rest)


def read_xylim(axis: int) -> Request[Limits]:
    """753: one axis (0 X, 1 Y, 2 Z) of the motion range."""
    return _xylim_read(753, axis, "", 5, lambda w: Limits(w.real("lower"), w.real("upper")))


def read_xylim_lower(axis: int) -> Request[str]:
    """754: one axis's lower limit of the motion range."""
    return _xylim_read(754, axis, " lower", 3, lambda w: w.real("lower"))


def read_xylim_upper(axis: int) -> Request[str]:
    """755: one axis's upper limit of the motion range."""
    return _xylim_read(755, axis, " upper", 3, lambda w: w.real("upper"))


def set_xylim(limits: Sequence[Limits], *, command_words: int = MAX_WORDS) -> WriteSequence:
    """750 for X, Y, Z (Rn), or 751 for X, Y, Z then 752 for X, Y, Z.

    Written to the controller's memory card.  All limits 0: the range is off.
    """
    words = _xyz_limits(limits, "XYLim")
    return _fit(
        "XYLim",
        command_words,
        tuple(_write(750, (axis, *low, *high), "XYLim") for axis, (low, high) in enumerate(words)),
        tuple(_write(751, (axis, *low), "XYLim") for axis, (low, _) in enumerate(words))
        + tuple(_write(752, (axis, *high), "XYLim") for axis, (_, high) in enumerate(words)),
    )


def _joint(joint: int) -> int:
    return _check(joint, 1, 6, "joint")


def _jrange_read(
    number: int, joint: int, what: str, data_words: int, rest: Callable[[_Words], T]
) -> Request[T]:
    joint = _joint(joint)
    return _echo_read(number, ((joint, "joint"),), f"JRange joint {joint}{what}", data_words, rest)


def read_jrange(joint: int) -> Request[PulseLimits]:
    """803: one joint's (1-6) range in pulses."""
    return _jrange_read(
        803, joint, "", 5, lambda w: PulseLimits(w.int32("lower pulse"), w.int32("upper pulse"))
    )


def read_jrange_lower(joint: int) -> Request[int]:
    """804: one joint's lower limit pulse."""
    return _jrange_read(804, joint, " lower", 3, lambda w: w.int32("lower pulse"))


def read_jrange_upper(joint: int) -> Request[int]:
    """805: one joint's upper limit pulse."""
    return _jrange_read(805, joint, " upper", 3, lambda w: w.int32("upper pulse"))


def set_jrange(joint: int, value: PulseLimits, *, command_words: int = MAX_WORDS) -> WriteSequence:
    """800, or 801 then 802 (written to the controller's memory card)."""
    joint = _joint(joint)
    lower, upper = int32_to_words(value.lower), int32_to_words(value.upper)
    what = f"JRange joint {joint}"
    return _fit(
        what,
        command_words,
        (_write(800, (joint, *lower, *upper), what),),
        (_write(801, (joint, *lower), what), _write(802, (joint, *upper), what)),
    )


def read_base(coord: int) -> Request[str]:
    """851: one coordinate (0 X ... 5 W) of the Base coordinate system."""
    coord = _check(coord, 0, 5, "coordinate")
    return _echo_read(
        851,
        ((coord, "coordinate"),),
        f"Base {COORDINATES[coord]}",
        3,
        lambda w: w.real(COORDINATES[coord]),
    )


def set_base(coords: Sequence[str]) -> WriteSequence:
    """850 for X, Y, Z, U (and V, W on a 6-axis robot), in order (Rn).

    Written to the controller's memory card; every Local must be defined again after.
    """
    return WriteSequence(
        "Base",
        tuple(
            _write(850, (coord, *words), "Base")
            for coord, words in enumerate(_coords(coords, "Base"))
        ),
    )


# --- LimZ (§10.26) -------------------------------------------------------------------


def read_limz() -> Request[str]:
    """1251: LimZ, mm."""
    return _read(1251, (), "LimZ", 2, lambda w: w.real("LimZ"))


def set_limz(z: str) -> WriteSequence:
    """1250: LimZ, mm (back to 0 at restart, Motor On, SFree, SLock)."""
    return WriteSequence("LimZ", (_write(1250, real_to_words(z), "LimZ"),))
