"""Response codes (§7): what a Response 1 code means and the error reply that
carries it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import NamedTuple

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
