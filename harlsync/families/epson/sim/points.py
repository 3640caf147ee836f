"""The controller's side of the point commands (§10.25): a point's coordinates
and attributes, read and written on a :class:`~.state.SimState`, and the table of
their command numbers (:data:`READ_COMMANDS`, :data:`WRITE_COMMANDS`) that
:mod:`.commands` carries out.

A point not defined, or a number past the point table, is answered as the
session's :class:`~.codes.PointAnswers` say (the manual is silent: variants);
the first coordinate written defines a point.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from .codes import EXECUTION, PARAMETER, Refused
from .params import Params, words_of
from .point import Point
from .session import Handler, Session, WordCount
from .state import RS, SIX_AXIS, SimState

__all__ = ["READ_COMMANDS", "WRITE_COMMANDS"]


def _point_number(s: Session, p: Params, i: int = 1) -> int:
    """The point number parameter ``i`` gives; one past the point table answers as
    :attr:`~.codes.PointAnswers.past_table` (a variant: the manual does not say)."""
    number = p.word(i)
    if number > s.points.last:
        raise Refused(*s.points.past_table)
    return number


def _point(s: Session, st: SimState, p: Params, i: int = 1) -> Point:
    """The point parameter ``i`` names; an undefined one answers as
    :attr:`~.codes.PointAnswers.undefined` (2004 by default, the profile's guess)."""
    point = st.points.get(_point_number(s, p, i))
    if point is None:
        raise Refused(*s.points.undefined)
    return point


def _type_point(s: Session, st: SimState, p: Params, types: tuple[int, ...]) -> Point:
    """The point of a command "available for" only some manipulators (1223-1228:
    6-axis, RS); another type's controller cannot execute it (error 2000)."""
    if st.robot_type not in types:
        raise Refused(EXECUTION)
    return _point(s, st, p)


def _point_coord(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    point, axis = _point(s, st, p), p.number(2, 0, st.axes - 1)
    return words_of(point.coords[axis])  # neither the point nor the axis is echoed


def _set_point_coord(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    number, selector = _point_number(s, p), p.word(2)
    if selector & ~0x7 or selector >= st.axes:  # bits 15-3 reserved: 0
        raise Refused(PARAMETER)
    value = p.int32(3)
    point = st.points.setdefault(number, Point((0,) * st.axes))  # the first defines it
    point.coords = tuple(value if i == selector else c for i, c in enumerate(point.coords))
    return s.done()


def _set_point_local(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    point, word = _point(s, st, p), p.word(2)
    if word & 0x8000:
        # "convert": the coordinates become the local's.  The simulator has no
        # kinematics to convert them with, and harlsync never asks for it.
        raise Refused(EXECUTION)
    if word & 0x7FF0 or not 1 <= word & 0xF <= 15:
        raise Refused(PARAMETER)
    point.local = word & 0xF
    return s.done()


def _j1angle(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    return words_of(_type_point(s, st, p, (RS,)).j1angle)


def _set_j1angle(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    """1227: parameter 1 0 omits the value, 1 uses it; parameter 2 the point."""
    if st.robot_type != RS:
        raise Refused(EXECUTION)
    option = p.number(1, 0, 1)
    point = _point(s, st, p, 2)
    if option:
        point.j1angle = p.int32(3)
    return s.done()


def _point_attribute(name: str) -> Handler:
    """1215-1220: one attribute of a point."""

    def read(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
        value: int = getattr(_point(s, st, p), name)
        return (value,)

    return read


def _set_point_flag(name: str, value: int) -> Handler:
    """1206-1211: a command a value, the point its only parameter."""

    def write(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
        setattr(_point(s, st, p), name, value)
        return s.done()

    return write


def _set_point_number(name: str, high: int, types: tuple[int, ...] = ()) -> Handler:
    """1212, 1213 (1223, 1225 on ``types`` only): the value in parameter 2."""

    def write(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
        point = _type_point(s, st, p, types) if types else _point(s, st, p)
        setattr(point, name, p.number(2, 0, high))
        return s.done()

    return write


def _type_attribute(name: str, types: tuple[int, ...]) -> Handler:
    """1224, 1226: an attribute only ``types`` of manipulator have."""

    def read(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
        value: int = getattr(_type_point(s, st, p, types), name)
        return (value,)

    return read


# --- the table: number -> (command words, word 0 included; handler) -------------------------

READ_COMMANDS: Mapping[int, tuple[WordCount, Handler]] = MappingProxyType(
    {
        **{
            1215 + i: (2, _point_attribute(name))  # 1215 hand ... 1220 local
            for i, name in enumerate(("hand", "elbow", "wrist", "j4flag", "j6flag", "local"))
        },
        1222: (3, _point_coord),
        1224: (2, _type_attribute("j1flag", (SIX_AXIS,))),
        1226: (2, _type_attribute("j2flag", (SIX_AXIS,))),
        1228: (2, _j1angle),
    }
)
WRITE_COMMANDS: Mapping[int, tuple[WordCount, Handler]] = MappingProxyType(
    {
        1204: (5, _set_point_coord),
        1206: (2, _set_point_flag("hand", 1)),  # Righty
        1207: (2, _set_point_flag("hand", 0)),  # Lefty
        1208: (2, _set_point_flag("elbow", 0)),  # Above
        1209: (2, _set_point_flag("elbow", 1)),  # Below
        1210: (2, _set_point_flag("wrist", 1)),  # Flip
        1211: (2, _set_point_flag("wrist", 0)),  # NoFlip
        1212: (3, _set_point_number("j4flag", 1)),
        1213: (3, _set_point_number("j6flag", 127)),
        1214: (3, _set_point_local),
        1223: (3, _set_point_number("j1flag", 1, (SIX_AXIS,))),
        1225: (3, _set_point_number("j2flag", 1, (SIX_AXIS,))),
        1227: (5, _set_j1angle),
    }
)
