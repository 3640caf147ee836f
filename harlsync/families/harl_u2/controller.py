"""What a HARL-U2 robot can do, as methods: read_step, write_timer, status(), config() ...

A :class:`Controller` talks to one station through a :class:`~harlsync.link.Link`
with the HARL-U2 codec (several controllers, one per station, may share a link).
Every request is typed (``Request[Step]`` ...), so each method returns its value
as the reply was decoded, without a cast.  Every failure is a
typed exception naming the port, the station and the command: an ``E`` + status
reply raises :class:`~harlsync.errors.ControllerError` (its ``status`` is the raw
text), the link raises :class:`~harlsync.errors.LinkError` subclasses.

Writes are confirmed, never blindly repeated.  When the reply to an SN write is
lost the link raises :class:`~harlsync.errors.WriteUnconfirmed`; the controller
then reads the item back::

    reads back what was written    -> the write took: done
    reads back what was there      -> it did not take: send it once more (then the same check)
    reads back anything else       -> WriteUnconfirmed (someone else changed it, or worse)

Before sending an unsafe write (SNA, SNM, SNS, SNH, SNE, SNX) once more, the
controller reads LNR again (twice: :meth:`Controller.idle_status`): the robot may have been started while the reply was
awaited.  Unless every task is known and idle it raises
:class:`~harlsync.errors.InterlockError` and does not send it again.  A caller
that needs an idle robot for a write the manual allows in automatic operation
(a push without live tuning: timers, tables, registers) says so with
``needs_idle=True``.  No argument lets an unsafe write be re-sent unchecked.

"What was there" is the ``old`` value the caller passes (push knows it from its
plan); without it the controller reads the item before writing.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import Any, TypeVar

from ...errors import ControllerError, SyncError, WriteUnconfirmed
from ...link import DEFAULT_LOCK_TIMEOUT
from ...link import Link as SharedLink
from ...link.confirm import confirmed_write, refuse_unless_idle
from ...link.owner import OnLink
from ...settings import SerialSettings
from .link import Link
from .model import (
    OFFSET_TABLE_COUNT,
    Config,
    OffsetTable,
    Parameters,
    ProgramKey,
    ProgramType,
    RobotData,
    Status,
    Step,
)
from .protocol import Ack, ErrorReply, Frame, Request, profile
from .protocol import commands as cmd

__all__ = ["Controller", "Progress", "TableBeyondRange"]

log = logging.getLogger(__name__)

#: ``progress(done, total)``, called after each item read.
Progress = Callable[[int, int], None]

T = TypeVar("T")


class Controller(OnLink):
    """One robot (``station``, default the link's) on an open HARL-U2 link."""

    def __init__(self, link: SharedLink[Frame], station: int | None = None) -> None:
        self.link = link
        self.station = link.station if station is None else station

    @classmethod
    def from_url(
        cls,
        url: str,
        station: int = 1,
        settings: SerialSettings | None = None,
        *,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | os.PathLike[str] | None = None,
    ) -> Controller:
        """Open a link to ``url`` and return a controller that closes it on :meth:`close`.

        Raises :class:`~harlsync.errors.PortBusyError` or :class:`~harlsync.errors.PortError`.
        """
        link = Link(url, station, settings, lock_timeout=lock_timeout, lock_dir=lock_dir).open()
        controller = cls(link)
        controller._owns_link = True
        return controller

    # --- the one place requests go through ----------------------------------------

    def request(self, request: Request[T]) -> T:
        """Send one request and return its typed value.

        Raises :class:`ControllerError` when the controller answers ``E`` + status.
        """
        value = self.link.exchange(request, station=self.station)
        if isinstance(value, ErrorReply):
            raise ControllerError(
                value.status, port=self.port, station=self.station, command=request.payload
            )
        return value

    def _write(
        self,
        request: Request[Ack],
        readback: Request[T],
        wanted: T,
        old: T | None,
        same: Callable[[T, T], bool] = lambda a, b: a == b,
        needs_idle: bool = False,
    ) -> None:
        """Send an SN write; when its reply is lost, decide on what ``readback`` returns.

        A re-send waits for LNR to show every task idle when the manual forbids
        the write in automatic operation, or when the caller asks (``needs_idle``).
        """
        needs_idle = request.unsafe or needs_idle
        if old is None:
            old = self.request(readback)
        confirmed_write(
            lambda: self.request(request),
            lambda: self.request(readback),
            wanted,
            old,
            before_resend=(
                (lambda lost: self._idle_before_resend(request, lost))
                if needs_idle
                else (lambda lost: None)
            ),
            same=same,
            show=_show,
            what=readback.payload,
        )

    def _idle_before_resend(self, request: Any, lost: WriteUnconfirmed) -> None:
        """Raise InterlockError unless the status, read now, shows the robot idle."""
        refuse_unless_idle(
            self.idle_status,
            lost,
            where=f"port {self.port}, station {self.station}, command {request.payload}",
            reading="the task states",
        )

    # --- programs -----------------------------------------------------------------

    def read_step(self, ptype: ProgramType, program: int, step: int) -> Step:
        return self.request(cmd.read_step(ptype, program, step))

    def write_step(
        self,
        ptype: ProgramType,
        program: int,
        step: int,
        value: Step,
        *,
        old: Step | None = None,
        needs_idle: bool = False,
    ) -> None:
        """Write one step (an empty :class:`Step` clears it)."""
        self._write(
            cmd.write_step(ptype, program, step, value),
            cmd.read_step(ptype, program, step),
            value,
            old,
            needs_idle=needs_idle,
        )

    def read_program(
        self,
        ptype: ProgramType,
        number: int,
        steps: int | None = None,
        progress: Progress | None = None,
    ) -> dict[int, Step]:
        """The non-empty steps of one program, by step number.

        ``steps`` is how many to read (default: what LNX reports for the type).
        """
        if steps is None:
            steps = self.config().area(ptype).steps
        out: dict[int, Step] = {}
        for n in range(steps):
            value = self.read_step(ptype, number, n)
            if not value.empty:
                out[n] = value
            if progress is not None:
                progress(n + 1, steps)
        return out

    # --- timers, registers, offsets, parameters ---------------------------------------

    def read_timer(self, number: int) -> str:
        return self.request(cmd.read_timer(number))

    def write_timer(
        self, number: int, value: str, *, old: str | None = None, needs_idle: bool = False
    ) -> None:
        self._write(
            cmd.write_timer(number, value),
            cmd.read_timer(number),
            value,
            old,
            needs_idle=needs_idle,
        )

    def read_register(self, number: int) -> str:
        return self.request(cmd.read_register(number))

    def write_register(
        self, number: int, value: str, *, old: str | None = None, needs_idle: bool = False
    ) -> None:
        self._write(
            cmd.write_register(number, value),
            cmd.read_register(number),
            value,
            old,
            needs_idle=needs_idle,
        )

    def read_offset(self, table: int) -> OffsetTable:
        return self.request(cmd.read_offset(table))

    def write_offset(
        self,
        table: int,
        value: OffsetTable,
        *,
        old: OffsetTable | None = None,
        needs_idle: bool = False,
    ) -> None:
        self._write(
            cmd.write_offset(table, value),
            cmd.read_offset(table),
            value,
            old,
            needs_idle=needs_idle,
        )

    def read_parameters(self) -> Parameters:
        return self.request(cmd.read_parameters())

    def write_parameters(
        self, value: Parameters, *, old: Parameters | None = None, needs_idle: bool = False
    ) -> None:
        self._write(
            cmd.write_parameters(value), cmd.read_parameters(), value, old, needs_idle=needs_idle
        )

    # --- I/O and memory bits ------------------------------------------------------------

    def read_di_bit(self, bit: int) -> bool:
        return bool(self.request(cmd.read_di_bit(bit)))

    def read_di_port(self, port: int) -> int:
        return self.request(cmd.read_di_port(port))

    def read_do_bit(self, bit: int) -> bool:
        return bool(self.request(cmd.read_do_bit(bit)))

    def read_do_port(self, port: int) -> int:
        return self.request(cmd.read_do_port(port))

    def read_mem_bit(self, bit: int) -> bool:
        return bool(self.request(cmd.read_mem_bit(bit)))

    def read_mem_port(self, port: int) -> int:
        return self.request(cmd.read_mem_port(port))

    # --- status, version, configuration -------------------------------------------------

    def status(self) -> Status:
        """The LNR task states; ``.idle`` is the fail-safe verdict.

        An unparsable reply raises (:class:`~harlsync.errors.LinkTimeout` from the
        :class:`~harlsync.errors.ReplyError`): treat any error as "not idle".
        """
        return self.request(cmd.read_status())

    def idle_status(self) -> Status:
        """LNR read until one reply is not idle, at most ``profile.IDLE_READS`` times:
        the robot is idle only when every one of those replies says so.

        The LRC cannot catch two flipped bits in one bit column, which can turn a
        task in execution into a stopped one; two such corruptions in a row are
        needed to clear a write.  Raises as :meth:`status` does.
        """
        status = self.status()
        for _ in range(profile.IDLE_READS - 1):
            if not status.idle:
                break
            status = self.status()
        return status

    def version(self) -> str:
        return self.request(cmd.read_version())

    def config(self) -> Config:
        return self.request(cmd.read_config())

    def write_config(
        self, value: Config, *, old: Config | None = None, needs_idle: bool = False
    ) -> None:
        """SNX: set the four program areas.  The controller drops every program."""
        self._write(
            cmd.write_config(value),
            cmd.read_config(),
            value,
            old,
            lambda a, b: a.same_programs(b),
            needs_idle=needs_idle,
        )

    def probe_offsets(self, count: int) -> None:
        """Make sure the controller has no offset table ``count`` (LNX does not
        report how many it has): LNL ``count`` must answer
        ``E`` + ``profile.NO_SUCH_TABLE``.

        Raises :class:`TableBeyondRange` naming the table and robot.yaml's
        ``offset_tables`` when it answers a table, and :class:`ControllerError`
        when it answers any other error status (busy, a fault): that does not
        say the table is absent, so the backup could be short.
        """
        try:
            table = self.read_offset(count)
        except ControllerError as exc:
            if exc.status == profile.NO_SUCH_TABLE:
                return
            raise ControllerError(
                exc.status,
                port=self.port,
                station=self.station,
                command=exc.command,
                message=(
                    f"offset table {count} answered error status "
                    f"{profile.ERROR_PREFIX}{exc.status}, not "
                    f"{profile.ERROR_PREFIX}{profile.NO_SUCH_TABLE} (no such table): "
                    f"harlsync cannot tell whether the controller has more than the "
                    f"{count} offset tables this pull reads, so it saves no backup; pull "
                    "again when the robot answers normally (a controller that always "
                    "answers this for a missing table needs NO_SUCH_TABLE set to it in "
                    "harlsync's HARL-U2 profile)"
                ),
            ) from exc
        shown = " ".join(table.values)
        raise TableBeyondRange(
            f"port {self.port}, station {self.station}: offset table {count} answers "
            f"({shown}): the controller has more than the {count} offset tables this pull "
            f"reads (0-{count - 1}), so the backup would be short; set offset_tables in "
            "robot.yaml to the controller's count and pull again"
        )

    # --- everything ---------------------------------------------------------------------

    def read_all(
        self,
        include_registers: bool = False,
        progress: Progress | None = None,
        *,
        offset_tables: int = OFFSET_TABLE_COUNT,
        known: tuple[Config, str] | None = None,
    ) -> RobotData:
        """Everything a backup holds, read in pull order.

        The configuration first (it says what exists), then version, parameters,
        every step of every program, the offset tables 0 to ``offset_tables`` - 1
        (robot.yaml's ``offset_tables``, the manual's 100 by default) and the
        probe past them (:meth:`probe_offsets`), the timers, and the registers
        when ``include_registers``.  Programs, timers and registers are read to
        the sizes LNX reports; only the offset tables' count is not reported.
        ``progress(done, total)`` is called after each item.

        ``known`` is the configuration and version just read (the robot's identity,
        :meth:`HarlU2Driver.identity`): not asked for again.

        Raises :class:`TableBeyondRange` when the controller has more offset tables.
        """
        config = self.config() if known is None else known[0]
        registers = config.registers if include_registers else 0
        total = 4 + config.step_count + offset_tables + config.timers + registers
        done = 0

        def tick(value: T) -> T:
            nonlocal done
            done += 1
            if progress is not None:
                progress(done, total)
            return value

        tick(config)
        version = tick(self.version() if known is None else known[1])
        parameters = tick(self.read_parameters())
        programs: dict[ProgramKey, dict[int, Step]] = {
            (ptype, number): self.read_program(
                ptype, number, config.area(ptype).steps, progress=lambda *_: tick(None)
            )
            for ptype, number in config.programs()
        }
        offsets = {n: tick(self.read_offset(n)) for n in range(offset_tables)}
        self.probe_offsets(offset_tables)
        tick(None)
        timers = {n: tick(self.read_timer(n)) for n in range(config.timers)}
        regs = {n: tick(self.read_register(n)) for n in range(registers)}
        return RobotData(
            version=version,
            config=config,
            parameters=parameters,
            programs=programs,
            offsets=offsets,
            timers=timers,
            registers=regs if include_registers else None,
        )


class TableBeyondRange(SyncError):
    """The controller has more of a table than the pull reads: a backup would be short."""


def _show(value: object) -> str:
    if isinstance(value, Step):
        return repr(value.text)
    if isinstance(value, (OffsetTable, Parameters)):
        return repr(" ".join(value.values))
    return repr(value)
