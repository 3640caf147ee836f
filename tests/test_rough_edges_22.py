"""The operator's rough edges of issue 22 (item 11), each as it was found.  The robot
is the toy family's (conftest's ``toy``): each edge is the engine's, whatever the family
(the Epson's port scheme is tests/families/epson/test_e2e.py's)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from conftest import git
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import audit, engine, writes
from harlsync.sync.engine import PushOptions

if TYPE_CHECKING:
    from harlsync.families.base import Driver, Words
    from harlsync.project import Robot as ProjectRobot


@dataclass
class Robot:
    sim: Simulator
    url: str
    project: Path
    repo: Path

    def slot(self, number: int) -> int:
        return self.sim.stations[1].slots[number]

    def edit_slot(self, number: int, value: int) -> None:
        slots = self.project / "slots.yaml"
        text = re.sub(rf"(?m)^  {number}: .*$", f"  {number}: {value}", slots.read_text())
        slots.write_text(text)
        git(self.repo, "commit", "-qam", f"slot {number} {value}")


@pytest.fixture
def robot(repo: Path, toy: str) -> Iterator[Robot]:
    sim = Simulator({1: SimState.generate(7)})
    url = register(sim)
    project = repo / "press"
    engine.pull(project, port=url, commit=True, family=toy)
    yield Robot(sim, url, project, repo)
    unregister(url)


def test_rollback_snapshot_takes_the_number_that_snapshots_shows(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    first = robot.slot(1)
    robot.edit_slot(1, 80)
    engine.push(robot.project, PushOptions(yes=True))  # snapshot 1: slot 1 as it was
    robot.edit_slot(1, 90)
    engine.push(robot.project, PushOptions(yes=True))  # snapshot 2: slot 1 80
    assert main(["snapshots", str(robot.project)]) == 0
    assert re.search(r"(?m)^     1  \S+ \S+  push ", capsys.readouterr().out)
    assert main(["rollback", str(robot.project), "--yes", "--snapshot", "1"]) == 0
    assert robot.slot(1) == first
    assert main(["rollback", str(robot.project), "--yes", "--snapshot", "7"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no snapshot 7 (taken: 1, 2, 3)" in err


def test_a_mistyped_plan_path_is_one_line_and_no_failed_push(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    robot.edit_slot(1, 80)
    missing = robot.project.parent / "plan-typo.json"
    assert main(["push", str(robot.project), "--yes", "--plan", str(missing)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{missing}: cannot read the plan" in err
    assert audit.read() == []  # no push was tried: none is recorded


def test_a_plan_of_another_robot_says_so_and_a_stale_plan_exits_3(
    robot: Robot, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot.edit_slot(1, 80)
    saved = tmp_path / "plan.json"
    assert main(["plan", str(robot.project), "--out", str(saved)]) == 0
    other = robot.repo / "other"
    engine.pull(other, port=robot.url, commit=True, family="toy")
    capsys.readouterr()
    assert main(["push", str(other), "--yes", "--plan", str(saved)]) == 3
    err = capsys.readouterr().err
    assert "was made for robot press" in err and "not other" in err
    robot.sim.stations[1].slots[2] = 4444  # the robot changed since the plan
    assert main(["push", str(robot.project), "--yes", "--plan", str(saved)]) == 3
    assert "the robot changed since the plan" in capsys.readouterr().err


def test_issue_32_a_push_called_from_python_refuses_another_robots_plan_before_reading(
    robot: Robot, tmp_path: Path
) -> None:
    """The plan file's check lived in the command line: a push called from Python
    read the robot before the plan's own check refused it."""
    from harlsync.errors import StalePlanError
    from harlsync.sync.deploy import PushOptions, push

    robot.edit_slot(1, 80)
    saved = tmp_path / "plan.json"
    assert main(["plan", str(robot.project), "--out", str(saved)]) == 0
    other = robot.repo / "other"
    engine.pull(other, port=robot.url, commit=True, family="toy")
    asked = len(robot.sim.received)
    with pytest.raises(StalePlanError, match="was made for robot press"):
        push(other, PushOptions(yes=True, plan_file=saved))
    assert robot.sim.received[asked:] == []  # refused before a single request
    assert audit.read() == []


def test_plan_lists_every_reason_a_push_would_be_refused(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    from datetime import datetime

    from harlsync.project.robot import DAYS

    other_day = DAYS[(datetime.now().weekday() + 3) % 7]
    robot_yaml = robot.project / "robot.yaml"
    window = f'maintenance_windows:\n  - days: [{other_day}]\n    start: "01:00"\n    end: "01:30"'
    robot_yaml.write_text(robot_yaml.read_text() + window + "\n")
    git(robot.repo, "commit", "-qam", "a window")
    slots = robot.project / "slots.yaml"
    slots.write_text(re.sub(r"(?m)^  1: .*$", "  1: 80", slots.read_text()))  # uncommitted
    robot.sim.control(robot.sim.family.busy_verb, robot.sim.stations[1], ())
    assert main(["plan", str(robot.project)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3 and all(
        line.startswith("harlsync: warning: a push would be refused now: ") for line in err
    ), err
    assert "has uncommitted changes (press/slots.yaml)" in err[0]
    assert f"outside its maintenance windows ({other_day} 01:00-01:30)" in err[1]
    assert "is not idle: " in err[2]


def test_a_push_refused_part_way_shows_in_status(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    robot.edit_slot(1, 80)
    robot.edit_slot(2, 90)
    real = writes.interlock
    calls: list[str] = []

    def refuse_the_second_write(  # the robot started meanwhile
        driver: Driver[Any, Any], robot_: ProjectRobot, words: Words, before: str
    ) -> None:
        calls.append(before)
        if before.startswith("writing") and len([c for c in calls if c.startswith("writing")]) == 2:
            from harlsync.errors import InterlockError

            raise InterlockError("task 0 in execution")
        return real(driver, robot_, words, before)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(writes, "interlock", refuse_the_second_write)
        assert main(["push", str(robot.project), "--yes"]) == 3
    capsys.readouterr()
    assert main(["status", str(robot.repo)]) == 1
    out = capsys.readouterr().out
    assert re.search(r"(?m)^press\s+partial push\s", out), out
    assert "press: last push refused" in out and "wrote 1 of 2 item(s)" in out


def test_a_second_backup_while_one_runs_says_so_and_backs_up_nothing(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    import threading

    from harlsync.project.lock import project_lock

    holding, done = threading.Event(), threading.Event()

    def first_backup() -> None:  # as a backup that runs: its run lock held
        with project_lock(robot.repo.resolve() / ".harlsync-backup-run", command="backup"):
            holding.set()
            done.wait(30)

    runner = threading.Thread(target=first_backup)
    runner.start()
    try:
        assert holding.wait(30)
        before = (robot.project / ".harlsync" / "backup.json").read_text()
        assert main(["backup", str(robot.repo)]) == 2
        err = capsys.readouterr().err
        assert (
            err.count("\n") == 1 and f"a backup of {robot.repo.resolve()} is running already" in err
        )
        assert "(harlsync backup)" in err and "backs up nothing" in err
        assert (robot.project / ".harlsync" / "backup.json").read_text() == before
    finally:
        done.set()
        runner.join()
    assert main(["backup", str(robot.repo)]) == 0  # once it ended


def test_a_host_and_port_without_a_scheme_suggests_socket_and_modbus(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["pull", str(tmp_path / "new"), "--port", "127.0.0.1:25020"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "socket://127.0.0.1:25020" in err and "modbus://127.0.0.1:25020" in err
    assert not (tmp_path / "new").exists()


def test_status_and_backup_tables_stay_aligned_whatever_a_cell_holds(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    from harlsync.sync.backup import BackupReport, RobotOutcome

    long_port = "socket://" + "a-very-long-serial-device-server-name.plant.example" + ":4001"
    robot_yaml = robot.project / "robot.yaml"
    robot_yaml.write_text(robot_yaml.read_text().replace(robot.url, long_port))
    git(robot.repo, "commit", "-qam", "a long port")
    engine.pull(robot.repo / "second", port=robot.url, commit=True, family="toy")
    assert main(["status", str(robot.repo)]) in (0, 1)
    lines = capsys.readouterr().out.splitlines()
    table = lines[: lines.index("")]
    starts = [m.start() for m in re.finditer(r"(?<=  )\S", table[0])]
    for line in table[1:]:
        for start in starts:  # every column starts under its header
            assert line[start - 2 : start] == "  " and line[start] != " ", (line, start)

    report = BackupReport(
        [
            RobotOutcome("a", "/a", "p", 1, ok=True, summary="no change", duration=1.0),
            RobotOutcome("b", "/b", "p", 1, error="x" * 200, duration=12.5),
        ]
    )
    rows = report.render().splitlines()[:3]
    assert rows[1].index("1.0s") + 4 == rows[2].index("12.5s") + 5  # durations aligned right


def test_tables_align_by_terminal_columns_with_wide_characters(
    robot: Robot, capsys: pytest.CaptureFixture[str]
) -> None:
    from harlsync.columns import fit, width
    from harlsync.sync.backup import BackupReport, RobotOutcome

    assert (width("プレス1"), width("é"), width("e\u0301")) == (7, 1, 1)
    assert fit("プレス1", 5) == "プレ…" and width(fit("プレス1", 5)) == 5
    robot_yaml = robot.project / "robot.yaml"
    robot_yaml.write_text(re.sub(r"(?m)^name: .*$", "name: プレス1", robot_yaml.read_text()))
    git(robot.repo, "commit", "-qam", "a name in Japanese")
    engine.pull(robot.repo / "second", port=robot.url, commit=True, family="toy")
    assert main(["status", str(robot.repo)]) in (0, 1)
    lines = capsys.readouterr().out.splitlines()
    shown = [re.sub(r"[\u3000-\u30ff]", "xx", line) for line in lines[: lines.index("")]]
    assert any("xx" in line for line in shown), lines  # the wide name is in the table
    starts = [m.start() for m in re.finditer(r"(?<=  )\S", shown[0])]
    for line in shown[1:]:
        for start in starts:  # every column starts under its header, on the screen
            assert line[start - 2 : start] == "  " and line[start] != " ", (line, start)
    report = BackupReport(
        [
            RobotOutcome("プレス1", "/a", "p", 1, ok=True, summary="no change", duration=1.0),
            RobotOutcome("b", "/b", "p", 1, ok=True, summary="no change", duration=12.5),
        ]
    )
    rows = [re.sub(r"[\u3000-\u30ff]", "xx", row) for row in report.render().splitlines()[:3]]
    assert rows[1].index("ok") == rows[2].index("ok") == rows[0].index("result")
