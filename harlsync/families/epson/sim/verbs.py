"""The control verbs of a simulated Epson controller (``harlsync sim`` reads them
on its standard input): what the robot is doing, set by hand, and the two that
reach further than its state (``function-error``, ``power-cycle``: the
simulator carries those out)."""

from __future__ import annotations

from collections.abc import Sequence

from ....sim.family import Verb
from .codes import MESSAGE_FAILURE, PRINT_ERROR, REQUEST_WHILE_EXECUTING
from .state import SimState

__all__ = ["ERROR_CODE", "TEACHING", "VERBS", "act", "function_error_detail"]

VERBS = (
    Verb("run", "[STATION]", "a task running (Running 1)"),
    Verb("pause", "[STATION]", "a task paused (Paused 1)"),
    Verb("estop", "[STATION]", "emergency stop (EStopOn 1), tasks stopped"),
    Verb("error", "[STATION]", "the controller in error (Error 1), tasks stopped"),
    Verb("safeguard", "[STATION]", "the safeguard open (SafeguardOn 1), a task paused"),
    Verb("teach", "[STATION]", "the control device a PC or TP4 (2156 answers 21), not Remote I/O"),
    Verb("stop", "[STATION]", "idle: no task, no stop, no error"),
    Verb("power-cycle", "[STATION]", "off and on: tables and LimZ cleared, function off"),
    Verb(
        "function-error",
        "[STATION [DETAIL]]",
        "halt the Remote Control function: 9999/DETAIL (hex: 0001, 9901, 9902; default 9901)",
    ),
)
#: What 2155 answers after the ``error`` verb **(simulator)**: a controller error
#: code (the manual sends the reader to the controller's own error list).
ERROR_CODE = 4001
#: The control device the ``teach`` verb makes (2156: 21, PC / TP4).
TEACHING = 21
_FUNCTION_ERRORS = (REQUEST_WHILE_EXECUTING, MESSAGE_FAILURE, PRINT_ERROR)


def function_error_detail(args: Sequence[str]) -> int:
    """The function error detail ``function-error [DETAIL]`` asks for (hex, 9901
    by default).  Raises ValueError for another."""
    detail = int(args[0], 16) if args else MESSAGE_FAILURE
    if detail not in _FUNCTION_ERRORS or len(args) > 1:
        raise ValueError(
            f"function-error [DETAIL]: DETAIL is one of "
            f"{', '.join(f'{d:04X}' for d in _FUNCTION_ERRORS)}"
        )
    return detail


def act(verb: str, state: SimState, args: Sequence[str]) -> None:
    """Do what ``verb`` (one that sets what the robot is doing) says to ``state``.
    Raises ValueError for arguments (a verb takes only a station) or an unknown verb."""
    if args:
        raise ValueError(f"{verb} takes only a station")
    if verb == "run":
        state.running, state.paused = True, False
    elif verb == "pause":
        state.running, state.paused = False, True
    elif verb in ("estop", "error"):
        state.running = state.paused = False
        if verb == "estop":
            state.estop = True
        else:
            state.error, state.error_code = True, ERROR_CODE
    elif verb == "teach":
        state.control_device = TEACHING
    elif verb == "safeguard":
        state.safeguard = True
        if state.running:
            state.running, state.paused = False, True
    elif verb == "stop":
        state.stop()
    else:
        raise ValueError(f"unknown command {verb!r}")
