"""Issue 34 item 16, the Epson interlock's remaining gaps: the safeguard, the
control device (2156) and the controller's error code (2155) are looked at before
a write, a read of them that fails refuses the write (fail closed), a map without
Ready is not written unless robot.yaml accepts that risk, and a status signal on
an address the controller does not drive shows as a wrong map.

Each test asserts from the simulator's own record that nothing was written."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from harlsync import cli
from harlsync.families.epson.sim import CommandReceived, SimState, Simulator
from harlsync.sim.control import apply_command

from .projects import edit, pulled
from .sample import sample_data


@pytest.fixture
def robot() -> Iterator[tuple[Simulator, str]]:
    sim = Simulator(SimState.from_data(sample_data()), execution_time=0.0)
    with sim.serve() as server:
        yield sim, server.url
    assert sim.off_list() == [] and sim.function_errors == []


def written(sim: Simulator, since: int = 0) -> list[CommandReceived]:
    return [c for c in sim.commands()[since:] if c.is_write]


def refused(project: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """``harlsync push`` refused (exit 3) in one line; that line."""
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.fixture
def project(robot: tuple[Simulator, str], repo: Path) -> Path:
    """The sample robot pulled, LimZ edited in the project (one write to make)."""
    _, url = robot
    path = pulled(repo, url)
    edit(path, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    return path


def test_issue_34_an_open_safeguard_refuses_a_push(
    robot: tuple[Simulator, str], project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, _ = robot
    apply_command(sim, "safeguard")
    err = refused(project, capsys)
    assert "SafeguardOn 1 (the safeguard is open: a person may be in the cell)" in err
    assert "close the safeguard" in err
    assert written(sim) == [] and sim.stations[1].limz == -10000
    apply_command(sim, "stop")
    assert cli.main(["push", str(project), "--yes"]) == 0


def test_issue_34_a_push_is_refused_while_a_pendant_or_pc_controls_the_robot(
    robot: tuple[Simulator, str], project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """2156 says which device controls the robot; anything but Remote I/O (22) means
    someone else has it, though every status signal reads idle."""
    sim, _ = robot
    apply_command(sim, "teach")
    err = refused(project, capsys)
    assert "the control device is 21 (PC / TP4), not 22 (Remote I/O)" in err
    assert written(sim) == [] and sim.stations[1].limz == -10000
    asked = [c.number for c in sim.commands()]
    assert 2156 in asked
    apply_command(sim, "stop")
    assert cli.main(["push", str(project), "--yes"]) == 0


def test_issue_34_a_controller_error_its_error_signal_does_not_show_refuses_a_push(
    robot: tuple[Simulator, str], project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, _ = robot
    sim.stations[1].error_code = 4001  # Error on a bit the controller does not drive
    err = refused(project, capsys)
    assert "the controller reports error 4001 (2155), though its Error signal reads 0" in err
    assert written(sim) == [] and sim.stations[1].limz == -10000


@pytest.mark.parametrize(
    ("lacking", "named"), [(2156, "control device"), (2155, "controller error")]
)
def test_issue_34_a_controller_whose_control_device_or_error_cannot_be_read_is_not_written(
    robot: tuple[Simulator, str],
    project: Path,
    capsys: pytest.CaptureFixture[str],
    lacking: int,
    named: str,
) -> None:
    """Fail closed: a controller that answers 2156 or 2155 with an error response
    (an older firmware, say) is backed up and compared, never written."""
    sim, _ = robot
    sim.lacks = frozenset({lacking})
    err = refused(project, capsys)
    assert f"the {named} ({lacking}) cannot be read (controller answered error 1000" in err
    assert "nothing is written" in err
    assert written(sim) == [] and sim.stations[1].limz == -10000
    assert cli.main(["diff", str(project)]) == 1  # read and compared as before


def test_issue_34_a_map_without_ready_is_not_written_unless_robot_yaml_accepts_the_risk(
    robot: tuple[Simulator, str], repo: Path, project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """With Ready unmapped harlsync only warned and wrote.  Now it refuses, naming
    the risk and the robot.yaml setting that accepts it; with that setting it writes
    and validate names the risk accepted."""
    sim, _ = robot
    edit(project, repo, "robot.yaml", "Ready: {register: 0, bit: 8}", "Ready: null")
    err = refused(project, capsys)
    assert "the register map has no Ready signal" in err
    assert "status signals mapped to addresses it does not drive" in err
    assert "connection.write_without: [Ready] in robot.yaml" in err
    assert written(sim) == [] and sim.stations[1].limz == -10000
    edit(
        project,
        repo,
        "robot.yaml",
        "  writes_whole: false\n",
        "  writes_whole: false\n  write_without: [Ready]\n",
    )
    capsys.readouterr()
    assert cli.main(["validate", str(project)]) == 0
    assert "connection.write_without accepts writing without it" in capsys.readouterr().out
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert sim.stations[1].limz == -12000


def test_issue_34_a_map_without_safeguard_on_is_not_written_unless_accepted(
    robot: tuple[Simulator, str], repo: Path, project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, _ = robot
    edit(project, repo, "robot.yaml", "SafeguardOn: {register: 0, bit: 13}", "SafeguardOn: null")
    err = refused(project, capsys)
    assert "no SafeguardOn signal: an open safeguard (safety door) cannot be seen" in err
    assert "connection.write_without: [SafeguardOn]" in err
    assert written(sim) == []


def test_issue_34_status_bits_on_addresses_the_controller_does_not_drive_show_as_a_wrong_map(
    robot: tuple[Simulator, str], repo: Path, project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A status signal mapped to an address the controller does not drive reads 0
    and looked idle.  Ready, which reads 1 at rest, shows it: a map whose Ready and
    Running sit on bits the controller does not drive is refused while a task runs,
    saying to check the map."""
    sim, _ = robot
    for name, bit in (("Ready", 8), ("Running", 9)):
        edit(
            project,
            repo,
            "robot.yaml",
            f"{name}: {{register: 0, bit: {bit}}}",
            f"{name}: {{register: 0, bit: {bit + 6}}}",
        )
    apply_command(sim, "run")  # a task runs, which the map cannot see
    err = refused(project, capsys)
    assert "Ready 0 (the controller is not ready: still starting up, or Ready is mapped" in err
    assert "check robot.yaml connection.map against RC+" in err
    assert written(sim) == [] and sim.stations[1].limz == -10000
    apply_command(sim, "stop")
