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
from typing import TypeVar

from ...errors import ControllerError, WriteUnconfirmed
from ...link import DEFAULT_LOCK_TIMEOUT
from ...link import Link as SharedLink
from ...link.confirm import confirmed_write, refuse_unless_idle
from ...link.owner import OnLink
from ...settings import SerialSettings
from .link import Link
from .model import (
    OFFSET_TABLE_COUNT,
    Config,
    OffsetEnd,
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
from .tableend import TableReader

__all__ = ["Controller", "Progress"]

log = logging.getLogger(__name__)

#: ``progress(done, total)``, called after each item read.
Progress = Callable[[int, int], None]

T = TypeVar("T")


class Controller(OnLink[Frame]):
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

    def _idle_before_resend(self, request: Request[object], lost: WriteUnconfirmed) -> None:
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

    def read_offsets(
        self,
        limit: int = OFFSET_TABLE_COUNT,
        *,
        pinned: str | None = None,
        tick: Callable[[], None] | None = None,
    ) -> tuple[dict[int, OffsetTable], OffsetEnd]:
        """The offset tables from 0 to where the controller's answers say they end,
        at most ``limit`` (robot.yaml's ``offset_tables``), and that end, found as
        :mod:`.tableend` tells: three exchanges beyond the tables' own reads.
        ``pinned`` is the reply robot.yaml's ``no_such_table`` pins; None:
        whatever the controller answers twice (what the project recorded is
        compared once the read is over: ``HarlU2Catalogue.other_robot``).
        ``tick`` is called after each table read.

        Raises :class:`~.tableend.TableBeyondRange` naming robot.yaml's
        ``offset_tables`` when table ``limit`` answers data, and
        :class:`ControllerError` in one line when the answers do not show an end
        (two different replies, table ``n`` - 1 not reading again, table 0
        missing) or show one with a reply other than ``pinned``: the tables read
        could be short.
        """
        offsets, end = TableReader(self.read_offset, self.port, self.station).read(
            limit, pinned=pinned, tick=tick
        )
        if end.count < limit:
            log.info(
                "port %s, station %s: %d offset tables, fewer than the %d a read goes "
                "to (robot.yaml offset_tables): table %d answered %s twice",
                self.port,
                self.station,
                end.count,
                limit,
                end.count,
                end.reply,
            )
        return offsets, end

    # --- everything ---------------------------------------------------------------------

    def read_all(
        self,
        include_registers: bool = False,
        progress: Progress | None = None,
        *,
        offset_tables: int = OFFSET_TABLE_COUNT,
        no_such_table: str | None = None,
        known: tuple[Config, str] | None = None,
    ) -> RobotData:
        """Everything a backup holds, read in pull order.

        The configuration first (it says what exists), then version, parameters,
        every step of every program, the offset tables from 0 to their end, at
        most ``offset_tables`` - 1 (robot.yaml's ``offset_tables``, the manual's
        100 by default: :meth:`read_offsets`, which holds the controller to
        ``no_such_table`` when given), the timers, and the registers when
        ``include_registers``.  Programs, timers and registers are read to the
        sizes LNX reports; only the offset tables' count is not reported.
        ``progress(done, total)`` is called after each item.

        ``known`` is the configuration and version just read (the robot's identity,
        :meth:`HarlU2Driver.identity`): not asked for again.

        Raises :class:`~.tableend.TableBeyondRange` when the controller has more offset tables,
        and :class:`ControllerError` when their end cannot be trusted.
        """
        config = self.config() if known is None else known[0]
        registers = config.registers if include_registers else 0
        # LNX, LNV, LNE, the steps, the tables and the three exchanges of their end
        # (:meth:`read_offsets`), the timers and the registers
        count = _Count(progress, 6 + config.step_count + offset_tables + config.timers + registers)
        count.tick(config)
        version = count.tick(self.version() if known is None else known[1])
        parameters = count.tick(self.read_parameters())
        programs: dict[ProgramKey, dict[int, Step]] = {
            (ptype, number): self.read_program(
                ptype, number, config.area(ptype).steps, progress=lambda *_: count.tick(None)
            )
            for ptype, number in config.programs()
        }
        offsets, end = self.read_offsets(
            offset_tables, pinned=no_such_table, tick=lambda: count.tick(None)
        )
        count.done += offset_tables - end.count  # the tables a smaller controller does not have
        for _ in range(3):  # the end: table N, table N - 1 again, table N again
            count.tick(None)
        timers = {n: count.tick(self.read_timer(n)) for n in range(config.timers)}
        regs = {n: count.tick(self.read_register(n)) for n in range(registers)}
        return RobotData(
            version=version,
            config=config,
            parameters=parameters,
            programs=programs,
            offsets=offsets,
            timers=timers,
            registers=regs if include_registers else None,
            offset_end=end,
        )


class _Count:
    """The items a read of everything has read, told to ``progress(done, total)``."""

    def __init__(self, progress: Progress | None, total: int) -> None:
        self.progress = progress
        self.total = total
        self.done = 0

    def tick(self, value: T) -> T:
        """One more item read (``value``, handed back)."""
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total)
        return value


def _show(value: object) -> str:
    if isinstance(value, Step):
        return repr(value.text)
    if isinstance(value, (OffsetTable, Parameters)):
        return repr(" ".join(value.values))
    return repr(value)
