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
from typing import Any, NamedTuple, TypeVar

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

__all__ = ["Controller", "NoSuchTable", "Progress", "TableBeyondRange"]

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

    def read_offsets(
        self,
        limit: int = OFFSET_TABLE_COUNT,
        *,
        expect: NoSuchTable | None = None,
        tick: Callable[[], None] | None = None,
    ) -> tuple[dict[int, OffsetTable], OffsetEnd]:
        """The offset tables from 0 to where the controller's answers say they end,
        at most ``limit`` (robot.yaml's ``offset_tables``), and that end.

        LNX does not report how many tables there are, and which status a missing
        one answers is not in the manual, so the end is the controller's own:
        table ``n`` answers an error reply, table ``n`` - 1 reads normally once
        more, and table ``n`` answers the same reply again.  That is table
        ``limit`` (the probe past the range) or an earlier one (a controller with
        fewer tables: read to its end, not failed).  Three exchanges beyond the
        tables' own reads; a table that answers an error once and then reads is
        taken as read.  ``expect`` is the reply robot.yaml pins or the project
        recorded; None: whatever the controller answers twice.  ``tick`` is
        called after each table read.

        Raises :class:`TableBeyondRange` naming robot.yaml's ``offset_tables`` when
        table ``limit`` answers data, and :class:`ControllerError` in one line when
        the answers do not show an end (two different replies, table ``n`` - 1 not
        reading again, table 0 missing) or show one with a reply other than
        ``expect``: the tables read could be short.
        """
        offsets: dict[int, OffsetTable] = {}
        n = 0
        while True:
            answer = self._table_or_reply(n)
            if isinstance(answer, str):
                answer = self._asked_again(n, answer)
            if isinstance(answer, OffsetTable):
                if n >= limit:
                    raise TableBeyondRange(
                        f"port {self.port}, station {self.station}: offset table {n} answers "
                        f"({' '.join(answer.values)}): the controller has more than the {n} "
                        f"offset tables a read goes to (0-{n - 1}), so the backup would be "
                        "short; set offset_tables in robot.yaml to the controller's count "
                        "and pull again"
                    )
                offsets[n] = answer
                if tick is not None:
                    tick()
                n += 1
                continue
            if expect is not None and answer != expect.reply:
                raise self._unreadable_end(
                    n,
                    answer,
                    f"offset table {n} answered {answer} twice, not {expect.reply} "
                    f"({expect.source}): the controller now answers a missing table "
                    "otherwise, or cannot answer normally (an abnormal condition)",
                    advice=(
                        f"; if {answer} is what this controller answers for a table it "
                        f"does not have, set no_such_table: {answer} in robot.yaml"
                    ),
                )
            end = OffsetEnd(n, answer, asked=limit)
            if n < limit:
                log.info(
                    "port %s, station %s: %d offset tables, fewer than the %d a read goes "
                    "to (robot.yaml offset_tables): table %d answered %s twice",
                    self.port,
                    self.station,
                    n,
                    limit,
                    n,
                    answer,
                )
            return offsets, end

    def _table_or_reply(self, table: int) -> OffsetTable | str:
        """LNL ``table``: the table, or the error reply (``E`` + status) it answered."""
        try:
            return self.read_offset(table)
        except ControllerError as exc:
            return profile.ERROR_PREFIX + exc.status

    def _asked_again(self, table: int, first: str) -> OffsetTable | str:
        """Table ``table`` answered the error reply ``first``: read the table before it
        again (the robot still answers normally), then ``table`` again.  Returns the
        table when it reads now, or ``first`` when it answers that again.

        Raises :class:`ControllerError` when the answers show no end.
        """
        if table > 0:
            before = self._table_or_reply(table - 1)
            if isinstance(before, str):
                raise self._unreadable_end(
                    table,
                    first,
                    f"offset table {table} answered {first}, and table {table - 1}, which "
                    f"read normally, answers {before} now: the robot does not answer "
                    "normally",
                )
        second = self._table_or_reply(table)
        if isinstance(second, OffsetTable) or (second == first and table > 0):
            return second
        if second == first:
            raise self._unreadable_end(
                table,
                first,
                f"offset table 0 answered {first} twice: no offset table reads normally, "
                "so the robot either has none or cannot answer now",
            )
        raise self._unreadable_end(
            table,
            second,
            f"offset table {table} answered {first}, then {second}: not the same reply twice",
        )

    def _unreadable_end(
        self, table: int, reply: str, why: str, advice: str = ""
    ) -> ControllerError:
        """The one-line error of a read whose offset tables show no end it can trust."""
        return ControllerError(
            reply[len(profile.ERROR_PREFIX) :],
            port=self.port,
            station=self.station,
            command=cmd.read_offset(table).payload,
            message=(
                f"{why}; harlsync cannot tell where the offset tables end, so it saves "
                f"nothing and writes nothing: pull again when the robot answers "
                f"normally{advice}"
            ),
        )

    # --- everything ---------------------------------------------------------------------

    def read_all(
        self,
        include_registers: bool = False,
        progress: Progress | None = None,
        *,
        offset_tables: int = OFFSET_TABLE_COUNT,
        no_such_table: NoSuchTable | None = None,
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

        Raises :class:`TableBeyondRange` when the controller has more offset tables,
        and :class:`ControllerError` when their end cannot be trusted.
        """
        config = self.config() if known is None else known[0]
        registers = config.registers if include_registers else 0
        # LNX, LNV, LNE, the steps, the tables and the three exchanges of their end
        # (:meth:`read_offsets`), the timers and the registers
        total = 6 + config.step_count + offset_tables + config.timers + registers
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
        offsets, end = self.read_offsets(
            offset_tables, expect=no_such_table, tick=lambda: tick(None)
        )
        done += offset_tables - end.count  # the tables a smaller controller does not have
        for _ in range(3):  # the end: table N, table N - 1 again, table N again
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
            offset_end=end,
        )


class NoSuchTable(NamedTuple):
    """The reply a read takes for "no such table" past the last offset table, and
    what says so, for its message: ``NoSuchTable("E21", "robot.yaml's no_such_table")``."""

    reply: str
    source: str


class TableBeyondRange(SyncError):
    """The controller has more of a table than the pull reads: a backup would be short."""


def _show(value: object) -> str:
    if isinstance(value, Step):
        return repr(value.text)
    if isinstance(value, (OffsetTable, Parameters)):
        return repr(" ".join(value.values))
    return repr(value)
