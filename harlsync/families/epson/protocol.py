"""Epson Remote Control command and response words, sans I/O.

How this works::

    command words: holding registers command_base .. +7, written in one write
      word   0        1         2         3      ...  7
             number   param 1   param 2   param 3     param 7     unused words 0
             003BH    000FH     0000H     0000H       0000H       59: AccelS table 15

    response words: input registers response_base .. +7, read in one read
      word   0        1           2           3      4      5
             003BH    000FH       0001H 871BH        0003H 0D40H   echo, table, accel, decel
             echo     Response 1  Response 2                       set/register: 0000H, 0000H
             echo     code        detail      ExtCmdResult 1: an error, always 3 words (§7)

    a real value: round(x * 1000) as a 32-bit two's complement integer in two
    words, high word first
             100.123  -> 0001H 871BH          -100.003 -> FFFEH 795DH

Word 0 of a command is its number; word 0 of the response echoes it, and a
response that does not is an error (:class:`~harlsync.errors.ReplyError`).
Real values are exact decimal text with three decimals (``"100.123"``),
converted with integer arithmetic only, never a float.

A :class:`Request` is one command and knows its reply type: ``decode`` turns
the response words into a typed value, or an :class:`ErrorReply` when the
controller set ExtCmdResult (Response 1 and 2 kept raw, with the §7.1
meaning).  A write is a :class:`WriteSequence`: one command, or a split write
(S1/S2, R1/R2) or an Rn sequence (one coordinate a command), whose commands go
out back to back: the controller applies them at the last one and cancels them
silently if any other command comes in between.  Where the map has too few
command words for the one-command form, the split form is chosen.

The allow-list: :data:`COMMANDS` holds every command this family sends, the
backup reads and the deploy writes, each a subset of the digest's lists.
:func:`encode` refuses any other number (motion, jog, teach, power, motor,
reset, outputs, memory I/O, the point-overwriting 554-557, 2051, 2052 ...), and
so does :class:`Request`: nothing off the two lists can be put on the wire.

Requests, one builder per command (backup reads, then deploy writes)::

    read_accel 3        read_accel_s 59 (60, 61)    read_accel_r 109 (110, 111)
    read_speed 153      read_speed_s 209 (210, 211) read_speed_r 253
    read_weight 302     read_inertia 353 (354, 355) read_arch 403 (404, 405)
    read_fine 453 (454, 455)  read_tool 501   read_box 603 (604, 605)
    read_plane 651      read_local 701   read_xylim 753 (754, 755)
    read_jrange 803 (804, 805)  read_base 851  read_limz 1251
    read_robot_type 2153  read_model_name_char 2154
    read_point_coord 1222  read_point_attribute 1215-1220, 1224, 1226
    read_point_j1angle 1228

    register_accel 1    register_accel_s 53 | 54+55  register_accel_r 103 | 104+105
    register_speed 151  register_speed_s 203 | 204+205  register_speed_r 251
    set_weight 300 | 301  set_inertia 350 | 351+352  set_arch 400 | 401+402
    set_fine 450 | 451+452  select_tool 500  set_box 600 xyz | 601 xyz + 602 xyz
    set_plane 650 x..w  set_local 700 x..w  set_xylim 750 xyz | 751 xyz + 752 xyz
    set_jrange 800 | 801+802  set_base 850 x..w  set_limz 1250
    set_point_coord 1204  set_point_attribute 1206-1214, 1223, 1225
    set_point_j1angle 1227
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Generic, Literal, NamedTuple, TypeVar

from ...errors import ReplyError

__all__ = [
    "BACKUP_READS",
    "COMMANDS",
    "COORDINATES",
    "DEPLOY_WRITES",
    "FUNCTION_ERROR",
    "FUNCTION_ERROR_DETAILS",
    "MAX_WORDS",
    "NEVER_SEND",
    "POINT_ATTRIBUTES",
    "REAL_MAX",
    "REAL_MIN",
    "RESPONSE_CODES",
    "ROBOT_TYPES",
    "AccelPercent",
    "AccelReal",
    "Command",
    "CommandSpec",
    "Distances",
    "ErrorReply",
    "Inertia",
    "Limits",
    "NameChar",
    "PointAttribute",
    "PulseLimits",
    "Request",
    "ResponseCode",
    "SpeedPercent",
    "SpeedReal",
    "Weight",
    "WriteSequence",
    "canonical_real",
    "describe_code",
    "encode",
    "int32_from_words",
    "int32_to_words",
    "read_accel",
    "read_accel_r",
    "read_accel_r_accel",
    "read_accel_r_decel",
    "read_accel_s",
    "read_accel_s_accel",
    "read_accel_s_decel",
    "read_arch",
    "read_arch_approach",
    "read_arch_depart",
    "read_base",
    "read_box",
    "read_box_lower",
    "read_box_upper",
    "read_fine",
    "read_fine_123",
    "read_fine_456",
    "read_inertia",
    "read_inertia_eccentricity",
    "read_inertia_load",
    "read_jrange",
    "read_jrange_lower",
    "read_jrange_upper",
    "read_limz",
    "read_local",
    "read_model_name_char",
    "read_plane",
    "read_point_attribute",
    "read_point_coord",
    "read_point_j1angle",
    "read_robot_type",
    "read_speed",
    "read_speed_r",
    "read_speed_s",
    "read_speed_s_approach",
    "read_speed_s_speed_depart",
    "read_tool",
    "read_weight",
    "read_xylim",
    "read_xylim_lower",
    "read_xylim_upper",
    "real_from_words",
    "real_text",
    "real_to_words",
    "real_units",
    "refusal",
    "register_accel",
    "register_accel_r",
    "register_accel_s",
    "register_speed",
    "register_speed_r",
    "register_speed_s",
    "select_tool",
    "set_arch",
    "set_base",
    "set_box",
    "set_fine",
    "set_inertia",
    "set_jrange",
    "set_limz",
    "set_local",
    "set_plane",
    "set_point_attribute",
    "set_point_coord",
    "set_point_j1angle",
    "set_weight",
    "set_xylim",
]

T = TypeVar("T")
#: A request's reply type: a ``Request[str]`` is a ``Request[object]`` too.
R_co = TypeVar("R_co", covariant=True)

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


# --- response codes (§7) -------------------------------------------------------------


class ResponseCode(NamedTuple):
    """A Response 1 code of §7.1: its outline and what to do."""

    outline: str
    remedy: str


_NEXT = "the next command is accepted; this one did not complete: review the control method"
#: Response 1 (a hex word: ``2004`` is 0x2004) -> its §7.1 meaning.
RESPONSE_CODES: Mapping[int, ResponseCode] = MappingProxyType(
    {
        0x0000: ResponseCode("normal", "-"),
        0x1000: ResponseCode("command number error: unsupported command number", _NEXT),
        0x1002: ResponseCode(
            "command sequence error: the order of the requests is not proper", _NEXT
        ),
        0x2000: ResponseCode("execution error: the command cannot be executed", _NEXT),
        0x2001: ResponseCode("command/response word number setting error", _NEXT),
        0x2002: ResponseCode("command word number setting error", _NEXT),
        0x2003: ResponseCode("response word number setting error", _NEXT),
        0x2004: ResponseCode("parameter error", _NEXT),
        0x2005: ResponseCode(
            "table number specification error: the table number is out of range", _NEXT
        ),
        0x2006: ResponseCode("table registration error: the table is not registered", _NEXT),
        0x2007: ResponseCode("pallet undefined", _NEXT),
        0x2008: ResponseCode("pallet point number discrepancy", _NEXT),
        0x2009: ResponseCode("Box undefined", _NEXT),
        0x200A: ResponseCode(
            "command execution error (Response 2: the controller's error code)", _NEXT
        ),
        0x200B: ResponseCode(
            "command not accepted because of the system status", "reboot the system"
        ),
        0x3000: ResponseCode(
            "RC error (Response 2: the controller's error code)",
            "look the code up in the controller manual",
        ),
        0x9999: ResponseCode("function error", "reset the function (the function reset signal)"),
    }
)
#: Response 1 of a function error (ExtError 1).
FUNCTION_ERROR = 0x9999
#: Response 2 of a function error (§7.2.3).
FUNCTION_ERROR_DETAILS: Mapping[int, str] = MappingProxyType(
    {
        0x0001: "command acceptance status error: a command was requested while another was "
        "executing",
        0x9901: "WBMPostMessageExtra failure (caused by the controller)",
        0x9902: "PRINT message error (caused by the controller)",
    }
)


def describe_code(code: int, detail: int = 0) -> str:
    """Response 1 and 2 as a person reads them: ``"2006 table registration error ..."``."""
    known = RESPONSE_CODES.get(code)
    text = f"{code:04X} {known.outline if known else 'unknown response code'}"
    if code == FUNCTION_ERROR:
        text += f", detail {detail:04X} {FUNCTION_ERROR_DETAILS.get(detail, '(unknown detail)')}"
    elif detail:
        text += f", detail {detail:04X}"
    return text


@dataclass(frozen=True)
class ErrorReply:
    """The controller answered with ExtCmdResult 1: the command did not complete.

    ``code`` and ``detail`` are Response 1 and 2 as received.
    """

    number: int
    code: int
    detail: int

    @property
    def meaning(self) -> str:
        known = RESPONSE_CODES.get(self.code)
        return known.outline if known else "unknown response code"

    @property
    def remedy(self) -> str:
        known = RESPONSE_CODES.get(self.code)
        return known.remedy if known else "see the manual"

    def __str__(self) -> str:
        return f"command {self.number}: error {describe_code(self.code, self.detail)}"


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


# --- commands on the wire ------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """A command number and its parameters, one 16-bit word each."""

    number: int
    params: tuple[int, ...] = ()

    @property
    def words(self) -> tuple[int, ...]:
        return (self.number, *self.params)

    def __str__(self) -> str:
        return " ".join(f"{w & _WORD:04X}H" for w in self.words)


def encode(command: Command, width: int = MAX_WORDS) -> tuple[int, ...]:
    """The ``width`` command words of ``command``: number, parameters, unused words 0.

    Raises :class:`ValueError` for a command off the allow-list (nothing else is
    ever sent), a parameter count the command does not take, a word outside
    0000H-FFFFH, or more words than ``width``.
    """
    why = refusal(command.number)
    if why is not None:
        raise ValueError(why)
    spec = COMMANDS[command.number]
    if len(command.params) not in spec.params:
        counts = " or ".join(str(n) for n in sorted(spec.params))
        raise ValueError(
            f"command {command.number} ({spec.name}) takes {counts} parameters, "
            f"not {len(command.params)}"
        )
    for i, word in enumerate(command.params, 1):
        if not 0 <= word <= _WORD:
            raise ValueError(
                f"command {command.number} parameter {i}: {word} is not a 16-bit word (0 to 65535)"
            )
    if not 1 <= width <= MAX_WORDS:
        raise ValueError(f"width {width} out of range (allowed: 1 to {MAX_WORDS})")
    words = command.words
    if len(words) > width:
        raise ValueError(
            f"command {command.number} ({spec.name}) needs {len(words)} "
            f"command words, the map has {width}"
        )
    return words + (0,) * (width - len(words))


class _Words:
    """A cursor over a response's data words (after the echo)."""

    def __init__(self, words: Sequence[int]) -> None:
        self._words = words
        self._at = 0

    def word(self, what: str) -> int:
        if self._at >= len(self._words):
            raise ValueError(f"the response ends before {what}")
        value = self._words[self._at]
        if not 0 <= value <= _WORD:
            raise ValueError(f"{what} {value} is not a 16-bit word")
        self._at += 1
        return value

    def expect(self, value: int, what: str) -> None:
        got = self.word(what)
        if got != value:
            raise ValueError(f"{what} {got}, asked for {value}")

    def int32(self, what: str) -> int:
        return int32_from_words(self.word(f"{what} (high word)"), self.word(f"{what} (low word)"))

    def real(self, what: str) -> str:
        return real_text(self.int32(what))

    def number(self, low: int, high: int, what: str) -> int:
        value = self.word(what)
        if not low <= value <= high:
            raise ValueError(f"{what} {value} out of range (allowed: {low} to {high})")
        return value


@dataclass(frozen=True)
class Request(Generic[R_co]):
    """One command and how to read its response.

    ``parse`` turns the response's data words (after the echo) into the value,
    raising :class:`ValueError` when they do not fit; ``data_words`` is how many
    the response carries.  Requests compare by command.  Constructing one for a
    command off the allow-list raises :class:`ValueError`.
    """

    command: Command
    what: str
    parse: Callable[[_Words], R_co] = field(repr=False, compare=False)
    data_words: int = field(default=2, compare=False)

    def __post_init__(self) -> None:
        encode(self.command)  # the allow-list and the parameter counts

    @property
    def number(self) -> int:
        return self.command.number

    @property
    def is_write(self) -> bool:
        return COMMANDS[self.number].is_write

    @property
    def command_words(self) -> int:
        """Command words the request needs (word 0 included)."""
        return len(self.command.words)

    @property
    def response_words(self) -> int:
        """Response words the reply needs: echo and data, and at least the 3 of an
        error response."""
        return max(3, 1 + self.data_words)

    def encode(self, width: int = MAX_WORDS) -> tuple[int, ...]:
        """The command words, padded with 0 to ``width``.  Raises :class:`ValueError`
        when the command needs more."""
        return encode(self.command, width)

    def decode(self, words: Sequence[int], *, error: bool = False) -> R_co | ErrorReply:
        """The value ``words`` (the response words from word 0) answer, or an
        :class:`ErrorReply` when ``error`` (ExtCmdResult was 1).

        Raises :class:`ReplyError` when word 0 does not echo the command number,
        or the words are too few or do not fit the command's layout.
        """
        need = 3 if error else 1 + self.data_words
        if len(words) < need:
            raise ReplyError(f"{self}: {len(words)} response words, {need} needed")
        if words[0] != self.number:
            raise ReplyError(
                f"{self}: response word 0 is {words[0]:04X}H, not the command "
                f"number {self.number:04X}H echoed"
            )
        if error:
            return ErrorReply(self.number, words[1], words[2])
        try:
            return self.parse(_Words(words[1 : 1 + self.data_words]))
        except ValueError as exc:
            shown = " ".join(f"{w:04X}H" for w in words[:need])
            raise ReplyError(f"{self}: bad response {shown}: {exc}") from exc

    def __str__(self) -> str:
        return f"{self.number} ({self.what})"


@dataclass(frozen=True)
class WriteSequence:
    """The commands of one write, in order.  More than one is a split write or an
    Rn sequence: they go out back to back, nothing in between (any other command
    cancels them), and take effect at the last."""

    what: str
    requests: tuple[Request[None], ...]

    @property
    def command_words(self) -> int:
        """Command words the longest of them needs."""
        return max(r.command_words for r in self.requests)

    def __iter__(self) -> Iterator[Request[None]]:
        return iter(self.requests)

    def __len__(self) -> int:
        return len(self.requests)


# --- building requests -------------------------------------------------------------


def _check(value: int, low: int, high: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{what} {value!r} out of range (allowed: {low} to {high})")
    return value


def _table(table: int) -> int:
    return _check(table, 0, 15, "table number")


def _read(
    number: int, params: tuple[int, ...], what: str, data_words: int, parse: Callable[[_Words], T]
) -> Request[T]:
    return Request(Command(number, params), what, parse, data_words)


def _ack(words: _Words) -> None:
    code = words.word("Response 1")
    if code:
        raise ValueError(f"Response 1 is {describe_code(code)} with ExtCmdResult 0")


def _write(number: int, params: Sequence[int], what: str) -> Request[None]:
    return Request(Command(number, tuple(params)), what, _ack, 2)


def _fit(what: str, command_words: int, *forms: tuple[Request[None], ...]) -> WriteSequence:
    """The first form whose commands fit ``command_words`` words."""
    for form in forms:
        sequence = WriteSequence(what, form)
        if sequence.command_words <= command_words:
            return sequence
    need = min(WriteSequence(what, form).command_words for form in forms)
    raise ValueError(f"{what}: needs {need} command words, the map has {command_words}")


def _echo_read(
    number: int,
    echoed: Sequence[tuple[int, str]],
    what: str,
    data_words: int,
    rest: Callable[[_Words], T],
) -> Request[T]:
    """A read whose parameters (table, axis, joint ...) come back before its data."""

    def parse(words: _Words) -> T:
        for value, name in echoed:
            words.expect(value, name)
        return rest(words)

    return _read(number, tuple(value for value, _ in echoed), what, data_words, parse)


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


# --- LimZ, the robot (§10.26, §8.5) -------------------------------------------------------


def read_limz() -> Request[str]:
    """1251: LimZ, mm."""
    return _read(1251, (), "LimZ", 2, lambda w: w.real("LimZ"))


def set_limz(z: str) -> WriteSequence:
    """1250: LimZ, mm (back to 0 at restart, Motor On, SFree, SLock)."""
    return WriteSequence("LimZ", (_write(1250, real_to_words(z), "LimZ"),))


#: Manipulator type codes of 2153.
ROBOT_TYPES: Mapping[int, str] = MappingProxyType(
    {1: "Joint", 2: "Cartesian", 3: "SCARA", 5: "6-AXIS", 6: "RS"}
)


def read_robot_type() -> Request[int]:
    """2153: the manipulator type (:data:`ROBOT_TYPES`)."""

    def parse(words: _Words) -> int:
        code = words.word("manipulator type")
        if code not in ROBOT_TYPES:
            raise ValueError(f"manipulator type {code} is not one the manual lists")
        return code

    return _read(2153, (), "manipulator type", 1, parse)


class NameChar(NamedTuple):
    """One answer of 2154: ``status`` 0 = this is the last character, 1 = more
    follow, 2 = the name is complete (no character)."""

    status: int
    char: str


def read_model_name_char(start: bool) -> Request[NameChar]:
    """2154: the next character of the model name (``start``: from the first one)."""

    def parse(words: _Words) -> NameChar:
        status = words.word("acquisition status")
        if status & ~0x7 or status & 0x7 > 2:
            raise ValueError(f"acquisition status {status:04X}H is not 0, 1 or 2")
        code = words.word("character")
        if code & ~0xFF or (status != 2 and not 0x20 <= code <= 0x7E):
            raise ValueError(f"character {code:04X}H is not printable ASCII")
        return NameChar(status, "" if status == 2 else chr(code))

    return _read(2154, (int(start),), "model name", 2, parse)


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
