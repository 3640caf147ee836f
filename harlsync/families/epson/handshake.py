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

The handshake does no I/O of its own: it is given a
:class:`~.remote_io.RegisterAccess` (Modbus TCP in :mod:`.transport`, a fake
register bank in the tests) and a :class:`~.remote_io.Clock` (the poll interval
and deadlines; a test's clock need not wait).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TypeVar

from ...errors import ControllerError, InterlockError, LinkError
from ...settings import seconds
from . import profile
from .profile import RegisterMap
from .protocol import FUNCTION_ERROR, ErrorReply, Request, WriteSequence
from .remote_io import Clock, RegisterAccess, RemoteIO, SystemClock
from .remote_status import RemoteStatus
from .steps import RESET_ADVICE, FunctionBusy, FunctionError, HandshakeTimeout, Pending, Step

__all__ = ["Handshake"]

log = logging.getLogger(__name__)

T = TypeVar("T")


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
        #: the Remote I/O signals, polls and waits
        self.io = RemoteIO(
            registers,
            self.map,
            poll_interval=poll_interval,
            deadline=deadline,
            clock=clock if clock is not None else SystemClock(),
        )
        #: where the one write of steps 2 and 3 starts; None: two writes
        self._block = self.map.command_block(whole=block_write_whole)
        #: how a message tells a person to reset the function: the command to run
        #: again, ``'harlsync push DIR --reset-function'``, once the driver knows it
        self.reset_advice = RESET_ADVICE
        self._started = False
        self._pending: Pending | None = None

    @property
    def label(self) -> str:
        return self.registers.label

    @property
    def pending(self) -> str | None:
        """The command sent and not answered, with the step it stopped at, or None."""
        p = self._pending
        return None if p is None else f"{p.request} at step {p.step.value}"

    # --- start, status, reset -----------------------------------------------------------

    def start(self) -> None:
        """Make the function usable (§6.1-6.2): when ExtCmdReset is 0, clear
        ExtCmdSet and ExtRespGet, then raise ExtCmdReset.  A function found with
        ExtCmdReset 1 is left as it is (dropping it aborts motion, §4.1.1)."""
        self.io.start()
        self._started = True

    def _refresh(self) -> None:
        """Before a command's step 1: read the control registers again (one read in
        the profile's map, where the three inputs share a register).

        The cache is stale when the controller restarted (a power cycle sets
        every register harlsync writes back to 0): driving a signal from the
        cache would then raise ExtCmdSet together with ExtCmdReset, which the
        controller ignores.  Found so, the function is started again (§6.2) and
        a command left unanswered is dropped (the restart aborted it)."""
        self.io.forget()
        if self.io.input(self.map.ext_cmd_reset):
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
        return self.io.snapshot()

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
        self.io.reset(at_rest=at_rest)
        self._started = True
        self._pending = None
        log.info("%s: function reset (§6.5.2)", self.label)
        self.io.await_function_idle()

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
            self._settle(self._pending.settle_by(self.io.clock.monotonic(), self.io.deadline))
        deadline = self.io.clock.monotonic() + self.io.deadline
        status = self.io.snapshot()
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
        self._pending = Pending(request, Step.COMMAND_WORDS, due=deadline)
        if self._block is None:
            self.registers.write_holding(self.map.command_base, words)
            self._pending.step = Step.COMMAND_SET
            self.io.drive(self.map.ext_cmd_set, True)
        else:
            self._pending.step = Step.COMMAND_SET
            self.io.write_command(self._block, words)
        self._wait(deadline, Step.COMMAND_ACQUIRED, lambda s: bool(s["ExtCmdGet"]))
        self._pending.acquired = True
        self._pending.step = Step.COMMAND_SET_CLEARED
        self.io.drive(self.map.ext_cmd_set, False)
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
        self.io.drive(self.map.ext_resp_get, True)
        self._wait(deadline, Step.RESPONSE_RELEASED, lambda s: not s["ExtRespSet"])
        self._pending.step = Step.RESPONSE_GET_CLEARED
        self.io.drive(self.map.ext_resp_get, False)
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
        since, polls = self.io.clock.monotonic(), 0
        while True:
            status = self.io.snapshot()
            polls += 1
            if status["ExtError"]:
                self._function_error(status, pending.request)
            if done(status):
                return status
            if self.io.clock.monotonic() >= deadline:
                self._timeout(pending)
            self.io.pause(since, polls, deadline)

    def _timeout(self, pending: Pending) -> None:
        """Leave ExtCmdSet and ExtRespGet low, keep the command pending, raise."""
        try:
            self.io.release()
        except LinkError as exc:  # the timeout is the error worth raising
            log.debug("%s: clearing the handshake inputs failed: %s", self.label, exc)
        note = ""
        if pending.acquired and pending.request.is_write:
            note = "; the controller took the write: it may or may not have taken effect"
        raise HandshakeTimeout(
            f"no answer within {seconds(self.io.deadline)} s: stopped at step {pending.step.value} of "
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
            self.io.release()
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
        end = self._pending.settle_by(self.io.clock.monotonic(), self.io.deadline)
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
                self.io.forget()  # at least three times: a lost request costs retries)
                if attempts >= 3 and self.io.clock.monotonic() >= end:
                    log.warning(
                        "%s: command %s is still unanswered: %s",
                        self.label,
                        self._pending.request if self._pending else "",
                        exc,
                    )
                    return
                self.io.clock.sleep(self.io.poll_interval)

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
            and self.io.input(self.map.ext_cmd_set)
            and self.io.snapshot()["ExtCmdGet"]
        ):
            pending.acquired = True
        self.io.release()
        since, polls = self.io.clock.monotonic(), 0
        while True:
            status = self.io.snapshot()
            polls += 1
            if status["ExtError"]:
                self._function_error(status, pending.request)
            if status["ExtRespSet"]:
                self._discard_late(pending, status, deadline)
                return
            if status["ExtCmdGet"]:
                pending.acquired = True
            now = self.io.clock.monotonic()
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
                    f"still unanswered after {seconds(self.io.deadline)} s more (stopped at step "
                    f"{pending.step.value} of §6.3, {pending.step.text}): nothing else is sent "
                    "while it may run (a second request halts the function, §6.5.1)",
                    port=self.label,
                    command=str(pending.request),
                    step=pending.step,
                    acquired=pending.acquired,
                )
            self.io.pause(since, polls, deadline)

    def _discard_late(self, pending: Pending, status: RemoteStatus, deadline: float) -> None:
        """The late response of ``pending``, in ``status``: acknowledged (steps 8-10)
        and discarded."""
        log.warning(
            "%s: command %s answered late: response %s discarded",
            self.label,
            pending.request,
            " ".join(f"{w:04X}" for w in status.response),
        )
        self.io.drive(self.map.ext_resp_get, True)
        self._wait(deadline, Step.RESPONSE_RELEASED, lambda s: not s["ExtRespSet"])
        self.io.drive(self.map.ext_resp_get, False)
        self._pending = None
