"""What ``harlsync probe`` learns of a controller with reads only: a :class:`Survey`.

A family's :meth:`Driver.survey <harlsync.families.base.Driver.survey>` reads the
robot's identity, then what only the family knows how to find (how far each
table really goes, the profile's guesses it confirms or contradicts), then the
interlock; :func:`surveyed` is that frame, counting the exchanges and timing
them, and the family gives the middle part as :class:`Findings`::

    identity()  ->  explore() -> Findings  ->  status()
    '------------- exchanges counted, turnaround timed -----------'
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:  # the link is not imported for --help (base.py imports this module)
    from ..link.received import LinkStats

__all__ = ["Extent", "Findings", "Guess", "Survey", "surveyed"]


@dataclass(frozen=True)
class Extent:
    """Where one of the controller's tables really ends, as a probe found it:
    ``Extent("offset tables", 100, "E21", ("offset_tables", "no_such_table"))``."""

    #: the table, in the family's words
    table: str
    #: how many items it holds (or the last number, as :attr:`counted` says)
    count: int
    #: what the controller answered past its end (its "not there" reply), as read
    reply: str
    #: the robot.yaml settings that cover this table's extent and reply
    settings: tuple[str, ...] = ()
    #: what :attr:`count` counts: ``tables`` (0 to count - 1), ``last position``
    counted: str = "items"


@dataclass(frozen=True)
class Guess:
    """One choice the family's profile made where its manual is silent, and what
    this controller showed of it (docs/profile.md lists every one)."""

    #: the guess, in a few words: ``the reply to a missing offset table``
    what: str
    #: what the profile guessed, as robot.yaml would write it
    guessed: str
    #: what this controller did
    found: str
    #: the robot.yaml setting that covers it
    setting: str

    @property
    def confirmed(self) -> bool:
        return self.guessed == self.found


@dataclass
class Survey:
    """What a probe learns of a controller with reads only
    (:meth:`~harlsync.families.base.Driver.survey`)."""

    #: what the robot says it is, by the names of
    #: :meth:`~harlsync.families.base.Catalogue.robot_identity`
    identity: Mapping[str, str]
    #: the interlock now: ``idle``, or what forbids a write
    status: str
    idle: bool
    extents: list[Extent] = field(default_factory=list)
    guesses: list[Guess] = field(default_factory=list)
    #: robot.yaml's family settings (:attr:`Robot.options <harlsync.project.robot.Robot>`)
    #: that make a pull read this controller as it is, each with its comment
    options: dict[str, object] = field(default_factory=dict)
    #: the reply turnaround measured: seconds from a request's first byte sent to its
    #: reply's last received, on average over the probe's exchanges (None: not measured)
    turnaround: float | None = None
    #: how many exchanges a full pull of this controller takes (None: not known)
    pull_exchanges: int | None = None


@dataclass
class Findings:
    """What a family's own probe reads found, between the identity and the status
    (:func:`surveyed` puts them in the :class:`Survey`)."""

    extents: list[Extent]
    guesses: list[Guess]
    #: as :attr:`Survey.options`
    options: dict[str, object] = field(default_factory=dict)
    #: how many exchanges a full pull takes; None: as many as the survey took
    #: (a pull reads what the probe read)
    pull_exchanges: int | None = None


class _Interlock(Protocol):
    """What a survey tells of the interlock's answer
    (:class:`~harlsync.families.base.Status`)."""

    @property
    def idle(self) -> bool: ...

    def describe(self) -> str: ...


def surveyed(
    stats: LinkStats,
    identity: Callable[[], Mapping[str, str]],
    explore: Callable[[], Findings],
    status: Callable[[], _Interlock],
) -> Survey:
    """The survey of a probe that reads ``identity``, then what ``explore`` reads,
    then ``status``, in that order, on the link whose ``stats`` count its
    exchanges: the turnaround is the time they took over their number."""
    before, started = stats.exchanges, time.perf_counter()
    said = identity()
    found = explore()
    now = status()
    exchanges = stats.exchanges - before
    turnaround = (time.perf_counter() - started) / exchanges if exchanges else None
    return Survey(
        identity=said,
        status=now.describe(),
        idle=now.idle,
        extents=found.extents,
        guesses=found.guesses,
        options=found.options,
        turnaround=turnaround,
        pull_exchanges=exchanges if found.pull_exchanges is None else found.pull_exchanges,
    )
