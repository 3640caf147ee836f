"""The Remote Control handshake (§6), by polling, over any register access.

How this works::

    harlsync (holding registers)              controller (input registers)
    ExtCmdReset 1, held while the function is in use (§6.1-6.2: raised once,
    after ExtCmdSet and ExtRespGet are 0; never dropped on a function found on)

     1  function ready?  ExtCmdSet 0 ExtRespGet 0 | ExtCmdGet 0 ExtRespSet 0 ExtError 0
     2  command words ---+--------------------> (one write, the words and
     3  ExtCmdSet 1 -----+                       ExtCmdSet's register, where
                                                 the map allows: see below)
     4                                 <-------- ExtCmdGet 1     (polled)
     5  ExtCmdSet 0 --------------------------->
     6                                 <-------- ExtRespSet 1    (polled: the same read
     7                                 <-------- ExtCmdResult     holds ExtCmdResult and
     8  (response read) ExtRespGet 1 ---------->                  the response words)
     9                                 <-------- ExtRespSet 0    (polled)
    10  ExtRespGet 0 -------------------------->

Steps 2 and 3 are one Modbus write (function 16) of the command words and the
register that holds ExtCmdSet, when the two are contiguous and the controller
sees the words no later than ExtCmdSet's rise: ExtCmdSet's register just after
the words (the registers' order is the manual's), or just before them on a
slave that applies a write whole (the profile's default map and assumption,
:data:`~.profile.BLOCK_WRITE_WHOLE`; :meth:`RegisterMap.command_block`).
Elsewhere they are two writes, the words first.

Every poll is one read of the input registers that hold all the controller's
outputs and response words (:attr:`RegisterMap.input_span`); the poll that
sees ExtRespSet 1 holds ExtCmdResult and the response words, so the response
costs no read of its own.  A wait polls at once, then on the poll interval
counted from its start (a poll's own round trip is not added to the
interval), the last poll at the deadline.  The handshake
keeps its own inputs as it wrote them, and reads them back once before each
command's step 1 (one holding register read in the profile's map): a
controller that restarted has them at 0 again, and driving a signal from a
stale copy would raise ExtCmdSet together with ExtCmdReset, which the
controller ignores; found at 0, the function is started again (§6.2).
Bits of the control registers that are not handshake signals keep the value
they were read with.

The step 1 read is the interlock too: a write goes out only while Running,
Paused, EStopOn, Error and SafeguardOn are 0 and Ready is 1, never with Ready
and Running at 1 together (a map that is wrong), and never to a robot whose map
lacks Running, Paused, EStopOn or Error, or Ready or SafeguardOn unless robot.yaml
accepts that (``connection.write_without``).  Before each item a push writes, the
controller's :meth:`~.controller.Controller.status` also asks 2156 (the control
device: Remote I/O) and 2155 (no controller error), which cannot go between the
commands of a split or Rn sequence.  Each command of a split write or Rn
sequence is looked at so: a robot that leaves idle part way stops the sequence,
which the controller then cancels.  Reads go out regardless.  ExtCmdReset is
raised only once the controller shows it is operable (Ready 1, §6.2).

A command has one deadline for all ten steps.  When it passes, ExtCmdSet and
ExtRespGet go low and the command stays *pending*: the next request first
waits for its late response (and discards it) or finds it never taken, and
sends nothing while it may still be running (a second request halts the
function, §6.5.1).  ExtError 1 is a function error (§6.5), raised with its
code; only :meth:`Handshake.reset_function`, asked for, resets the function
(§6.5.2), and only while Running is 0.

The handshake does no I/O of its own: it is given a :class:`RegisterAccess`
(Modbus TCP in :mod:`.transport`, a fake register bank in the tests) and a
:class:`Clock` (the poll interval and deadlines; a test's clock need not wait).
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Protocol, TypeVar

from ...errors import ControllerError, InterlockError, LinkError, LinkTimeout, PortBusyError
from ...settings import seconds
from . import profile
from .profile import HANDSHAKE_INPUTS, INTERLOCK_SIGNALS, READY, Bit, RegisterMap
from .protocol import (
    CONTROL_DEVICES,
    FUNCTION_ERROR,
    REMOTE_IO,
    ErrorReply,
    Request,
    WriteSequence,
    describe_code,
)

__all__ = [
    "Clock",
    "FunctionBusy",
    "FunctionError",
    "Handshake",
    "HandshakeTimeout",
    "RegisterAccess",
    "RemoteStatus",
    "Step",
    "SystemClock",
]

log = logging.getLogger(__name__)

T = TypeVar("T")


class RegisterAccess(Protocol):
    """What the handshake needs of a line: read and write 16-bit registers."""

    #: Where the registers are, for messages: ``"modbus://10.0.0.5:502 unit 1"``.
    label: str

    def read_holding(self, address: int, count: int) -> Sequence[int]:
        """``count`` holding registers from ``address``."""
        ...

    def read_input(self, address: int, count: int) -> Sequence[int]:
        """``count`` input registers from ``address``."""
        ...

    def write_holding(self, address: int, values: Sequence[int]) -> None:
        """Write holding registers from ``address``, in one request."""
        ...


class Clock(Protocol):
    """Time for polls and deadlines."""

    def monotonic(self) -> float: ...

    def sleep(self, seconds: float) -> None: ...


class SystemClock:
    """The real clock."""

    def monotonic(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        time.sleep(seconds)


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

#: What each interlock signal at 1 means.
_BUSY_TEXT: Mapping[str, str] = MappingProxyType(
    {
        "Running": "a task is executing",
        "Paused": "a task is paused",
        "EStopOn": "emergency stop",
        "Error": "the controller is in error",
        "SafeguardOn": "the safeguard is open: a person may be in the cell",
    }
)
_FUNCTION_SIGNALS = (
    "ExtCmdReset",
    "ExtCmdSet",
    "ExtRespGet",
    "ExtCmdGet",
    "ExtRespSet",
    "ExtError",
)


#: How a message tells a person to reset the function when it does not know the
#: command being run (:attr:`Handshake.reset_advice`).
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


@dataclass(frozen=True)
class RemoteStatus:
    """One read of the controller's outputs, with the handshake's own inputs.

    ``signals`` holds every signal by its manual name (None: not mapped);
    ``response`` the response words as read.  It is the interlock's answer too
    (:class:`~harlsync.families.base.Status`).
    """

    signals: Mapping[str, bool | None]
    response: tuple[int, ...]
    #: why the map never allows a write (:attr:`RegisterMap.unwritable`)
    unwritable: str | None = None
    #: what 2156 (the control device) and 2155 (the controller's error code)
    #: answered, read before a write when the signals allow one; None: not read
    control_device: int | None = None
    controller_error: int | None = None
    #: why they could not be read (then no write goes: fail closed)
    unreadable: str | None = None

    def __getitem__(self, name: str) -> bool | None:
        return self.signals[name]

    @property
    def busy(self) -> tuple[str, ...]:
        """The interlock signals at 1: Running, Paused, EStopOn, Error."""
        return tuple(name for name in INTERLOCK_SIGNALS if self.signals[name])

    @property
    def mismapped(self) -> str | None:
        """Why these outputs cannot be the controller's as mapped, or None: Ready
        and Running at 1 together (the controller's Ready means no task runs)."""
        if self.signals.get(READY) and self.signals.get("Running"):
            return (
                "Ready 1 and Running 1 together, which the controller never shows (Ready "
                "means no task runs): one of them is mapped to the wrong bit; check "
                "robot.yaml connection.map against RC+"
            )
        return None

    @property
    def not_ready(self) -> bool:
        """Ready is mapped and reads 0 (while no interlock signal says why)."""
        return self.signals.get(READY) is False

    @property
    def blocked(self) -> str | None:
        """Why a write may not go now, the function aside, or None."""
        if self.unwritable is not None:
            return self.unwritable
        if self.mismapped is not None:
            return self.mismapped
        if self.busy:
            return ", ".join(f"{name} 1 ({_BUSY_TEXT[name]})" for name in self.busy)
        if self.not_ready:
            return (
                "Ready 0 (the controller is not ready: still starting up, or Ready is "
                "mapped to a bit it does not drive)"
            )
        if self.unreadable is not None:
            return self.unreadable
        if self.control_device is not None and self.control_device != REMOTE_IO:
            device = CONTROL_DEVICES.get(self.control_device, "unknown")
            return (
                f"the control device is {self.control_device} ({device}), not 22 (Remote "
                "I/O): someone controls the robot from there (2156)"
            )
        if self.controller_error:
            return (
                f"the controller reports error {self.controller_error} (2155), though its "
                "Error signal reads 0: the controller is in error, or Error is mapped to a "
                "bit it does not drive"
            )
        return None

    @property
    def unsettled(self) -> str | None:
        """Why the robot is not plainly at rest, or None: what :attr:`blocked` says,
        or a map without Ready (then nothing shows the controller up with no task
        run).  A function reset no person asked for goes only to a robot at rest:
        dropping ExtCmdReset aborts a paused task too (§4.1.1)."""
        blocked = self.blocked
        if blocked is not None:
            return blocked
        if self.signals.get(READY) is None:
            return "the register map has no Ready signal (nothing shows that no task runs)"
        return None

    @property
    def function_off(self) -> tuple[str, ...]:
        """The signals that keep the function from taking a command (step 1):
        ExtCmdReset at 0, any other handshake signal at 1."""
        return tuple(
            name
            for name in _FUNCTION_SIGNALS
            if bool(self.signals[name]) != (name == "ExtCmdReset")
        )

    @property
    def function_idle(self) -> bool:
        return not self.function_off

    @property
    def operable(self) -> bool:
        """Whether the controller shows it is up (§6.2, "operable"): Ready, or a
        task, an error or an emergency stop at 1; True when Ready is not mapped."""
        if self.signals.get(READY) is None:
            return True
        return any(self.signals.get(name) for name in (READY, *INTERLOCK_SIGNALS))

    @property
    def idle(self) -> bool:
        """Whether a write may go now."""
        return self.blocked is None and self.function_idle

    def describe(self) -> str:
        """``"idle"``, or what forbids a write, naming the signal."""
        blocked = self.blocked
        if blocked is not None:
            return blocked
        if not self.function_idle:
            return f"the Remote Control function is not idle ({self.function_signals()})"
        return "idle"

    def function_signals(self) -> str:
        """The handshake signals that keep the function from taking a command:
        ``"ExtCmdReset 0, ExtRespSet 1"`` (empty when it is idle)."""
        return ", ".join(f"{name} {int(bool(self.signals[name]))}" for name in self.function_off)


@dataclass
class _Pending:
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


class Handshake:
    """The §6 handshake for one controller, over ``registers`` with ``register_map``.

    One command at a time: :meth:`execute` returns when the ten steps are done
    (or raises).  Not thread-safe; one harlsync per controller is the line
    lock's job.
    """

    def __init__(
        self,
        registers: RegisterAccess,
        register_map: RegisterMap | None = None,
        *,
        poll_interval: float = profile.POLL_INTERVAL,
        deadline: float = profile.COMMAND_DEADLINE,
        clock: Clock | None = None,
        block_write_whole: bool = profile.BLOCK_WRITE_WHOLE,
    ) -> None:
        self.registers = registers
        self.map = register_map if register_map is not None else RegisterMap()
        #: where the one write of steps 2 and 3 starts; None: two writes
        self._block = self.map.command_block(whole=block_write_whole)
        self.poll_interval = poll_interval
        self.deadline = deadline
        self.clock: Clock = clock if clock is not None else SystemClock()
        #: how a message tells a person to reset the function: the command to run
        #: again, ``'harlsync push DIR --reset-function'``, once the driver knows it
        self.reset_advice = RESET_ADVICE
        #: the control holding registers as harlsync last wrote (or first read) them
        self._control: dict[int, int] | None = None
        self._started = False
        self._pending: _Pending | None = None

    @property
    def label(self) -> str:
        return self.registers.label

    @property
    def pending(self) -> str | None:
        """The command sent and not answered, with the step it stopped at, or None."""
        p = self._pending
        return None if p is None else f"{p.request} at step {p.step.value}"

    # --- signals ------------------------------------------------------------------------

    def _load_control(self) -> dict[int, int]:
        if self._control is None:
            control = {}
            for register in self.map.control_registers:
                values = self.registers.read_holding(register, 1)
                if len(values) != 1:
                    raise LinkError(
                        f"holding register {register}: {len(values)} values read, 1 asked for",
                        port=self.label,
                    )
                control[register] = values[0]
            self._control = control
        return self._control

    def _input(self, bit: Bit) -> bool:
        return bool(self._load_control()[bit.register] >> bit.bit & 1)

    def _drive(self, bit: Bit, on: bool) -> None:
        """Set one of harlsync's signals; writes its register only if it changes."""
        control = self._load_control()
        old = control[bit.register]
        new = old | 1 << bit.bit if on else old & ~(1 << bit.bit)
        if new != old:
            try:
                self.registers.write_holding(bit.register, [new])
            except LinkError:
                self._control = None  # it may or may not have taken: read them again
                raise
            control[bit.register] = new

    def _snapshot(self) -> RemoteStatus:
        """One read of every output signal and response word."""
        first, count = self.map.input_span
        values = tuple(self.registers.read_input(first, count))
        if len(values) != count:
            raise LinkError(
                f"input registers {first}-{first + count - 1}: {len(values)} "
                f"values read, {count} asked for",
                port=self.label,
            )
        control = self._load_control()
        signals: dict[str, bool | None] = {}
        for name, bit in self.map.signals():
            if bit is None:
                signals[name] = None
            elif name in HANDSHAKE_INPUTS:
                signals[name] = bool(control[bit.register] >> bit.bit & 1)
            else:
                signals[name] = bool(values[bit.register - first] >> bit.bit & 1)
        start = self.map.response_base - first
        response = values[start : start + self.map.response_words]
        return RemoteStatus(signals, response, self.map.unwritable)

    # --- start, status, reset -----------------------------------------------------------

    def start(self) -> None:
        """Make the function usable (§6.1-6.2): when ExtCmdReset is 0, clear
        ExtCmdSet and ExtRespGet, then raise ExtCmdReset.  A function found with
        ExtCmdReset 1 is left as it is (dropping it aborts motion, §4.1.1)."""
        self._control = None
        if self._input(self.map.ext_cmd_reset):
            log.debug("%s: ExtCmdReset already 1: the function is kept as found", self.label)
        else:
            self._drive(self.map.ext_cmd_set, False)
            self._drive(self.map.ext_resp_get, False)
            self._await_operable()
            self._drive(self.map.ext_cmd_reset, True)
            log.debug("%s: ExtCmdReset raised (§6.2)", self.label)
        self._started = True

    def _await_operable(self) -> None:
        """§6.2: the reset is released only "after the Controller becomes operable":
        poll until Ready (or a task, an error, an emergency stop) reads 1.

        Raises :class:`HandshakeTimeout` when the deadline passes first (ExtCmdReset
        stays 0)."""
        since = self.clock.monotonic()
        deadline, polls = since + self.deadline, 0
        while not (status := self._snapshot()).operable:
            polls += 1
            if self.clock.monotonic() >= deadline:
                raise HandshakeTimeout(
                    f"Ready is still 0 after {seconds(self.deadline)} s, and no task, error or "
                    "emergency stop shows: the controller is not operable yet, or Ready is "
                    "mapped to a bit it does not drive; ExtCmdReset not raised (§6.2)",
                    port=self.label,
                    command="starting the function",
                    step=Step.FUNCTION_READY,
                    acquired=False,
                )
            log.debug(
                "%s: waiting for Ready before raising ExtCmdReset (%s)",
                self.label,
                status.describe(),
            )
            self._pause(since, polls, deadline)

    def _refresh(self) -> None:
        """Before a command's step 1: read the control registers again (one read in
        the profile's map, where the three inputs share a register).

        The cache is stale when the controller restarted (a power cycle sets
        every register harlsync writes back to 0): driving a signal from the
        cache would then raise ExtCmdSet together with ExtCmdReset, which the
        controller ignores.  Found so, the function is started again (§6.2) and
        a command left unanswered is dropped (the restart aborted it)."""
        self._control = None
        if self._input(self.map.ext_cmd_reset):
            return
        log.warning(
            "%s: ExtCmdReset found 0 (the controller restarted?): the function is started again%s",
            self.label,
            f"; command {self._pending.request} left unanswered is dropped"
            if self._pending is not None
            else "",
        )
        self._pending = None
        self.start()

    def status(self) -> RemoteStatus:
        """The controller's outputs now, and the interlock's answer.  Sends no command."""
        return self._snapshot()

    def reset_function(self, *, at_rest: bool = False) -> None:
        """The §6.5.2 function reset: ExtCmdReset, ExtCmdSet, ExtRespGet low, at
        least 30 ms, ExtCmdReset high; then wait for the function to be ready.

        Raises :class:`InterlockError` (and changes nothing) when Running is 1 or
        the map has no Running signal: dropping ExtCmdReset aborts motion.  With
        ``at_rest`` (a reset no person asked for), also unless the same read shows
        the robot at rest (:attr:`RemoteStatus.unsettled` is None).
        Raises :class:`HandshakeTimeout` when the function is not ready again
        within the deadline.
        """
        if self.map.running is None:
            raise InterlockError(
                f"{self.label}: the register map has no Running signal, so "
                "harlsync cannot see that the robot is idle: no function reset"
            )
        status = self._snapshot()
        if status["Running"]:
            raise InterlockError(
                f"{self.label}: Running 1 (a task is executing): dropping "
                "ExtCmdReset would abort motion; the function is not reset"
            )
        if at_rest and (why := status.unsettled) is not None:
            raise InterlockError(f"{self.label}: {why}: the function is not reset")
        self._drive(self.map.ext_cmd_reset, False)
        self._drive(self.map.ext_cmd_set, False)
        self._drive(self.map.ext_resp_get, False)
        low_since = self.clock.monotonic()
        while (left := profile.FUNCTION_RESET_LOW - (self.clock.monotonic() - low_since)) > 0:
            self.clock.sleep(left)
        self._drive(self.map.ext_cmd_reset, True)
        self._started = True
        self._pending = None
        log.info("%s: function reset (§6.5.2)", self.label)
        since = self.clock.monotonic()
        deadline, polls = since + self.deadline, 0
        while True:
            status = self._snapshot()
            polls += 1
            if status.function_idle:
                return
            if self.clock.monotonic() >= deadline:
                raise HandshakeTimeout(
                    f"the function is not ready {seconds(self.deadline)} s after its reset "
                    f"({status.describe()}): reset the controller",
                    port=self.label,
                    command="function reset",
                    step=Step.FUNCTION_READY,
                    acquired=False,
                )
            self._pause(since, polls, deadline)

    # --- commands -----------------------------------------------------------------------

    def execute(self, request: Request[T]) -> T | ErrorReply:
        """Send ``request`` and return its decoded response, or the
        :class:`ErrorReply` of an error response.

        A write goes out only when the step 1 read (no extra one) finds Running,
        Paused, EStopOn and Error at 0; send a split write or an Rn sequence with
        :meth:`execute_sequence`, which looks once, before its first command.

        Raises :class:`ValueError` for a request the map has too few words for,
        :class:`InterlockError` (nothing sent) for a write to a robot that is
        busy or whose map is unwritable, naming the signal,
        :class:`FunctionBusy` when the function is in use, :class:`FunctionError`
        on ExtError, :class:`HandshakeTimeout` when the deadline passes (or an
        earlier command is still unanswered: nothing is sent),
        :class:`~harlsync.errors.ReplyError` for a response that does not answer
        it, and the transport's :class:`~harlsync.errors.LinkError`.
        """
        return self._execute(request, interlock=request.is_write)

    def _execute(self, request: Request[T], *, interlock: bool) -> T | ErrorReply:
        self._fits(request)
        if request.is_write and self.map.unwritable is not None:
            raise InterlockError(f"{self.label}: {self.map.unwritable}")
        if not self._started:
            self.start()
        else:
            self._refresh()
        # an earlier command left unanswered gets a deadline of its own: settling it
        # must not eat this command's, or this one times out early and may still run
        # when the line is let go (the next client's first request then halts the
        # function, §6.5.1)
        if self._pending is not None:
            self._settle(self._pending.settle_by(self.clock.monotonic(), self.deadline))
        deadline = self.clock.monotonic() + self.deadline
        status = self._snapshot()
        if status["ExtError"]:
            self._function_error(status, None)
        if interlock and status.blocked is not None:
            raise InterlockError(f"{self.label}: {status.blocked}: command {request} not sent")
        if not status.function_idle:
            raise FunctionBusy(
                f"the Remote Control function is in use ({status.function_signals()}): a "
                "command of another client, or one left by an earlier harlsync, is "
                "unanswered; nothing sent. If no one else drives this controller, "
                f"{self.reset_advice} clears it on an idle robot",
                port=self.label,
                command=str(request),
            )
        words = request.encode(self.map.command_words)
        log.debug("%s: command %s", self.label, " ".join(f"{w:04X}" for w in words))
        self._pending = _Pending(request, Step.COMMAND_WORDS, due=deadline)
        if self._block is None:
            self.registers.write_holding(self.map.command_base, words)
            self._pending.step = Step.COMMAND_SET
            self._drive(self.map.ext_cmd_set, True)
        else:
            self._pending.step = Step.COMMAND_SET
            self._write_command(self._block, words)
        self._wait(deadline, Step.COMMAND_ACQUIRED, lambda s: bool(s["ExtCmdGet"]))
        self._pending.acquired = True
        self._pending.step = Step.COMMAND_SET_CLEARED
        self._drive(self.map.ext_cmd_set, False)
        status = self._wait(deadline, Step.RESPONSE_SET, lambda s: bool(s["ExtRespSet"]))
        error = bool(status["ExtCmdResult"])
        response = status.response
        log.debug(
            "%s: response %s%s",
            self.label,
            " ".join(f"{w:04X}" for w in response),
            " (ExtCmdResult 1)" if error else "",
        )
        self._pending.step = Step.RESPONSE_ACQUIRED
        self._drive(self.map.ext_resp_get, True)
        self._wait(deadline, Step.RESPONSE_RELEASED, lambda s: not s["ExtRespSet"])
        self._pending.step = Step.RESPONSE_GET_CLEARED
        self._drive(self.map.ext_resp_get, False)
        self._pending = None
        return request.decode(response, error=error)

    def execute_sequence(self, sequence: WriteSequence) -> ErrorReply | None:
        """Send a write's commands back to back, the interlock read before each.

        Raises :class:`InterlockError` when it refuses one: before the first,
        nothing was sent; part way, the commands sent are an unfinished split or
        Rn sequence, which the controller cancels (it takes effect only at its
        last step), and the message says so.  The first error response stops it
        (the controller then cancels the rest anyway) and is returned."""
        requests = list(sequence)
        for i, request in enumerate(requests):
            try:
                reply = self._execute(request, interlock=True)
            except InterlockError as exc:
                if i == 0:
                    raise
                raise InterlockError(
                    f"{exc}; {sequence.what} stopped after {i} of its {len(requests)} "
                    "commands: the controller cancels an unfinished sequence, so none of it "
                    "took effect"
                ) from exc
            if isinstance(reply, ErrorReply):
                return reply
        return None

    def _write_command(self, first: int, words: Sequence[int]) -> None:
        """Steps 2 and 3 in one write: the command words and ExtCmdSet's register
        with ExtCmdSet 1 (its other bits as :meth:`_drive` keeps them), from
        ``first`` (:meth:`RegisterMap.command_block`)."""
        control = self._load_control()
        bit = self.map.ext_cmd_set
        value = control[bit.register] | 1 << bit.bit
        block = [value, *words] if first == bit.register else [*words, value]
        try:
            self.registers.write_holding(first, block)
        except LinkError:
            self._control = None  # ExtCmdSet may or may not have risen: read it again
            raise
        control[bit.register] = value

    def _pause(self, since: float, polls: int, deadline: float) -> None:
        """Sleep until poll ``polls + 1`` of a wait begun at ``since`` is due: the
        polls keep to their interval from the first one (the time a poll takes is
        not added to it), and none is later than ``deadline``.  A poll that is
        already due (the line slower than the interval) goes at once."""
        due = min(since + polls * self.poll_interval, deadline)
        left = due - self.clock.monotonic()
        if left > 0:
            self.clock.sleep(left)

    def _fits(self, request: Request[object]) -> None:
        for what, need, have in (
            ("command", request.command_words, self.map.command_words),
            ("response", request.response_words, self.map.response_words),
        ):
            if need > have:
                raise ValueError(
                    f"{self.label}: {request} needs {need} {what} words, the "
                    f"register map has {have}"
                )

    def _wait(
        self, deadline: float, step: Step, done: Callable[[RemoteStatus], bool]
    ) -> RemoteStatus:
        """Poll until ``done``; on the way, ExtError raises and the deadline times out."""
        pending = self._pending
        assert pending is not None
        pending.step = step
        since, polls = self.clock.monotonic(), 0
        while True:
            status = self._snapshot()
            polls += 1
            if status["ExtError"]:
                self._function_error(status, pending.request)
            if done(status):
                return status
            if self.clock.monotonic() >= deadline:
                self._timeout(pending)
            self._pause(since, polls, deadline)

    def _timeout(self, pending: _Pending) -> None:
        """Leave ExtCmdSet and ExtRespGet low, keep the command pending, raise."""
        try:
            self._drive(self.map.ext_cmd_set, False)
            self._drive(self.map.ext_resp_get, False)
        except LinkError as exc:  # the timeout is the error worth raising
            log.debug("%s: clearing the handshake inputs failed: %s", self.label, exc)
        note = ""
        if pending.acquired and pending.request.is_write:
            note = "; the controller took the write: it may or may not have taken effect"
        raise HandshakeTimeout(
            f"no answer within {seconds(self.deadline)} s: stopped at step {pending.step.value} of "
            f"§6.3 ({pending.step.text}){note}",
            port=self.label,
            command=str(pending.request),
            step=pending.step,
            acquired=pending.acquired,
        )

    def _function_error(self, status: RemoteStatus, request: Request[object] | None) -> None:
        """ExtError 1: the function halted and the command (if any) was aborted."""
        self._pending = None
        try:
            self._drive(self.map.ext_cmd_set, False)
            self._drive(self.map.ext_resp_get, False)
        except LinkError as exc:
            log.debug("%s: clearing the handshake inputs failed: %s", self.label, exc)
        words = status.response
        code = words[1] if len(words) > 1 else FUNCTION_ERROR
        detail = words[2] if len(words) > 2 else 0
        raise FunctionError(
            code,
            detail,
            port=self.label,
            command=None if request is None else str(request),
            reset=self.reset_advice,
        )

    def finish(self) -> None:
        """Before the line is let go: a command left unanswered (its deadline passed)
        is waited for once more, up to the deadline, and its late response taken,
        so that the next client (the next harlsync run) finds the function idle.
        A controller's outputs while a command executes look idle once ExtCmdSet
        is 0 (ExtCmdGet falls with it), so a new client could not tell, and its
        first request would halt the function (§6.5.1).  What still fails is
        logged; the error that ended the run is the one worth raising."""
        if self._pending is None:
            return
        log.info(
            "%s: waiting for command %s, left unanswered, before letting go",
            self.label,
            self._pending.request,
        )
        end = self._pending.settle_by(self.clock.monotonic(), self.deadline)
        attempts = 0
        while self._pending is not None:
            attempts += 1
            try:
                self._settle(end)
            except (HandshakeTimeout, ControllerError) as exc:
                log.warning(
                    "%s: command %s is still unanswered: %s",
                    self.label,
                    self._pending.request if self._pending else "",
                    exc,
                )
                return
            except LinkError as exc:  # a request lost: again, until the deadline (and
                self._control = None  # at least three times: a lost request costs retries)
                if attempts >= 3 and self.clock.monotonic() >= end:
                    log.warning(
                        "%s: command %s is still unanswered: %s",
                        self.label,
                        self._pending.request if self._pending else "",
                        exc,
                    )
                    return
                self.clock.sleep(self.poll_interval)

    def _settle(self, deadline: float) -> None:
        """Before a new command: finish with one left unanswered.

        Its late response is acknowledged and discarded; one never taken is
        dropped.  While it may still run, nothing is sent: the deadline times
        out naming it.
        """
        pending = self._pending
        if pending is None:
            return
        # ExtCmdSet may have risen without harlsync knowing (the reply to its write
        # was lost: the link never sends a write again, issue 34): look before
        # dropping it, since ExtCmdGet, which says the controller took the command,
        # falls with it
        if (
            not pending.acquired
            and self._input(self.map.ext_cmd_set)
            and self._snapshot()["ExtCmdGet"]
        ):
            pending.acquired = True
        self._drive(self.map.ext_cmd_set, False)
        self._drive(self.map.ext_resp_get, False)
        since, polls = self.clock.monotonic(), 0
        while True:
            status = self._snapshot()
            polls += 1
            if status["ExtError"]:
                self._function_error(status, pending.request)
            if status["ExtRespSet"]:
                log.warning(
                    "%s: command %s answered late: response %s discarded",
                    self.label,
                    pending.request,
                    " ".join(f"{w:04X}" for w in status.response),
                )
                self._drive(self.map.ext_resp_get, True)
                self._wait(deadline, Step.RESPONSE_RELEASED, lambda s: not s["ExtRespSet"])
                self._drive(self.map.ext_resp_get, False)
                self._pending = None
                return
            if status["ExtCmdGet"]:
                pending.acquired = True
            now = self.clock.monotonic()
            if not pending.acquired and now >= deadline:
                # ExtCmdGet falls with ExtCmdSet, and ExtRespSet is 0 while a command
                # runs: one taken just before ExtCmdSet fell (or whose ExtCmdGet the
                # client never saw, a reply lost) looks the same as one never taken
                # until it answers.  Only a deadline without an answer tells.
                log.debug("%s: command %s was never taken: dropped", self.label, pending.request)
                self._pending = None
                return
            if now >= deadline:
                raise HandshakeTimeout(
                    f"still unanswered after {seconds(self.deadline)} s more (stopped at step "
                    f"{pending.step.value} of §6.3, {pending.step.text}): nothing else is sent "
                    "while it may run (a second request halts the function, §6.5.1)",
                    port=self.label,
                    command=str(pending.request),
                    step=pending.step,
                    acquired=pending.acquired,
                )
            self._pause(since, polls, deadline)
