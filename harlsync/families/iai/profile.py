"""Every choice the IAI protocol B manual leaves open, in one place.

These are the *(profile)* decisions of ``shared/spec/iai-protocol-b-profile.md``
(and the few fixed facts the codec needs beside them, each with its manual page):
the codec, the link settings, the simulator and the sync engine read them from
this module.  Each is a default.  Where a controller may answer otherwise, either
its own replies decide at each read (where a table ends, what a number it lacks
answers, the real variables' word order: :mod:`.tables`), or robot.yaml has the
setting, named beside the default and in every message that mentions it; a site
never edits this module.  docs/profile.md lists every one, with the simulator
variant that answers the other way.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Literal, NamedTuple

__all__ = [
    "ACCEPT_LOWER_CASE_HEX",
    "ALLOWED_MESSAGE_IDS",
    "BAUDRATE",
    "BAUDRATES",
    "BUFFERS",
    "BYTESIZE",
    "COORDINATE_SYSTEM_TYPES",
    "CORE_MESSAGE_IDS",
    "DEFAULT_MODEL",
    "DEFAULT_POSITION_RANGE",
    "DEFAULT_REAL_WORD_ORDER",
    "DEFAULT_STATION",
    "DEFAULT_VARIABLE_RANGES",
    "FLAG_QUERY_ALIGNMENT",
    "INTER_COMMAND_GAP",
    "MAX_FRAME",
    "NUMBER_FIRST",
    "OPT_IN_MESSAGE_IDS",
    "PARITY",
    "PERSISTENCE_NOTICE",
    "POSITION_NUMBER_END",
    "POSITION_PROBE_FALLBACK_END",
    "POSITION_RECORD_HAS_NUMBER",
    "READ_RECORD_MAX",
    "REAL_WORD_ORDERS",
    "RECORD_MESSAGE_IDS",
    "RECORD_NUMBER_END",
    "REPLY_DEADLINE_BASE",
    "REPLY_DEADLINE_FACTOR",
    "RTSCTS",
    "STATION_ALLOWED",
    "STOPBITS",
    "STRING_ROW",
    "VARIABLE_NUMBER_END",
    "VOLATILE_MESSAGE_IDS",
    "WRITE_MESSAGE_IDS",
    "WRITE_RECORD_MAX",
    "XONXOFF",
    "Buffers",
    "bits_per_char",
    "reply_deadline",
]

# --- station and serial line --------------------------------------------------------

#: Station when the robot file gives none: 99h, written and shown as hex.
DEFAULT_STATION = 0x99
#: What a station may be, as every message about one says it (robot.yaml, --station).
STATION_ALLOWED = "two hex digits, 00-FF; 99 by default"

#: Serial settings when the robot file gives none: 9600 8N1, no flow control.
BAUDRATE = 9600
BYTESIZE = 8
PARITY: Literal["N", "E", "O"] = "N"
STOPBITS: Literal[1, 2] = 1
RTSCTS = False
XONXOFF = False

#: The speeds the controller offers (p.7); 57600 and 115200 only on X-SEL
#: P/Q/.../SXD, SSEL/ASEL/PSEL and TTA.
BAUDRATES = (9600, 19200, 38400, 57600, 115200)

#: Seconds to wait after a reply before the next command (p.9: at least 1 ms).
INTER_COMMAND_GAP = 0.001

#: Reply deadline: this many seconds ...
REPLY_DEADLINE_BASE = 0.5
#: ... plus this many times the wire time of the longest reply the command can get.
REPLY_DEADLINE_FACTOR = 1.5


def bits_per_char(bytesize: int = BYTESIZE, parity: str = PARITY, stopbits: int = STOPBITS) -> int:
    """Bits one character takes on the wire: start bit, data, parity, stop bits."""
    return 1 + bytesize + (0 if parity == "N" else 1) + stopbits


def reply_deadline(reply_bytes: int, baudrate: int = BAUDRATE, char_bits: int = 10) -> float:
    """Seconds to wait for a reply of at most ``reply_bytes`` bytes.

    ``0.5 + 1.5 x wire time``: a 2048-byte reply at 9600 8N1 is 2.13 s on the
    wire, so 3.7 s.
    """
    return REPLY_DEADLINE_BASE + REPLY_DEADLINE_FACTOR * reply_bytes * char_bits / baudrate


# --- buffers per controller model (p.15) ----------------------------------------------


class Buffers(NamedTuple):
    """The largest frame, in bytes, a controller takes (receive) and gives (send)."""

    receive: int
    send: int


_LARGE = Buffers(receive=2051, send=2048)
_SMALL = Buffers(receive=1023, send=1024)

#: Model name (the per-robot setting) -> its buffers.  The manual's model list;
#: ``XSEL-JK`` names the whole X-SEL J/K family.
BUFFERS: Mapping[str, Buffers] = MappingProxyType(
    {
        "TTA": _LARGE,
        **{
            f"XSEL-{m}": _LARGE
            for m in ("P", "Q", "PCT", "QCT", "PX", "QX", "R", "S", "RX", "SX", "RXD", "SXD")
        },
        "SSEL": _LARGE,
        "ASEL": _LARGE,
        "PSEL": _LARGE,
        "XSEL-JK": _SMALL,
        **{f"XSEL-{m}": _SMALL for m in ("J", "K", "KE", "KT", "KET", "JX", "KX", "KTX")},
        "TT": _SMALL,
    }
)

#: Model when the robot file gives none.
DEFAULT_MODEL = "TTA"

#: The decoder gives up on a frame with no LF after this many bytes and resyncs at
#: the next header.  The largest buffer of any model, plus slack in case the
#: manual's sizes leave out the header or SC, CR and LF.
MAX_FRAME = max(max(b) for b in BUFFERS.values()) + 16

# --- frames -----------------------------------------------------------------------

#: A reader accepts upper- or lower-case hex (station, id, data, SC); the client
#: always sends upper case.
ACCEPT_LOWER_CASE_HEX = True

# --- positions ----------------------------------------------------------------------

#: Position numbers a robot's table holds when the robot file gives no range
#: (first, last), inclusive.
DEFAULT_POSITION_RANGE = (1, 1000)

#: The highest position number 22DH can name (4 hex digits).
POSITION_NUMBER_END = 0xFFFF
#: Where a probe past the position table stops reading when a controller will not
#: answer a 22DH for every number past it at once (it refuses so wide a query, or
#: is seen to scan fewer numbers than asked) and does not show where its table
#: ends (it answers a number past it with an empty reply, not ``&``): the most
#: position records 22DH carries (p.36, "Max 20000 records").  Such a probe reads
#: that far in queries of the table's read size (tables.py).
POSITION_PROBE_FALLBACK_END = 20000

#: 291H records carry no position number: pattern, acc, dec, speed, up to 8
#: coordinates, extended = at most 80 bytes (the manual prints 84).
POSITION_RECORD_HAS_NUMBER = False
WRITE_RECORD_MAX = 80
#: 22DH records carry the 4-digit number in front: at most 84 bytes.
READ_RECORD_MAX = 84

# --- global flags and variables (kept only when the project opts in) --------------

#: The global flags and integer and real variables a project that keeps them
#: (robot.yaml ``keep_registers: true``) backs up when robot.yaml gives no range:
#: robot.yaml key -> (first, last), inclusive.  The manual pages we have do not
#: number flags or variables (digest 4.10): these are the X-SEL's usual global
#: ranges (its programming manual, not our pages).  A controller whose global
#: ranges differ, or that has more of them, gives its ranges in robot.yaml.
DEFAULT_VARIABLE_RANGES: Mapping[str, tuple[int, int]] = MappingProxyType(
    {"flags": (600, 899), "integers": (200, 299), "reals": (300, 399)}
)

#: 20DH must start at "a category's head flag + a multiple of 8" (p.22), and the
#: category heads are not on our pages: the global flags start at 600, a multiple
#: of 8, so every flag query starts at a multiple of 8 (below the first flag kept,
#: the extra flags read and dropped).
FLAG_QUERY_ALIGNMENT = 8

#: The last flag (20DH: 4 hex digits) and variable (20EH, 20FH: 3 hex digits)
#: number the messages can name: a probe past a kept range stops there when the
#: controller's table goes on that far.
VARIABLE_NUMBER_END: Mapping[str, int] = MappingProxyType(
    {"flags": 0xFFFF, "integers": 0xFFF, "reals": 0xFFF}
)
#: The lowest number of each table a probe below a range goes down to: positions
#: and variables from 1, as the X-SEL numbers them (no page says); flags from 0,
#: the multiple of 8 below (20DH starts at one, p.22); coordinate systems from 0
#: (2A0H: "0~", p.65).  Where a controller's table starts above it, its own
#: "not there" reply says so (tables.py).
NUMBER_FIRST: Mapping[str, int] = MappingProxyType(
    {
        "positions": 1,
        "flags": 0,
        "integers": 1,
        "reals": 1,
        "strings": 1,
        "work_coordinates": 0,
        "tool_coordinates": 0,
    }
)

#: How 20FH (and, **(profile)**, 24DH) carry a real variable's IEEE double (p.24):
#: ``upper-first``, plain big endian (``0123456789ABCDEF``); ``lower-first``, the
#: lower 4 bytes then the upper 4 (``89ABCDEF01234567``), on X-SEL-J/K main
#: application V0.41 or earlier, or with Other parameter No. 46 bits 0-3 at 0.
#: Which one a controller uses is read from the values themselves at each read
#: (:func:`~.model.real_word_order_of`) unless robot.yaml's
#: ``controller.real_word_order`` says it; a pull records what it saw in
#: controller.yaml.  p.50 prints only the big-endian form for 24DH and does not say
#: whether the parameter swaps writes too: the profile writes in the order it
#: reads, so that a value written reads back the same.
REAL_WORD_ORDERS = ("upper-first", "lower-first")
#: The order values are read in when neither robot.yaml nor any value read (now or
#: at the last pull) tells: all-zero reals read the same either way; a push that
#: would write a value that differs between the orders is then refused.
DEFAULT_REAL_WORD_ORDER = "upper-first"

# --- messages -----------------------------------------------------------------------

#: What backup, diff and deploy of positions need: version, system status, axis
#: status, read positions, write positions.
CORE_MESSAGE_IDS = frozenset({0x201, 0x215, 0x212, 0x22D, 0x291})
#: Global flags and variables, when the project opts in: read flags, integer and
#: real variables; write a flag, integer variables, real variables.
OPT_IN_MESSAGE_IDS = frozenset({0x20D, 0x20E, 0x20F, 0x24B, 0x24C, 0x24D})
#: Records, when robot.yaml gives their ranges (issue 20): coordinate system
#: definitions (2A0H, p.65), read only (no message we have writes them), and string
#: variables, read (210H, p.26) and written back (24EH, p.51, issue 34 item 18).
RECORD_MESSAGE_IDS = frozenset({0x2A0, 0x210, 0x24E})
#: The only message ids the encoder will put on the wire.
ALLOWED_MESSAGE_IDS = CORE_MESSAGE_IDS | OPT_IN_MESSAGE_IDS | RECORD_MESSAGE_IDS
#: The allowed ids that change the controller's data.
WRITE_MESSAGE_IDS = frozenset({0x291, 0x24B, 0x24C, 0x24D, 0x24E})
#: The allowed reads whose answer changes without any write from us: status, and
#: the flags and variables running programs change.
VOLATILE_MESSAGE_IDS = frozenset({0x215, 0x212, 0x20D, 0x20E, 0x20F, 0x210})

#: 2A0H's type field (p.65), by the robot.yaml key of the records it reads.
COORDINATE_SYSTEM_TYPES: Mapping[str, int] = MappingProxyType(
    {"work_coordinates": 0, "tool_coordinates": 1}
)
#: The last number each read-only record's message can name: 2A0H's definition
#: number is 2 hex digits, 210H's variable (column) number 3.
RECORD_NUMBER_END: Mapping[str, int] = MappingProxyType(
    {"work_coordinates": 0xFF, "tool_coordinates": 0xFF, "strings": 0xFFF}
)
#: String variable columns (one character each, 210H) per line of records.yaml.
STRING_ROW = 32

# --- persistence --------------------------------------------------------------------

#: Said after every deploy, and kept in its audit record.
PERSISTENCE_NOTICE = (
    "The data written is in the controller's working memory only: write it to flash "
    "ROM with the controller's own tools, or the next power cycle loses it."
)
