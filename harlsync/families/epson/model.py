"""The Epson data model: what a backup holds, its item keys, and how long each item
lives on the controller.

Every item is keyed by a typed NamedTuple and holds the codec's own value types,
numbers as exact text (reals with three decimals, ``"100.123"``)::

    TableKey("accel_s", 3)     AccelReal("100.123", "200.000")   one table entry (0-15)
    SettingKey("box", 5)       (Limits, Limits, Limits)          one numbered setting
    SettingKey("weight")       Weight("2.000", "0.000")          a setting there is one of
    PointKey("point", 12)      Point(("1.000", ...), hand=1 ...) one point

A table entry, point, Box, Plane or Local the controller does not hold is absent.

Volatility (digest §2) is said per kind, in the files, their schemas and the diff:

======================  ==========================================================
volatile                the six tables (cleared at power-off and reset, §9.1), LimZ
                        (0 again at power-on, Motor On, SFree, SLock) and Fine (its
                        defaults again at Motor On, SFree, SLock)
persistent              Weight, Inertia, Tool, Box, Plane, XYLim, JRange, Base: kept
                        on the controller's memory card (its life shortens with each
                        write, so a push writes only what changed)
volatility not stated   Arch, Local and points: the manual does not say
======================  ==========================================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, NamedTuple

from .profile import ROBOT_AXES
from .protocol import (
    COORDINATES,
    RESPONSE_CODES,
    ROBOT_TYPES,
    AccelPercent,
    AccelReal,
    Distances,
    Inertia,
    PointAttribute,
    PulseLimits,
    SpeedPercent,
    SpeedReal,
    Weight,
)

__all__ = [
    "ATTRIBUTES",
    "ATTRIBUTE_NAMES",
    "ATTRIBUTE_OF",
    "EXTRA_ATTRIBUTES",
    "KINDS",
    "PAST_TABLE",
    "PERSISTENT",
    "POINT",
    "TYPE_ATTRIBUTES",
    "UNSTATED",
    "VOLATILE",
    "EpsonData",
    "Key",
    "Kind",
    "NotThere",
    "Point",
    "PointKey",
    "PointTable",
    "SettingKey",
    "TableKey",
    "axes_of_type",
    "coordinate_names",
    "covered_text",
    "field_texts",
    "table_notes",
    "type_attributes",
    "type_code",
    "value_text",
]

VOLATILE = "volatile"
PERSISTENT = "persistent"
UNSTATED = "not stated"


class TableKey(NamedTuple):
    """One entry (0-15) of one of the six speed and acceleration tables."""

    kind: str  # accel, accel_s, accel_r, speed, speed_s, speed_r
    number: int


class SettingKey(NamedTuple):
    """One setting: numbered (Arch 0-6, Box/Plane/Local 1-15, JRange joint 1-6) or
    the only one of its kind (``number`` None: Weight, Fine, LimZ ...)."""

    kind: str
    number: int | None = None


class PointKey(NamedTuple):
    """One point, P0 to P65535."""

    kind: str  # "point"
    number: int


Key = TableKey | SettingKey | PointKey


@dataclass(frozen=True)
class Kind:
    """What one kind of item is: its name as the manual writes it, its volatility,
    its numbers, and the shape of its value."""

    key: str
    #: as the manual and a diff name it: ``AccelS``
    name: str
    volatility: str
    #: why, for the files and the docs: ``cleared at power-off and reset (§9.1)``
    why: str
    #: ``shape`` of the value: ``record`` (a NamedTuple of ``fields``), ``real`` or
    #: ``integer`` (one number), ``joints`` (Fine: one integer a joint), ``coords``
    #: (one real a coordinate), ``limits`` (lower and upper of X, Y, Z)
    shape: str
    #: the first and last number of a numbered kind; None: there is one item
    numbers: tuple[int, int] | None = None
    #: ``record``: its NamedTuple and whether its fields are reals
    record: Callable[..., tuple[object, ...]] | None = None
    fields: tuple[str, ...] = ()
    real: bool = True

    @property
    def numbered(self) -> bool:
        return self.numbers is not None

    @property
    def table(self) -> bool:
        return self.key in TABLES


_TABLE_WHY = "cleared at power-off and reset (§9.1); a push registers it again"
_CARD_WHY = "on the controller's memory card; a push writes it only when it changed"
_UNSTATED_WHY = "by the manual"
TABLE_NUMBERS = (0, 15)
FRAME_NUMBERS = (1, 15)


def _kinds(*kinds: Kind) -> Mapping[str, Kind]:
    return MappingProxyType({k.key: k for k in kinds})


#: Every kind of setting, in the order settings.yaml writes them.
KINDS: Mapping[str, Kind] = _kinds(
    Kind(
        "accel",
        "Accel",
        VOLATILE,
        _TABLE_WHY,
        "record",
        TABLE_NUMBERS,
        AccelPercent,
        AccelPercent._fields,
        real=False,
    ),
    Kind(
        "accel_s",
        "AccelS",
        VOLATILE,
        _TABLE_WHY,
        "record",
        TABLE_NUMBERS,
        AccelReal,
        AccelReal._fields,
    ),
    Kind(
        "accel_r",
        "AccelR",
        VOLATILE,
        _TABLE_WHY,
        "record",
        TABLE_NUMBERS,
        AccelReal,
        AccelReal._fields,
    ),
    Kind(
        "speed",
        "Speed",
        VOLATILE,
        _TABLE_WHY,
        "record",
        TABLE_NUMBERS,
        SpeedPercent,
        SpeedPercent._fields,
        real=False,
    ),
    Kind(
        "speed_s",
        "SpeedS",
        VOLATILE,
        _TABLE_WHY,
        "record",
        TABLE_NUMBERS,
        SpeedReal,
        SpeedReal._fields,
    ),
    Kind("speed_r", "SpeedR", VOLATILE, _TABLE_WHY, "real", TABLE_NUMBERS),
    Kind("arch", "Arch", UNSTATED, _UNSTATED_WHY, "record", (0, 6), Distances, Distances._fields),
    Kind(
        "fine",
        "Fine",
        VOLATILE,
        "back to its defaults at Motor On, SFree, SLock and reset",
        "joints",
    ),
    Kind("weight", "Weight", PERSISTENT, _CARD_WHY, "record", None, Weight, Weight._fields),
    Kind("inertia", "Inertia", PERSISTENT, _CARD_WHY, "record", None, Inertia, Inertia._fields),
    Kind(
        "tool",
        "Tool",
        PERSISTENT,
        _CARD_WHY + " (the tool selected: no command reads a tool's offset)",
        "integer",
    ),
    Kind("box", "Box", PERSISTENT, _CARD_WHY, "limits", FRAME_NUMBERS),
    Kind("plane", "Plane", PERSISTENT, _CARD_WHY, "coords", FRAME_NUMBERS),
    Kind("local", "Local", UNSTATED, _UNSTATED_WHY, "coords", FRAME_NUMBERS),
    Kind("xylim", "XYLim", PERSISTENT, _CARD_WHY, "limits"),
    Kind(
        "jrange",
        "JRange",
        PERSISTENT,
        _CARD_WHY + " (encoder pulses)",
        "record",
        (1, 6),
        PulseLimits,
        PulseLimits._fields,
        real=False,
    ),
    Kind("base", "Base", PERSISTENT, _CARD_WHY, "coords"),
    Kind("limz", "LimZ", VOLATILE, "0 again at power-on, Motor On, SFree, SLock and reset", "real"),
)
TABLES = ("accel", "accel_s", "accel_r", "speed", "speed_s", "speed_r")
#: Points, as a kind of item.
POINT = Kind(
    "point",
    "P",
    UNSTATED,
    _UNSTATED_WHY + "; harlsync never saves points to Points.pts (command 2052)",
    "point",
)

#: Point attributes and the names of their values (1215-1217), or None for a number.
ATTRIBUTE_NAMES: Mapping[str, tuple[str, ...] | None] = MappingProxyType(
    {
        "hand": ("Lefty", "Righty"),
        "elbow": ("Above", "Below"),
        "wrist": ("NoFlip", "Flip"),
        "j4flag": None,
        "j6flag": None,
        "local": None,
    }
)
ATTRIBUTES: tuple[PointAttribute, ...] = ("hand", "elbow", "wrist", "j4flag", "j6flag", "local")
#: The attributes only some manipulator types (2153 codes) have, and only theirs
#: (§10.25): a 6-axis robot's J1Flag and J2Flag (0-1; 1223-1226), an RS robot's
#: J1Angle (a real, degrees; 1227/1228).  None on a point of any other type.
TYPE_ATTRIBUTES: Mapping[int, tuple[str, ...]] = MappingProxyType(
    {5: ("j1flag", "j2flag"), 6: ("j1angle",)}
)
EXTRA_ATTRIBUTES = ("j1flag", "j2flag", "j1angle")
#: An attribute's name -> itself, typed (a plan's fields are text).
ATTRIBUTE_OF: Mapping[str, PointAttribute] = MappingProxyType(
    {a: a for a in (*ATTRIBUTES, "j1flag", "j2flag")}
)


def type_attributes(robot_type: int) -> tuple[str, ...]:
    """The attributes a point of this manipulator type has beyond 1215-1220."""
    return TYPE_ATTRIBUTES.get(robot_type, ())


def coordinate_names(axes: int) -> tuple[str, ...]:
    """``("x", "y", "z", "u")`` for 4 axes, up to ``w`` for 6."""
    return tuple(c.lower() for c in COORDINATES[:axes])


@dataclass(frozen=True)
class Point:
    """One point: a coordinate per axis (X, Y, Z, U and on a 6-axis robot V, W) as
    exact text, and its attributes as the 1215-1220 codes (hand 0 Lefty 1 Righty,
    elbow 0 Above 1 Below, wrist 0 NoFlip 1 Flip, j4flag 0-1, j6flag 0-127,
    local 0 none or 1-15); a 6-axis robot's J1Flag and J2Flag (0-1) and an RS
    robot's J1Angle (exact text), None on any other robot (:data:`TYPE_ATTRIBUTES`)."""

    coords: tuple[str, ...]
    hand: int = 0
    elbow: int = 0
    wrist: int = 0
    j4flag: int = 0
    j6flag: int = 0
    local: int = 0
    j1flag: int | None = None
    j2flag: int | None = None
    j1angle: str | None = None

    def attribute(self, name: str) -> int:
        value: int = getattr(self, name)
        return value

    def extras(self) -> list[tuple[str, str]]:
        """The type's own attributes it has, as (name, text): ``("j1flag", "0")``."""
        return [
            (name, str(value))
            for name in EXTRA_ATTRIBUTES
            if (value := getattr(self, name)) is not None
        ]

    def fields(self) -> list[tuple[str, str]]:
        """Every field as (name, text): ``("x", "1.000")`` ... ``("hand", "Righty")``."""
        out = list(zip(coordinate_names(len(self.coords)), self.coords))
        for name, names in ATTRIBUTE_NAMES.items():
            value = self.attribute(name)
            out.append((name, names[value] if names and 0 <= value < len(names) else str(value)))
        return out + self.extras()


def axes_of_type(code: int) -> int | None:
    """The axes a manipulator type (2153) has, or None when it does not say."""
    return ROBOT_AXES.get(code)


def type_code(name: str) -> int:
    """The 2153 code of a manipulator type name (``SCARA`` -> 3).  Raises KeyError."""
    return {text: code for code, text in ROBOT_TYPES.items()}[name]


class NotThere(NamedTuple):
    """An error response that says "no point here" (the manual gives no code for
    it): Response 1 and 2 as the controller answered them."""

    code: int
    detail: int = 0

    def __str__(self) -> str:
        """``2004/0000``: as controller.yaml records it."""
        return f"{self.code:04X}/{self.detail:04X}"

    def describe(self) -> str:
        """``2004/0000 (parameter error)``: as a message names it."""
        known = RESPONSE_CODES.get(self.code)
        outline = known.outline.split(":")[0].split(" (")[0] if known else "unknown code"
        return f"{self} ({outline})"

    @classmethod
    def parse(cls, text: str) -> NotThere:
        """``"2004/0000"`` as a NotThere.  Raises ValueError."""
        code, sep, detail = text.partition("/")
        if not sep or len(code) != 4 or len(detail) != 4:
            raise ValueError(f"{text!r} is not CODE/DETAIL in hex")
        return cls(int(code, 16), int(detail, 16))


@dataclass
class PointTable:
    """What a controller's point table showed where the manual is silent (issue
    29): its last point number, what a point past it answered (asked twice), and
    what a point not defined answered (asked twice; None when the read met none).
    controller.yaml records it; a later pull whose controller answers past the table
    (at its first exchanges) or for a point not defined (once the read is over:
    ``EpsonCatalogue.other_robot``) otherwise is refused, naming both answers."""

    end: int
    past_end: NotThere
    not_defined: NotThere | None = None


@dataclass
class EpsonData:
    """What a backup of an Epson controller holds: the manipulator (2153's type, its
    axes and 2154's model name) and every item by key.

    ``unwritable`` is set on data read from a robot that harlsync never writes to
    (its register map lacks Running, Paused or EStopOn); it is never saved.
    """

    robot_type: int
    axes: int
    model: str
    items: dict[Key, Any] = field(default_factory=dict)
    unwritable: str | None = None
    #: what a plan must say of the register map it was read through (no Ready)
    map_note: str | None = None
    #: the points a pull read (first, last) and the end of the probe that found
    #: none defined outside them (P0 up to it); None for data from the files
    covered: tuple[int, int] | None = None
    probed_to: int | None = None
    #: what the point table showed (controller.yaml ``points``); None: not recorded
    table: PointTable | None = None
    #: the points a first pull found past its default range and took in (first, last)
    taken_in: tuple[int, int] | None = None
    #: the point where the read found the table's end before robot.yaml's
    #: ``point_table_end`` (the table is smaller); None: it did not
    cut_at: int | None = None

    @property
    def type_name(self) -> str:
        return ROBOT_TYPES.get(self.robot_type, str(self.robot_type))

    def points(self) -> dict[int, Point]:
        return {k.number: v for k, v in self.items.items() if isinstance(k, PointKey)}


#: The robot identity's name for what a point past the point table answers.
PAST_TABLE = "answer past the point table"


def table_notes(data: EpsonData) -> list[str]:
    """What a pull says of the points beyond its range: those a first pull took in,
    a point table that ended before robot.yaml's end."""
    notes = []
    if data.taken_in is not None and data.covered is not None:
        low, high = data.taken_in
        notes.append(
            f"P{low}-P{high} found past the default range and taken in: robot.yaml "
            f"controller.first_point {data.covered[0]}, last_point {data.covered[1]}"
        )
    table = data.table
    if table is not None and data.cut_at is not None:
        notes.append(
            f"the controller's points end at P{table.end}: P{data.cut_at} answered "
            f"{table.past_end.describe()} twice, as a point past its table does"
        )
    return notes


def covered_text(data: EpsonData) -> str:
    """``P0-P99 read, none defined P100-P999``, ``P20-P99 read, none defined P0-P19
    and P100-P999`` (the range a pull covered)."""
    assert data.covered is not None
    first, last = data.covered
    text = f"P{first}-P{last} read"
    if data.probed_to is not None:
        probed = [(0, first - 1), (last + 1, data.probed_to)]
        shown = [f"P{a}-P{b}" for a, b in probed if a <= b]
        if shown:
            text += ", none defined " + " and ".join(shown)
    return text


def field_texts(kind: Kind, value: Any) -> list[tuple[str, str]]:
    """A value field by field as (field, exact text), as a diff names them:
    ``("accel", "100.123")``, ``("x upper", "10.000")``, ``("joint 2", "10000")``;
    one field ``""`` for a value that is one number."""
    shape = kind.shape
    if shape == "record":
        return [(f, str(getattr(value, f))) for f in kind.fields]
    if shape in ("real", "integer"):
        return [("", str(value))]
    if shape == "joints":
        return [(f"joint {i}", str(v)) for i, v in enumerate(value, 1)]
    if shape == "coords":
        return list(zip(coordinate_names(len(value)), value))
    if shape == "limits":
        return [
            (f"{axis} {end}", getattr(lim, end))
            for axis, lim in zip("xyz", value)
            for end in ("lower", "upper")
        ]
    point: Point = value
    return point.fields()


def value_text(kind: Kind, value: Any) -> str:
    """A whole value on one line, as its line of settings.yaml or points.yaml writes
    it: ``{accel: 100.123, decel: 200.000}``, ``[10000, 10000, 10000, 10000]``, ``0.000``."""
    shape = kind.shape
    if shape in ("real", "integer"):
        return str(value)
    if shape == "joints":
        return "[" + ", ".join(map(str, value)) + "]"
    if shape == "limits":
        return (
            "{"
            + ", ".join(f"{axis}: [{lim.lower}, {lim.upper}]" for axis, lim in zip("xyz", value))
            + "}"
        )
    return "{" + ", ".join(f"{name}: {text}" for name, text in field_texts(kind, value)) + "}"
