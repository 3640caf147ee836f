"""Read-only tests that run against the simulator, and against a real controller too
when ``HARLSYNC_TEST_PORT`` names one (``HARLSYNC_TEST_STATION``, default 1).

Nothing here sends an SN command, so they are safe on a production robot. The
hardware runs are marked ``hardware``; CI has no such port and skips them.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from harlsync.families.harl_u2.catalogue import CATALOGUE
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.model import OFFSET_TABLE_COUNT, TIMER_RE, ProgramType
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.serve import PtyServer
from harlsync.sync import engine
from harlsync.sync import items as sync_items

PORT = os.environ.get("HARLSYNC_TEST_PORT")
STATION = int(os.environ.get("HARLSYNC_TEST_STATION", "1"))


@dataclass
class Target:
    url: str
    station: int
    sim: Simulator | None  # None: a real controller, whose contents we do not know


@pytest.fixture(
    params=[
        "simulator",
        pytest.param(
            "hardware",
            marks=[
                pytest.mark.hardware,
                pytest.mark.skipif(not PORT, reason="HARLSYNC_TEST_PORT is not set"),
            ],
        ),
    ]
)
def target(request: pytest.FixtureRequest) -> Iterator[Target]:
    if request.param == "hardware":
        assert PORT is not None
        yield Target(PORT, STATION, None)
        return
    sim = Simulator(SimState.generate(31))
    with PtyServer(sim) as server:
        yield Target(server.device, 1, sim)
    assert sim.writes_received() == []


def test_config_version_and_status_read_and_make_sense(target: Target) -> None:
    with Controller.from_url(target.url, target.station) as robot:
        config = robot.config()
        version = robot.version()
        status = robot.status()
    assert config.step_count > 0 and config.timers >= 0
    assert version
    assert len(status.tasks) == 5
    if target.sim is not None:
        assert config == target.sim.stations[1].data.config
        assert status.idle


def test_every_kind_of_read_answers_within_its_range(target: Target) -> None:
    with Controller.from_url(target.url, target.station) as robot:
        config = robot.config()
        if config.timers:
            assert TIMER_RE.fullmatch(robot.read_timer(0))
        if config.registers:
            assert len(robot.read_register(0)) == 4
        table = robot.read_offset(OFFSET_TABLE_COUNT - 1)
        assert not table.problems()
        assert len(robot.read_parameters().values) == 13
        assert robot.read_di_bit(0) in (False, True)
        assert robot.read_do_bit(0) in (False, True)
        assert 0 <= robot.read_di_port(0) <= 255 and 0 <= robot.read_do_port(0) <= 255
        if config.memory_bits:
            assert robot.read_mem_bit(256) in (False, True)
            assert 0 <= robot.read_mem_port(0) <= 255
        start = robot.read_program(ProgramType.START, 0, config.start.steps)
    assert all(0 <= n < config.start.steps for n in start)


def test_a_pull_then_a_diff_of_the_same_robot_finds_nothing(target: Target, tmp_path: Path) -> None:
    project = tmp_path / "robot"
    engine.pull(project, port=target.url, station=target.station)
    comparison = engine.compare(project, port=target.url, station=target.station)
    # A robot running in production may change between the two reads; the
    # simulator may not.
    if target.sim is not None:
        assert comparison.changes == []
        state = target.sim.stations[1].data
        assert sync_items.diff(CATALOGUE, state, comparison.project.data) == []
