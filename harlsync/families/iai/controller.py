"""What an IAI controller can do for harlsync, as methods: version, status, read and
write positions, the global flags and integer and real variables, and string
variables; read coordinate systems.

A :class:`Controller` talks to one station through the shared
:class:`~harlsync.link.Link` with the IAI codec, and sends only what the codec
can encode (the profile's allow-list).  Every failure names the port, the
station (in hex) and the message: an ``&`` reply raises
:class:`~harlsync.errors.ControllerError` with its 3-hex code.

Reading the table walks the robot's position range with 22DH queries sized so
that no reply can be cut by the controller's send buffer (it could not be told
from undefined positions).  Flags (20DH) and integer and real variables (20EH,
20FH) are read the same way, each query sized to the send buffer, flag queries
starting at a multiple of 8 (p.22).  How far each table goes, and what lies
outside the range read, the controller's own replies say
(:mod:`~harlsync.families.iai.tables`).  Writes (291H, 24BH, 24CH, 24DH, 24EH) are
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
from .layout import IaiData
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
    real_word_order_of,
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
    position_record,
    read_coordinate_systems,
    read_flags,
    read_integers,
    read_positions,
    read_real_words,
    read_reals,
    read_strings,
    real_from_wire,
    real_to_wire,
    system_status,
    version,
    write_flag,
    write_integers,
    write_positions,
    write_reals,
    write_strings,
)
from .protocol import axis_status as axis_status_request
from .protocol.frame import _READ_OVERHEAD
from .tables import (
    EMPTY,
    Coverage,
    NotThere,
    Reader,
    TableBeyondRange,
    TableUnclear,
    Values,
    error_reply,
)

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
        real_word_order: str | None = None,
        records: Mapping[str, tuple[int, int]] | None = None,
        known_axes: Iterable[int] = (),
        recorded_word_order: str | None = None,
    ) -> None:
        self.link = link
        self.station = link.station
        self.model = model
        self.axes = axes
        self.first, self.last = first, last
        self.variables = dict(variables)
        #: robot.yaml's controller.real_word_order; None: read from the values
        self.real_word_order = real_word_order
        #: the order the last pull saw the values in (controller.yaml), if any
        self.recorded_word_order = recorded_word_order
        #: the order this session's values showed, if any
        self._seen_word_order: str | None = None
        #: whether the controller scans a 22DH for every number past the range whole
        #: (None: not asked yet this read)
        self._wide_scan: bool | None = None
        #: the position numbers the controller has, as far as a read showed it by
        #: refusing the numbers around them
        self._position_table = (1, profile.POSITION_NUMBER_END)
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
        that fit the send buffer.  Numbers outside the table as this session's read
        found it (:meth:`read_position_table`: the controller refused those around
        it) hold none, and are not asked for."""
        out: dict[int, Position] = {}
        low, high = self._position_table
        head, end = max(head, low), min(head + count - 1, high)
        for start, n in _chunks(head, end, max_positions_per_read(self.model)):
            for position in self.request(read_positions(start, n)):
                if position.number < start + n:  # one past them: a controller counting records
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
        section: str = "",
    ) -> dict[int, T]:
        """Values ``first`` .. ``last`` by number, in queries of at most ``step``
        starting at a multiple of ``align`` (the numbers before ``first`` dropped).
        Raises TableUnclear when a reply carries fewer than asked for: the
        controller's table ends among them."""
        out: dict[int, T] = {}
        for start, n in _chunks(first - first % align, last, step):
            request = query(start, n)
            values = self.request(request)
            if len(values) < n:
                raise TableUnclear(
                    f"{self.label}: {request.message_id:03X}H answered {len(values)} of the "
                    f"{n} {section} from {start}: the controller's table ends at "
                    f"{start + len(values) - 1}; pull to read it to its end, or check "
                    f"robot.yaml controller.{section}"
                )
            out.update((start + i, v) for i, v in enumerate(values) if start + i >= first)
        return out

    def read_flags(self, first: int, last: int) -> dict[int, bool]:
        """Global flags ``first`` .. ``last`` (20DH)."""
        step = max_flags_per_read(self.model)
        align = profile.FLAG_QUERY_ALIGNMENT
        return self._read_numbered(first, last, step, read_flags, align, "flags")

    def read_integers(self, first: int, last: int) -> dict[int, int]:
        """Global integer variables ``first`` .. ``last`` (20EH)."""
        step = max_variables_per_read(self.model, "integers")
        return self._read_numbered(first, last, step, read_integers, section="integers")

    def read_reals(self, first: int, last: int) -> dict[int, str]:
        """Global real variables ``first`` .. ``last`` (20FH), as their exact text,
        read in :meth:`word_order`."""
        step = max_variables_per_read(self.model, "reals")
        order = self.word_order()
        values = self._read_numbered(
            first, last, step, lambda start, n: read_reals(start, n, order=order), section="reals"
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

    # --- the real variables' word order -----------------------------------------------

    def word_order(self) -> str:
        """The order real variables are read and written in: robot.yaml's
        ``controller.real_word_order``, else what the values read showed (this
        session, else the last pull's, controller.yaml), else the profile's."""
        return (
            self.real_word_order
            or self._seen_word_order
            or self.recorded_word_order
            or profile.DEFAULT_REAL_WORD_ORDER
        )

    def writing_order(self, start: int, values: Sequence[float]) -> str:
        """:meth:`word_order`, for writing ``values``; raises SyncError (nothing
        sent) when nothing tells the order and a value differs between the two."""
        if self.real_word_order or self._seen_word_order or self.recorded_word_order:
            return self.word_order()
        for i, value in enumerate(values):
            words = real_to_wire(value)
            if words[:8] != words[8:]:
                raise SyncError(
                    f"{self.label}: real variable {start + i} is not written: the controller's "
                    "real variables read 0 (or alike in both word orders), so harlsync cannot "
                    "tell in which order it keeps their words (p.24); set "
                    "controller.real_word_order in robot.yaml (upper-first, or lower-first on "
                    "an X-SEL-J/K V0.41 or earlier or with Other parameter No. 46 bits 0-3 at 0)"
                )
        return self.word_order()

    def _reals_from_words(self, words: Mapping[int, str]) -> dict[int, str]:
        """The reals read as ``words`` (20FH's digits) as text, in the order they
        show (:func:`real_word_order_of`), robot.yaml's when it gives one.  Raises
        SyncError when every value contradicts robot.yaml's order (plausible only in
        the other)."""
        given = self.real_word_order
        other = real_word_order_of(words.values(), every=True)
        if given is not None and other is not None and other != given:
            odd = [n for n, w in sorted(words.items()) if w[:8] != w[8:]][:2]
            shown = ", ".join(
                f"{n} as {real_text(real_from_wire(words[n], given))} "
                f"({real_text(real_from_wire(words[n], other))} {other})"
                for n in odd
            )
            raise SyncError(
                f"{self.label}: real variables read in robot.yaml's controller.real_word_order "
                f"{given} come out as no program keeps them ({shown}): the controller keeps "
                f"them {other}; set controller.real_word_order: {other} in robot.yaml, or leave "
                "it out and harlsync reads the order from the values"
            )
        self._seen_word_order = real_word_order_of(words.values()) or self._seen_word_order
        order = self.word_order()
        return {n: real_text(real_from_wire(w, order)) for n, w in words.items()}

    # --- a whole read, and how far each table goes ------------------------------------

    def read_all(
        self,
        progress: Progress | None = None,
        *,
        variables: bool = False,
        whole: bool = False,
        version: Version | None = None,
    ) -> IaiData:
        """The version and every defined position of the robot's range, and with
        ``variables`` the flags and variables of their ranges; each table read to
        its end when the controller's ends inside the range, and probed outside it
        (:mod:`~harlsync.families.iai.tables`), what each covered recorded in
        :attr:`IaiData.covered`.  With ``whole`` (a pull) and no axes in robot.yaml,
        one 212H too: :attr:`IaiData.axes` keeps every axis any 212H reported, for
        a later push's interlock.

        ``progress(done, total)`` after each position query and each section.
        ``version`` is the 201H reply just read (:meth:`IaiDriver.identity`): not
        asked for again.  Raises :class:`TableBeyondRange` when a table goes on past
        its range, :class:`TableUnclear` when the controller's replies do not say
        where one ends.
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
        self._wide_scan = None
        data.positions, data.covered["positions"] = self.read_position_table(tick)
        done = 1 + axis_read + len(chunks)
        tick()
        if variables:
            for section in VARIABLE_SECTIONS:
                values, data.covered[section] = self.read_section(section)
                if section == "reals":
                    data.reals = self._reals_from_words({n: str(v) for n, v in values.items()})
                    data.real_word_order = self._seen_word_order
                else:
                    setattr(data, section, values)
                tick()
        for section, (first, last) in self.records.items():
            reader: Reader[Any] = Reader(_Records(self, section), self.label, self._model_advice())
            values, data.covered[section] = reader.read_range(first, last)
            if section == "strings":
                covered = data.covered[section]
                data.strings = self._string_rows(first, covered.read_last, values)
            else:
                setattr(data, section, values)
        if self.axes is None:
            data.axes = tuple(sorted(self._reported_axes))
        return data

    def _model_advice(self) -> str:
        buffers = profile.BUFFERS[self.model]
        return (
            f"check robot.yaml controller.model ({self.model}: commands up to "
            f"{buffers.receive} and replies up to {buffers.send} bytes)"
        )

    def read_position_table(
        self, tick: Callable[[], None] | None = None
    ) -> tuple[dict[int, Position], Coverage]:
        """The defined positions of ``first`` .. ``last`` (read to the table's end
        when it ends inside), and what was made sure of outside: below the range
        down to 1, and past it up to 65535 (:meth:`_positions_past`)."""
        reader: Reader[Position] = Reader(_Positions(self), self.label, self._model_advice())
        positions, covered = reader.read_range(self.first, self.last, tick)
        self.note_axes(positions.values())
        if covered.end is None and self.last < profile.POSITION_NUMBER_END:
            covered = self._positions_past(reader, positions, covered)
        if covered.start is None and self.first > 1:
            covered = self._positions_before(reader, positions, covered)
        refused = [
            number if reply is not None and reply != EMPTY else default
            for number, reply, default in (
                (covered.start, covered.before, 1),
                (covered.end, covered.past, profile.POSITION_NUMBER_END),
            )
        ]
        self._position_table = (refused[0] or 1, refused[1] or profile.POSITION_NUMBER_END)
        return positions, covered

    def _positions_past(
        self, reader: Reader[Position], known: Mapping[int, Position], covered: Coverage
    ) -> Coverage:
        """Past ``last``: the number after it alone; "not there" twice, and the
        table ends at ``last``.  Otherwise one 22DH for every number past it, when
        the controller is seen to scan so wide a query whole (:meth:`_scans_wide`),
        else queries of the read size up to the table's end (or the profile's
        fallback end)."""
        after = self.last + 1
        answer = reader.one(after)
        if isinstance(answer, NotThere):
            past = reader.twice(after)
            return covered._replace(checked_to=self.last, end=self.last, past=past)
        if answer.values:  # defined past the range: one query more, to name how far
            more = reader.ask(after, profile.POSITION_NUMBER_END - after + 1)
            if not (isinstance(more, Values) and more.values):  # refused so wide a query
                more = reader.ask(after, reader.table.step)
            found = more.values if isinstance(more, Values) and more.values else answer.values
            self._defined_past(sorted(found))
        if self._scans_wide(reader, known):
            return covered._replace(checked_to=profile.POSITION_NUMBER_END, past=EMPTY)
        checked, end, reply = reader.walk_up(after + 1, after, self._defined_past)
        return covered._replace(checked_to=checked, end=end, past=reply or EMPTY)

    def _positions_before(
        self, reader: Reader[Position], known: Mapping[int, Position], covered: Coverage
    ) -> Coverage:
        """Below ``first``: the number before it alone; "not there" twice, and the
        table starts at ``first``.  Otherwise the numbers down to 1: in one query
        when they fit one or the controller scans wide queries whole, else in
        queries of the read size."""
        before = self.first - 1
        answer = reader.one(before)
        if isinstance(answer, NotThere):
            reply = reader.twice(before)
            return covered._replace(checked_from=self.first, start=self.first, before=reply)
        self._defined_before(sorted(answer.values))
        if before == 1:
            return covered._replace(checked_from=1, before=EMPTY)
        if before - 1 > reader.table.step and self._scans_wide(reader, known):
            wide = reader.ask(1, before - 1)
            if isinstance(wide, Values):
                self._defined_before(sorted(wide.values))
                return covered._replace(checked_from=1, before=EMPTY)
        checked, start, below = reader.walk_down(before - 1, self._defined_before)
        return covered._replace(checked_from=checked, start=start, before=below or EMPTY)

    def _scans_wide(self, reader: Reader[Position], known: Mapping[int, Position]) -> bool:
        """Whether the controller answers a 22DH for every number past ``last``
        (one query) with every position defined there: asked from inside the
        range, so that the reply must also carry the positions the read found
        there, the last of them more than a read's numbers in when the table
        allows.  A reply that leaves one of them out is a controller that scans
        fewer numbers than asked (or a table that changed meanwhile): not trusted.
        What the reply carries past ``last`` fails the read.  Asked once a read."""
        if self._wide_scan is not None:
            return self._wide_scan
        send = profile.BUFFERS[self.model].send
        room = send - _READ_OVERHEAD - profile.READ_RECORD_MAX  # room for one more
        numbers = sorted(known)
        step = reader.table.step
        # The fewest of the last positions read whose first lies more than a read's
        # numbers before the last (so that a short scan shows), if they fit a reply.
        tail: list[int] = []
        head = self.last + 1
        size = 0
        for i in range(len(numbers) - 1, -1, -1):
            size += len(position_record(known[numbers[i]], numbered=True))
            if size > room:
                break
            tail.insert(0, numbers[i])
            head = numbers[i - 1] + 1 if i else self.first
            if numbers[-1] - head >= step:
                break
        if tail and numbers[-1] - head < step:  # cannot show a short scan: not worth a page
            tail, head = [], self.last + 1
        answer = reader.ask(head, profile.POSITION_NUMBER_END - head + 1)
        if isinstance(answer, NotThere):
            log.info(
                "%s: the controller refused a 22DH for every number from %d (%s): the "
                "positions past %d are read in queries of %d",
                self.label,
                head,
                answer.reply,
                self.last,
                reader.table.step,
            )
            self._wide_scan = False
            return False
        got = sorted(answer.values)
        if [n for n in got if n <= self.last] != tail:
            log.info(
                "%s: a 22DH for every number from %d left out positions the read found "
                "(it scans fewer numbers than asked): the positions past %d are read in "
                "queries of %d",
                self.label,
                head,
                self.last,
                reader.table.step,
            )
            self._wide_scan = False
            return False
        self._defined_past([n for n in got if n > self.last])
        if not tail:
            log.info(
                "%s: no position of the table lies far enough from another to check that "
                "the controller scans a wide 22DH whole: taken as it answers",
                self.label,
            )
        self._wide_scan = True
        return True

    def _defined_past(self, found: list[int]) -> None:
        """Raise TableBeyondRange naming positions defined past ``last``."""
        found = [n for n in found if n > self.last]
        if not found:
            return
        more = f", {found[1]}" if len(found) > 1 else ""
        highest = f" and more, up to at least {found[-1]}" if len(found) > 2 else ""
        raise TableBeyondRange(
            f"{self.label}: position {found[0]}{more}{highest} is defined past the "
            f"range this backup reads ({self.first}-{self.last}), and is not backed up; "
            f"set controller.last_position: {found[-1]} (or higher) in robot.yaml and "
            "run again"
        )

    def _defined_before(self, found: list[int]) -> None:
        """Raise TableBeyondRange naming positions defined before ``first``."""
        found = [n for n in found if n < self.first]
        if not found:
            return
        raise TableBeyondRange(
            f"{self.label}: position {found[0]} is defined before the range this "
            f"backup reads ({self.first}-{self.last}), and is not backed up; set "
            f"controller.first_position: {found[0]} (or lower) in robot.yaml and run again"
        )

    def read_section(self, section: str) -> tuple[dict[int, object], Coverage]:
        """Global ``flags``, ``integers`` or ``reals`` (as 20FH's digits) of their
        range, read to the table's end when it ends inside, and probed below the
        range down to the lowest number and past it up to the last the message
        names, or to where the controller's table starts and ends.  Raises
        TableBeyondRange naming what is set outside the range."""
        first, last = self.variables[section]
        table = _Variables(self, section)
        reader: Reader[object] = Reader(table, self.label, self._model_advice())
        values, covered = reader.read_range(first, last)
        called = VARIABLE_SECTIONS[section]
        kept = f"({first}-{last})"

        def past(found: list[int]) -> None:
            raise TableBeyondRange(
                f"{self.label}: {_listed(called, found)} set past the range this backup "
                f"keeps {kept}, and not backed up; set controller.{section}: "
                f"{{first: {first}, last: {found[-1]}}} (or higher) in robot.yaml and run "
                "again"
            )

        def before(found: list[int]) -> None:
            raise TableBeyondRange(
                f"{self.label}: {_listed(called, found)} set before the range this backup "
                f"keeps {kept}, and not backed up; set controller.{section}: "
                f"{{first: {found[0]}, last: {last}}} (or lower) in robot.yaml and run again"
            )

        if covered.end is None:
            checked, end, reply = reader.walk_up(last + 1, last, past)
            covered = covered._replace(checked_to=checked, end=end, past=reply)
        if covered.start is None and first > table.lowest:
            checked, start, reply = reader.walk_down(first - 1, before)
            covered = covered._replace(checked_from=checked, start=start, before=reply)
        return values, covered

    def read_coordinate_systems(
        self, section: str, first: int, last: int
    ) -> dict[int, tuple[str, ...]]:
        """Work or tool (``section``) coordinate system definitions ``first`` ..
        ``last`` (2A0H), each X, Y, Z, R as coordinate text."""
        kind = profile.COORDINATE_SYSTEM_TYPES[section]
        step = max_coordinate_systems_per_read(self.model)
        return self._read_numbered(
            first,
            last,
            step,
            lambda head, n: read_coordinate_systems(kind, head, n),
            section=section,
        )

    def read_string_rows(self, first: int, last: int) -> dict[int, str]:
        """Global string variable columns ``first`` .. ``last`` (210H), as rows of
        :data:`profile.STRING_ROW` columns by first column, each character's code
        as two hex digits."""
        step = max_string_columns_per_read(self.model)
        codes = self._read_numbered(first, last, step, read_strings, section="strings")
        return self._string_rows(first, last, codes)

    @staticmethod
    def _string_rows(first: int, last: int, codes: Mapping[int, object]) -> dict[int, str]:
        row = profile.STRING_ROW
        return {
            start: "".join(
                f"{int(str(codes[n])):02X}" for n in range(start, min(last, start + row - 1) + 1)
            )
            for start in range(first, last + 1, row)
        }

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

    def write_strings(self, start: int, row: str, old: str | None) -> None:
        """Write the string variable columns of one row from ``start`` (two hex
        digits a column, as records.yaml keeps it) with one 24EH and confirm it,
        as :meth:`write_run`."""
        codes = [int(row[i : i + 2], 16) for i in range(0, len(row), 2)]
        last = start + len(codes) - 1
        self._confirmed(
            write_strings(start, codes),
            None,
            lambda: self.read_string_rows(start, last)[start],
            row,
            old,
            _numbers("string variable column", "string variable columns", start, len(codes)),
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
        doubles = [real_value(v) for v in values]
        self._confirmed(
            write_reals(start, doubles, order=self.writing_order(start, doubles)),
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


def _listed(called: str, found: list[int]) -> str:
    """``flag 905 is``, ``integer variables 206, 213 and 218 are``: what a probe
    found set, for a message."""
    if len(found) == 1:
        return f"{called} {found[0]} is"
    shown = [str(n) for n in found[:3]]
    more = f" and more, up to {found[-1]}," if len(found) > 3 else ""
    listed = ", ".join(shown[:-1]) + f" and {shown[-1]}" if not more else ", ".join(shown) + more
    return f"{called}s {listed} are"


class _Positions:
    """The position table as 22DH reads it (a :class:`~.tables.Table`): a number
    the controller lacks answers ``&``, or (to a 22DH that asks for it and defined
    ones) nothing, as an undefined position does."""

    section = "positions"
    called = "position"
    message = "22DH"
    align = 1
    exact = False
    lowest = profile.NUMBER_FIRST["positions"]
    setting = "controller.first_position/last_position"

    def __init__(self, controller: Controller) -> None:
        self._controller = controller
        self.step = max_positions_per_read(controller.model)
        #: where a walk past the range stops (tables.py)
        self.highest = max(profile.POSITION_PROBE_FALLBACK_END, controller.last + 1)

    def ask(self, head: int, count: int) -> Values[Position] | NotThere:
        c = self._controller
        send = profile.BUFFERS[c.model].send
        try:
            records = c.request(read_positions(head, count, send))
        except ControllerError as refused:
            return NotThere(error_reply(refused.status))
        end = head + count - 1
        return Values({p.number: p for p in records if p.number <= end}, end)

    def is_set(self, value: Position) -> bool:
        return True  # a record in a 22DH reply is a defined position


class _Variables:
    """Global flags (20DH), integer (20EH) or real variables (20FH, as their 16 hex
    digits) as a :class:`~.tables.Table`: a number the controller lacks answers
    ``&``, or a reply that stops before it."""

    def __init__(self, controller: Controller, section: str) -> None:
        self._controller = controller
        self.section = section
        self.called = VARIABLE_SECTIONS[section]
        self.message = {"flags": "20DH", "integers": "20EH", "reals": "20FH"}[section]
        self.setting = f"controller.{section}"
        self.lowest = profile.NUMBER_FIRST[section]
        self.highest = profile.VARIABLE_NUMBER_END[section]
        model = controller.model
        self.step = (
            max_flags_per_read(model)
            if section == "flags"
            else max_variables_per_read(model, section)
        )
        self.align = profile.FLAG_QUERY_ALIGNMENT if section == "flags" else 1
        self.exact = True

    def ask(self, head: int, count: int) -> Values[object] | NotThere:
        query: Callable[[int, int], Request[tuple[object, ...]]] = {
            "flags": read_flags,
            "integers": read_integers,
            "reals": read_real_words,
        }[self.section]
        try:
            values = self._controller.request(query(head, count))
        except ControllerError as refused:
            return NotThere(error_reply(refused.status))
        if not values:
            return NotThere(EMPTY)
        return Values({head + i: v for i, v in enumerate(values)}, head + len(values) - 1)

    def is_set(self, value: object) -> bool:
        if isinstance(value, str):  # a real's digits: +0 and -0 as they read
            return int(value, 16) != 0
        return bool(value)


class _Records:
    """The read-only records (2A0H coordinate systems, 210H string variable
    columns) as a :class:`~.tables.Table`, for reading their range to the end of
    the controller's table (no probe outside it)."""

    def __init__(self, controller: Controller, section: str) -> None:
        self._controller = controller
        self.section = section
        self.setting = f"controller.{section}"
        self.lowest = profile.NUMBER_FIRST[section]
        self.highest = profile.RECORD_NUMBER_END[section]
        self.align = 1
        self.exact = True
        if section == "strings":
            self.called, self.message = "string variable column", "210H"
            self.step = max_string_columns_per_read(controller.model)
        else:
            self.called = f"{section.split('_')[0]} coordinate system"
            self.message = "2A0H"
            self.step = max_coordinate_systems_per_read(controller.model)

    def ask(self, head: int, count: int) -> Values[object] | NotThere:
        if self.section == "strings":
            request: Request[tuple[object, ...]] = read_strings(head, count)
        else:
            kind = profile.COORDINATE_SYSTEM_TYPES[self.section]
            request = read_coordinate_systems(kind, head, min(count, 0xFF - head + 1))
        try:
            values = self._controller.request(request)
        except ControllerError as refused:
            return NotThere(error_reply(refused.status))
        if not values:
            return NotThere(EMPTY)
        return Values({head + i: v for i, v in enumerate(values)}, head + len(values) - 1)

    def is_set(self, value: object) -> bool:
        return False  # never probed outside their range
