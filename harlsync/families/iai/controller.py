"""What an IAI controller can do for harlsync, as methods: version, status, read and
write positions, and the global flags and integer and real variables.

A :class:`Controller` talks to one station through the shared
:class:`~harlsync.link.Link` with the IAI codec, and sends only what the codec
can encode (the profile's allow-list).  Every failure names the port, the
station (in hex) and the message: an ``&`` reply raises
:class:`~harlsync.errors.ControllerError` with its 3-hex code.

Reading the table walks the robot's position range with 22DH queries sized so
that no reply can be cut by the controller's send buffer (it could not be told
from undefined positions).  Flags (20DH) and integer and real variables (20EH,
20FH) are read the same way, each query sized to the send buffer, flag queries
starting at a multiple of 8 (p.22).  Writes (291H, 24BH, 24CH, 24DH) are
confirmed, never blindly repeated (:func:`~harlsync.link.confirm.confirmed_write`):
after a lost reply what was written is read back, and a second send first
checks that the robot is still idle.

The interlock (:meth:`Controller.status`) is 212H then 215H, back to back (215H
last, so MANUAL mode and an emergency stop are the freshest read): AUTO mode, no
program running, no flash write, system ready, no emergency stop, no critical
error, drive source on, program (not positioner) mode, safety gate closed, and
every axis of the robot reported and not in use.  With no axes in robot.yaml the
robot's axes are every axis any 212H has reported (this session, and the pulls
before it: controller.yaml ``axes``) and every axis a position read or written
uses: an axis reported once and then left out of a reply is not idle.
"""

from __future__ import annotations

import logging
import os
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from ...errors import (
    ControllerError,
    HarlsyncError,
    InterlockError,
    NotWritten,
    ReplyError,
    SyncError,
    WriteRefused,
    WriteUnconfirmed,
)
from ...link import DEFAULT_LOCK_TIMEOUT, Link
from ...link.confirm import confirmed_write, refuse_unless_idle
from ...link.owner import OnLink
from ...settings import SerialSettings
from ..base import Progress
from . import profile
from .codec import CODEC
from .layout import Coverage, IaiData
from .model import (
    READ_AGAIN_ADVICE,
    VARIABLE_SECTIONS,
    AxisStatus,
    Position,
    SystemStatus,
    Version,
    axes_advice,
    axes_refusal,
    real_text,
    real_value,
)
from .protocol import (
    ErrorReply,
    Frame,
    Request,
    max_coordinate_systems_per_read,
    max_flags_per_read,
    max_positions_per_read,
    max_string_columns_per_read,
    max_variables_per_read,
    read_coordinate_systems,
    read_flags,
    read_integers,
    read_positions,
    read_reals,
    read_strings,
    system_status,
    version,
    write_flag,
    write_integers,
    write_positions,
    write_reals,
)
from .protocol import axis_status as axis_status_request

__all__ = ["Controller", "IaiStatus", "TableBeyondRange"]

log = logging.getLogger(__name__)

T = TypeVar("T")

#: 212H for every axis the controller has (it reports only those connected).
ALL_AXES = 0xFF


def _numbers(one: str, several: str, start: int, count: int) -> str:
    """``position 7``, ``positions 7-9``: what a write of ``count`` items from ``start`` is."""
    return f"{one} {start}" if count == 1 else f"{several} {start}-{start + count - 1}"


def _chunks(first: int, last: int, step: int) -> list[tuple[int, int]]:
    """``first`` .. ``last`` as (start, count) pieces of at most ``step`` numbers."""
    return [(start, min(step, last + 1 - start)) for start in range(first, last + 1, step)]


#: What an ``&`` code means is in the controller's error list, which our manual
#: pages lack (digest section 6): said beside every code shown.
ERROR_CODE_NOTE = "the controller's error list gives the code's meaning"


class TableBeyondRange(SyncError):
    """A table goes on past the range robot.yaml says to read: a backup of it would be short."""


class _AxisUnseen(InterlockError, NotWritten):
    """A write refused before it was sent: it moves an axis 212H did not report."""


@dataclass(frozen=True)
class IaiStatus:
    """The interlock's answer: 212H and 215H, and the first reason not to write."""

    system: SystemStatus
    axes: tuple[AxisStatus, ...]
    refusal: str | None
    #: what a person does about :attr:`refusal`, in IAI's words (None when idle)
    advice: str | None = None

    @property
    def idle(self) -> bool:
        return self.refusal is None

    def describe(self) -> str:
        return "idle" if self.refusal is None else self.refusal


class Controller(OnLink):
    """One IAI controller on a link.

    ``axes`` are the robot's axes (robot.yaml); ``None`` checks every axis the
    controller reports.  ``first``/``last`` bound the position table; ``model``
    sizes the queries (its send and receive buffers).  ``variables`` are the
    flags and variables :meth:`read_all` reads when asked, by section
    (``flags``, ``integers``, ``reals``) -> (first, last); the profile's by default.
    ``known_axes`` are the axes earlier 212H replies reported (controller.yaml's
    ``axes``): with no ``axes``, every later reply must report them too.
    """

    def __init__(
        self,
        link: Link[Frame],
        *,
        model: str = profile.DEFAULT_MODEL,
        axes: tuple[int, ...] | None = None,
        first: int = profile.DEFAULT_POSITION_RANGE[0],
        last: int = profile.DEFAULT_POSITION_RANGE[1],
        variables: Mapping[str, tuple[int, int]] = profile.DEFAULT_VARIABLE_RANGES,
        real_word_order: str = profile.DEFAULT_REAL_WORD_ORDER,
        records: Mapping[str, tuple[int, int]] | None = None,
        known_axes: Iterable[int] = (),
    ) -> None:
        self.link = link
        self.station = link.station
        self.model = model
        self.axes = axes
        self.first, self.last = first, last
        self.variables = dict(variables)
        self.real_word_order = real_word_order
        #: the read-only records read_all reads: section -> (first, last); none by default
        self.records = dict(records or {})
        #: axes of the positions read or written in this session (robot_axes)
        self._seen_axes: set[int] = set()
        #: every axis a 212H reported, in this session or (known_axes) a pull before it
        self._reported_axes: set[int] = set(known_axes)
        #: the status read last (the interlock's before the next write)
        self._last_status: IaiStatus | None = None

    @classmethod
    def from_url(
        cls,
        url: str,
        station: int = profile.DEFAULT_STATION,
        settings: SerialSettings | None = None,
        *,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | os.PathLike[str] | None = None,
        **options: object,
    ) -> Controller:
        """Open a link to ``url``; the controller closes it on :meth:`close`.

        Raises :class:`~harlsync.errors.PortBusyError` or :class:`~harlsync.errors.PortError`.
        """
        link = Link(
            url, station, settings, codec=CODEC, lock_timeout=lock_timeout, lock_dir=lock_dir
        ).open()
        controller = cls(link, **options)  # type: ignore[arg-type]
        controller._owns_link = True
        return controller

    @property
    def label(self) -> str:
        return f"port {self.port} station {self.station:02X}"

    # --- the one place requests go through ---------------------------------------

    def request(self, request: Request[T], what: str | None = None) -> T:
        """Send one request and return its typed value.

        An ``&`` reply raises ControllerError naming the message (and ``what`` it
        was for), and its code; to a write it raises WriteRefused: the
        controller did not carry it out.  The command's data is for -vv only.
        """
        value = self.link.exchange(request)
        if isinstance(value, ErrorReply):
            name = f"{request.message_id:03X}H"
            log.debug("%s: %s answered & %s", self.label, request.payload, value.code)
            about = f" ({what})" if what else ""
            said = f"with error code {value.code}H (an & reply: it did not carry the command out; "
            error = WriteRefused if request.is_write else ControllerError
            raise error(
                value.code,
                port=self.port,
                station=self.station,
                command=name,
                station_text=f"{self.station:02X}",
                message=(
                    f"not written{about}: the controller refused it {said}{ERROR_CODE_NOTE})"
                    if request.is_write
                    else f"the controller refused it{about} {said}{ERROR_CODE_NOTE})"
                ),
            )
        return value

    # --- reads ----------------------------------------------------------------------

    def version(self) -> Version:
        return self.request(version())

    def note_axes(self, positions: Iterable[Position | None]) -> None:
        """Count the axes ``positions`` use among the robot's (what the interlock's
        212H must report) when robot.yaml names none: the positions read, and
        those a plan will write, before its first write."""
        for position in positions:
            if position is not None:
                self._seen_axes.update(position.axes)

    def status(self) -> IaiStatus:
        """212H, then 215H: whether a write may go now, and if not, which bit says no.

        215H comes last, so what only it shows (MANUAL mode, an emergency stop)
        is the freshest read before the write.  The two must be answered back to
        back: a 215H sent again (its reply lost or garbled) leaves the 212H before
        it stale by a whole deadline or more, so both are read again.  When they
        cannot be read back to back, that is not idle.  212H fails closed: a
        reply that does not report every one of the robot's axes (or reports
        none) is not idle.
        """
        pattern = ALL_AXES if self.axes is None else sum(1 << (a - 1) for a in self.axes)
        rounds = 1 + max(0, self.link.settings.retries)
        for _ in range(rounds):
            axes = self.request(axis_status_request(pattern))
            retries = self.link.stats.retries
            system = self.request(system_status())
            if self.link.stats.retries == retries:
                break
            log.info(
                "%s: 215H was sent again, so the 212H before it is stale: reading both again",
                self.label,
            )
        else:
            status = IaiStatus(
                system,
                axes,
                f"212H and 215H could not be read back to back "
                f"({rounds} times 215H had to be sent again)",
                READ_AGAIN_ADVICE,
            )
            self._last_status = status
            return status
        refusal, advice = system.refusal, system.advice
        if refusal is None:
            # Every axis of the robot must be reported; with no axes in robot.yaml,
            # every axis any 212H reported (now, earlier, or at a pull before) is
            # checked too: one left out of this reply cannot be seen to be idle.
            wanted = self.axes
            if wanted is None:
                reported = self._reported_axes | {a.axis for a in axes}
                wanted = tuple(sorted(self._seen_axes | reported))
            refusal, advice = axes_refusal(wanted, axes), axes_advice(wanted, axes)
        self._reported_axes.update(a.axis for a in axes)
        status = IaiStatus(system, axes, refusal, advice)
        self._last_status = status
        return status

    def read_positions(self, head: int, count: int) -> dict[int, Position]:
        """The defined positions among ``head`` .. ``head + count - 1``, in queries
        that fit the send buffer."""
        out: dict[int, Position] = {}
        for start, n in _chunks(head, head + count - 1, max_positions_per_read(self.model)):
            for position in self.request(read_positions(start, n)):
                out[position.number] = position
        self.note_axes(out.values())
        return out

    def read_run(self, start: int, size: int) -> tuple[Position | None, ...]:
        """Positions ``start`` .. ``start + size - 1``, ``None`` where undefined."""
        found = self.read_positions(start, size)
        return tuple(found.get(n) for n in range(start, start + size))

    def _read_numbered(
        self,
        first: int,
        last: int,
        step: int,
        query: Callable[[int, int], Request[tuple[T, ...]]],
        align: int = 1,
    ) -> dict[int, T]:
        """Values ``first`` .. ``last`` by number, in queries of at most ``step``
        starting at a multiple of ``align`` (the numbers before ``first`` dropped)."""
        out: dict[int, T] = {}
        for start, n in _chunks(first - first % align, last, step):
            values = self.request(query(start, n))
            out.update((start + i, v) for i, v in enumerate(values) if start + i >= first)
        return out

    def read_flags(self, first: int, last: int) -> dict[int, bool]:
        """Global flags ``first`` .. ``last`` (20DH)."""
        return self._read_numbered(
            first, last, max_flags_per_read(self.model), read_flags, profile.FLAG_QUERY_ALIGNMENT
        )

    def read_integers(self, first: int, last: int) -> dict[int, int]:
        """Global integer variables ``first`` .. ``last`` (20EH)."""
        step = max_variables_per_read(self.model, "integers")
        return self._read_numbered(first, last, step, read_integers)

    def read_reals(self, first: int, last: int) -> dict[int, str]:
        """Global real variables ``first`` .. ``last`` (20FH), as their exact text."""
        step = max_variables_per_read(self.model, "reals")
        order = self.real_word_order
        values = self._read_numbered(
            first, last, step, lambda start, n: read_reals(start, n, order=order)
        )
        return {n: real_text(v) for n, v in values.items()}

    def read_variables(self, section: str, first: int, last: int) -> dict[int, object]:
        """Global ``flags``, ``integers`` or ``reals`` ``first`` .. ``last``."""
        readers: dict[str, Callable[[int, int], Mapping[int, object]]] = {
            "flags": self.read_flags,
            "integers": self.read_integers,
            "reals": self.read_reals,
        }
        return dict(readers[section](first, last))

    def read_all(
        self,
        progress: Progress | None = None,
        *,
        variables: bool = False,
        whole: bool = False,
        version: Version | None = None,
    ) -> IaiData:
        """The version and every defined position of the robot's range, and with
        ``variables`` the flags and variables of their ranges; each table probed
        past its range (:meth:`probe_positions`, :meth:`probe_variables`), and the
        range it covered recorded in :attr:`IaiData.covered`.  With ``whole`` (a
        pull) and no axes in robot.yaml, one 212H too: :attr:`IaiData.axes` keeps
        every axis any 212H reported, for a later push's interlock.

        ``progress(done, total)`` after each position query and each section.
        ``version`` is the 201H reply just read (:meth:`IaiDriver.identity`): not
        asked for again.  Raises :class:`TableBeyondRange` when a table goes on past
        its range.
        """
        chunks = _chunks(self.first, self.last, max_positions_per_read(self.model))
        axis_read = whole and self.axes is None
        total = 2 + len(chunks) + (3 if variables else 0) + axis_read
        done = 0

        def tick() -> None:
            nonlocal done
            done += 1
            if progress is not None:
                progress(done, total)

        data = IaiData(version=self.version() if version is None else version, model=self.model)
        tick()
        if axis_read:
            self._reported_axes.update(
                a.axis for a in self.request(axis_status_request(ALL_AXES), "the robot's axes")
            )
            tick()
        for start, n in chunks:
            data.positions.update((p.number, p) for p in self.request(read_positions(start, n)))
            tick()
        self.note_axes(data.positions.values())
        data.covered["positions"] = self.probe_positions()
        tick()
        if variables:
            data.flags = self.read_flags(*self.variables["flags"])
            data.covered["flags"] = self.probe_variables("flags")
            tick()
            data.integers = self.read_integers(*self.variables["integers"])
            data.covered["integers"] = self.probe_variables("integers")
            tick()
            data.reals = self.read_reals(*self.variables["reals"])
            data.covered["reals"] = self.probe_variables("reals")
            tick()
        for section, (first, last) in self.records.items():
            if section == "strings":
                data.strings = self.read_string_rows(first, last)
            else:
                setattr(data, section, self.read_coordinate_systems(section, first, last))
            data.covered[section] = Coverage(first, last, last)
        if self.axes is None:
            data.axes = tuple(sorted(self._reported_axes))
        return data

    def read_coordinate_systems(
        self, section: str, first: int, last: int
    ) -> dict[int, tuple[str, ...]]:
        """Work or tool (``section``) coordinate system definitions ``first`` ..
        ``last`` (2A0H), each X, Y, Z, R as coordinate text."""
        kind = profile.COORDINATE_SYSTEM_TYPES[section]
        step = max_coordinate_systems_per_read(self.model)
        return self._read_numbered(
            first, last, step, lambda head, n: read_coordinate_systems(kind, head, n)
        )

    def read_string_rows(self, first: int, last: int) -> dict[int, str]:
        """Global string variable columns ``first`` .. ``last`` (210H), as rows of
        :data:`profile.STRING_ROW` columns by first column, each character's code
        as two hex digits."""
        step = max_string_columns_per_read(self.model)
        codes = self._read_numbered(first, last, step, read_strings)
        row = profile.STRING_ROW
        return {
            start: "".join(f"{codes[n]:02X}" for n in range(start, min(last, start + row - 1) + 1))
            for start in range(first, last + 1, row)
        }

    def probe_positions(self) -> Coverage:
        """Make sure no position is defined outside ``first`` .. ``last``: one 22DH
        below the range and one above it, each asking for every number there (the
        reply holds the first defined records that fit: one is enough).  A
        controller that answers ``&`` to so wide a query is probed in queries
        sized as the table's reads, up to the profile's fallback end.

        Returns the range covered; raises :class:`TableBeyondRange` naming what
        lies outside and the robot.yaml setting that takes it in.
        """
        send = profile.BUFFERS[self.model].send
        end = profile.POSITION_NUMBER_END
        found: list[int] = []
        if self.first > 1:
            found += [p.number for p in self.request(read_positions(1, self.first - 1, send))]
        if found:
            raise TableBeyondRange(
                f"{self.label}: position {found[0]} is defined before the range this "
                f"backup reads ({self.first}-{self.last}), and is not backed up; set "
                f"controller.first_position: {found[0]} (or lower) in robot.yaml and run again"
            )
        if self.last < end:
            try:
                found = [
                    p.number
                    for p in self.request(read_positions(self.last + 1, end - self.last, send))
                ]
            except ControllerError:
                end = max(self.last, profile.POSITION_PROBE_FALLBACK_END)
                log.info(
                    "%s: the controller refused a 22DH for every number past %d: probing "
                    "up to %d in queries of the table's size",
                    self.label,
                    self.last,
                    end,
                )
                found = []
                step = max_positions_per_read(self.model)
                for start, n in _chunks(self.last + 1, end, step):
                    found = [p.number for p in self.request(read_positions(start, n))]
                    if found:
                        break
        if found:
            more = f", {found[1]}" if len(found) > 1 else ""
            highest = f" and more, up to at least {found[-1]}" if len(found) > 2 else ""
            raise TableBeyondRange(
                f"{self.label}: position {found[0]}{more}{highest} is defined past the "
                f"range this backup reads ({self.first}-{self.last}), and is not backed up; "
                f"set controller.last_position: {found[-1]} (or higher) in robot.yaml and "
                "run again"
            )
        return Coverage(self.first, self.last, end)

    def probe_variables(self, section: str) -> Coverage:
        """Make sure no flag (or integer, or real variable) past the kept range is
        set, up to the last number the message can name
        (:data:`profile.VARIABLE_NUMBER_END`), in queries of the largest size, the
        flags from a multiple of 8.  A query answered ``&`` is narrowed (halved)
        rather than taken for the table's end; a number refused alone (a flag
        byte, for flags) is one the controller does not have: the probe goes on
        one number at a time past it until one reads, then in whole queries again.

        Returns the range covered, ``checked_to`` the last number actually read;
        raises :class:`TableBeyondRange` naming the first set past the range.
        """
        first, last = self.variables[section]
        end = profile.VARIABLE_NUMBER_END[section]
        if last >= end:
            return Coverage(first, last, last)
        step = {
            "flags": max_flags_per_read(self.model),
            "integers": max_variables_per_read(self.model, "integers"),
            "reals": max_variables_per_read(self.model, "reals"),
        }[section]
        align = profile.FLAG_QUERY_ALIGNMENT if section == "flags" else 1
        kept = {"flags": False, "integers": 0, "reals": "0.0"}[section]
        checked = last
        refused: list[int] = []  # the first number of each query refused alone
        head = (last + 1) - (last + 1) % align
        pending = deque(_chunks(head, end, step))
        while pending:
            start, n = pending.popleft()
            try:
                values = self.read_variables(section, max(start, last + 1), start + n - 1)
            except ControllerError:
                if n <= align:
                    refused.append(start)
                    # Past a number it does not have, one at a time until one reads.
                    pending = deque(_chunks(start + n, end, align))
                    continue
                half = max(align, n // 2 // align * align)
                pending.extendleft([(start + half, n - half), (start, half)])
                continue
            beyond = [n for n, v in sorted(values.items()) if v != kept]
            if beyond:
                called = VARIABLE_SECTIONS[section]
                raise TableBeyondRange(
                    f"{self.label}: {called} {beyond[0]} is set past the range this backup "
                    f"keeps ({first}-{last}), and is not backed up; set controller.{section}: "
                    f"{{first: {first}, last: {beyond[-1]}}} (or higher) in robot.yaml and run "
                    "again"
                )
            checked = start + n - 1
            if n == align and refused and refused[-1] + align == start:
                # The first to read after refused ones: whole queries again from here.
                pending = deque(_chunks(start + n, end, step))
        if refused:
            log.info(
                "%s: the controller refused %d %s queries past %d (from %s): numbers "
                "it does not have; the probe read up to %d",
                self.label,
                len(refused),
                section,
                last,
                ", ".join(str(n) for n in refused[:5]) + (" ..." if len(refused) > 5 else ""),
                checked,
            )
        return Coverage(first, last, checked)

    # --- writes ---------------------------------------------------------------------

    def write_run(
        self, start: int, positions: Sequence[Position], old: Sequence[Position | None]
    ) -> None:
        """Write consecutive positions with one 291H and confirm it.

        Raises InterlockError instead of sending it again after a lost reply when
        the robot is not idle, WriteUnconfirmed when the read-back is neither, and
        before sending it (nothing written) when it moves an axis the status read
        just before did not report.
        """
        self.note_axes(positions)
        what = _numbers("position", "positions", start, len(positions))
        self._refuse_unseen_axes(positions, what)
        self._confirmed(
            write_positions(start, positions),
            len(positions),
            lambda: self.read_run(start, len(positions)),
            tuple(positions),
            tuple(old),
            what,
        )

    def _refuse_unseen_axes(self, positions: Sequence[Position], what: str) -> None:
        """Refuse (nothing sent) positions with an axis the last 212H did not report
        idle: with no axes in robot.yaml, a new position's axis is known only now."""
        last = self._last_status
        if last is None or not last.idle:
            return  # the engine's interlock went first: nothing to add
        reported = {s.axis for s in last.axes}
        for position in positions:
            unseen = sorted(set(position.axes) - reported)
            if unseen:
                raise _AxisUnseen(
                    f"{self.label}: axis {unseen[0]} not reported by 212H before writing "
                    f"{what}: an axis it does not report cannot be seen to be idle; not writing"
                )

    def write_flag(self, number: int, on: bool, old: bool) -> None:
        """Set or clear one global flag with 24BH and confirm it, as :meth:`write_run`."""
        self._confirmed(
            write_flag(number, on),
            None,
            lambda: self.read_flags(number, number)[number],
            on,
            old,
            f"flag {number}",
        )

    def write_integers(self, start: int, values: Sequence[int], old: Sequence[int]) -> None:
        """Write consecutive global integer variables with one 24CH and confirm it,
        as :meth:`write_run`."""
        last = start + len(values) - 1
        self._confirmed(
            write_integers(start, values),
            len(values),
            lambda: tuple(self.read_integers(start, last).values()),
            tuple(values),
            tuple(old),
            _numbers("integer variable", "integer variables", start, len(values)),
        )

    def write_reals(self, start: int, values: Sequence[str], old: Sequence[str]) -> None:
        """Write consecutive global real variables (exact text) with one 24DH and
        confirm it, as :meth:`write_run`.  Raises ValueError for NaN or an infinity."""
        last = start + len(values) - 1
        self._confirmed(
            write_reals(start, [real_value(v) for v in values], order=self.real_word_order),
            len(values),
            lambda: tuple(self.read_reals(start, last).values()),
            tuple(values),
            tuple(old),
            _numbers("real variable", "real variables", start, len(values)),
        )

    def _confirmed(
        self,
        request: Request[int | None],
        count: int | None,
        readback: Callable[[], T],
        wanted: T,
        old: T,
        what: str,
    ) -> None:
        """Send one write, ``count`` items when its reply says how many, and confirm it.

        An ``&`` reply raises WriteRefused (not written) only when the items read
        back exactly as they were; otherwise ControllerError (may or may not have been).
        """
        if request.frame_size > profile.BUFFERS[self.model].receive:
            raise ReplyError(
                f"{request.payload[:12]}...: {request.frame_size} bytes do not fit "
                f"the {self.model}'s receive buffer"
            )

        def sent() -> None:
            try:
                written = self.request(request, what)
            except WriteRefused as refused:
                self._refused_unless_unchanged(refused, readback, old, what)
                raise
            if count is not None and written != count:
                raise ControllerError(
                    str(written),
                    port=self.port,
                    station=self.station,
                    command=f"{request.message_id:03X}H",
                    station_text=f"{self.station:02X}",
                    message=f"{request.message_id:03X}H wrote {written} of {count} ({what})",
                )

        confirmed_write(
            sent,
            readback,
            wanted,
            old,
            before_resend=lambda lost: self._idle_before_resend(request, lost),
            what=what,
        )

    def _refused_unless_unchanged(
        self, refused: WriteRefused, readback: Callable[[], T], old: T, what: str
    ) -> None:
        """Return when ``what`` reads back exactly as before the refused write (it was
        not written); otherwise raise ControllerError: it may or may not have been.

        That the controller applies a write it answers ``&`` to whole or not at all
        is only the profile's assumption for 291H, and not even that for 24CH/24DH:
        the read-back is the evidence.
        """
        try:
            now = readback()
        except HarlsyncError as exc:
            why = f"and it could not be read back ({exc})"
        else:
            if now == old:
                return
            why = "and it no longer reads back as it was before"
        raise ControllerError(
            refused.status,
            port=self.port,
            station=self.station,
            command=refused.command,
            station_text=f"{self.station:02X}",
            message=(
                f"{what} may or may not have been written: the controller refused it "
                f"with error code {refused.status}H ({ERROR_CODE_NOTE}), {why}; pull to "
                "see what the controller holds"
            ),
        ) from refused

    def _idle_before_resend(self, request: Any, lost: WriteUnconfirmed) -> None:
        """Raise InterlockError unless the status, read now, shows the robot idle."""
        refuse_unless_idle(
            self.status,
            lost,
            where=f"{self.label}, message {request.message_id:03X}H",
            reading="the status",
        )
