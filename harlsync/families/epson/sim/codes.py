"""What a Remote Control command comes to: the Response 1 codes (§7.1) and the
Response 2 details (§7.2.3) the controller answers with, the refusal a command
handler raises to answer one (:class:`Refused`), the outcome of one command
(:class:`Outcome`), and how points not there are answered (:class:`PointAnswers`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from .. import profile
from .state import MAX_POINT

__all__ = [
    "COMMAND_WORDS",
    "EXECUTION",
    "FUNCTION_ERROR",
    "MESSAGE_FAILURE",
    "NORMAL",
    "PARAMETER",
    "PRINT_ERROR",
    "REQUEST_WHILE_EXECUTING",
    "RESPONSE_WORDS",
    "SEQUENCE",
    "UNSUPPORTED",
    "Outcome",
    "PointAnswers",
    "Refused",
]

# --- §7.1 Response 1 and §7.2.3 Response 2 codes -----------------------------------------

NORMAL = 0x0000
UNSUPPORTED = 0x1000
SEQUENCE = 0x1002
EXECUTION = 0x2000
COMMAND_WORDS = 0x2002
RESPONSE_WORDS = 0x2003
PARAMETER = 0x2004
FUNCTION_ERROR = 0x9999
#: Function error details: a request while a command executes (external, a
#: function reset clears it), and the two the controller causes (a controller
#: reset clears them).
REQUEST_WHILE_EXECUTING = 0x0001
MESSAGE_FAILURE = 0x9901
PRINT_ERROR = 0x9902


class Refused(Exception):
    """The command is answered with an error response carrying ``code`` (Response 1)
    and ``detail`` (Response 2)."""

    def __init__(self, code: int, detail: int = 0) -> None:
        super().__init__(f"{code:04X}/{detail:04X}")
        self.code = code
        self.detail = detail


class PointAnswers(NamedTuple):
    """How a controller answers for points where the manual is silent (the
    simulator's variants, :data:`~.device.SIM_FAMILY`): Response 1 and 2 of a point
    not defined, of a point number past its point table, and the table's last point."""

    undefined: tuple[int, int] = (profile.UNDEFINED_POINT, 0)
    past_table: tuple[int, int] = (PARAMETER, 0)
    last: int = MAX_POINT


@dataclass(frozen=True)
class Outcome:
    """What the controller made of one command."""

    number: int
    #: the response words from word 0 (the echo), as the controller sets them
    response: tuple[int, ...]
    #: ExtCmdResult: an error response (Response 1 is the code)
    error: bool
    #: a write command (everything off the command set counts as one)
    is_write: bool
    #: whether the number is in the command set (the backup reads and deploy writes)
    known: bool
    #: a write whose last step was carried out: the robot changed
    took_effect: bool = False
    #: a later step of a split or Rn write, taken as part of its sequence
    continuation: bool = False

    @property
    def code(self) -> int:
        """Response 1 of an error response; 0 for a normal one."""
        return self.response[1] if self.error else NORMAL
