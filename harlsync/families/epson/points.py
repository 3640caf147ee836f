"""An Epson controller's points: where its point table ends and what a point that
is not defined answers, learned from the controller itself (issue 29), since the
manual has no command that says how many points there are, nor a code for "no
point here".

The point past the table's end (robot.yaml ``controller.point_table_end``) must
answer the same error response twice; a point not defined answers an error
response that repeats, the same for every point.  An answer that does not repeat,
or that is neither, stops the read: harlsync never takes a point as not there on
a guess.
"""

from __future__ import annotations

import logging

from ...errors import ProjectError
from . import protocol as p
from .channel import CommandChannel
from .model import NotThere, PointTable
from .protocol import ErrorReply

__all__ = ["END", "End", "PointProbe", "refuse_left_out"]

log = logging.getLogger(__name__)

#: Response 1 codes that never say "no point here": the command was not understood,
#: the words are wrong, or the controller could not run it for a reason of its own
#: (§7.1).  Any other error response to a point's read may be one (asked twice).
_NEVER_ABSENT = frozenset({0x1000, 0x1002, 0x2001, 0x2002, 0x2003, 0x200B, 0x3000, 0x9999})


class End:
    """A point number past the controller's point table (:meth:`PointProbe.first_coord`)."""


END = End()


class PointProbe:
    """What the point table of the controller behind ``channel`` showed this session;
    ``table_end``: its last point as robot.yaml says."""

    def __init__(self, channel: CommandChannel, table_end: int) -> None:
        self.channel = channel
        self.table_end = table_end
        #: what the point table showed this session (:meth:`table`)
        self._table: PointTable | None = None
        #: what the table's last point answered at its probe, and where the
        #: "not defined" answer was first met (for messages)
        self._last_answer: str | NotThere | None = None
        self._not_defined_at: int | None = None

    def _answer(self, number: int, axis: int = 0) -> str | NotThere:
        """1222 of one coordinate: the coordinate, or the error response as a
        :class:`NotThere` when it may say "no point here".  Raises ControllerError
        for one that never does (:data:`_NEVER_ABSENT`)."""
        request = p.read_point_coord(number, axis)
        reply = self.channel.execute(request)
        if isinstance(reply, ErrorReply):
            if reply.code in _NEVER_ABSENT:
                raise self.channel.error(request, reply)
            return NotThere(reply.code, reply.detail)
        return reply

    def _unsteady(self, number: int, first: str | NotThere, again: str | NotThere) -> ProjectError:
        def said(answer: str | NotThere) -> str:
            return answer.describe() if isinstance(answer, NotThere) else f"a coordinate ({answer})"

        return ProjectError(
            f"{self.channel.label}: P{number} answered {said(first)}, then {said(again)} when asked "
            "again: harlsync takes a point as not there only from an answer that repeats; "
            "look at the controller (RC+) and run again"
        )

    def table(self) -> PointTable:
        """Where the controller's point table ends, from its own behaviour, asked once
        a session: the point past :attr:`table_end` must answer the same error
        response twice (that answer is recorded in controller.yaml and is part of
        the robot's identity), and the last point's answer is kept.  A few
        exchanges: P(end+1) twice, P(end) once (twice when it answers otherwise
        than P(end+1): what a point not defined answers, learned at once).

        Raises ProjectError when the point past the table is defined (the table is
        larger than robot.yaml says), or answers two different things."""
        if self._table is not None:
            return self._table
        end = self.table_end
        past = self._answer(end + 1)
        if not isinstance(past, NotThere):
            raise ProjectError(
                f"{self.channel.label}: P{end + 1} is defined: the controller's points go past "
                f"P{end}, where harlsync takes its point table to end; set "
                "controller.point_table_end in robot.yaml to the controller's last point "
                "number and pull again"
            )
        again = self._answer(end + 1)
        if again != past:
            raise self._unsteady(end + 1, past, again)
        table = PointTable(end, past)
        last = self._answer(end)
        if isinstance(last, NotThere) and last != past:
            again = self._answer(end)
            if again != last:
                raise self._unsteady(end, last, again)
            table.not_defined, self._not_defined_at = last, end
        self._last_answer = last
        self._table = table
        return table

    def first_coord(self, number: int, axis: int = 0) -> str | None | End:
        """A point's coordinate ``axis`` (a point's first read: X), None when the
        point is not defined, :data:`END` when ``number`` lies past the point table.

        An error response is taken as "not defined" when it is the one points not
        defined answered before, or, the first time one is met, when it answers
        the same when asked again.  The answer of the point past the table, asked
        twice, is the table's end only when the table's last point answered it too
        and points not defined answer otherwise (a table smaller than
        robot.yaml's).  Raises ProjectError for an answer that does not repeat, or
        that is neither."""
        table = self.table()
        answer = self._answer(number, axis)
        if not isinstance(answer, NotThere):
            return answer
        if answer == table.not_defined:
            return None
        again = self._answer(number, axis)
        if again != answer:
            raise self._unsteady(number, answer, again)
        if (
            axis == 0
            and answer == table.past_end
            and table.not_defined is not None
            and self._last_answer == table.past_end
        ):
            return END
        if table.not_defined is None:
            table.not_defined, self._not_defined_at = answer, number
            log.info(
                "%s: P%d not defined: it answers %s", self.channel.label, number, answer.describe()
            )
            return None
        where = f"P{self._not_defined_at}" if self._not_defined_at is not None else "a point"
        raise ProjectError(
            f"{self.channel.label}: P{number} answers {answer.describe()} twice, where {where}, not "
            f"defined, answered {table.not_defined.describe()}: one of them is not the "
            "controller's answer for a point not defined (an error of the controller?); "
            "look at the controller (RC+) and run again"
        )


def refuse_left_out(label: str, outside: list[int], first: int, last: int) -> None:
    """Raise ProjectError when points are defined ``outside`` the range ``first`` to
    ``last`` that a backup would leave out, naming them and the robot.yaml setting
    that takes them in."""
    before = [n for n in outside if n < first]
    beyond = [n for n in outside if n > last]
    if before:
        raise ProjectError(
            f"{label}: {len(before)} point(s) defined before "
            f"controller.first_point {first}, which this backup would leave out: "
            f"{_numbers(before)}; set controller.first_point: {before[0]} (or less) in "
            "robot.yaml and pull again"
        )
    if beyond:
        raise ProjectError(
            f"{label}: {len(beyond)} point(s) defined past controller.last_point "
            f"{last}, which this backup would leave out: {_numbers(beyond)}; set "
            f"controller.last_point: {beyond[-1]} (or more) in robot.yaml and pull again"
        )


def _numbers(points: list[int], most: int = 6) -> str:
    """``P100-P104, P120 and 3 more``: point numbers in runs, long lists folded."""
    runs: list[list[int]] = []
    for n in points:
        if runs and runs[-1][-1] == n - 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    texts = [f"P{r[0]}" if len(r) == 1 else f"P{r[0]}-P{r[-1]}" for r in runs]
    more = f" and {len(texts) - most} more" if len(texts) > most else ""
    return ", ".join(texts[:most]) + more
