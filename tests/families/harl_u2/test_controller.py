"""The controller API against the simulator over a real pty: reads, confirmed writes,
error replies, status, and a full read under random line faults.

``HARLSYNC_TEST_PORT`` (and ``HARLSYNC_TEST_STATION``) runs the read-only
``hardware`` tests against a real controller; they are skipped otherwise.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from simline import LOSE, SMALL, Act, DuplicatingLine, EchoingLine, ScriptedSim, drop

from harlsync.errors import ControllerError, LinkError, LinkTimeout, WriteUnconfirmed
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import (
    OFFSET_TABLE_COUNT,
    Config,
    OffsetEnd,
    OffsetTable,
    ProgramArea,
    ProgramType,
    RobotData,
    Step,
    TaskState,
)
from harlsync.families.harl_u2.protocol import profile
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.families.harl_u2.sim.device import STATUS_RANGE
from harlsync.link import SerialSettings
from harlsync.sim import Faults
from harlsync.sim.serve import PtyServer

FAST = SerialSettings(timeout=0.25, retries=3)
MAIN, START = ProgramType.MAIN, ProgramType.START


@pytest.fixture
def sim() -> ScriptedSim:
    return ScriptedSim(SimState.generate(11, SMALL))


@pytest.fixture
def state(sim: ScriptedSim) -> SimState:
    return sim.stations[1]


@pytest.fixture
def device(sim: ScriptedSim) -> Iterator[str]:
    with PtyServer(sim) as server:
        yield server.device


@pytest.fixture
def robot(device: str) -> Iterator[Controller]:
    with Controller.from_url(device, 1, FAST) as controller:
        yield controller


# --- reads ----------------------------------------------------------------------------------


def test_every_read_returns_what_the_robot_holds(robot: Controller, state: SimState) -> None:
    data = state.data
    assert data.registers is not None
    state.di[17] = 1
    state.do[40:48] = [1, 0, 1, 0, 0, 0, 0, 1]
    state.mem[8:16] = [0, 1, 0, 0, 0, 0, 0, 0]
    data.offsets[42] = OffsetTable(
        "-12.50", "3.00", "0.00", "1.25", "9999.99", "-9999.99", "7", "99"
    )

    assert robot.version() == "5.00"
    assert robot.config() == SMALL
    assert robot.read_parameters() == data.parameters
    assert robot.read_step(MAIN, 1, 0) == data.programs[(MAIN, 1)][0]
    assert robot.read_step(START, 0, 1) == data.programs[(START, 0)][1]
    assert robot.read_step(MAIN, 0, 7) == data.programs[(MAIN, 0)].get(7, Step())
    assert robot.read_timer(3) == data.timers[3]
    assert robot.read_register(2) == data.registers[2]
    assert robot.read_offset(42) == data.offsets[42]
    assert robot.read_di_bit(17) is True and robot.read_di_bit(16) is False
    assert robot.read_di_port(2) == 0b10
    assert robot.read_do_bit(40) is True and robot.read_do_bit(41) is False
    assert robot.read_do_port(5) == 0b10000101
    assert robot.read_mem_bit(256 + 9) is True and robot.read_mem_bit(256 + 8) is False
    assert robot.read_mem_port(1) == 0b10


def test_read_program_returns_only_the_steps_that_hold_something(
    robot: Controller, state: SimState
) -> None:
    state.data.programs[(MAIN, 1)] = {0: Step.parse("MOVE P001 S50"), 5: Step("END")}
    seen: list[tuple[int, int]] = []
    assert robot.read_program(MAIN, 1, progress=lambda d, t: seen.append((d, t))) == {
        0: Step.parse("MOVE P001 S50"),
        5: Step("END"),
    }
    assert seen == [(n, 8) for n in range(1, 9)]
    assert robot.read_program(MAIN, 1, steps=3) == {0: Step.parse("MOVE P001 S50")}


def expected(state: SimState, registers: bool) -> RobotData:
    """What a read of everything returns: the robot's data, and where its offset
    tables end (the simulator's 100, ended by the profile's E21: issue 29)."""
    data = state.data
    return replace(
        data,
        registers=dict(data.registers or {}) if registers else None,
        offset_end=OffsetEnd(OFFSET_TABLE_COUNT, "E" + profile.NO_SUCH_TABLE),
    )


@pytest.mark.parametrize("registers", [False, True])
def test_read_all_reads_everything_the_configuration_says_exists(
    robot: Controller, state: SimState, sim: ScriptedSim, registers: bool
) -> None:
    seen: list[tuple[int, int]] = []
    got = robot.read_all(include_registers=registers, progress=lambda d, t: seen.append((d, t)))
    assert got == expected(state, registers)
    # the end of the offset tables: table 100, table 99 again, table 100 again (issue 29)
    end = 3
    total = 3 + SMALL.step_count + OFFSET_TABLE_COUNT + end + SMALL.timers + 4 * registers
    assert seen == [(n, total) for n in range(1, total + 1)]
    assert sim.received[0].payload == "LNX" and len(sim.received) == total
    assert not sim.writes_received()


def test_read_all_comes_through_random_line_faults_unchanged(tmp_path: Path) -> None:
    # Each lost or late reply costs the 0.15 s deadline: rates that cost some 3 s, not 7.
    faults = Faults(
        noise=0.1, drop=0.015, bad_checksum=0.015, fragment=0.2, slow=0.01, slow_delay=0.22, seed=5
    )
    sim = Simulator(SimState.generate(4, SMALL), faults=faults)
    settings = SerialSettings(timeout=0.15, retries=5)
    with PtyServer(sim) as server, Controller.from_url(server.device, 1, settings) as robot:
        got = robot.read_all(include_registers=True)
        stats = robot.link.stats
    assert got == expected(sim.stations[1], True)
    assert stats.retries > 0 and stats.noise_bytes > 0
    assert len(stats.reasons) == stats.retries


def test_issue_11_read_all_over_a_line_that_echoes_every_request_is_unchanged() -> None:
    sim = EchoingLine(SimState.generate(4, SMALL))
    with PtyServer(sim) as server, Controller.from_url(server.device, 1, FAST) as robot:
        got = robot.read_all(include_registers=True)
        stats = robot.link.stats
    assert got == expected(sim.stations[1], True)
    assert got.version != "LNV"
    assert stats.echoes == len(sim.received) and stats.retries == 0


def test_issue_11_read_all_over_a_line_that_repeats_every_reply_fails_with_one_clear_line() -> None:
    # Each reply twice, 3 ms apart: the repeat answered the next request, and a pull
    # saved hundreds of wrong timers and offsets with exit 0.
    sim = DuplicatingLine(SimState.generate(4, SMALL))
    with (
        PtyServer(sim) as server,
        Controller.from_url(server.device, 1, FAST) as robot,
        pytest.raises(LinkError) as info,
    ):
        robot.read_all(include_registers=True)
    assert re.fullmatch(
        rf"port {server.device}, station 1: the line delivers replies nobody asked for "
        r"\(\d+ unrequested frames\): two devices answering, or a device server "
        r"retransmitting; fix the line",
        str(info.value),
    )


def test_one_link_carries_a_controller_per_station(device: str) -> None:
    sim = ScriptedSim({1: SimState.generate(1, SMALL), 3: SimState.generate(2, SMALL)})
    sim.stations[3].data.timers[0] = "9.87"
    with PtyServer(sim) as server, Link(server.device, 1, FAST) as link:
        first, third = Controller(link), Controller(link, station=3)
        assert third.read_timer(0) == "9.87"
        assert first.read_timer(0) == sim.stations[1].data.timers[0]
        assert {r.station for r in sim.received} == {1, 3}


# --- error replies ----------------------------------------------------------------------------


def test_an_error_reply_raises_controller_error_naming_port_station_command_status(
    robot: Controller,
) -> None:
    with pytest.raises(ControllerError) as info:
        robot.read_timer(99)
    error = info.value
    assert (error.status, error.port, error.station, error.command) == (
        STATUS_RANGE,
        robot.port,
        1,
        "LNT 99",
    )
    assert str(error) == (
        f"port {robot.port}, station 1, command LNT 99: controller answered error status "
        f"E{STATUS_RANGE}"
    )


def test_a_refused_write_raises_controller_error_and_is_not_resent(
    robot: Controller, sim: ScriptedSim
) -> None:
    with pytest.raises(ControllerError, match="command SNT 9 1.00") as info:
        robot.write_timer(9, "1.00", old="0.00")
    assert info.value.status == STATUS_RANGE
    assert sim.sent("SNT 9") == ["SNT 9 1.00"]


# --- writes ---------------------------------------------------------------------------------


class Kind:
    """One write kind: the request key, how to write, what the robot must hold after."""

    def __init__(
        self,
        name: str,
        key: str,
        write: Callable[[Controller], None],
        holds: Callable[[SimState], bool],
    ) -> None:
        self.name, self.key, self.write, self.holds = name, key, write, holds

    def __repr__(self) -> str:
        return self.name


TABLE = OffsetTable("1.00", "-2.00", "3.00", "4.00", "5.00", "6.00", "7", "8")
NEW_CONFIG = Config(
    ProgramArea(1, 4), ProgramArea(1, 4), ProgramArea(1, 4), ProgramArea(1, 4), 4, 16, 4
)

KINDS = [
    Kind(
        "step",
        "SNM 1 2",
        lambda c: c.write_step(MAIN, 1, 2, Step.parse("MOVE P777 S20")),
        lambda s: s.data.programs[(MAIN, 1)].get(2) == Step.parse("MOVE P777 S20"),
    ),
    Kind(
        "step-clear",
        "SNA 0",
        lambda c: c.write_step(START, 0, 0, Step()),
        lambda s: 0 not in s.data.programs[(START, 0)],
    ),
    Kind(
        "timer", "SNT 1", lambda c: c.write_timer(1, "7.25"), lambda s: s.data.timers[1] == "7.25"
    ),
    Kind(
        "register",
        "SND 3",
        lambda c: c.write_register(3, "0042"),
        lambda s: (s.data.registers or {})[3] == "0042",
    ),
    Kind(
        "offset", "SNL 9", lambda c: c.write_offset(9, TABLE), lambda s: s.data.offsets[9] == TABLE
    ),
    Kind(
        "parameters",
        "SNE",
        lambda c: c.write_parameters(replace(c.read_parameters(), pull_rate="77")),
        lambda s: s.data.parameters.pull_rate == "77",
    ),
    Kind(
        "config",
        "SNX",
        lambda c: c.write_config(NEW_CONFIG),
        lambda s: s.data.config.same_programs(NEW_CONFIG) and not any(s.data.programs.values()),
    ),
]


@pytest.fixture
def prepared(state: SimState) -> SimState:
    """A robot where every item a KIND writes holds something else first."""
    state.data.programs[(START, 0)][0] = Step("END")
    return state


@pytest.mark.parametrize("kind", KINDS, ids=repr)
def test_every_write_kind_lands_with_a_single_request(
    robot: Controller, sim: ScriptedSim, prepared: SimState, kind: Kind
) -> None:
    assert not kind.holds(prepared)
    kind.write(robot)
    assert kind.holds(prepared)
    assert len(sim.sent(kind.key)) == 1


@pytest.mark.parametrize("kind", KINDS, ids=repr)
def test_a_write_whose_reply_is_lost_but_took_is_not_sent_again(
    robot: Controller, sim: ScriptedSim, prepared: SimState, kind: Kind
) -> None:
    sim.plan(kind.key, Act(wire=drop))
    kind.write(robot)
    assert kind.holds(prepared)
    assert len(sim.sent(kind.key)) == 1
    assert robot.link.stats.unconfirmed_writes == 1


@pytest.mark.parametrize("kind", KINDS, ids=repr)
def test_a_write_that_did_not_take_is_sent_once_more(
    robot: Controller, sim: ScriptedSim, prepared: SimState, kind: Kind
) -> None:
    sim.plan(kind.key, LOSE)
    kind.write(robot)
    assert kind.holds(prepared)
    assert len(sim.sent(kind.key)) == 2


def test_a_write_that_never_takes_raises_after_the_second_send(
    robot: Controller, sim: ScriptedSim, state: SimState
) -> None:
    sim.plan("SNT 1", LOSE, LOSE)
    before = state.data.timers[1]
    with pytest.raises(
        WriteUnconfirmed, match="command SNT 1 7.25: write not confirmed: sent twice"
    ):
        robot.write_timer(1, "7.25")
    assert len(sim.sent("SNT 1")) == 2 and state.data.timers[1] == before


def test_a_write_whose_item_changed_under_it_raises_without_sending_again(
    robot: Controller, sim: ScriptedSim, state: SimState
) -> None:
    def pendant(s: SimState) -> None:
        s.data.timers[1] = "3.33"

    state.data.timers[1] = "1.00"
    sim.plan("SNT 1", Act(apply=False, before=pendant, wire=drop))
    with pytest.raises(WriteUnconfirmed, match="reads back '3.33': neither what was written"):
        robot.write_timer(1, "7.25")
    assert len(sim.sent("SNT 1")) == 1


def test_a_known_old_value_saves_the_read_before_the_write(
    robot: Controller, sim: ScriptedSim, state: SimState
) -> None:
    old = state.data.timers[2]
    robot.write_timer(2, "1.50", old=old)
    robot.write_timer(2, "1.75")
    assert [r.payload for r in sim.received] == ["SNT 2 1.50", "LNT 2", "SNT 2 1.75"]


# --- status ---------------------------------------------------------------------------------


def test_an_idle_robot_reports_idle(robot: Controller) -> None:
    status = robot.status()
    assert status.idle and len(status.tasks) == 5


@pytest.mark.parametrize(
    "change",
    [
        pytest.param(lambda s: s.start_task(2, "MAIN", 1, 4), id="in execution"),
        pytest.param(lambda s: (s.start_task(0), s.suspend_task(0)), id="suspended"),
        pytest.param(
            lambda s: s.tasks.__setitem__(4, TaskState(4, 16, "SUB", 0, 0)), id="unknown status"
        ),
        pytest.param(
            lambda s: s.tasks.__setitem__(1, TaskState(1, 3, "MAIN", 0, 0)), id="two bits"
        ),
        pytest.param(lambda s: s.tasks.pop(), id="a task missing"),
    ],
)
def test_a_robot_is_not_idle_when_a_task_runs_is_suspended_or_unknown(
    robot: Controller, state: SimState, change: Callable[[SimState], object]
) -> None:
    change(state)
    assert not robot.status().idle


def test_a_stopped_task_in_error_or_complete_is_idle(robot: Controller, state: SimState) -> None:
    state.tasks[1] = TaskState(1, 8, "MAIN", 0, 3)
    state.tasks[2] = TaskState(2, 4, "SUB", 1, 0)
    assert robot.status().idle


def test_an_unparsable_status_raises_rather_than_passing_for_idle(
    device: str, sim: ScriptedSim
) -> None:
    sim.plan("LNR", *[Act(reply="0 START 0 x 0 START 0 0")] * 2)
    robot = Controller.from_url(device, 1, SerialSettings(timeout=0.2, retries=1))
    with robot, pytest.raises(LinkTimeout, match="command LNR: .*reply does not fit"):
        robot.status()


# --- the controller owns a link it opened --------------------------------------------------------


def test_from_url_closes_its_link_and_a_given_link_is_left_open(device: str) -> None:
    with Controller.from_url(device, 1, FAST) as robot:
        assert robot.link.is_open
    assert not robot.link.is_open
    with Link(device, 1, FAST) as link:
        with Controller(link):
            pass
        assert link.is_open


# --- a real controller, read-only -------------------------------------------------------------

PORT = os.environ.get("HARLSYNC_TEST_PORT")


@pytest.mark.hardware
@pytest.mark.skipif(not PORT, reason="HARLSYNC_TEST_PORT is not set")
def test_a_real_controller_answers_the_read_only_commands() -> None:
    assert PORT is not None
    station = int(os.environ.get("HARLSYNC_TEST_STATION", "1"))
    with Controller.from_url(PORT, station) as robot:
        config = robot.config()
        assert robot.version()
        assert isinstance(robot.status().describe(), str)
        if config.timers:
            robot.read_timer(0)
        robot.read_offset(0)
        robot.read_parameters()
