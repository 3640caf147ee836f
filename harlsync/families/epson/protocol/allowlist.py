"""The allow-list: every command this family sends (the backup reads and the
deploy writes) and the ones it must never send."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import NamedTuple

# --- the allow-list ----------------------------------------------------------------


class CommandSpec(NamedTuple):
    """What the family knows of one command it may send."""

    #: the manual's item and what the command does, for messages
    name: str
    #: whether it changes the controller
    is_write: bool
    #: the parameter counts the command takes (the word count less word 0)
    params: frozenset[int]


def _specs(
    is_write: bool, table: Mapping[int, tuple[str, tuple[int, ...]]]
) -> dict[int, CommandSpec]:
    return {
        number: CommandSpec(name, is_write, frozenset(counts))
        for number, (name, counts) in table.items()
    }


#: The reads a backup makes: the digest's safe-read list, only what the family uses.
_READS = _specs(
    False,
    {
        3: ("Accel table entry", (1,)),
        59: ("AccelS table entry", (1,)),
        60: ("AccelS table entry, accel", (1,)),
        61: ("AccelS table entry, decel", (1,)),
        109: ("AccelR table entry", (1,)),
        110: ("AccelR table entry, accel", (1,)),
        111: ("AccelR table entry, decel", (1,)),
        153: ("Speed table entry", (1,)),
        209: ("SpeedS table entry", (1,)),
        210: ("SpeedS table entry, speed and depart", (1,)),
        211: ("SpeedS table entry, approach", (1,)),
        253: ("SpeedR table entry", (1,)),
        302: ("Weight", (0,)),
        353: ("Inertia", (0,)),
        354: ("Inertia, load inertia", (0,)),
        355: ("Inertia, eccentricity", (0,)),
        403: ("Arch", (1,)),
        404: ("Arch, depart distance", (1,)),
        405: ("Arch, approach distance", (1,)),
        453: ("Fine", (0,)),
        454: ("Fine, joints 1-3", (0,)),
        455: ("Fine, joints 4-6", (0,)),
        501: ("Tool selected", (0,)),
        603: ("Box", (2,)),
        604: ("Box, lower limit", (2,)),
        605: ("Box, upper limit", (2,)),
        651: ("Plane", (2,)),
        701: ("Local", (2,)),
        753: ("XYLim", (1,)),
        754: ("XYLim, lower limit", (1,)),
        755: ("XYLim, upper limit", (1,)),
        803: ("JRange", (1,)),
        804: ("JRange, lower limit", (1,)),
        805: ("JRange, upper limit", (1,)),
        851: ("Base", (1,)),
        1215: ("point hand orientation", (1,)),
        1216: ("point elbow orientation", (1,)),
        1217: ("point wrist orientation", (1,)),
        1218: ("point j4flag", (1,)),
        1219: ("point j6flag", (1,)),
        1220: ("point local number", (1,)),
        1222: ("point coordinate", (2,)),
        1224: ("point J1Flag", (1,)),
        1226: ("point J2Flag", (1,)),
        1228: ("point J1Angle", (1,)),
        1251: ("LimZ", (0,)),
        2153: ("manipulator type", (0,)),
        2154: ("manipulator model name", (1,)),
        2155: ("controller error", (0,)),
        2156: ("control device", (0,)),
    },
)
#: The writes a deploy makes: each item's Set/Register command of the digest (§2).
_WRITES = _specs(
    True,
    {
        1: ("register Accel table entry", (3,)),
        53: ("register AccelS table entry", (5,)),
        54: ("register AccelS table entry, accel (R1)", (3,)),
        55: ("register AccelS table entry, decel (R2)", (3,)),
        103: ("register AccelR table entry", (5,)),
        104: ("register AccelR table entry, accel (R1)", (3,)),
        105: ("register AccelR table entry, decel (R2)", (3,)),
        151: ("register Speed table entry", (4,)),
        203: ("register SpeedS table entry", (7,)),
        204: ("register SpeedS table entry, speed and depart (R1)", (5,)),
        205: ("register SpeedS table entry, approach (R2)", (3,)),
        251: ("register SpeedR table entry", (3,)),
        300: ("set Weight and arm length", (4,)),
        301: ("set Weight", (2,)),
        350: ("set Inertia", (4,)),
        351: ("set Inertia, load inertia (S1)", (2,)),
        352: ("set Inertia, eccentricity (S2)", (2,)),
        400: ("set Arch", (5,)),
        401: ("set Arch, depart distance (S1)", (3,)),
        402: ("set Arch, approach distance (S2)", (3,)),
        450: ("set Fine", (4, 6)),
        451: ("set Fine, joints 1-3 (S1)", (3,)),
        452: ("set Fine, joints 4-6 (S2)", (1, 3)),
        500: ("select Tool", (1,)),
        600: ("set Box, one axis (Rn)", (6,)),
        601: ("set Box, lower limit of one axis (R1)", (4,)),
        602: ("set Box, upper limit of one axis (R2)", (4,)),
        650: ("set Plane, one coordinate (Rn)", (4,)),
        700: ("set Local, one coordinate (Rn)", (4,)),
        750: ("set XYLim, one axis (Rn)", (5,)),
        751: ("set XYLim, lower limit of one axis (R1)", (3,)),
        752: ("set XYLim, upper limit of one axis (R2)", (3,)),
        800: ("set JRange", (5,)),
        801: ("set JRange, lower limit (R1)", (3,)),
        802: ("set JRange, upper limit (R2)", (3,)),
        850: ("set Base, one coordinate (Rn)", (3,)),
        1204: ("set a point coordinate", (4,)),
        1206: ("set a point's hand orientation to Righty", (1,)),
        1207: ("set a point's hand orientation to Lefty", (1,)),
        1208: ("set a point's elbow orientation to Above", (1,)),
        1209: ("set a point's elbow orientation to Below", (1,)),
        1210: ("set a point's wrist orientation to Flip", (1,)),
        1211: ("set a point's wrist orientation to NoFlip", (1,)),
        1212: ("set a point's j4flag", (2,)),
        1213: ("set a point's j6flag", (2,)),
        1214: ("set a point's local number", (2,)),
        1223: ("set a point's J1Flag", (2,)),
        1225: ("set a point's J2Flag", (2,)),
        1227: ("set a point's J1Angle", (4,)),
        1250: ("set LimZ", (2,)),
    },
)
BACKUP_READS = frozenset(_READS)
DEPLOY_WRITES = frozenset(_WRITES)
#: The allow-list: every command the family may send, by number.
COMMANDS: Mapping[int, CommandSpec] = MappingProxyType({**_READS, **_WRITES})

#: The digest's never-send list (§4), by number, with the reason.
NEVER_SEND: Mapping[int, str] = MappingProxyType(
    {
        **dict.fromkeys((2000, 2001, 2002, 2003, 2005, 2006, 2007), "motion"),
        2050: "jog",
        2051: "teach: it writes the current pose into a point",
        2052: "it saves the points to Points.pts",
        2053: "motor excitation",
        1150: "power",
        1400: "motor",
        1450: "reset: it switches outputs off and re-initialises settings",
        **dict.fromkeys((2102, 2103, 2105, 2106), "outputs"),
        **dict.fromkeys((2109, 2110, 2112, 2113), "memory I/O"),
        **dict.fromkeys((554, 555, 556, 557), "it overwrites point variables with pallet corners"),
    }
)
if not NEVER_SEND.keys().isdisjoint(COMMANDS):  # pragma: no cover - a broken table
    raise AssertionError("a never-send command is on the allow-list")


def refusal(number: int) -> str | None:
    """Why ``number`` is never sent, or None when it is on the allow-list."""
    if number in COMMANDS:
        return None
    why = NEVER_SEND.get(number)
    return f"command {number} is not on the Epson allow-list: harlsync never sends it" + (
        f" ({why})" if why else " (only the backup reads and deploy writes are sent)"
    )
