"""Every choice the HARL-U2 manual leaves open, in one place.

These are the *(profile)* decisions of ``shared/spec/harl-u2-wire-profile.md``:
the codec, the link, the simulator and the sync engine all read them from this
module.  Each is a default.  Where a site's controller may differ, robot.yaml
has the setting that overrides it (the serial settings and timeout under
``connection``, ``offset_tables``, ``no_such_table``), or the controller's own
answers decide at each pull; docs/profile.md lists every guess with its setting,
its simulator variant, and the ones that have neither ("one way only").
"""

from __future__ import annotations

from typing import Literal

#: Frame control bytes (the manual).
STX = 0x02
ETX = 0x03
SP = 0x20

#: How the LRC travels after ETX: ``"raw"`` is one raw byte (0x00-0xFF, may equal
#: STX or ETX); ``"hex"`` would be two upper-case ASCII hex digits.
LRC_ENCODING: Literal["raw", "hex"] = "raw"

#: The only commands harlsync ever sends: every LN read of the manual, and the SN
#: writes of program data (steps, timers, registers, offset tables, expanded
#: parameters, program configuration).  SNO (physical outputs) and SNB (memory
#: bits) are process state, not program data: the codec refuses to encode them,
#: and anything else off this list (``frame.encode_frame``, ``Request.encode``).
SENT_COMMANDS = frozenset(
    (
        "LNA", "LNM", "LNS", "LNH", "LNT", "LND", "LNL",
        "LNIB", "LNID", "LNOB", "LNOD", "LNBB", "LNBD",
        "LNE", "LNR", "LNV", "LNX",
        "SNA", "SNM", "SNS", "SNH", "SNT", "SND", "SNL", "SNE", "SNX",
    )
)  # fmt: skip

#: A successful SN write is answered with this payload.
SN_OK = "0"

#: An error reply is this letter followed directly by the raw status.
ERROR_PREFIX = "E"

#: The status the profile guesses an LNL read of a table the controller does not
#: have answers (``E21``, the status this profile gives any number outside the
#: configuration).  The manual does not give it: it says only that a robot that
#: cannot answer normally sends "E" + status and defers the codes to the HRCS-R3
#: manual, which we do not have.  So harlsync does not rely on it: the offset
#: tables end where one answers the same reply twice (``Controller.read_offsets``),
#: a pull records that reply in controller.yaml and later reads hold the
#: controller to it, and robot.yaml's ``no_such_table`` pins one.  The simulator
#: answers this by default (its ``missing_table`` variant answers others).
NO_SUCH_TABLE = "21"

#: LNR reports this many tasks (0-4), four fields each: S K N L.
TASK_COUNT = 5

#: How many LNR replies in a row must each show every task idle before harlsync
#: takes the robot for idle (before each write, and before a re-send).  The LRC
#: is an XOR: two flipped bits in one bit column of a frame pass it, so a reply
#: ``1 MAIN 3 7`` (task in execution) can arrive as ``0 MAIN 3 6`` (stopped).
#: One such corruption in two independent reads is not enough to clear a write.
#: docs/SAFETY.md and docs/BENCHMARKS.md (bench/lnr_twice.py) give the cost.
IDLE_READS = 2

#: A step that holds nothing is answered with its step number alone, and an SN
#: step write with no command clears the step.
EMPTY_STEP_IS_NUMBER_ONLY = True

#: Serial settings when the robot file gives none: 9600 8N1, no flow control.
BAUDRATE = 9600
BYTESIZE = 8
PARITY: Literal["N", "E", "O"] = "N"
STOPBITS: Literal[1, 2] = 1
RTSCTS = False

#: Seconds to wait for a complete reply frame before retrying.
REPLY_TIMEOUT = 1.0

#: Longest frame the decoder accepts before dropping it as noise: its ETX must
#: come within this many bytes of its STX.  Typical frames are well under 200
#: bytes; validate refuses a step or parameters whose write, or its read-back,
#: would not fit (``readback.read_back``), since such an item could never be read.
MAX_FRAME = 512

#: Default station numbers 1-4 (set on the pendant: SYSTEM GENERATION >
#: MAINTENANCE > STATION NO.).
STATIONS = (1, 2, 3, 4)
