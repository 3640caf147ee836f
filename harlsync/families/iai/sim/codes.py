"""The 3-hex codes the simulated IAI controller puts in its ``&`` error replies.

PLACEHOLDERS, all of them: the manual's error-code list is not in the pages we
have (digest section 6), so these codes are the simulator's own, plausible and
distinct.  harlsync never interprets an ``&`` code (it shows it raw, and records
the one a table's "not there" reply carries), so nothing but the simulator and the
tests read them.  The simulator's ``past_table`` variant varies the code a number
past a table answers.
"""

from __future__ import annotations

__all__ = [
    "BAD_DATA",
    "EXTENDED_BITS",
    "NOT_IDLE",
    "NOT_SUPPORTED",
    "NO_AXIS",
    "OUT_OF_RANGE",
    "PATTERN_ZERO",
    "TOO_LONG",
]

#: A message this controller does not take: every message off the allow-list.
NOT_SUPPORTED = "0A1"
#: Command data of the wrong length or form, or a unit or program it does not have.
BAD_DATA = "0A2"
#: A command, or the reply it asks for, larger than the model's buffer.
TOO_LONG = "0A3"
#: A position record (or a 212H query) with axis pattern 00.
PATTERN_ZERO = "0B1"
#: A coordinate for an axis the robot does not have.
NO_AXIS = "0B2"
#: A position record whose extended data has a spare bit 0-3 set.
EXTENDED_BITS = "0B3"
#: A position number outside the robot's position range.
OUT_OF_RANGE = "0B4"
#: A write while the controller is not idle by the profile's interlock: a program
#: running, MANUAL mode, a flash ROM write, an emergency stop, an axis in use.
NOT_IDLE = "0C1"
