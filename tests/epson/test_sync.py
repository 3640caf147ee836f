"""An Epson robot through the whole workflow over a real TCP socket, against a pymodbus
server whose registers are a fake controller: pull, diff, plan, push, rollback, the
interlock, volatile tables after a power cycle, split writes, points, the register
map and the function reset.  Every check of what reached the robot reads the fake's
own record of the commands it took.

(The full end to end against the Epson simulator is wired when it lands.)"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync import cli, families
from harlsync.errors import InterlockError, ProjectError
from harlsync.families.epson import protocol as p
from harlsync.families.epson.controller import Controller
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.model import PointKey, SettingKey, TableKey
from harlsync.families.epson.protocol import AccelReal, Limits
from harlsync.project import load_project
from harlsync.sync import engine
from harlsync.sync.backup import backup

from .fakerobot import WRITES, FakeRobot, RobotState
from .modbus_server import ModbusServer, free_port


@pytest.fixture
def robot() -> Iterator[tuple[FakeRobot, str]]:
    fake = FakeRobot()
    with ModbusServer(bank=fake.bank) as server:
        yield fake, server.url
    assert fake.bank.function_errors == []  # a correct client never halts the function
    assert fake.busy_writes == []  # ... nor writes to a robot that is not idle
    assert {w[0] for w in fake.commands} <= set(p.COMMANDS)  # ... nor anything off the lists


def pulled(repo: Path, url: str, name: str = "cell-3") -> Path:
    project = repo / name
    assert cli.main(["pull", str(project), "--family", "epson", "--port", url]) == 0
    path = project / "robot.yaml"
    path.write_text(path.read_text().replace("last_point: 99", "last_point: 29"))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    return project


def edit(project: Path, repo: Path, file: str, old: str, new: str) -> None:
    path = project / file
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))
    git(repo, "commit", "-qam", f"edit {file}")


def writes(fake: FakeRobot) -> list[tuple[int, ...]]:
    return [tuple(w[:1]) + tuple(w[1:]) for w in fake.written()]


def test_a_pull_backs_up_every_setting_and_point_exactly_and_diff_finds_no_difference(
    robot, repo
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    loaded = load_project(project)
    assert loaded.robot.family == "epson" and loaded.robot.port == url
    data = loaded.data
    assert (data.type_name, data.axes, data.model) == ("SCARA", 4, "LS6-B602S")
    assert data.items[TableKey("accel_s", 3)] == AccelReal("100.123", "200.000")
    assert data.items[TableKey("speed_s", 2)] == p.SpeedReal("2000.000", "1500.500", "1000.000")
    assert TableKey("accel_s", 4) not in data.items  # not registered: absent
    assert data.items[SettingKey("box", 5)] == (
        Limits("-10.000", "10.000"), Limits("-20.000", "20.000"), Limits("0.000", "50.000"))
    assert data.items[SettingKey("plane", 2)] == ("100.000", "200.000", "-3.250", "90.000")
    assert data.items[SettingKey("limz")] == "-10.000"
    assert sorted(data.points()) == [0, 12, 13]
    assert data.points()[13].coords == ("-1.000", "300.000", "-20.000", "0.000")
    assert (data.points()[13].local, data.points()[13].j6flag) == (1, 5)
    assert [w[0] for w in fake.commands[:2]] == [2153, 2154]
    assert cli.main(["diff", str(project)]) == 0
    assert not fake.written()


def test_diff_shows_a_changed_entry_plan_its_words_and_push_writes_only_it(
    robot, repo, capsys
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "3: {accel: 100.123, decel: 200.000}",
         "3: {accel: 100.123, decel: 250.000}")
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    assert capsys.readouterr().out == (
        f"--- robot {url} unit 1\n+++ project {project}\n"
        "@@ AccelS (volatile) @@\n"
        "-AccelS 3 decel: 200.000\n"
        "+AccelS 3 decel: 250.000\n"
    )
    assert cli.main(["plan", str(project)]) == 0
    assert capsys.readouterr().out.splitlines() == [
        ("53 register AccelS table entry: 0035 0003 0001 871B 0003 D090  # unsafe in automatic "
        "operation"),
        f"# 1 write(s) to cell-3 ({url} unit 1)",
    ]
    assert not fake.written()
    before = dict(fake.state.accel_s)
    assert cli.main(["push", str(project), "--yes"]) == 0
    out = capsys.readouterr().out
    assert "memory card" not in out  # a table is volatile
    assert writes(fake) == [(53, 3, 0x0001, 0x871B, 0x0003, 0xD090, 0, 0)]
    assert fake.state.accel_s[3] == [100123, 250000]
    assert cli.main(["diff", str(project)]) == 0
    assert cli.main(["rollback", str(project), "--yes"]) == 0
    assert fake.state.accel_s == before


def test_a_power_cycle_shows_the_tables_cleared_and_push_registers_them_again(
    robot, repo, capsys
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    held = (dict(fake.state.accel), dict(fake.state.accel_s), dict(fake.state.speed_r),
            fake.state.limz)
    fake.state.power_cycle()
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    out = capsys.readouterr().out
    assert ("@@ AccelS (volatile) @@\n"
            "-AccelS 3: not registered: cleared, e.g. by a power cycle\n"
            "+AccelS 3: {accel: 100.123, decel: 200.000}\n") in out
    assert "@@ LimZ (volatile) @@\n-LimZ: 0.000\n+LimZ: -10.000\n" in out
    assert cli.main(["diff", str(project), "--format", "json"]) == 1
    changes = json.loads(capsys.readouterr().out)["changes"]
    cleared = next(c for c in changes if c["item"] == "AccelS 3")
    assert cleared["kind"] == "accel_s" and cleared["number"] == 3
    assert cleared["fields"] == [{"field": None,
                                  "old": "not registered: cleared, e.g. by a power cycle",
                                  "new": "{accel: 100.123, decel: 200.000}"}]
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert (fake.state.accel, fake.state.accel_s, fake.state.speed_r, fake.state.limz) == held
    assert cli.main(["diff", str(project)]) == 0


def test_push_names_the_persistent_items_it_writes_to_the_memory_card(
    robot, repo, capsys, tmp_path
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "5: {x: [-10.000, 10.000]", "5: {x: [-10.000, 12.000]")
    edit(project, repo, "settings.yaml", "weight: {weight: 2.000,", "weight: {weight: 2.500,")
    capsys.readouterr()
    assert cli.main(["plan", str(project)]) == 0
    lines = capsys.readouterr().out.splitlines()
    note = ("note: written to the controller's memory card (persistent; its life shortens "
            "with each write): Weight, Box 5")
    assert lines[0] == f"# {note}"
    assert lines[1].startswith("300 set Weight and arm length: 012C 0000 09C4 0000 0000  #")
    assert lines[2].startswith("600 set Box, one axis (Rn): 0258 0005 0000 FFFF D8F0 0000 2EE0 | "
                               "0258 0005 0001 ")
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert note in capsys.readouterr().out.splitlines()
    assert [w[0] for w in fake.written()] == [300, 600, 600, 600]
    assert fake.state.box[5][:2] == [-10000, 12000] and fake.state.weight[0] == 2500
    audit = [json.loads(line) for line in (tmp_path / "audit.jsonl").read_text().splitlines()]
    assert audit[-1]["result"] == "ok" and audit[-1]["notes"] == [note[len("note: "):]]


@pytest.mark.parametrize(("signal", "named"), [
    ("Running", "Running 1 (a task is executing)"),
    ("Paused", "Paused 1 (a task is paused)"),
    ("EStopOn", "EStopOn 1 (emergency stop)"),
    ("Error", "Error 1 (the controller is in error)"),
])
def test_a_push_to_a_robot_that_is_not_idle_is_refused_naming_the_signal(
    robot, repo, capsys, signal, named
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    fake.signal(signal)
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert named in err and len(err.strip().splitlines()) == 1
    assert not fake.written()
    fake.signal(signal, False)


def test_a_program_started_mid_push_gets_no_write_after_it(robot, repo, capsys) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    edit(project, repo, "settings.yaml", "  0: 720.000", "  0: 700.000")
    edit(project, repo, "points.yaml", "12: {x: 1.000", "12: {x: 2.000")
    fake.run_after_writes = fake.writes + 1
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert "Running 1 (a task is executing)" in err
    assert "wrote 1 of 3 item(s)" in err and "written:     LimZ: 1250 set LimZ: 04E2 FFFF D120" in err
    assert [w[0] for w in fake.written()] == [1250]
    fake.signal("Running", False)


def test_a_robot_whose_map_lacks_running_is_read_but_never_written(robot, repo, capsys) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "Running: {register: 0, bit: 9}", "Running: null")
    assert cli.main(["diff", str(project)]) == 0
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    capsys.readouterr()
    assert cli.main(["plan", str(project)]) == 0
    reason = ("the register map has no Running signal: harlsync cannot see whether the robot is "
              "busy, so it never writes to it (map the signal in RC+ and in robot.yaml)")
    assert capsys.readouterr().out.splitlines()[0] == f"# cannot write: {reason}"
    assert cli.main(["push", str(project), "--yes"]) == 3
    assert reason in capsys.readouterr().err
    assert not fake.written()


def test_split_writes_go_out_back_to_back_when_rc_plus_assigned_fewer_words(
    robot, repo
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "command_words: 8", "command_words: 5")
    edit(project, repo, "settings.yaml", "3: {accel: 100.123, decel: 200.000}",
         "3: {accel: 1.000, decel: 2.000}")
    edit(project, repo, "settings.yaml", "5: {x: [-10.000, 10.000]", "5: {x: [-10.000, 11.000]")
    taken = len(fake.commands)
    assert cli.main(["push", str(project), "--yes"]) == 0
    sent = [w[0] for w in fake.commands[taken:]]
    # each split or R1/R2 sequence goes out whole, nothing in between
    assert [601, 601, 601, 602, 602, 602] == sent[sent.index(601):sent.index(601) + 6]
    assert [54, 55] == sent[sent.index(54):sent.index(54) + 2]
    assert 53 not in sent and 600 not in sent
    assert fake.state.accel_s[3] == [1000, 2000] and fake.state.box[5][1] == 11000


def test_an_item_on_the_robot_the_project_lacks_is_shown_and_refused(robot, repo,
                                                                    capsys) -> None:
    fake, url = robot
    project = pulled(repo, url)
    fake.state.accel[7] = [10, 20]
    fake.state.points[20] = [0] * 12
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    out = capsys.readouterr().out
    assert "@@ Accel (volatile) @@\n-Accel 7: {accel: 10, decel: 20}\n" in out
    assert "@@ points @@\n-P20: {x: 0.000, y: 0.000" in out
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert "Accel 7: registered on the robot but not in the project" in err
    assert "P20: defined on the robot but not in the project" in err
    assert not fake.written()


def test_push_writes_a_points_changed_fields_and_a_new_point_coordinates_first(
    robot, repo, capsys
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "points.yaml", "12: {x: 1.000, y: 400.000, z: -10.500, u: 90.000, "
         "hand: Lefty", "12: {x: 1.000, y: 400.000, z: -10.750, u: 90.000, hand: Righty")
    edit(project, repo, "points.yaml", "  13: {", "  20: {x: 5.000, y: 6.000, z: 0.000, u: 0.000, "
         "hand: Lefty, elbow: Below, wrist: NoFlip, j4flag: 0, j6flag: 3, local: 2}\n  13: {")
    capsys.readouterr()
    assert cli.main(["plan", str(project)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == ("1204 set a point coordinate: 04B4 000C 0002 FFFF D602; 1206 set a point's "
                        "hand orientation to Righty: 04B6 000C  # unsafe in automatic operation")
    assert lines[2].startswith("1204 set a point coordinate: 04B4 0014 0000 0000 1388 | 04B4 0014 "
                               "0001 0000 1770 | ")
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert fake.state.points[12][2] == -10750 and fake.state.points[12][6] == 1
    assert fake.state.points[20] == [5000, 6000, 0, 0, 0, 0, 0, 1, 0, 0, 3, 2]
    assert [w[0] for w in fake.written()] == [1204, 1206, 1204, 1204, 1204, 1204, 1207, 1209,
                                              1211, 1212, 1213, 1214]
    assert cli.main(["diff", str(project)]) == 0


def test_a_function_left_halted_is_reset_only_when_asked_and_only_on_an_idle_robot(
    robot, repo, capsys
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    fake.bank.fail_next = 0x0001  # the next command halts the function (9999/0001)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 2
    err = capsys.readouterr().err
    assert "function error (ExtError 1): 9999 function error, detail 0001" in err
    assert "--reset-function, on an idle robot" in err
    fake.bank.function_errors.clear()  # that one was on purpose
    assert cli.main(["diff", str(project)]) == 2  # still halted: nothing resets it unasked
    fake.signal("Running")
    assert cli.main(["diff", str(project), "--reset-function"]) == 3
    assert "Running 1 (a task is executing): dropping ExtCmdReset would abort motion" in (
        capsys.readouterr().err)
    fake.signal("Running", False)
    assert cli.main(["diff", str(project), "--reset-function"]) == 0
    assert fake.bank.state == "idle"


def test_reset_function_leaves_an_idle_function_alone(robot, repo) -> None:
    fake, url = robot
    project = pulled(repo, url)
    resets = len([op for op in fake.bank.writes() if op.address == 0 and not op.values[0] & 4])
    assert cli.main(["diff", str(project), "--reset-function"]) == 0
    assert len([op for op in fake.bank.writes()
                if op.address == 0 and not op.values[0] & 4]) == resets


def test_reset_function_is_refused_for_a_family_without_it(tmp_path) -> None:
    robot = families.get("iai").new_robot("cell-9", "socket://127.0.0.1:1", None)
    with pytest.raises(ProjectError, match=r"--reset-function: the iai family has no such "
                       r"option \(only epson\); leave it out"):
        engine.connect(robot, options={"reset_function": True})
    engine_robot = families.get("harl-u2").new_robot("press", "/dev/null", None)
    with pytest.raises(ProjectError, match="the harl-u2 family has no such option"):
        engine.connect(engine_robot, options={"reset_function": True})


def test_a_robot_of_another_type_than_robot_yaml_says_is_refused(robot, repo, capsys) -> None:
    _fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "type: SCARA", "type: RS")
    capsys.readouterr()
    assert cli.main(["pull", str(project)]) == 2
    assert ("the controller reports a SCARA robot (2153), robot.yaml controller.type says RS"
            in capsys.readouterr().err)


def test_a_plant_with_an_epson_robot_is_backed_up_and_committed(robot, repo) -> None:
    fake, url = robot
    pulled(repo, url)
    fake.state.power_cycle()
    report = backup([repo], commit=True)
    assert report.ok, report.render()
    assert report.robots[0].summary == "7 table entries, 1 setting"
    assert "cell-3" in git(repo, "log", "-1", "--format=%B")
    assert "accel_s: {}" in (repo / "cell-3" / "settings.yaml").read_text()


def test_a_refused_connection_is_one_line_without_pymodbus_s_own_log_lines(tmp_path) -> None:
    port = free_port()
    result = subprocess.run(
        [sys.executable, "-m", "harlsync", "pull", str(tmp_path / "x"), "--family", "epson",
         "--port", f"modbus://127.0.0.1:{port}"],
        capture_output=True, text=True, check=False,
    )
    assert result.returncode == 2
    assert result.stderr.splitlines() == [
        (f"harlsync: error: port modbus://127.0.0.1:{port} unit 1: cannot connect: [Errno 111] "
        "Connection refused; check the controller is on, its Modbus TCP slave enabled and the "
        "port right")]


# --- a lost reply, in memory: the handshake's deadline on a fake clock ----------------------


def controller_of(fake: FakeRobot) -> Controller:
    handshake = Handshake(fake.bank, fake.bank.map, clock=fake.bank.clock)
    return Controller(handshake)


def test_a_write_answered_too_late_is_read_back_and_not_sent_again() -> None:
    fake = FakeRobot()
    c = controller_of(fake)
    key, old, new = TableKey("accel_s", 3), AccelReal("100.123", "200.000"), AccelReal("1.000",
                                                                                        "2.000")
    # 500 polls of 5 ms: past the 2 s deadline of the write, within that of the read after
    fake.bank.delays.execute = 500
    answer = fake.answer

    def once(words: tuple[int, ...]) -> tuple[bool, tuple[int, ...]]:
        fake.bank.delays.execute = 0
        return answer(words)

    fake.bank.answer = once
    c.write(c.write_steps(key, new), new, old)
    assert [w[0] for w in fake.commands] == [53, 59]
    assert fake.state.accel_s[3] == [1000, 2000]
    assert fake.bank.function_errors == []


def test_a_write_the_controller_never_took_is_sent_once_more_only_on_an_idle_robot() -> None:
    fake = FakeRobot()
    c = controller_of(fake)
    key = SettingKey("limz")
    pause = False
    write_holding = fake.bank.write_holding

    def withdraw(address: int, values: tuple[int, ...]) -> None:
        requested = fake.bank.state == "requested"
        write_holding(address, values)
        if requested and fake.bank.state == "idle":  # withdrawn at the deadline
            fake.bank.never_acquire = False
            if pause:
                fake.signal("Paused")  # an operator, between the write and its re-send

    fake.bank.write_holding = withdraw  # type: ignore[method-assign]
    fake.bank.never_acquire = True
    c.write(c.write_steps(key, "-5.000"), "-5.000", "-10.000")
    assert [w[0] for w in fake.commands] == [1251, 1250]  # read back, then sent once more
    assert fake.state.limz == -5000

    fake.bank.never_acquire, pause = True, True
    with pytest.raises(InterlockError, match=r"Paused 1 .*not sending it again"):
        c.write(c.write_steps(key, "-6.000"), "-6.000", "-5.000")
    assert [w[0] for w in fake.commands] == [1251, 1250, 1251]
    assert fake.state.limz == -5000 and fake.busy_writes == []


def test_the_read_of_a_point_stops_at_its_first_coordinate_when_it_is_not_defined() -> None:
    fake = FakeRobot(RobotState.sample())
    c = controller_of(fake)
    c.identify()
    assert c.read_point(5) is None
    assert c.read_item(PointKey("point", 12)) is not None
    assert [w[:3] for w in fake.commands[-11:]][:1] == [(1222, 5, 0)]
    assert WRITES.isdisjoint(w[0] for w in fake.commands)


def test_a_map_with_too_few_words_is_refused_by_name_before_anything_is_sent(
    robot, repo, capsys
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "response_words: 8", "response_words: 5")
    taken = len(fake.commands)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"harlsync: error: {url} unit 1: 210 (SpeedS speed and depart table 0) needs 6 response "
        "words, the register map has 5: assign more words in RC+ and in robot.yaml "
        "connection.map")
    sent = {w[0] for w in fake.commands[taken:]}
    assert {60, 61} <= sent and 59 not in sent  # AccelS was read in halves
    assert 210 not in sent
