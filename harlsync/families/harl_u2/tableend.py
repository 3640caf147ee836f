"""Where a HARL-U2's offset tables end, found with LNL reads only.

LNX does not report how many tables there are, and which status a missing one
answers is not in the manual, so the end is the controller's own::

    LNL n        -> E + status        table n answers an error reply
    LNL n - 1    -> the table         the table before it reads normally once more
    LNL n        -> the same E+status table n answers the same reply again: the end

That is table ``limit`` (the probe past the range) or an earlier one (a
controller with fewer tables: read to its end, not failed).  Three exchanges
beyond the tables' own reads; a table that answers an error once and then reads
is taken as read.  :meth:`Controller.read_offsets
<harlsync.families.harl_u2.controller.Controller.read_offsets>` reads through a
:class:`TableReader`.
"""

from __future__ import annotations

from collections.abc import Callable

from ...errors import ControllerError, SyncError
from .model import OffsetEnd, OffsetTable
from .protocol import commands as cmd
from .protocol import profile

__all__ = ["TableBeyondRange", "TableReader"]


class TableBeyondRange(SyncError):
    """The controller has more of a table than the pull reads: a backup would be short."""


class TableReader:
    """The offset tables of one station, read to their end: ``read_offset(n)`` is
    LNL ``n`` (raising :class:`ControllerError` for an error reply); ``port`` and
    ``station`` name the robot in the errors."""

    def __init__(self, read_offset: Callable[[int], OffsetTable], port: str, station: int) -> None:
        self._read_offset = read_offset
        self.port = port
        self.station = station

    def read(
        self,
        limit: int,
        *,
        pinned: str | None = None,
        tick: Callable[[], None] | None = None,
    ) -> tuple[dict[int, OffsetTable], OffsetEnd]:
        """The tables from 0 to their end, at most ``limit``, and that end; ``pinned``
        is the reply the end must have (robot.yaml's ``no_such_table``; None: any),
        ``tick`` is called after each table read.  Raises as
        :meth:`Controller.read_offsets` says."""
        offsets: dict[int, OffsetTable] = {}
        n = 0
        while True:
            answer = self._table_or_reply(n)
            if isinstance(answer, str):
                answer = self._asked_again(n, answer)
            if isinstance(answer, str):
                return offsets, self._end(n, answer, limit, pinned)
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

    def _end(self, table: int, reply: str, limit: int, pinned: str | None) -> OffsetEnd:
        """The end at ``table``, which answered ``reply`` twice.  Raises
        :class:`ControllerError` when that is not the reply ``pinned`` says."""
        if pinned is not None and reply != pinned:
            raise self._unreadable_end(
                table,
                reply,
                f"offset table {table} answered {reply} twice, not {pinned} "
                "(robot.yaml's no_such_table): the controller now answers a missing "
                "table otherwise, or cannot answer normally (an abnormal condition)",
                advice=(
                    f"; if {reply} is what this controller answers for a table it "
                    f"does not have, set no_such_table: {reply} in robot.yaml"
                ),
            )
        return OffsetEnd(table, reply, asked=limit, pinned=pinned is not None)

    def _table_or_reply(self, table: int) -> OffsetTable | str:
        """LNL ``table``: the table, or the error reply (``E`` + status) it answered."""
        try:
            return self._read_offset(table)
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
