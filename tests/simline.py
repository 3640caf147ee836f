"""Test helpers for link and controller tests: a simulator whose replies follow a script.

:class:`ScriptedSim` is the real :class:`~harlsync.sim.Simulator` with one hook:
``sim.plan("SNT 3", Act(...))`` decides, for the next request whose payload is
``SNT 3`` or starts with ``SNT 3 ``, whether it is carried out, what payload is
answered and how the reply frame goes on the wire (dropped, corrupted, split,
late).  Requests without a plan are answered normally.  It is served over a real
pty or TCP socket by :mod:`harlsync.sim.serve`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import pytest

from harlsync.families.harl_u2.model import Config, ProgramArea
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim import Faults

Chunks = list[tuple[float, bytes]]

SMALL = Config(ProgramArea(1, 8), ProgramArea(2, 8), ProgramArea(1, 4), ProgramArea(1, 4), 4, 16, 4)


@dataclass(frozen=True)
class Act:
    """What the simulator does with one request."""

    #: carry the request out (False: as if it never arrived whole)
    apply: bool = True
    #: called with the robot's state first (someone else changing an item)
    before: Callable[[SimState], None] | None = None
    #: answer this payload instead of the real one
    reply: str | None = None
    #: how the reply frame goes on the wire; None: whole, at once
    wire: Callable[[bytes], Chunks] | None = None


def drop(frame: bytes) -> Chunks:
    return []


def bad_lrc(frame: bytes) -> Chunks:
    return [(0.0, frame[:-1] + bytes([frame[-1] ^ 0x5A]))]


JUNK = b"\x00\xff#*\x03 ZQ"


def noise(frame: bytes) -> Chunks:
    return [(0.0, JUNK + frame)]


def bytewise(frame: bytes) -> Chunks:
    return [(i * 0.002, frame[i : i + 1]) for i in range(len(frame))]


def slow(delay: float) -> Callable[[bytes], Chunks]:
    return lambda frame: [(delay, frame)]


def preceded_by(extra: bytes) -> Callable[[bytes], Chunks]:
    return lambda frame: [(0.0, extra + frame)]


LOSE = Act(apply=False, wire=drop)


class _Shaper(Faults):
    wire: Callable[[bytes], Chunks] | None = None

    def shape(self, frame: bytes, corrupt: Callable[[bytes], bytes]) -> Chunks:
        wire, self.wire = self.wire, None
        return [(0.0, frame)] if wire is None else wire(frame)


class ScriptedSim(Simulator):
    """A simulator that follows :meth:`plan` for chosen requests."""

    def __init__(self, stations: dict[int, SimState] | SimState, **kwargs: object) -> None:
        super().__init__(stations, faults=_Shaper(), **kwargs)  # type: ignore[arg-type]
        self.script: list[tuple[str, Act]] = []

    def plan(self, payload: str, *acts: Act) -> None:
        """Use ``acts``, in turn, for the next requests that match ``payload``."""
        with self.lock:
            self.script += [(payload, act) for act in acts]

    def handle(self, state: SimState, payload: str) -> str:
        act = self._take(payload)
        assert isinstance(self.faults, _Shaper)
        self.faults.wire = act.wire if act else None
        if act is None:
            return super().handle(state, payload)
        if act.before is not None:
            act.before(state)
        reply = super().handle(state, payload) if act.apply else "0"
        return reply if act.reply is None else act.reply

    def _take(self, payload: str) -> Act | None:
        for i, (key, act) in enumerate(self.script):
            if payload == key or payload.startswith(key + " "):
                del self.script[i]
                return act
        return None

    def sent(self, payload: str) -> list[str]:
        """Every request received whose payload matches ``payload`` (as in :meth:`plan`)."""
        with self.lock:
            return [
                r.payload
                for r in self.received
                if r.payload == payload or r.payload.startswith(payload + " ")
            ]


class LinkClock:
    """The link module's clock (its ``time``), frozen, and the waits the link asks for.

    :func:`watch_waits` puts it in the link's place: ``time.monotonic`` stands still
    and moves on only by what the link waits for with nothing arriving (a ``sleep``,
    a ``poll`` that times out), so every wait the link asks for is known exactly,
    whatever the machine's load.  ``sleeps`` are the link's ``time.sleep`` calls,
    ``polls`` the timeouts it gave ``poll`` (seconds); the bytes themselves come in
    real time.
    """

    def __init__(self) -> None:
        self.start = self.now = time.monotonic()  # on from the link's real clock
        self.sleeps: list[float] = []
        self.polls: list[float] = []

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


class _WatchedPoll:
    def __init__(self, poll: Any, clock: LinkClock) -> None:
        self._poll, self._clock = poll, clock

    def poll(self, timeout: float) -> list[tuple[int, int]]:
        self._clock.polls.append(timeout / 1000)
        ready: list[tuple[int, int]] = self._poll.poll(timeout)
        if not ready:
            self._clock.now += timeout / 1000
        return ready


def watch_waits(link: Any, monkeypatch: pytest.MonkeyPatch) -> LinkClock:
    """A :class:`LinkClock` in place of the open ``link``'s clock and its poll."""
    from harlsync.link import exchange

    clock = LinkClock()
    monkeypatch.setattr(exchange, "time", clock)
    link._poll = _WatchedPoll(link._poll, clock)
    return clock


class EchoingLine(Simulator):
    """A simulator on a line that echoes every byte sent, before the reply (a 2-wire
    RS-485 adapter does: its receiver hears its own transmitter)."""

    def receive(self, data: bytes, *args: object, **kwargs: object) -> Chunks:
        return [(0.0, data), *super().receive(data, *args, **kwargs)]  # type: ignore[arg-type]


class DuplicatingLine(Simulator):
    """A simulator on a line that delivers every reply twice, ``gap`` seconds apart
    (two devices answering, a device server that retransmits, a reflection)."""

    gap = 0.003

    def receive(self, data: bytes, *args: object, **kwargs: object) -> Chunks:
        chunks = super().receive(data, *args, **kwargs)  # type: ignore[arg-type]
        return [*chunks, *((delay + self.gap, chunk) for delay, chunk in chunks)]
