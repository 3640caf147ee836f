"""The Remote Control function's signals over Modbus registers, as the handshake
drives and reads them: the controller's Remote inputs harlsync drives (ExtCmdSet,
ExtRespGet, ExtCmdReset: bits of holding registers, a copy kept as last written or
first read), one read of every Remote output and response word, and the function's
start (§6.2) and reset (§6.5.2), which are signals alone (no command).

Bits of the control registers that are not handshake signals keep the value they
were read with.  A wait polls at once, then on the poll interval counted from its
start (a poll's own round trip is not added to the interval), the last poll at
the deadline.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Protocol

from ...errors import InterlockError, LinkError
from ...settings import seconds
from . import profile
from .profile import HANDSHAKE_INPUTS, Bit, RegisterMap
from .remote_status import RemoteStatus
from .steps import HandshakeTimeout, Step

__all__ = ["Clock", "RegisterAccess", "RemoteIO", "SystemClock"]

log = logging.getLogger(__name__)


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


class RemoteIO:
    """One controller's Remote I/O over ``registers`` with ``register_map``; waits
    poll every ``poll_interval`` up to ``deadline`` seconds on ``clock``."""

    def __init__(
        self,
        registers: RegisterAccess,
        register_map: RegisterMap,
        *,
        poll_interval: float,
        deadline: float,
        clock: Clock,
    ) -> None:
        self.registers = registers
        self.map = register_map
        self.poll_interval = poll_interval
        self.deadline = deadline
        self.clock = clock
        #: the control holding registers as harlsync last wrote (or first read) them
        self._control: dict[int, int] | None = None

    @property
    def label(self) -> str:
        return self.registers.label

    # --- signals ------------------------------------------------------------------------

    def forget(self) -> None:
        """Read the control registers again before the next signal is driven: a write
        that failed may or may not have taken, a controller that restarted has them
        at 0."""
        self._control = None

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

    def input(self, bit: Bit) -> bool:
        """One of harlsync's signals, as it stands in the copy (read if there is none)."""
        return bool(self._load_control()[bit.register] >> bit.bit & 1)

    def drive(self, bit: Bit, on: bool) -> None:
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

    def release(self) -> None:
        """ExtCmdSet and ExtRespGet low."""
        self.drive(self.map.ext_cmd_set, False)
        self.drive(self.map.ext_resp_get, False)

    def write_command(self, first: int, words: Sequence[int]) -> None:
        """Steps 2 and 3 in one write: the command words and ExtCmdSet's register
        with ExtCmdSet 1 (its other bits as :meth:`drive` keeps them), from
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

    def snapshot(self) -> RemoteStatus:
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

    def pause(self, since: float, polls: int, deadline: float) -> None:
        """Sleep until poll ``polls + 1`` of a wait begun at ``since`` is due: the
        polls keep to their interval from the first one (the time a poll takes is
        not added to it), and none is later than ``deadline``.  A poll that is
        already due (the line slower than the interval) goes at once."""
        due = min(since + polls * self.poll_interval, deadline)
        left = due - self.clock.monotonic()
        if left > 0:
            self.clock.sleep(left)

    # --- the function's start and reset -------------------------------------------------

    def start(self) -> None:
        """Make the function usable (§6.1-6.2): when ExtCmdReset is 0, clear
        ExtCmdSet and ExtRespGet, then raise ExtCmdReset.  A function found with
        ExtCmdReset 1 is left as it is (dropping it aborts motion, §4.1.1)."""
        self._control = None
        if self.input(self.map.ext_cmd_reset):
            log.debug("%s: ExtCmdReset already 1: the function is kept as found", self.label)
        else:
            self.release()
            self._await_operable()
            self.drive(self.map.ext_cmd_reset, True)
            log.debug("%s: ExtCmdReset raised (§6.2)", self.label)

    def _await_operable(self) -> None:
        """§6.2: the reset is released only "after the Controller becomes operable":
        poll until Ready (or a task, an error, an emergency stop) reads 1.

        Raises :class:`HandshakeTimeout` when the deadline passes first (ExtCmdReset
        stays 0)."""
        since = self.clock.monotonic()
        deadline, polls = since + self.deadline, 0
        while not (status := self.snapshot()).operable:
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
            self.pause(since, polls, deadline)

    def reset(self, *, at_rest: bool = False) -> None:
        """The §6.5.2 function reset's signals: ExtCmdReset, ExtCmdSet, ExtRespGet low,
        at least 30 ms, ExtCmdReset high (:meth:`await_function_idle` then waits).

        Raises :class:`InterlockError` (and changes nothing) when Running is 1 or
        the map has no Running signal: dropping ExtCmdReset aborts motion.  With
        ``at_rest`` (a reset no person asked for), also unless the same read shows
        the robot at rest (:attr:`RemoteStatus.unsettled` is None)."""
        if self.map.running is None:
            raise InterlockError(
                f"{self.label}: the register map has no Running signal, so "
                "harlsync cannot see that the robot is idle: no function reset"
            )
        status = self.snapshot()
        if status["Running"]:
            raise InterlockError(
                f"{self.label}: Running 1 (a task is executing): dropping "
                "ExtCmdReset would abort motion; the function is not reset"
            )
        if at_rest and (why := status.unsettled) is not None:
            raise InterlockError(f"{self.label}: {why}: the function is not reset")
        self.drive(self.map.ext_cmd_reset, False)
        self.release()
        low_since = self.clock.monotonic()
        while (left := profile.FUNCTION_RESET_LOW - (self.clock.monotonic() - low_since)) > 0:
            self.clock.sleep(left)
        self.drive(self.map.ext_cmd_reset, True)

    def await_function_idle(self) -> None:
        """After a reset: poll until the function is idle.  Raises
        :class:`HandshakeTimeout` when it is not within the deadline."""
        since = self.clock.monotonic()
        deadline, polls = since + self.deadline, 0
        while True:
            status = self.snapshot()
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
            self.pause(since, polls, deadline)
