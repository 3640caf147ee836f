"""The link's paced wait (harlsync/link/exchange.py, "Waiting"): asleep while a reply
is on the wire, it still takes every reply whole and answers every request with its
own reply, whatever the reply's length against the recent ones of its kind.

Over a real pty and a real TCP socket to a simulator that emulates a 9600-baud line
(each reply's bytes paced at the character rate), so that the link does sleep.
"""

from __future__ import annotations

import select
from collections.abc import Iterator

import pytest
from simline import SMALL, Act, ScriptedSim, slow

from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import ProgramType, Step
from harlsync.families.harl_u2.protocol import commands as cmd
from harlsync.families.harl_u2.sim import SimState
from harlsync.link import SerialSettings
from harlsync.link.exchange import MIN_SLEEP
from harlsync.sim.serve import PtyServer, TcpServer

LINE = SerialSettings(baudrate=9600, timeout=0.5, retries=3)

#: Steps of MAIN 0: long ones, then a short one (END), a long one, and empty steps.
STEPS = {
    0: Step("MOVE", ("P001", "S100")),
    1: Step("MOVE", ("P002", "S100")),
    2: Step("MOVE", ("P003", "S100")),
    3: Step("END"),
    4: Step("WAIT", ("DI02", "ON")),
}


@pytest.fixture
def sim() -> ScriptedSim:
    state = SimState.generate(3, SMALL)
    state.data.programs[(ProgramType.MAIN, 0)] = dict(STEPS)
    return ScriptedSim(state, baudrate=LINE.baudrate)


@pytest.fixture(params=["pty", "tcp"])
def link(request: pytest.FixtureRequest, sim: ScriptedSim) -> Iterator[Link]:
    server = PtyServer(sim) if request.param == "pty" else TcpServer(sim)
    with server:
        url = server.device if isinstance(server, PtyServer) else server.url
        link = Link(url, 1, LINE)
        with link:
            yield link


def test_a_reply_is_long_enough_on_the_wire_for_the_link_to_sleep(link: Link) -> None:
    # The premise of the other tests: a step's exchange takes longer than MIN_SLEEP.
    request = cmd.read_step(ProgramType.MAIN, 0, 0)
    link.exchange(request)
    took = next(iter(link._took.values()))
    assert took.shortest(len(request.encode(1)), link._char) > 2 * MIN_SLEEP


def test_replies_shorter_and_longer_than_the_recent_ones_are_each_read_whole(
    link: Link,
) -> None:
    for _ in range(2):
        for n, step in STEPS.items():
            assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, n)) == step
        empty = link.exchange(cmd.read_step(ProgramType.MAIN, 0, 7))
        assert isinstance(empty, Step) and empty.empty
    assert link.stats.retries == 0 and link.stats.timeouts == 0
    assert link.stats.late_replies == 0 and link.stats.unrequested == 0


@pytest.mark.parametrize(("delay", "retries"), [(0.1, 0), (0.7, 1)], ids=["slow", "past-deadline"])
def test_a_reply_slower_than_the_recent_ones_is_its_own_or_retried_past_its_deadline(
    link: Link, sim: ScriptedSim, delay: float, retries: int
) -> None:
    for n in range(3):
        link.exchange(cmd.read_step(ProgramType.MAIN, 0, n))
    sim.plan("LNM 0 4", Act(wire=slow(delay)))  # the deadline is 0.5 s
    assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, 4)) == STEPS[4]
    assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, 0)) == STEPS[0]
    assert link.stats.retries == retries and link.stats.unrequested == 0


class _CountedPoll:
    """The link's poll object, counting how often the link waits in it."""

    def __init__(self, poll: select.poll) -> None:
        self._poll, self.calls = poll, 0

    def poll(self, timeout: float) -> list[tuple[int, int]]:
        self.calls += 1
        return self._poll.poll(timeout)


def test_replies_a_little_shorter_each_time_keep_the_link_asleep_while_on_the_wire(
    link: Link, sim: ScriptedSim
) -> None:
    # Each reply a byte shorter than every one before it (as IAI positions with
    # fewer digits are): each is whole before the link wakes, and the next is still
    # timed from the kind's history, not read a byte per wake-up (some 20 at 9600).
    params = [
        ("P001", "S100", "A123"),
        ("P001", "S100", "A12"),
        ("P001", "S100", "A1"),
        ("P001", "S10", "A1"),
        ("P01", "S10", "A1"),
        ("P1", "S10", "A1"),
        ("P1", "S1", "A1"),
        ("P1", "S1", "A"),
    ]
    program = sim.stations[1].data.programs[(ProgramType.MAIN, 0)]
    program.update((n, Step("MOVE", p)) for n, p in enumerate(params))
    assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, 0)) == program[0]  # by poll
    counted = link._poll = _CountedPoll(link._poll)
    for n in range(1, len(params)):
        assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, n)) == program[n]
    (took,) = link._took.values()
    assert len(took.turnaround) == len(params)  # every exchange timed the next
    assert counted.calls <= 3 * (len(params) - 1)
    assert link.stats.retries == 0 and link.stats.unrequested == 0
