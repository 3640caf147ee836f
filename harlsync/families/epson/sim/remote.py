"""The controller's side of the Remote Control handshake (§6), over its Remote I/O
as the profile maps it to Modbus registers.

How this works::

    phase      the controller                                        its outputs
    OFF        ExtCmdReset 0: the function is inactive (§4.1.1)      ExtCmdGet, ExtRespSet,
                                                                     ExtCmdResult 0
    IDLE       waits for ExtCmdSet 0 -> 1 while ExtCmdReset is 1; raised while the
               reset is 0, or in the same write as the reset, it is no request (§6.2);
               raised over command words not all written since the last request,
               the request is flagged ("stale words": the data comes first, §4.1.1)
    REQUESTED  the command words latched; taken after ``acquire_time``
               (ExtCmdSet back to 0 before that: withdrawn, back to IDLE)
    EXECUTING  taken: it runs for its execution time                 ExtCmdGet 1
               ExtCmdSet 0 ->                                        ExtCmdGet 0
               run and ExtCmdSet 0: carried out, response words set  ExtCmdResult, ExtRespSet 1
    RESPONDED  ExtRespGet 0 -> 1 ->                                  ExtRespSet 0
    RELEASED   ExtRespGet 1 -> 0: the command is complete, IDLE

    §6.5 function error: ExtError 1, response words [number, 9999H, detail]
      ExtCmdSet 0 -> 1 from REQUESTED to RELEASED: detail 0001 (a request while a
      command is in progress); the command running is aborted, no response.
      On demand (:meth:`RemoteIO.halt`): 0001, 9901 or 9902.
      The function stays halted, taking no request, until a §6.5.2 function reset
      (ExtCmdReset 0 for at least 30 ms, then 1) clears a 0001; 9901 and 9902 are
      the controller's and only a controller reset (:meth:`RemoteIO.power_cycle`)
      clears them.

The controller moves when it is looked at: each register access first brings it
to the present (:meth:`RemoteIO.advance`), doing what came due since, in order.
So no thread is needed, and a client sees the same as from a controller that
moved on its own.  The state machine does no I/O and reads the time from the
clock it is given; what a command does is the :class:`Robot`'s.
"""

from __future__ import annotations

import enum
import logging
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal, Protocol

from .. import profile
from ..profile import HANDSHAKE_OUTPUTS, STATUS_SIGNALS, Bit, RegisterMap
from .codes import FUNCTION_ERROR, REQUEST_WHILE_EXECUTING

__all__ = ["Access", "Event", "FunctionFault", "Phase", "RemoteIO", "Robot"]

log = logging.getLogger(__name__)

Words = tuple[int, ...]


class Phase(enum.Enum):
    OFF = "off"
    IDLE = "idle"
    REQUESTED = "requested"
    EXECUTING = "executing"
    RESPONDED = "responded"
    RELEASED = "released"


#: Phases in which a command is in progress: a new request then halts the function.
_IN_PROGRESS = (Phase.REQUESTED, Phase.EXECUTING, Phase.RESPONDED, Phase.RELEASED)


@dataclass(frozen=True)
class FunctionFault:
    """A §6.5 function error: Response 2 ``detail``, when and why."""

    detail: int
    at: float
    why: str
    #: word 0 of the response words: the command aborted or refused (0: none)
    number: int = 0

    @property
    def external(self) -> bool:
        """Caused by the client (0001): a function reset clears it."""
        return self.detail == REQUEST_WHILE_EXECUTING


EventKind = Literal[
    "ignored",
    "withdrawn",
    "refused while halted",
    "short reset",
    "still halted",
    "stray ExtRespGet",
    "stale words",
]


@dataclass(frozen=True)
class Event:
    """Something a client did that the controller passed over without a function
    error (what the manual says it ignores, and a few more)."""

    at: float
    kind: EventKind
    detail: str


@dataclass(frozen=True)
class Access:
    """One register access the controller answered, as it came: ``kind`` is
    read_holding, read_input or write; ``values`` the words a write carried."""

    at: float
    kind: str
    address: int
    count: int
    values: tuple[int, ...] = ()


#: The most register accesses :attr:`RemoteIO.log` keeps (the latest).
ACCESS_LOG = 65536


class Robot(Protocol):
    """What the Remote I/O asks of the controller behind it."""

    def signals(self) -> Mapping[str, bool]:
        """The standard Remote outputs: Ready, Running, Paused, Error, EStopOn, SafeguardOn."""
        ...

    def take(self, words: Words) -> float:
        """A command is taken (ExtCmdGet 1); return the seconds it runs."""
        ...

    def carry_out(self, words: Words) -> tuple[bool, Words]:
        """Carry the command out; return ExtCmdResult and the response words."""
        ...

    def abort(self, words: Words, why: str) -> None:
        """A command taken is aborted: it gets no response."""
        ...

    def halted(self, fault: FunctionFault, request: Words | None) -> None:
        """The function halted; ``request`` the command words of the request that
        halted it (None: on demand)."""
        ...


class RemoteIO:
    """One controller's Remote I/O: the holding registers a client writes (the
    controller's inputs), the input registers it reads (its outputs), and the §6
    handshake between them.  Not thread-safe: the simulator's lock covers it.

    ``acquire_time`` is the seconds between a request and ExtCmdGet;
    ``reset_low`` how long ExtCmdReset must stay 0 for a function reset (§6.5.2).
    ``whole_writes``: a write of several registers reaches the controller at
    once (the profile's BLOCK_WRITE_WHOLE); False, a register at a time in
    address order, the controller reacting to each (a slave that hands them over
    so: ExtCmdSet before the words in one write then requests the old words).
    """

    def __init__(
        self,
        robot: Robot,
        register_map: RegisterMap | None = None,
        *,
        clock: Callable[[], float] = time.monotonic,
        acquire_time: float = 0.0,
        reset_low: float = profile.FUNCTION_RESET_LOW,
        whole_writes: bool = True,
    ) -> None:
        self.robot = robot
        self.map = register_map if register_map is not None else RegisterMap()
        self.clock = clock
        self.acquire_time = acquire_time
        self.reset_low = reset_low
        self.whole_writes = whole_writes
        #: register accesses answered, by kind (read_holding, read_input, write):
        #: the client's round trips, as the controller counts them
        self.accesses: dict[str, int] = {"read_holding": 0, "read_input": 0, "write": 0}
        #: every register access, in order (the latest :data:`ACCESS_LOG`): what the
        #: controller's Modbus slave received, whatever the client believes it sent
        self.log: deque[Access] = deque(maxlen=ACCESS_LOG)
        #: what the controller passed over, in order
        self.events: list[Event] = []
        #: every function error raised, in order
        self.faults: list[FunctionFault] = []
        #: the controller's outputs each time ExtCmdReset went from 1 to 0 (a function
        #: reset, §6.5.2: it aborts a command running and a task paused, §4.1.1)
        self.reset_drops: list[dict[str, bool]] = []
        self._outputs = [
            (name, bit)
            for name, bit in self.map.signals()
            if bit is not None and (name in HANDSHAKE_OUTPUTS or name in STATUS_SIGNALS)
        ]
        self._boot()

    def _boot(self) -> None:
        """As the controller comes up: every input 0, the function off, no error."""
        self.holding: dict[int, int] = {}
        self.phase = Phase.OFF
        self.fault: FunctionFault | None = None
        self._cmd_get = self._resp_set = self._result = False
        self._response = [0] * self.map.response_words
        self._words: Words = ()
        self._due = 0.0
        self._set_cleared = False
        self._reset_low_since = self.clock()
        #: command word registers written since the last request was latched
        self._fresh: set[int] = set()

    # --- the registers -------------------------------------------------------------------

    def read_holding(self, address: int, count: int) -> list[int]:
        self.accesses["read_holding"] += 1
        self.log.append(Access(self.clock(), "read_holding", address, count))
        return [self.holding.get(address + i, 0) for i in range(count)]

    def read_input(self, address: int, count: int) -> list[int]:
        self.accesses["read_input"] += 1
        self.log.append(Access(self.clock(), "read_input", address, count))
        self.advance()
        levels = self.levels()
        return [self._input_register(address + i, levels) for i in range(count)]

    def write_holding(self, address: int, values: list[int]) -> None:
        self.accesses["write"] += 1
        self.log.append(Access(self.clock(), "write", address, len(values), tuple(values)))
        self.advance()
        before = self._inputs()
        for i, value in enumerate(values):
            self.holding[address + i] = value & 0xFFFF
            self._fresh.add(address + i)
            if not self.whole_writes:
                before = self._react(before, self._inputs())
        if self.whole_writes:
            self._react(before, self._inputs())
        self.advance()

    def _input_register(self, address: int, levels: Mapping[str, bool] | None = None) -> int:
        value = 0
        levels = self.levels() if levels is None else levels
        for name, bit in self._outputs:
            if bit.register == address and levels[name]:
                value |= 1 << bit.bit
        at = address - self.map.response_base
        if 0 <= at < self.map.response_words:
            value |= self._response[at]
        return value

    def levels(self) -> dict[str, bool]:
        """Every output signal of the controller now, by its manual name."""
        return {
            "ExtCmdGet": self._cmd_get,
            "ExtRespSet": self._resp_set,
            "ExtCmdResult": self._result,
            "ExtError": self.fault is not None,
            **self.robot.signals(),
        }

    def _bit(self, bit: Bit) -> bool:
        return bool(self.holding.get(bit.register, 0) >> bit.bit & 1)

    def _inputs(self) -> tuple[bool, bool, bool]:
        """ExtCmdSet, ExtRespGet, ExtCmdReset as the client drives them."""
        return (
            self._bit(self.map.ext_cmd_set),
            self._bit(self.map.ext_resp_get),
            self._bit(self.map.ext_cmd_reset),
        )

    @property
    def response(self) -> list[int]:
        """The response words as the client reads them."""
        return list(self._response)

    # --- the handshake ---------------------------------------------------------------------

    def _react(
        self, before: tuple[bool, bool, bool], after: tuple[bool, bool, bool]
    ) -> tuple[bool, bool, bool]:
        """The edges of one write, as the controller sees them: the reset first.
        Returns ``after``."""
        (was_set, was_get, was_reset), (cmd_set, resp_get, reset) = before, after
        now = self.clock()
        if was_reset and not reset:
            self._function_off(now)
        elif reset and not was_reset:
            self._function_on(now)
        if cmd_set and not was_set:
            if not (was_reset and reset):
                why = "while ExtCmdReset is 0" if not reset else "together with ExtCmdReset"
                self._note(now, "ignored", f"ExtCmdSet raised {why}: no request (§6.2)")
            else:
                self._request(now)
        elif was_set and not cmd_set:
            self._command_set_dropped(now)
        if not reset:
            return after
        if resp_get and not was_get:
            if self.phase is Phase.RESPONDED:
                self._resp_set = False
                self.phase = Phase.RELEASED
            else:
                self._note(
                    now, "stray ExtRespGet", f"ExtRespGet raised in phase {self.phase.value}"
                )
        elif was_get and not resp_get and self.phase is Phase.RELEASED:
            self.phase = Phase.IDLE
        return after

    def _request(self, now: float) -> None:
        registers = range(self.map.command_base, self.map.command_base + self.map.command_words)
        words = tuple(self.holding.get(r, 0) for r in registers)
        stale = [r - self.map.command_base for r in registers if r not in self._fresh]
        self._fresh.clear()
        if stale:
            # the controller takes what the words hold: a client that raised
            # ExtCmdSet before writing them all (§4.1.1: the command data first)
            self._note(
                now,
                "stale words",
                f"ExtCmdSet raised over command words {', '.join(map(str, stale))} not "
                f"written since the last request: command {words[0]} taken as they were",
            )
        if self.fault is not None:
            self._note(
                now,
                "refused while halted",
                f"command {words[0]} requested while the function is halted",
            )
        elif self.phase is Phase.IDLE:
            self._words, self.phase, self._due = words, Phase.REQUESTED, now + self.acquire_time
        else:
            self.halt(
                REQUEST_WHILE_EXECUTING,
                f"command {words[0]} requested while command {self._words[0]} is "
                f"{self.phase.value} (§6.5.1)",
                request=words,
            )

    def _command_set_dropped(self, now: float) -> None:
        if self.phase is Phase.REQUESTED:
            self._note(
                now, "withdrawn", f"ExtCmdSet dropped before command {self._words[0]} was taken"
            )
            self.phase = Phase.IDLE
        elif self.phase is Phase.EXECUTING:
            self._cmd_get, self._set_cleared = False, True

    def _function_off(self, now: float) -> None:
        """ExtCmdReset 0: the function stops; a command running is aborted (§4.1.1)."""
        self.reset_drops.append(self.levels())
        if self.phase is Phase.EXECUTING:
            self.robot.abort(self._words, "ExtCmdReset dropped")
        self._cmd_get = self._resp_set = self._result = False
        self.phase = Phase.OFF
        self._reset_low_since = now

    def _function_on(self, now: float) -> None:
        fault = self.fault
        if fault is not None:
            low = now - self._reset_low_since
            if not fault.external:
                self._note(
                    now,
                    "still halted",
                    f"function error {fault.detail:04X} is the "
                    "controller's: only a controller reset clears it",
                )
            elif low < self.reset_low:
                self._note(
                    now,
                    "short reset",
                    f"ExtCmdReset was 0 for {low * 1000:.1f} ms, "
                    f"{self.reset_low * 1000:g} ms needed (§6.5.2)",
                )
            else:
                log.info("sim: function reset: function error %04X cleared", fault.detail)
                self.fault = None
        self.phase = Phase.IDLE

    def advance(self) -> None:
        """Do what has come due: take a request, complete a command."""
        now = self.clock()
        if self.fault is not None:
            return
        if self.phase is Phase.REQUESTED and now >= self._due:
            self._cmd_get, self._result, self._set_cleared = True, False, False
            self._due += self.robot.take(self._words)
            self.phase = Phase.EXECUTING
        if self.phase is Phase.EXECUTING and self._set_cleared and now >= self._due:
            error, words = self.robot.carry_out(self._words)
            self._response[: len(words)] = words  # the rest keep what they held
            self._result, self._resp_set = error, True
            self.phase = Phase.RESPONDED

    def halt(self, detail: int, why: str, *, request: Words | None = None) -> FunctionFault:
        """A §6.5 function error now: the command running is aborted with no
        response, ExtError 1 and [number, 9999H, ``detail``] in the response words."""
        now = self.clock()
        in_progress = self.phase in _IN_PROGRESS and self._words
        number = self._words[0] if in_progress else (request[0] if request else 0)
        if self.phase is Phase.EXECUTING:
            self.robot.abort(self._words, why)
        fault = FunctionFault(detail, now, why, number)
        log.warning("sim: function error 9999/%04X: %s", detail, why)
        self.fault = fault
        self.faults.append(fault)
        self._cmd_get = self._resp_set = self._result = False
        self._response[:3] = [number, FUNCTION_ERROR, detail]
        if self.phase is not Phase.OFF:
            self.phase = Phase.IDLE
        self.robot.halted(fault, request)
        return fault

    def power_cycle(self) -> None:
        """The controller off and on: a command running aborted, every register 0,
        the function off and any function error gone."""
        if self.phase is Phase.EXECUTING:
            self.robot.abort(self._words, "power cycle")
        self._boot()

    def describe(self) -> str:
        """The function's state in a few words."""
        if self.fault is not None:
            return f"function halted ({FUNCTION_ERROR:04X}/{self.fault.detail:04X})"
        if self.phase in (Phase.OFF, Phase.IDLE):
            return f"function {self.phase.value}"
        return f"command {self._words[0]} {self.phase.value}"

    def _note(self, now: float, kind: EventKind, detail: str) -> None:
        log.info("sim: %s: %s", kind, detail)
        self.events.append(Event(now, kind, detail))
