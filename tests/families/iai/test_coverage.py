"""Issue 20 item 1 for IAI: no silent truncation.  A pull makes sure no position is
defined outside the range robot.yaml reads (and, when flags and variables are
kept, that none is set past theirs); a table that goes on fails that robot's pull
and backup with one line naming what lies beyond and the robot.yaml setting, and
the range covered is recorded.  Every check of what the controller holds reads
the simulator's own state."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.families.iai.layout import Coverage
from harlsync.families.iai.model import Position
from harlsync.families.iai.protocol import Frame, max_positions_per_read
from harlsync.families.iai.sim import SimState, Simulator, codes
from harlsync.project import load_project
from harlsync.sim import Refused
from harlsync.sim.serve import TcpServer
from harlsync.sync import engine
from harlsync.sync.backup import backup

STATION = 0x99
AXES = (1, 2)


def position(n: int) -> Position:
    rng = random.Random(n)
    return Position(n, AXES, "0.30", "0.30", 100, (f"{rng.randint(0, 999)}.000", "1.500"))


def controller(numbers: list[int], end: int = 2000) -> SimState:
    """A controller whose table goes up to ``end`` (more than robot.yaml's 1-1000)."""
    return SimState.from_positions(
        [position(n) for n in numbers], axes=AXES, position_range=(1, end)
    )


class NarrowQueries(Simulator):
    """A controller that answers & to a 22DH asking for more numbers than the
    table's reads do (the manual does not say what one does with such a query)."""

    def handle(self, state: SimState, frame: Frame) -> str:
        if frame.message_id == 0x22D and int(frame.data[6:10], 16) > max_positions_per_read(
            state.model
        ):
            raise Refused(codes.TOO_LONG)
        return super().handle(state, frame)


def pull(repo: Path, url: str, *extra: str) -> int:
    return cli.main(
        ["pull", str(repo / "cell"), "--family", "iai", "--port", url, "--station", "99", *extra]
    )


def pull_after_edit(
    repo: Path, state: SimState, capsys: pytest.CaptureFixture[str], old: str, new: str
) -> str:
    """A first backup of ``state``; then robot.yaml's ``old`` made ``new`` (``$&``
    in it: ``old`` itself) and a pull that must fail: what it said."""
    server = TcpServer(Simulator({STATION: state}))
    try:
        assert pull(repo, server.start()) == 0
        robot = repo / "cell" / "robot.yaml"
        robot.write_text(robot.read_text().replace(old, new.replace("$&", old)))
        capsys.readouterr()
        assert cli.main(["pull", str(repo / "cell"), "--allow-dirty"]) == 2
    finally:
        server.stop()
    return capsys.readouterr().err


@pytest.mark.parametrize("sim_class", [Simulator, NarrowQueries], ids=["wide probe", "narrow"])
def test_issue_20_positions_past_the_range_fail_the_pull_naming_them_and_the_setting(
    repo: Path, capsys: pytest.CaptureFixture[str], sim_class: type[Simulator]
) -> None:
    # 870 positions defined, 339 of them past 1000: the pull once kept 531 and exited 0.
    numbers = sorted(random.Random(20).sample(range(1, 1400), 870))
    beyond = [n for n in numbers if n > 1000]
    sim = sim_class({STATION: controller(numbers)})
    server = TcpServer(sim)
    try:
        code = pull(repo, server.start())
    finally:
        server.stop()
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert f"position {beyond[0]}, {beyond[1]} and more" in lines[0]
    assert "past the range this backup reads (1-1000)" in lines[0]
    assert "set controller.last_position:" in lines[0] and "in robot.yaml" in lines[0]
    assert "backed up" not in err.replace("not backed up", "")
    assert not (repo / "cell" / "positions.yaml").exists()  # nothing saved
    assert not sim.writes_received() and not sim.off_list()


def test_issue_20_a_position_before_the_first_fails_the_pull_naming_first_position(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = controller([3, 50, 60])
    err = pull_after_edit(repo, state, capsys, "first_position: 1", "first_position: 10")
    assert "position 3 is defined before the range this backup reads (10-1000)" in err
    assert "set controller.first_position: 3 (or lower)" in err


def test_issue_20_a_whole_table_is_read_and_its_range_recorded_and_said(repo: Path) -> None:
    sim = Simulator({STATION: controller([1, 2, 999, 1000])})
    server = TcpServer(sim)
    try:
        result = engine.pull(repo / "cell", port=server.start(), station=STATION, family="iai")
    finally:
        server.stop()
    assert result.contents == "4 positions in 1-1000 (none defined outside it)"
    data = load_project(repo / "cell").data
    assert data.covered == {"positions": Coverage(1, 1000, 0xFFFF, checked_from=1, past="empty")}
    assert sorted(data.positions) == [1, 2, 999, 1000]
    text = (repo / "cell" / "controller.yaml").read_text()
    assert (
        "covered:\n  positions: {first: 1, last: 1000, checked_from: 1, checked_to: 65535, "
        'past: "empty"}\n'
    ) in text
    # Issue 29: the probe is two requests (none below the range: it starts at 1).  Position
    # 1001 alone (its table goes to 2000: an empty reply), then every number from 3, past
    # the positions read before 999 (FFFDh of them): the reply must carry 999 and 1000, the
    # last more than a read's 24 numbers in, so the controller is seen to scan so wide a
    # query whole.
    probes = [r.payload for r in sim.received if r.command == "22D"][-2:]
    assert probes == ["22D0003E90001", "22D000003FFFD"]


def test_issue_20_a_flag_set_past_the_kept_range_fails_the_pull(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = controller([1, 2])
    state.flags = {600, 905}  # kept: 600-899
    err = pull_after_edit(repo, state, capsys, "maintenance_windows", "keep_registers: true\n$&")
    assert "flag 905 is set past the range this backup keeps (600-899)" in err
    assert "set controller.flags: {first: 600, last: 905} (or higher) in robot.yaml" in err


def test_issue_20_a_short_table_fails_the_nightly_backup_and_is_not_reported_good(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = Simulator({STATION: controller([1, 2, 3])})
    server = TcpServer(sim)
    try:
        url = server.start()
        assert pull(repo, url) == 0
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "first backup")
        state = sim.stations[STATION]
        state.positions[1200] = position(1200).canonical()  # taught past the range since
        report = backup([repo], commit=True)
        capsys.readouterr()
        code = cli.main(["backup", str(repo)])
        status = cli.main(["status", str(repo)])
    finally:
        server.stop()
    assert not report.ok
    (robot,) = report.robots
    assert not robot.ok and "position 1200 is defined past the range" in (robot.error or "")
    out = capsys.readouterr()
    assert code == 1 and status != 0, out
    assert "position 1200 is defined past the range" in out.out + out.err
    assert "1200" not in (repo / "cell" / "positions.yaml").read_text()
