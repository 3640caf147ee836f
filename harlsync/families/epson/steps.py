"""The ten steps of one Remote Control command (§6.3), a command left at one of them,
and how the handshake fails: a deadline passed at a step, the function halted
(ExtError), the function in use."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from ...errors import ControllerError, LinkTimeout, PortBusyError
from .protocol import Request, describe_code

__all__ = [
    "RESET_ADVICE",
    "FunctionBusy",
    "FunctionError",
    "HandshakeTimeout",
    "Pending",
    "Step",
]


class Step(enum.IntEnum):
    """The ten steps of one command (§6.3)."""

    FUNCTION_READY = 1
    COMMAND_WORDS = 2
    COMMAND_SET = 3
    COMMAND_ACQUIRED = 4
    COMMAND_SET_CLEARED = 5
    RESPONSE_SET = 6
    RESULT = 7
    RESPONSE_ACQUIRED = 8
    RESPONSE_RELEASED = 9
    RESPONSE_GET_CLEARED = 10

    @property
    def text(self) -> str:
        return _STEP_TEXT[self]


_STEP_TEXT = {
    Step.FUNCTION_READY: "the function ready: ExtCmdReset 1, every other signal 0",
    Step.COMMAND_WORDS: "writing the command words",
    Step.COMMAND_SET: "raising ExtCmdSet",
    Step.COMMAND_ACQUIRED: "waiting for ExtCmdGet 1: the controller takes the command",
    Step.COMMAND_SET_CLEARED: "clearing ExtCmdSet",
    Step.RESPONSE_SET: "waiting for ExtRespSet 1: the command completes",
    Step.RESULT: "reading ExtCmdResult",
    Step.RESPONSE_ACQUIRED: "reading the response, raising ExtRespGet",
    Step.RESPONSE_RELEASED: "waiting for ExtRespSet 0: the controller releases the response",
    Step.RESPONSE_GET_CLEARED: "clearing ExtRespGet",
}


#: How a message tells a person to reset the function when it does not know the
#: command being run (:attr:`.Handshake.reset_advice`).
RESET_ADVICE = "--reset-function"


class HandshakeTimeout(LinkTimeout):
    """A command's deadline passed: ``step`` is where it stopped, ``acquired`` whether
    the controller had taken it (a write may then have taken effect)."""

    def __init__(
        self, message: str, *, port: str, command: str, step: Step, acquired: bool
    ) -> None:
        self.step = step
        self.acquired = acquired
        super().__init__(message, port=port, command=command)


class FunctionError(ControllerError):
    """ExtError 1: the Remote Control function is halted (§6.5) until a function
    reset (detail 0001) or a controller reset (9901, 9902).  ``code`` and
    ``detail`` are Response 1 and 2 as read."""

    def __init__(
        self,
        code: int,
        detail: int,
        *,
        port: str,
        command: str | None,
        reset: str = RESET_ADVICE,
    ) -> None:
        self.code = code
        self.detail = detail
        remedy = (
            f"reset the function ({reset}, on an idle robot)"
            if detail == 0x0001
            else "reset the controller"
        )
        super().__init__(
            f"{code:04X}/{detail:04X}",
            port=port,
            command=command,
            message=f"function error (ExtError 1): {describe_code(code, detail)}; {remedy}",
        )


class FunctionBusy(PortBusyError):
    """The function is in use: a command of someone else, or left by an earlier
    harlsync, is unanswered, so nothing may be sent."""


@dataclass
class Pending:
    """A command sent and not answered."""

    request: Request[object]
    step: Step
    acquired: bool = False
    #: when its own deadline passes (a reply lost on the line ends the wait for it
    #: early: what is left of its deadline is still its)
    due: float = 0.0

    def settle_by(self, now: float, deadline: float) -> float:
        """When to stop waiting for it: one more ``deadline`` after its own."""
        return max(now, self.due) + deadline
