"""How far an IAI table goes, as the controller itself answers it (issue 29).

A table's size (positions, flags, integer and real variables, string variables,
coordinate systems) is on none of our manual pages, and neither is what a
controller answers for a number its table lacks.  A controller may refuse the
query with an ``&`` error reply (any code), or answer it normally with nothing
for those numbers: no records (22DH), fewer values than asked (a count short of
the one asked, or none).  Either is its *"not there" reply*; harlsync guesses
neither, it finds out::

        below the range                 the range                  past the range
    lowest ... start-1 | start ... first ........ last ... end | end+1 ... highest
                  ^ "not there", asked twice        "not there", asked twice ^

- :meth:`Reader.read_range` reads ``first`` .. ``last`` in queries of the
  table's read size.  A query the controller answers "not there" (or short) is
  not an error: the table starts or ends inside the range.  Single-number
  queries (:meth:`Reader.one`) find the edge by halving (a dozen queries at
  most), the numbers inside it are read, and the number past the edge must
  answer the same "not there" reply twice.  A table smaller than the range is
  so read to its real end, and the :class:`Coverage` says where it ends.
- :meth:`Reader.probe_above` and :meth:`Reader.probe_below` make sure nothing is
  set outside the range: they read on, in queries of the read size, until the
  controller answers "not there" (checked twice: the table ends there) or the
  last number the message can name.  Their cost is that of reading the part of
  the table outside the range, and a handful of queries at its edge; a number the
  controller does not have is never walked past one by one.  What they find set
  raises :class:`TableBeyondRange`, naming the robot.yaml setting.
- The "not there" replies are recorded (:attr:`Coverage.before`,
  :attr:`Coverage.past`): controller.yaml keeps them, and a later read whose
  replies differ is another controller, or one that now answers otherwise
  (:func:`replies_differ`).

A :class:`Table` is one table as its messages read it; the controller module
makes one per section.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Generic, NamedTuple, Protocol, TypeVar

from ...errors import SyncError

__all__ = [
    "EMPTY",
    "Coverage",
    "NotThere",
    "Reader",
    "Table",
    "TableBeyondRange",
    "TableUnclear",
    "Values",
    "error_reply",
    "replies_differ",
    "reply_words",
]

log = logging.getLogger(__name__)

V = TypeVar("V")
V_co = TypeVar("V_co", covariant=True)

#: The "not there" reply that is a normal reply with nothing in it.
EMPTY = "empty"


def error_reply(code: str) -> str:
    """An ``&`` reply as a "not there" reply is recorded: ``error 0A3H``."""
    return f"error {code.upper()}H"


def reply_words(reply: str | None) -> str:
    """A recorded "not there" reply in a person's words."""
    if reply is None:
        return 'no "not there" reply (the table went on to the last number its message names)'
    if reply == EMPTY:
        return "an empty reply"
    return f"error code {reply.removeprefix('error ')}"


class Coverage(NamedTuple):
    """What a read of one table covered (controller.yaml ``covered``).

    ``first`` .. ``last`` is the range robot.yaml says to read.  The pull made
    sure nothing is set from ``checked_from`` to ``first - 1`` and from ``last + 1``
    to ``checked_to``.  ``start`` and ``end`` are where the controller's own table
    starts and ends, when its replies showed it (the number before ``start`` and
    after ``end`` answered the "not there" reply ``before`` / ``past`` twice): a
    table smaller than the range is read to its real end.  ``past`` is also the
    reply to the number after ``last`` when that answered "not there" or (for
    positions) an empty reply.
    """

    first: int
    last: int
    checked_to: int
    checked_from: int | None = None
    start: int | None = None
    end: int | None = None
    before: str | None = None
    past: str | None = None

    @property
    def read_first(self) -> int:
        """The first number of the range the controller has."""
        return self.first if self.start is None else max(self.first, self.start)

    @property
    def read_last(self) -> int:
        """The last number of the range the controller has."""
        return self.last if self.end is None else min(self.last, self.end)


class TableBeyondRange(SyncError):
    """A table goes on past the range robot.yaml says to read: a backup of it would be short."""


class TableUnclear(SyncError):
    """The controller's replies do not say where a table ends (they disagree)."""


@dataclass(frozen=True)
class Values(Generic[V_co]):
    """A normal reply: the values it carried by number (for positions, only the
    defined ones), and ``upto``, the last number it answered for (less than asked
    when the controller's table ends among them)."""

    values: Mapping[int, V_co]
    upto: int


@dataclass(frozen=True)
class NotThere:
    """A "not there" reply: :data:`EMPTY` or :func:`error_reply`'s text."""

    reply: str


class Table(Protocol[V]):
    """One table, as its messages read it."""

    @property
    def section(self) -> str:
        """controller.yaml's and robot.yaml's name for it: ``positions``, ``flags`` ..."""
        ...

    @property
    def called(self) -> str:
        """A person's name for one item: ``position``, ``flag``, ``integer variable``."""
        ...

    @property
    def message(self) -> str:
        """The message that reads it: ``22DH``."""
        ...

    @property
    def lowest(self) -> int:
        """The lowest number the message names (a probe below stops there)."""
        ...

    @property
    def highest(self) -> int:
        """The highest number a probe above goes to."""
        ...

    @property
    def step(self) -> int:
        """The most numbers one read asks for (what the send buffer carries)."""
        ...

    @property
    def align(self) -> int:
        """Every query starts at a multiple of this (flags: 8, p.22)."""
        ...

    @property
    def exact(self) -> bool:
        """Whether a normal reply shows that every number it asked for is there
        (variables: the controller refuses, or answers a short count, when one is
        not); False for positions: a 22DH whose head is in the table answers for
        the numbers after its end as for undefined positions."""
        ...

    def ask(self, head: int, count: int) -> Values[V] | NotThere:
        """One query for ``count`` numbers from ``head``.  An ``&`` reply is a
        :class:`NotThere`; other failures raise."""
        ...

    def is_set(self, value: V) -> bool:
        """Whether a value read outside the range is something a backup would lose."""
        ...

    @property
    def setting(self) -> str:
        """The robot.yaml setting of its range: ``controller.flags``."""
        ...


class Reader(Generic[V]):
    """Reads one :class:`Table` for one read: its range, and probes around it.

    ``label`` names the port and station in every message; ``model_advice`` is
    what to check when a query is refused though each number in it reads alone.
    """

    def __init__(self, table: Table[V], label: str, model_advice: str) -> None:
        self.table = table
        self.label = label
        self.model_advice = model_advice
        #: every "not there" reply seen, by the number asked alone
        self._absent: dict[int, list[str]] = {}

    # --- queries -----------------------------------------------------------------

    def ask(self, head: int, count: int) -> Values[V] | NotThere:
        return self.table.ask(head, count)

    def one(self, number: int) -> Values[V] | NotThere:
        """``number`` alone (from the multiple of :attr:`Table.align` below it): a
        :class:`NotThere` when the controller does not have it."""
        align = self.table.align
        head = number - number % align
        answer = self.ask(head, number - head + 1)
        if isinstance(answer, Values) and answer.upto < number:
            answer = NotThere(EMPTY)
        if isinstance(answer, NotThere):
            self._absent.setdefault(number, []).append(answer.reply)
        return answer

    def twice(self, number: int, seen: str | None = None) -> str:
        """The "not there" reply of ``number``, answered the same twice (``seen``:
        a reply to a query that began at it counts as once).  Raises
        :class:`TableUnclear` when it reads, or answers two ways."""
        replies = self._absent.setdefault(number, [])
        if seen is not None:
            replies.insert(0, seen)
        while len(replies) < 2:
            if isinstance(self.one(number), Values):
                raise self._unclear(number, f"{reply_words(replies[0])}, then read normally")
        if replies[0] != replies[1]:
            said = f"{reply_words(replies[0])}, then {reply_words(replies[1])}"
            raise self._unclear(number, said)
        return replies[0]

    def _unclear(self, number: int, said: str) -> TableUnclear:
        t = self.table
        return TableUnclear(
            f"{self.label}: {t.message} for {t.called} {number} answered {said}: where the "
            f"controller's {t.section} table ends is unclear; run again, and if it persists check "
            f"the line and {t.setting} in robot.yaml"
        )

    def _exact(self, first: int, last: int) -> dict[int, V]:
        """``first`` .. ``last``, known to be there, in one query (or raise)."""
        head = first - first % self.table.align
        answer = self.ask(head, last - head + 1)
        if isinstance(answer, NotThere) or answer.upto < last:
            raise self._unclear(last, "that it is there, then that it is not")
        return {n: v for n, v in answer.values.items() if first <= n <= last}

    def _edge_up(self, there: int, head: int, count: int, refused: NotThere) -> int:
        """The last number there, between ``there`` (known there) and the end of a
        query (``head``, ``count``) answered ``refused``."""
        gone = head + count - 1
        if isinstance(self.one(gone), Values):
            t = self.table
            raise TableUnclear(
                f"{self.label}: {t.message} for {t.section} {head}-{gone} answered "
                f"{reply_words(refused.reply)}, though the first and last of them read alone; "
                f"{self.model_advice}"
            )
        return self._edge(there, gone)

    def _edge(self, there: int, gone: int) -> int:
        """Halving between ``there`` (known there) and ``gone`` (known not there),
        on either side of it: the number there next to the edge."""
        while abs(gone - there) > 1:
            mid = (there + gone) // 2
            if isinstance(self.one(mid), NotThere):
                gone = mid
            else:
                there = mid
        return there

    def _end_before(self, there: int, gone: int) -> int:
        """The table's last number when ``gone`` (a query's head) is not there and
        ``there`` (an earlier query's head, or the number before it) is: the one
        before ``gone`` when a normal reply shows every number it asked for is there
        (:attr:`Table.exact`), else found by halving."""
        return gone - 1 if self.table.exact else self._edge(there, gone)

    def _chunks(self, head: int, last: int) -> list[tuple[int, int]]:
        step = self.table.step
        start = head - head % self.table.align
        return [(a, min(step, last + 1 - a)) for a in range(start, last + 1, step)]

    # --- the range ---------------------------------------------------------------

    def read_range(
        self, first: int, last: int, tick: Callable[[], None] | None = None
    ) -> tuple[dict[int, V], Coverage]:
        """The values of ``first`` .. ``last`` the controller has, and what was
        covered: ``start``/``end`` set when its table starts or ends inside the
        range (``checked_*`` then the range's ends; the probes set them further).

        Raises :class:`TableUnclear` when its replies disagree, and when it has
        none of the range (naming the setting)."""
        values: dict[int, V] = {}
        start: int | None = None
        before: str | None = None
        head = first
        known_there: int | None = None  # a number of the range known to be there
        for a, n in self._chunks(head, last):
            answer = self.ask(a, n)
            if tick is not None:
                tick()
            low = max(a, head)
            if isinstance(answer, Values) and answer.upto >= low:
                values.update((k, v) for k, v in answer.values.items() if low <= k <= last)
                known_there = answer.upto if self.table.exact else low
                if answer.upto < a + n - 1 and answer.upto < last:
                    end = answer.upto  # a short reply: the table ends among them
                    self._absent.setdefault(end + 1, []).append(EMPTY)
                    past = self.twice(end + 1)
                    return values, Coverage(first, last, end, first, start, end, before, past)
                continue
            refused = answer if isinstance(answer, NotThere) else NotThere(EMPTY)
            if known_there is None:
                probe = self.one(low)
                if isinstance(probe, NotThere):
                    # The table starts above the range's first number (or misses it).
                    if isinstance(self.one(last), NotThere):
                        t = self.table
                        raise TableUnclear(
                            f"{self.label}: the controller has none of {t.section} "
                            f"{first}-{last}: {t.called} {first} and {last} answer "
                            f"{reply_words(probe.reply)}; set {t.setting} in robot.yaml to "
                            "numbers the controller has"
                        )
                    start = self._edge(last, low)
                    before = self.twice(start - 1)
                    rest, covered = self.read_range(start, last, tick)
                    values.update(rest)
                    return values, covered._replace(
                        first=first, checked_from=first, start=start, before=before
                    )
                known_there = low
            elif a == low:
                if isinstance(self.one(a), NotThere):
                    end = self._end_before(known_there, a)
                    past = self.twice(end + 1, refused.reply if end + 1 == a else None)
                    return values, Coverage(first, last, end, first, start, end, before, past)
                known_there = a
            end = self._edge_up(known_there, a, n, refused)
            values.update(self._exact(low, end))
            past = self.twice(end + 1)
            return values, Coverage(first, last, end, first, start, end, before, past)
        return values, Coverage(first, last, last, first, start, None, before, None)

    # --- outside the range ---------------------------------------------------------

    def walk_up(
        self, head: int, last: int, found: Callable[[list[int]], None]
    ) -> tuple[int, int | None, str | None]:
        """Read on from ``head`` (past ``last``, the range's last number) until the
        table ends or the last number the message names; ``found`` is given the
        numbers set there (it raises).  Returns (checked to, the table's end or
        None, its "not there" reply or None)."""
        t = self.table
        if head > t.highest:
            return last, None, None
        checked = there = head - 1  # the caller has read the number before ``head``
        for a, n in self._chunks(head, t.highest):
            low = max(a, head)
            answer = self.ask(a, n)
            if isinstance(answer, Values) and answer.upto >= low:
                self._found(answer.values, low, answer.upto, found)
                if answer.upto < a + n - 1:
                    end = answer.upto
                    self._absent.setdefault(end + 1, []).append(EMPTY)
                    return end, end, self.twice(end + 1)
                checked = a + n - 1
                there = checked if t.exact else low
                continue
            refused = answer if isinstance(answer, NotThere) else NotThere(EMPTY)
            if isinstance(self.one(low), NotThere):
                end = self._end_before(there, low)
                reply = self.twice(end + 1, refused.reply if a == end + 1 else None)
                return end, end, reply
            end = self._edge_up(low, a, n, refused)
            self._found(self._exact(low, end), low, end, found)
            return end, end, self.twice(end + 1)
        return checked, None, None

    def walk_down(
        self, head: int, found: Callable[[list[int]], None]
    ) -> tuple[int, int | None, str | None]:
        """Read down from ``head`` until the table starts or the lowest number;
        ``found`` is given the numbers set there.  Returns (checked from, the
        table's start or None, its "not there" reply or None)."""
        t = self.table
        top = head
        while top >= t.lowest:
            a = max(t.lowest, top - t.step + 1)
            a -= a % t.align
            answer = self.ask(a, top - a + 1)
            if isinstance(answer, Values) and answer.upto >= top:
                self._found(answer.values, a, top, found)
                top = a - 1
                continue
            if isinstance(self.one(top), NotThere):
                return top + 1, top + 1, self.twice(top)
            if isinstance(self.one(a), Values):
                refused = answer if isinstance(answer, NotThere) else NotThere(EMPTY)
                raise TableUnclear(
                    f"{self.label}: {t.message} for {t.section} {a}-{top} answered "
                    f"{reply_words(refused.reply)}, though the first and last of them read alone; "
                    f"{self.model_advice}"
                )
            start = self._edge(top, a)
            self._found(self._exact(start, top), start, top, found)
            return start, start, self.twice(start - 1)
        return t.lowest, None, None

    def _found(
        self, values: Mapping[int, V], low: int, high: int, found: Callable[[list[int]], None]
    ) -> None:
        hits = sorted(n for n, v in values.items() if low <= n <= high and self.table.is_set(v))
        if hits:
            found(hits)


def replies_differ(section: str, was: Coverage, now: Coverage) -> str | None:
    """Why ``now`` (this read) is not the controller ``was`` recorded: a "not
    there" reply that differs for the same range; None when none does (or ``was``
    was recorded before harlsync recorded them)."""
    if was.checked_from is None or (was.first, was.last) != (now.first, now.last):
        return None  # recorded by an older harlsync, or another range: other numbers asked
    for side, where in (("past", "past its end"), ("before", "before its start")):
        old, new = getattr(was, side), getattr(now, side)
        if old != new:
            return (
                f"{section} {where}: the controller now answers {reply_words(new)}, where the "
                f"last pull got {reply_words(old)} (controller.yaml covered.{section}.{side})"
            )
    return None
