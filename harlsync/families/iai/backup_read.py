"""A whole read of an IAI controller for a backup, and how far each table goes.

Reading the table walks the robot's position range with 22DH queries sized so
that no reply can be cut by the controller's send buffer (it could not be told
from undefined positions).  Flags (20DH) and integer and real variables (20EH,
20FH) are read the same way, each query sized to the send buffer, flag queries
starting at a multiple of 8 (p.22).  How far each table goes, and what lies
outside the range read, the controller's own replies say
(:mod:`~harlsync.families.iai.tables`, on the queries of
:mod:`~harlsync.families.iai.table_queries`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping

from ...errors import SyncError
from ..base import Progress
from . import profile
from .layout import IaiData
from .model import (
    VARIABLE_SECTIONS,
    Position,
    Version,
    real_text,
    real_word_order_of,
)
from .protocol import axis_status as axis_status_request
from .protocol import (
    max_positions_per_read,
    position_record,
    real_from_wire,
)
from .protocol.frame import _READ_OVERHEAD
from .station import ALL_AXES, Station, chunks
from .table_queries import PositionTable, RecordTable, VariableTable
from .tables import EMPTY, Coverage, NotThere, Reader, TableBeyondRange, Values

__all__ = ["BackupRead"]

log = logging.getLogger(__name__)


class BackupRead(Station):
    """A :class:`~.station.Station` that reads everything a backup keeps
    (:meth:`read_all`), each table to its end and probed outside its range."""

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
        queries = chunks(self.first, self.last, max_positions_per_read(self.model))
        axis_read = whole and self.axes is None
        total = 2 + len(queries) + (3 if variables else 0) + axis_read
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
        done = 1 + axis_read + len(queries)
        tick()
        if variables:
            self._read_variables_into(data, tick)
        self._read_records_into(data)
        if self.axes is None:
            data.axes = tuple(sorted(self._reported_axes))
        return data

    def _read_variables_into(self, data: IaiData, tick: Callable[[], None]) -> None:
        """The flags and integer and real variables of their ranges, into ``data``."""
        for section in VARIABLE_SECTIONS:
            values, data.covered[section] = self.read_section(section)
            if section == "reals":
                data.reals = self._reals_from_words({n: str(v) for n, v in values.items()})
                data.real_word_order = self._seen_word_order
            else:
                setattr(data, section, values)
            tick()

    def _read_records_into(self, data: IaiData) -> None:
        """The read-only records of robot.yaml's ranges, into ``data``."""
        for section, (first, last) in self.records.items():
            table = RecordTable(self, section)
            reader: Reader[object] = Reader(table, self.label, self._model_advice())
            values, data.covered[section] = reader.read_range(first, last)
            if section == "strings":
                covered = data.covered[section]
                data.strings = self._string_rows(first, covered.read_last, values)
            else:
                setattr(data, section, values)

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

    def read_position_table(
        self, tick: Callable[[], None] | None = None
    ) -> tuple[dict[int, Position], Coverage]:
        """The defined positions of ``first`` .. ``last`` (read to the table's end
        when it ends inside), and what was made sure of outside: below the range
        down to 1, and past it up to 65535 (:meth:`_positions_past`)."""
        reader: Reader[Position] = Reader(PositionTable(self), self.label, self._model_advice())
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
        tail, head = self._wide_query_tail(reader.table.step, known)
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

    def _wide_query_tail(self, step: int, known: Mapping[int, Position]) -> tuple[list[int], int]:
        """What a wide 22DH must carry back from inside the range: the fewest of the
        last positions read whose first lies more than a read's numbers (``step``)
        before the last, so that a short scan shows, if they fit one reply (none
        when they cannot show it); and the number it asks from, the one after the
        position before them (``first`` when none is), else the one after ``last``."""
        send = profile.BUFFERS[self.model].send
        room = send - _READ_OVERHEAD - profile.READ_RECORD_MAX  # room for one more
        numbers = sorted(known)
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
        return tail, head

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
        table = VariableTable(self, section)
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


def _listed(called: str, found: list[int]) -> str:
    """``flag 905 is``, ``integer variables 206, 213 and 218 are``: what a probe
    found set, for a message."""
    if len(found) == 1:
        return f"{called} {found[0]} is"
    shown = [str(n) for n in found[:3]]
    more = f" and more, up to {found[-1]}," if len(found) > 3 else ""
    listed = ", ".join(shown[:-1]) + f" and {shown[-1]}" if not more else ", ".join(shown) + more
    return f"{called}s {listed} are"
