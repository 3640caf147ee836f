"""The link's wait for a reply (harlsync/link/exchange.py, "Waiting"): it reads each
reply as it comes, woken by its bytes, and waits for no time of its own making: not
one worked out from robot.yaml's baud rate, which behind a device server is not the
line's (issue 29), nor one learnt from earlier replies.  Every reply is taken whole
and answers its own request, whatever its length against the others of its kind.

Over a real pty and a real TCP socket to a simulator that emulates a serial line
(each reply's bytes paced at the character rate).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from simline import SMALL, Act, ScriptedSim, slow, watch_waits

from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import ProgramType, Step
from harlsync.families.harl_u2.protocol import commands as cmd
from harlsync.families.harl_u2.sim import SimState
from harlsync.link import SerialSettings
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


def robot(baudrate: int) -> ScriptedSim:
    """A robot whose MAIN 0 holds :data:`STEPS`, on a line of ``baudrate``."""
    state = SimState.generate(3, SMALL)
    state.data.programs[(ProgramType.MAIN, 0)] = dict(STEPS)
    return ScriptedSim(state, baudrate=baudrate)


@pytest.fixture
def sim() -> ScriptedSim:
    return robot(LINE.baudrate)


@pytest.fixture(params=["pty", "tcp"])
def link(request: pytest.FixtureRequest, sim: ScriptedSim) -> Iterator[Link]:
    server = PtyServer(sim) if request.param == "pty" else TcpServer(sim)
    with server:
        url = server.device if isinstance(server, PtyServer) else server.url
        link = Link(url, 1, LINE)
        with link:
            yield link


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


def test_a_reply_paced_by_a_slow_line_is_read_as_it_comes_woken_by_its_bytes_only(
    link: Link, monkeypatch: pytest.MonkeyPatch
) -> None:
    # At 9600 baud a step's reply is some 30 ms on the wire, in 1 ms ticks: the link
    # waits in poll until its deadline, woken by the bytes; no wait ends without
    # bytes (the link's clock never moves), and it never sleeps.
    clock = watch_waits(link, monkeypatch)
    for n, step in STEPS.items():
        assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, n)) == step
    assert clock.sleeps == [] and clock.now == clock.start
    assert len(clock.polls) >= len(STEPS)
    assert all(wait == pytest.approx(LINE.timeout) for wait in clock.polls)


def test_issue_29_behind_a_device_server_no_exchange_waits_for_a_wire_time_from_robot_yaml_baud(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The device server runs the line at 115200 baud and robot.yaml keeps its default,
    # 9600: a wire time worked out from it is 12 times the line's.  The link timed one
    # exchange in 16 of a kind by it, a sleep of 20-70 ms each (a pull 1.60 x a bare
    # client's).  Now it asks for no wait but the reply's deadline, and never sleeps.
    yaml = SerialSettings(baudrate=9600, timeout=5.0, retries=0)  # 5 s: never reached
    sim = robot(115200)
    timer = sim.stations[1].data.timers[2]
    with TcpServer(sim) as server, Link(server.url, 1, yaml) as link:
        clock = watch_waits(link, monkeypatch)
        for _ in range(8):  # 40 step reads, 40 timer reads: kinds of more than 16 each
            for n, step in STEPS.items():
                assert link.exchange(cmd.read_step(ProgramType.MAIN, 0, n)) == step
                assert link.exchange(cmd.read_timer(2)) == timer
    assert clock.sleeps == [], "slept for wire times at robot.yaml's 9600 baud"
    assert all(wait == pytest.approx(yaml.timeout) for wait in clock.polls)
    assert link.stats.retries == 0
