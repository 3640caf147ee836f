"""Issue 20: the disaster-recovery drill for a HARL-U2, end to end through the
``harlsync`` command over a real TCP socket and a real pty (docs/restore.md).

Back the robot up; bring a controller up blank (its memory lost: the factory
program configuration, nothing written); push the backup with
``--allow-reconfigure``; ``diff`` exits 0 and the new controller holds exactly
what the old one did, asserted from the simulator's own state.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync.cli import main
from harlsync.families.harl_u2.model import Config, ProgramArea, RobotData
from harlsync.families.harl_u2.sim import DEFAULT_CONFIG, SimState, Simulator
from harlsync.sim.serve import PtyServer, TcpServer

#: The cell's configuration: its program areas differ from the factory's (a blank
#: controller needs SNX), its timer, memory bit and register counts do not (no
#: SNX can write those).
CELL = Config(
    ProgramArea(1, 8),
    ProgramArea(2, 12),
    ProgramArea(2, 8),
    ProgramArea(1, 6),
    DEFAULT_CONFIG.timers,
    DEFAULT_CONFIG.memory_bits,
    DEFAULT_CONFIG.registers,
)


def held(data: RobotData) -> tuple[object, ...]:
    """Everything a controller's memory holds that a backup keeps."""
    programs = {key: steps for key, steps in data.programs.items()}
    return (
        data.version,
        data.config,
        data.parameters,
        programs,
        data.offsets,
        data.timers,
        data.registers,
    )


@pytest.fixture(params=["tcp", "pty"])
def server_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def serving(sim: Simulator, kind: str) -> TcpServer | PtyServer:
    return TcpServer(sim) if kind == "tcp" else PtyServer(sim)


def address(server: TcpServer | PtyServer) -> str:
    """The port a person would give: the pty's device path, or socket://host:port."""
    return server.device if isinstance(server, PtyServer) else server.url


@pytest.fixture
def old_robot() -> Iterator[Simulator]:
    yield Simulator(SimState.generate(20, CELL))


def test_issue_20_a_dead_controller_is_restored_from_its_backup_and_diff_is_clean(
    repo: Path, old_robot: Simulator, server_kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    original = old_robot.stations[1].data
    project = repo / "cell"
    # 1. The nightly backup, registers kept.
    with serving(old_robot, server_kind) as old:
        assert main(["pull", str(project), "--port", address(old)]) == 0
        robot_yaml = project / "robot.yaml"
        robot_yaml.write_text(
            robot_yaml.read_text().replace("keep_registers: false", "keep_registers: true")
        )
        assert main(["pull", str(project), "--port", address(old)]) == 0
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    capsys.readouterr()

    # 2. The controller dies; its replacement comes up blank.
    new_robot = Simulator(SimState.blank())
    assert held(new_robot.stations[1].data) != held(original)
    with serving(new_robot, server_kind) as new:
        # 3. A push without --allow-reconfigure is refused, writing nothing ...
        assert main(["push", str(project), "--port", address(new), "--yes", "--registers"]) == 3
        assert new_robot.writes_received() == []
        assert "--allow-reconfigure" in capsys.readouterr().err
        # ... and with it restores everything: SNX first, then every program.
        push = ["push", str(project), "--port", address(new), "--yes", "--registers"]
        assert main([*push, "--allow-reconfigure"]) == 0
        letters = [r.command for r in new_robot.writes_received()]
        assert letters[0] == "SNX"
        assert {"SNE", "SNL", "SNT", "SND", "SNA", "SNM", "SNS", "SNH"} <= set(letters)
        capsys.readouterr()
        # 4. diff exits 0, and the new controller holds what the old one did.
        assert main(["diff", str(project), "--port", address(new), "--registers"]) == 0
    assert held(new_robot.stations[1].data) == held(original)
