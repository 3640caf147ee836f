"""One IAI controller on a link, as the rest of the controller builds on it: the one
place requests go through, the interlock's status (212H then 215H), and the
reads by number (positions, flags, integer and real variables, coordinate
systems, string variable columns), each query sized to the send buffer.

An ``&`` reply raises :class:`~harlsync.errors.ControllerError` naming the
port, the station (in hex), the message and its 3-hex code; to a write,
:class:`~harlsync.errors.WriteRefused`.  The whole read of a backup builds on
this (:mod:`.backup_read`), and the writes on that (:mod:`.controller`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from typing import TypeVar

from ...errors import ControllerError, WriteRefused
from ...link import Link
from ...link.owner import OnLink
from . import profile
from .interlock import (
    READ_AGAIN_ADVICE,
    IaiStatus,
    axes_advice,
    axes_refusal,
)
from .model import Position, Version, real_text
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
)
from .protocol import axis_status as axis_status_request
from .tables import TableUnclear

__all__ = ["ALL_AXES", "ERROR_CODE_NOTE", "Station", "chunks"]

log = logging.getLogger(__name__)

T = TypeVar("T")

#: 212H for every axis the controller has (it reports only those connected).
ALL_AXES = 0xFF


def chunks(first: int, last: int, step: int) -> list[tuple[int, int]]:
    """``first`` .. ``last`` as (start, count) pieces of at most ``step`` numbers."""
    return [(start, min(step, last + 1 - start)) for start in range(first, last + 1, step)]


#: What an ``&`` code means is in the controller's error list, which our manual
#: pages lack (digest section 6): said beside every code shown.
ERROR_CODE_NOTE = "the controller's error list gives the code's meaning"


class Station(OnLink[Frame]):
    """One IAI controller on a link: its requests, its status and its reads.

    The arguments are :class:`~harlsync.families.iai.controller.Controller`'s.
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
        for start, n in chunks(head, end, max_positions_per_read(self.model)):
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
        for start, n in chunks(first - first % align, last, step):
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

    # --- read-only records ----------------------------------------------------------------

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

    def _model_advice(self) -> str:
        buffers = profile.BUFFERS[self.model]
        return (
            f"check robot.yaml controller.model ({self.model}: commands up to "
            f"{buffers.receive} and replies up to {buffers.send} bytes)"
        )
