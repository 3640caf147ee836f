"""Requests for points: coordinates, attributes and J1Angle (§10.25)."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Literal

from .numbers import _WORD, COORDINATES, real_to_words
from .request import Request, WriteSequence, _check, _read, _write

# --- points (§10.25) -----------------------------------------------------------------

PointAttribute = Literal["hand", "elbow", "wrist", "j4flag", "j6flag", "local", "j1flag", "j2flag"]

#: Attribute -> (the read command, its values): 1215 hand 0 Lefty 1 Righty, 1216
#: elbow 0 Above 1 Below, 1217 wrist 0 NoFlip 1 Flip, 1218 j4flag 0-1, 1219
#: j6flag 0-127, 1220 local (0 = none); on a 6-axis robot only (§10.25, "available
#: for 6-axis manipulators"), 1224 J1Flag and 1226 J2Flag 0-1.
POINT_ATTRIBUTES: Mapping[str, tuple[int, int, int]] = MappingProxyType(
    {
        "hand": (1215, 0, 1),
        "elbow": (1216, 0, 1),
        "wrist": (1217, 0, 1),
        "j4flag": (1218, 0, 1),
        "j6flag": (1219, 0, 127),
        "local": (1220, 0, 15),
        "j1flag": (1224, 0, 1),
        "j2flag": (1226, 0, 1),
    }
)
#: Attribute -> the write command for each value (hand 0 Lefty -> 1207 ...), or
#: one command that takes the value as its second parameter.
_POINT_SETS: Mapping[str, tuple[int, ...]] = MappingProxyType(
    {
        "hand": (1207, 1206),
        "elbow": (1208, 1209),
        "wrist": (1211, 1210),
        "j4flag": (1212,),
        "j6flag": (1213,),
        "local": (1214,),
        "j1flag": (1223,),
        "j2flag": (1225,),
    }
)


def _point(point: int) -> int:
    return _check(point, 0, _WORD, "point number")


def read_point_coord(point: int, axis: int) -> Request[str]:
    """1222: one coordinate (0 X ... 5 W) of a point.  The answer echoes neither the
    point nor the axis; an undefined point answers error 2004 (the profile)."""
    point, axis = _point(point), _check(axis, 0, 5, "axis")
    return _read(
        1222, (point, axis), f"P{point} {COORDINATES[axis]}", 2, lambda w: w.real(COORDINATES[axis])
    )


def read_point_attribute(attribute: PointAttribute, point: int) -> Request[int]:
    """1215-1220: one attribute of a point, as :data:`POINT_ATTRIBUTES` codes it."""
    number, low, high = POINT_ATTRIBUTES[attribute]
    point = _point(point)
    return _read(
        number, (point,), f"P{point} {attribute}", 1, lambda w: w.number(low, high, attribute)
    )


def read_point_j1angle(point: int) -> Request[str]:
    """1228: a point's J1Angle (RS robots: Joint 1's angle at the singularity)."""
    point = _point(point)
    return _read(1228, (point,), f"P{point} j1angle", 2, lambda w: w.real("J1Angle"))


def set_point_j1angle(point: int, value: str) -> WriteSequence:
    """1227: a point's J1Angle, parameter 1 = 1 ("use the setting value"): the
    value is always given, so what 1228 reads back is what was set."""
    point = _point(point)
    what = f"P{point} j1angle"
    return WriteSequence(what, (_write(1227, (1, point, *real_to_words(value)), what),))


def set_point_coord(point: int, axis: int, value: str) -> WriteSequence:
    """1204: one coordinate of a point (the first 1204 of an undefined point
    defines it, its other axes 0)."""
    point, axis = _point(point), _check(axis, 0, 5, "axis")
    what = f"P{point} {COORDINATES[axis]}"
    return WriteSequence(what, (_write(1204, (point, axis, *real_to_words(value)), what),))


def set_point_attribute(attribute: PointAttribute, point: int, value: int) -> WriteSequence:
    """1206-1214: one attribute of a point, coded as 1215-1220 read it.

    The local number is 1-15 (1214 cannot set "none"); it is set without
    converting the coordinates (bit 15 of parameter 2 is 0).
    """
    point = _point(point)
    what = f"P{point} {attribute}"
    commands = _POINT_SETS[attribute]
    _, low, high = POINT_ATTRIBUTES[attribute]
    if attribute == "local":
        low = 1
    value = _check(value, low, high, attribute)
    if len(commands) == 2:
        return WriteSequence(what, (_write(commands[value], (point,), what),))
    return WriteSequence(what, (_write(commands[0], (point, value), what),))
