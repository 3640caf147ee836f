"""An Epson robot through the whole workflow over real TCP against the Epson
simulator (harlsync.families.epson.sim, a pymodbus server running the §6
handshake): pull, diff, plan, push, rollback, backup (a mixed plant too), the
interlock, volatile tables after a power cycle, split writes, points, the register
map and the function reset.

Every check of what reached the robot reads the simulator's own record; every
test of a correct client ends asserting that the record holds no command off the
lists, no function error and no write while the robot was busy.  One test
drives the Remote I/O wrongly on purpose and does see a function error."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.cli.common import EXIT_REFUSED
from harlsync.families.epson import profile
from harlsync.families.epson.model import EpsonData, SettingKey, TableKey
from harlsync.families.epson.protocol import AccelReal, Limits, SpeedReal
from harlsync.families.epson.sim import CommandReceived, SimState, Simulator
from harlsync.families.epson.sim.memory import memory_of
from harlsync.families.epson.sim.remote import Access
from harlsync.families.epson.transport import ModbusLink
from harlsync.families.harl_u2.model import Config, ProgramArea
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.project import load_project
from harlsync.sim.control import apply_command
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.sync import audit, engine
from harlsync.sync.backup import backup

from .projects import edit, pulled
from .sample import sample_data

SMALL = Config(ProgramArea(1, 6), ProgramArea(2, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)


def clean(sim: Simulator) -> None:
    """What a correct client leaves in the record: nothing off the lists, no
    function error, no write while the robot was not idle."""
    assert sim.off_list() == []
    assert sim.function_errors == []
    assert sim.writes_while_busy() == []


@pytest.fixture
def robot() -> Iterator[tuple[Simulator, str]]:
    """The sample robot (tests/families/epson/sample.py) on the simulator, served over TCP."""
    sim = Simulator(SimState.from_data(sample_data()), execution_time=0.0)
    with sim.serve() as server:
        yield sim, server.url
    clean(sim)


def written(sim: Simulator, since: int = 0) -> list[CommandReceived]:
    """The writes the simulator took (each command of a split or Rn write once)."""
    return [c for c in sim.commands()[since:] if c.is_write]


def numbers(commands: list[CommandReceived]) -> list[int]:
    return [c.number for c in commands]


def test_a_pull_backs_up_every_setting_and_point_exactly_and_diff_finds_no_difference(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    loaded = load_project(project)
    assert loaded.robot.family == "epson" and loaded.robot.port == url
    data = loaded.data
    assert (data.type_name, data.axes, data.model) == ("SCARA", 4, "LS6-B602S")
    assert data.items == sample_data().items  # every item, exactly
    assert data.items[TableKey("accel_s", 3)] == AccelReal("100.123", "200.000")
    assert data.items[TableKey("speed_s", 2)] == SpeedReal("2000.000", "1500.500", "1000.000")
    assert TableKey("accel_s", 4) not in data.items  # not registered: absent
    assert data.items[SettingKey("box", 5)] == (
        Limits("-10.000", "10.000"),
        Limits("-20.000", "20.000"),
        Limits("0.000", "50.000"),
    )
    assert numbers(sim.commands()[:2]) == [2153, 2154]
    assert cli.main(["diff", str(project)]) == 0
    assert written(sim) == []


def test_points_past_the_range_fail_the_pull_and_the_backup_naming_the_setting(
    robot: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 20 item 1: points past P99 were never read, and the pull said nothing."""
    monkeypatch.setattr(profile, "POINT_PROBE_END", 450)
    sim, url = robot
    project = pulled(repo, url)  # last_point: 29 from here on
    capsys.readouterr()
    st = sim.stations[1]
    for n in (30, 31, 32, 150, 400):
        st.points[n] = st.points[12]
    before = (project / "points.yaml").read_text()
    assert cli.main(["pull", str(project)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "5 point(s) defined past controller.last_point 29" in err[0]
    assert "P30-P32, P150, P400" in err[0]
    assert "set controller.last_point: 400 (or more) in robot.yaml and pull again" in err[0]
    assert (project / "points.yaml").read_text() == before  # nothing saved
    report = backup([repo])
    assert not report.ok
    (cell,) = report.robots
    assert not cell.ok and "defined past controller.last_point 29" in (cell.error or "")
    assert "0 of 1 robot(s) backed up" in report.render()
    edit(project, repo, "robot.yaml", "last_point: 29", "last_point: 400")
    result = engine.pull(project)  # the closing line on a terminal says its contents
    assert result.contents.endswith("points (P0-P400 read, none defined P401-P450)")
    assert (
        "P0-P400 read, none defined P401-P450 when pulled" in (project / "points.yaml").read_text()
    )
    assert {150, 400} <= set(load_project(project).data.points())


def test_issue_20_points_before_first_point_fail_the_pull_and_the_backup_naming_the_setting(
    robot: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Review finding 4: the probe looked only past last_point, so with first_point
    20 the sample's P0, P12 and P13 dropped out of the backup and the pull said 0."""
    monkeypatch.setattr(profile, "POINT_PROBE_END", 450)
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "first_point: 0", "first_point: 20")
    before = (project / "points.yaml").read_text()
    capsys.readouterr()
    assert cli.main(["pull", str(project)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "3 point(s) defined before controller.first_point 20" in err[0]
    assert "which this backup would leave out: P0, P12-P13" in err[0]
    assert "set controller.first_point: 0 (or less) in robot.yaml and pull again" in err[0]
    assert (project / "points.yaml").read_text() == before  # nothing saved
    report = backup([repo])
    assert not report.ok
    assert "defined before controller.first_point 20" in (report.robots[0].error or "")
    st = sim.stations[1]
    st.points[14] = st.points.pop(0)
    edit(project, repo, "robot.yaml", "first_point: 20", "first_point: 10")
    result = engine.pull(project)
    assert result.contents.endswith("points (P10-P29 read, none defined P0-P9 and P30-P450)")
    text = (project / "points.yaml").read_text()
    assert "P10-P29 read, none defined P0-P9 and P30-P450 when pulled" in text
    data = load_project(project).data
    assert set(data.points()) == {12, 13, 14}
    assert (data.covered, data.probed_to) == ((10, 29), 450)  # kept by a load and a save


def test_diff_plan_push_and_rollback_of_a_changed_table_entry(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit(
        project,
        repo,
        "settings.yaml",
        "3: {accel: 100.123, decel: 200.000}",
        "3: {accel: 100.123, decel: 250.000}",
    )
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    assert capsys.readouterr().out == (
        f"--- robot {url} unit 1\n+++ project {project}\n"
        "@@ AccelS (volatile) @@\n"
        "-AccelS 3 decel: 200.000\n"
        "+AccelS 3 decel: 250.000\n"
    )
    assert cli.main(["plan", str(project)]) == 0
    assert capsys.readouterr().out.splitlines() == [  # what diff shows (issue 22)
        "@@ AccelS (volatile) @@",
        "-AccelS 3 decel: 200.000",
        "+AccelS 3 decel: 250.000",
        f"# 1 item(s) to cell-3 ({url} unit 1)",
    ]
    assert cli.main(["plan", str(project), "-v"]) == 0
    assert (
        "# AccelS 3: 53 register AccelS table entry: 0035 0003 0001 871B 0003 D090  # unsafe in "
        "automatic operation"
    ) in capsys.readouterr().out.splitlines()
    assert written(sim) == []
    before = dict(sim.stations[1].accel_s)
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert "memory card" not in capsys.readouterr().out  # a table is volatile
    assert [c.payload for c in written(sim, taken)] == ["0035 0003 0001 871B 0003 D090 0000 0000"]
    assert sim.stations[1].accel_s[3] == (100123, 250000)
    assert cli.main(["diff", str(project)]) == 0
    assert cli.main(["rollback", str(project), "--yes"]) == 0
    assert sim.stations[1].accel_s == before
    assert cli.main(["diff", str(project)]) == 1  # the project still says 250.000


def test_a_power_cycle_shows_the_tables_cleared_and_push_registers_them_again(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    st = sim.stations[1]
    held = (
        dict(st.accel),
        dict(st.accel_s),
        dict(st.speed),
        dict(st.speed_s),
        dict(st.speed_r),
        st.limz,
    )
    apply_command(sim, "power-cycle")
    assert (st.accel, st.accel_s, st.limz) == ({}, {}, 0)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    out = capsys.readouterr().out
    assert (
        "@@ AccelS (volatile) @@\n"
        "-AccelS 3: not registered: cleared, e.g. by a power cycle\n"
        "+AccelS 3: {accel: 100.123, decel: 200.000}\n"
    ) in out
    assert "@@ LimZ (volatile) @@\n-LimZ: 0.000\n+LimZ: -10.000\n" in out
    assert cli.main(["diff", str(project), "--format", "json"]) == 1
    changes = json.loads(capsys.readouterr().out)["changes"]
    cleared = next(c for c in changes if c["item"] == "AccelS 3")
    assert cleared["kind"] == "accel_s" and cleared["number"] == 3
    assert cleared["fields"] == [
        {
            "field": None,
            "old": "not registered: cleared, e.g. by a power cycle",
            "new": "{accel: 100.123, decel: 200.000}",
        }
    ]
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert "memory card" not in capsys.readouterr().out  # volatile items only
    assert sorted(numbers(written(sim, taken))) == [1, 53, 151, 203, 251, 1250]
    assert (st.accel, st.accel_s, st.speed, st.speed_s, st.speed_r, st.limz) == held
    assert cli.main(["diff", str(project)]) == 0


def test_push_writes_only_what_differs_and_names_the_persistent_items(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "5: {x: [-10.000, 10.000]", "5: {x: [-10.000, 12.000]")
    edit(project, repo, "settings.yaml", "weight: {weight: 2.000,", "weight: {weight: 2.500,")
    capsys.readouterr()
    assert cli.main(["plan", str(project)]) == 0
    lines = capsys.readouterr().out.splitlines()
    note = (
        "note: written to the controller's memory card (persistent; its life shortens "
        "with each write): Weight, Box 5"
    )
    assert lines[0] == f"# {note}"
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0
    assert note in capsys.readouterr().out.splitlines()
    assert numbers(written(sim, taken)) == [300, 600, 600, 600]
    st = sim.stations[1]
    assert st.boxes[5][0] == (-10000, 12000) and st.weight[0] == 2500
    audit = [json.loads(line) for line in (tmp_path / "audit.jsonl").read_text().splitlines()]
    assert audit[-1]["result"] == "ok" and audit[-1]["notes"] == [note[len("note: ") :]]
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0  # again: nothing differs
    assert written(sim, taken) == []


@pytest.mark.parametrize(
    ("verb", "named"),
    [
        ("run", "Running 1 (a task is executing)"),
        ("pause", "Paused 1 (a task is paused)"),
        ("estop", "EStopOn 1 (emergency stop)"),
        ("error", "Error 1 (the controller is in error)"),
    ],
)
def test_a_push_to_a_robot_that_is_not_idle_is_refused_naming_the_signal(
    robot: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    verb: str,
    named: str,
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    apply_command(sim, verb)
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert named in err and len(err.strip().splitlines()) == 1
    assert written(sim) == [] and sim.stations[1].limz == -10000
    apply_command(sim, "stop")


def writes_sent_again_unlooked(sim: Simulator) -> list[Access]:
    """From the simulator's own record of register accesses: each write that
    arrived again, the same words at the same address, with no read of the
    controller's outputs (the status) since the first."""
    since_status: set[tuple[int, tuple[int, ...]]] = set()
    again: list[Access] = []
    for access in sim.remote().log:
        if access.kind == "read_input":
            since_status.clear()
        elif access.kind == "write":
            key = (access.address, access.values)
            if key in since_status:
                again.append(access)
            since_status.add(key)
    return again


def test_issue_34_a_lost_write_is_not_sent_again_to_a_robot_that_started(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 34 item 0: the reply to a push's command words (Tool, 500) was lost,
    the robot started, and the Modbus client sent the same words again on its own,
    with no status read between.  Now the link never sends a write twice: harlsync
    reads the tool back, then the status, finds Running and stops."""
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "deadline: 2.0", "deadline: 0.3")
    edit(project, repo, "settings.yaml", "tool: 0", "tool: 3")
    remote = sim.remote()
    real = remote.write_holding
    lost: list[tuple[int, ...]] = []

    def write_holding(address: int, values: list[int]) -> None:
        real(address, values)
        if not lost and values[:1] == [500]:  # the Tool command's words: reply lost
            lost.append(tuple(values))
            sim.drop_replies(1)
            sim.stations[1].running = True  # and the robot starts meanwhile

    remote.write_holding = write_holding  # type: ignore[method-assign]
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert "Running 1 (a task is executing)" in err and "Traceback" not in err
    assert lost, "the Tool command was never sent"
    assert writes_sent_again_unlooked(sim) == []
    sent = [a for a in remote.log if a.kind == "write" and a.values == lost[0]]
    assert len(sent) == 1  # the command words went out once
    assert written(sim) == [] and sim.stations[1].tool == 0  # ExtCmdSet never rose
    sim.stations[1].running = False


def test_a_program_started_mid_push_gets_no_write_after_it(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    edit(project, repo, "settings.yaml", "  0: 720.000", "  0: 700.000")
    edit(project, repo, "points.yaml", "12: {x: 1.000", "12: {x: 2.000")
    sim.busy_after_writes = sim.writes + 1
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert "Running 1 (a task is executing)" in err
    assert "wrote 1 of 3 item(s)" in err
    assert numbers(written(sim)) == [1250]
    sim.busy_after_writes = 0
    apply_command(sim, "stop")


def test_a_point_interrupted_part_way_is_recorded_as_partly_written_and_completed_next(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 19 item 3: a point is several writes; the robot started after the first
    stops the rest, and the result, the audit record and status name what went out
    (the push said "nothing written" while z had changed)."""
    sim, url = robot
    project = pulled(repo, url)
    edit_p12(project, repo)
    sim.busy_after_writes = sim.writes + 1
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert "partly written: P12: z went out; hand not sent" in err
    assert "nothing written" not in err
    assert numbers(written(sim)) == [1204]
    st = sim.stations[1]
    assert st.points[12].coords[2] == -10750 and st.points[12].hand == 0
    record = audit.read()[-1]
    assert record.partly_written is not None
    assert record.partly_written.to_json() == {
        "item": "P12",
        "command": record.partly_written.command,
        "sent": ["z"],
        "unknown": None,
        "not sent": ["hand"],
    }
    assert cli.main(["status", str(project)]) == 1
    out = capsys.readouterr().out
    assert "unfinished push" in out
    assert "stopped part way through P12: z went out; hand not sent" in out
    assert cli.main(["log", str(project)]) == 0
    assert "partly written: P12: z went out; hand not sent" in capsys.readouterr().out
    sim.busy_after_writes = 0
    apply_command(sim, "stop")
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0  # completes it: hand only
    assert numbers(written(sim, taken)) == [1206]
    assert cli.main(["diff", str(project)]) == 0
    capsys.readouterr()
    cli.main(["status", str(project)])
    assert "part way" not in capsys.readouterr().out


def test_a_robot_whose_map_lacks_running_paused_or_estop_is_read_but_never_written(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    for signal, line in (
        ("Running", "Running: {register: 0, bit: 9}"),
        ("Paused", "Paused: {register: 0, bit: 10}"),
        ("EStopOn", "EStopOn: {register: 0, bit: 12}"),
    ):
        robot_yaml = (project / "robot.yaml").read_text()
        assert line in robot_yaml, line
        edit(project, repo, "robot.yaml", line, f"{signal}: null")
        assert cli.main(["diff", str(project)]) == 1  # read: LimZ differs
        capsys.readouterr()
        assert cli.main(["push", str(project), "--yes"]) == 3
        assert f"the register map has no {signal} signal" in capsys.readouterr().err
        assert written(sim) == []
        edit(project, repo, "robot.yaml", f"{signal}: null", line)


def test_split_writes_go_out_back_to_back_when_rc_plus_assigned_fewer_words(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "command_words: 8", "command_words: 5")
    edit(
        project,
        repo,
        "settings.yaml",
        "3: {accel: 100.123, decel: 200.000}",
        "3: {accel: 1.000, decel: 2.000}",
    )
    edit(project, repo, "settings.yaml", "5: {x: [-10.000, 10.000]", "5: {x: [-10.000, 11.000]")
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0
    sent = numbers(sim.commands()[taken:])
    assert [601, 601, 601, 602, 602, 602] == sent[sent.index(601) : sent.index(601) + 6]
    assert [54, 55] == sent[sent.index(54) : sent.index(54) + 2]
    assert 53 not in sent and 600 not in sent
    st = sim.stations[1]
    assert st.accel_s[3] == (1000, 2000) and st.boxes[5][0] == (-10000, 11000)


def test_push_writes_a_points_changed_fields_and_a_new_point_coordinates_first(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    edit_p12(project, repo)
    edit(
        project,
        repo,
        "points.yaml",
        "  13: {",
        "  20: {x: 5.000, y: 6.000, z: 0.000, u: 0.000, "
        "hand: Lefty, elbow: Below, wrist: NoFlip, j4flag: 0, j6flag: 3, local: 2}\n  13: {",
    )
    taken = len(sim.commands())
    assert cli.main(["push", str(project), "--yes"]) == 0
    st = sim.stations[1]
    assert st.points[12].coords[2] == -10750 and st.points[12].hand == 1
    new = st.points[20]
    assert (new.coords, new.hand, new.elbow, new.j6flag, new.local) == (
        (5000, 6000, 0, 0),
        0,
        1,
        3,
        2,
    )
    assert numbers(written(sim, taken)) == [
        1204,
        1206,
        1204,
        1204,
        1204,
        1204,
        1207,
        1209,
        1211,
        1212,
        1213,
        1214,
    ]
    assert cli.main(["diff", str(project)]) == 0


def test_an_item_on_the_robot_the_project_lacks_is_shown_and_refused(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    sim.stations[1].accel[7] = (10, 20)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    assert "@@ Accel (volatile) @@\n-Accel 7: {accel: 10, decel: 20}\n" in capsys.readouterr().out
    assert cli.main(["push", str(project), "--yes"]) == 3
    assert "Accel 7: registered on the robot but not in the project" in capsys.readouterr().err
    assert written(sim) == []


def test_a_function_halted_by_a_client_driving_it_wrongly_is_seen_and_reset_when_asked(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """On purpose: a second request while a command runs (§6.5.1) halts the function;
    the simulator records the function error, harlsync reports it and resets it only
    when asked, on an idle robot."""
    sim, url = robot
    project = pulled(repo, url)
    m = sim.register_map
    reset, cmd_set = 1 << m.ext_cmd_reset.bit, 1 << m.ext_cmd_set.bit
    with ModbusLink(url) as link:  # someone else's client, doing it wrong
        link.write_holding(m.command_base, [59, 4, 0, 0, 0, 0, 0, 0])
        link.write_holding(m.ext_cmd_set.register, [reset | cmd_set])
        sim.execution_time = 5.0  # still running when the second request comes
        link.write_holding(m.ext_cmd_set.register, [reset])
        link.write_holding(m.command_base, [3, 4, 0, 0, 0, 0, 0, 0])
        link.write_holding(m.ext_cmd_set.register, [reset | cmd_set])
        link.write_holding(m.ext_cmd_set.register, [reset])
    sim.execution_time = 0.0
    assert [f.detail for f in sim.function_errors] == [0x0001]
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 2
    err = capsys.readouterr().err
    assert "function error (ExtError 1): 9999 function error, detail 0001" in err
    assert cli.main(["diff", str(project)]) == 2  # nothing resets it unasked
    apply_command(sim, "run")
    assert cli.main(["diff", str(project), "--reset-function"]) == 3
    assert "dropping ExtCmdReset would abort motion" in capsys.readouterr().err
    apply_command(sim, "stop")
    assert cli.main(["diff", str(project), "--reset-function"]) == 0
    assert len(sim.function_errors) == 1  # the one caused on purpose, no other
    assert sim.off_list() == [] and sim.writes_while_busy() == []
    sim.remote().faults.clear()  # the teardown checks the correct client's run


def test_a_mixed_plant_of_harl_u2_iai_and_epson_robots_is_backed_up_in_one_run(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    iai = IaiSimulator({0x99: IaiState.generate(9, position_range=(1, 60))})
    harl = HarlSimulator(HarlState.generate(3, SMALL))
    servers: list[TcpServer | PtyServer] = [TcpServer(iai), PtyServer(harl)]
    try:
        iai_url, harl_url = (s.start() for s in servers)
        pulled(repo, url, "epson-cell")
        assert (
            cli.main(
                [
                    "pull",
                    str(repo / "iai-cell"),
                    "--family",
                    "iai",
                    "--port",
                    iai_url,
                    "--station",
                    "99",
                ]
            )
            == 0
        )
        robot_yaml = repo / "iai-cell" / "robot.yaml"
        robot_yaml.write_text(
            robot_yaml.read_text().replace("last_position: 1000", "last_position: 60")
        )
        engine.pull(repo / "press", port=harl_url)
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "first backup")
        apply_command(sim, "power-cycle")  # the Epson tables are gone
        first = min(iai.stations[0x99].positions)
        iai.stations[0x99].positions.pop(first)
        report = backup([repo], commit=True)
        assert report.ok, report.render()
        by_name = {r.name: r for r in report.robots}
        assert sorted(by_name) == ["epson-cell", "iai-cell", "press"]
        assert by_name["epson-cell"].changed and by_name["iai-cell"].changed
        assert not by_name["press"].changed
        assert by_name["epson-cell"].summary == "5 table entries, 1 setting"
        # Issue 30: kept on the backup branch, the approved files as committed.
        message = git(repo, "log", "-1", "--format=%B", "harlsync/backup")
        assert "epson-cell" in message and "iai-cell" in message
        assert "accel_s: {}" in git(repo, "show", "harlsync/backup:epson-cell/settings.yaml")
        assert "accel_s: {}" not in (repo / "epson-cell" / "settings.yaml").read_text()
        assert not iai.writes_while_busy() and not iai.off_list()
    finally:
        for server in servers:
            server.stop()


def test_a_robot_of_another_type_than_robot_yaml_says_is_refused(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "type: SCARA", "type: RS")
    capsys.readouterr()
    assert cli.main(["pull", str(project)]) == 2
    assert (
        "the controller reports a SCARA robot (2153), robot.yaml controller.type says RS"
        in capsys.readouterr().err
    )


def test_a_push_or_diff_to_a_controller_of_another_model_is_refused_in_one_line(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 22 item 6: push and diff compare the controller's model (2154) with the
    project's, as pull does."""
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "settings.yaml", "limz: -10.000", "limz: -12.000")
    sim.stations[1].model = "G3-301S"
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    why = (
        "the project is of a LS6-B602S, the controller reports a G3-301S (2154): another "
        "robot, or a replaced one; check the port, or accept it with 'harlsync pull DIR "
        "--new-robot'"
    )
    assert err[-1].endswith(why), err
    assert written(sim) == []
    assert cli.main(["diff", str(project)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"harlsync: error: {project}: not compared: {why}"], err


def with_words(robot: tuple[Simulator, str], repo: Path, words: int) -> tuple[Simulator, Path, int]:
    """The robot pulled, its map given ``words`` response words; the commands so far."""
    sim, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "response_words: 8", f"response_words: {words}")
    return sim, project, len(sim.commands())


def test_a_map_with_too_few_words_is_refused_by_name_before_anything_is_sent(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, project, taken = with_words(robot, repo, 5)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 2
    assert capsys.readouterr().err.strip() == (
        "harlsync: error: robot.yaml:17: connection.map.response_words: 5 words "
        "are fewer than harlsync's reads need: 210 (SpeedS speed and depart table 0) answers "
        "in 6 (allowed: 6-8, as many assigned in RC+)"
    )
    assert sim.commands()[taken:] == []  # validate refused it: nothing was sent


def test_a_map_of_the_fewest_words_the_reads_need_backs_the_robot_up_in_halves(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # fewest_response_words is what protocol/reads.py makes of the controller's reads:
    # a read added to the controller that needs more words fails this pull.
    sim, project, taken = with_words(robot, repo, 6)
    assert cli.main(["diff", str(project)]) == 0
    sent = set(numbers(sim.commands()[taken:]))
    assert {59, 210, 211} <= sent and 209 not in sent  # SpeedS was read in halves


@pytest.mark.parametrize(
    ("data", "field", "old", "new", "command"),
    [
        (sample_data(axes=6), "j1flag", "j1flag: 1", "j1flag: 0", 1223),
        (sample_data(axes=6), "j2flag", "j2flag: 1", "j2flag: 0", 1225),
        (sample_data(rs=True), "j1angle", "j1angle: -12.500", "j1angle: 30.250", 1227),
    ],
    ids=["6-axis J1Flag", "6-axis J2Flag", "RS J1Angle"],
)
def test_a_robot_types_own_point_attributes_are_backed_up_diffed_pushed_and_verified(
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    data: EpsonData,
    field: str,
    old: str,
    new: str,
    command: int,
) -> None:
    """Issue 20 item 2: J1Flag/J2Flag (6-axis, manual 10.25) and J1Angle (RS) were not
    kept, so a restore gave every point flag 0: another joint solution."""
    sim = Simulator(SimState.from_data(data), execution_time=0.0)
    with sim.serve() as server:
        project = pulled(repo, server.url)
        assert load_project(project).data.items == data.items  # kept, exactly
        line = next(t for t in (project / "points.yaml").read_text().splitlines() if "13:" in t)
        assert old in line
        edit(project, repo, "points.yaml", old, new)
        capsys.readouterr()
        assert cli.main(["diff", str(project)]) == 1
        out = capsys.readouterr().out
        assert f"P13 {field}" in out
        taken = len(sim.commands())
        assert cli.main(["push", str(project), "--yes"]) == 0
        assert numbers(written(sim, taken)) == [command]
        held = sim.stations[1].points[13]
        assert {"j1flag": held.j1flag, "j2flag": held.j2flag, "j1angle": held.j1angle}[field] == (
            {"j1flag": 0, "j2flag": 0, "j1angle": 30250}[field]
        )
        assert cli.main(["diff", str(project)]) == 0
    clean(sim)


def test_a_six_axis_project_without_j1flag_and_j2flag_is_refused_naming_them(repo: Path) -> None:
    sim = Simulator(SimState.from_data(sample_data(axes=6)), execution_time=0.0)
    with sim.serve() as server:
        project = pulled(repo, server.url)
    path = project / "points.yaml"
    path.write_text(path.read_text().replace(", j1flag: 1, j2flag: 1", ""))
    from harlsync.project import validate_project

    issues = validate_project(project)
    assert any(
        "points.13: j1flag, j2flag missing: a 6-AXIS robot's points have j1flag and j2flag" in i
        for i in issues
    ), issues


def edit_p12(project: Path, repo: Path) -> None:
    """P12's z and hand changed in the project (two writes: 1204 then 1206)."""
    edit(
        project,
        repo,
        "points.yaml",
        "12: {x: 1.000, y: 400.000, z: -10.500, u: 90.000, hand: Lefty",
        "12: {x: 1.000, y: 400.000, z: -10.750, u: 90.000, hand: Righty",
    )


def _blank(state: SimState) -> SimState:
    """The same manipulator as a new controller has it: its memory lost."""
    return SimState(robot_type=state.robot_type, model=state.model)


@pytest.mark.parametrize(
    "state",
    [
        pytest.param(lambda: SimState.from_data(sample_data()), id="sample SCARA"),
        pytest.param(
            lambda: SimState.generate(11, robot_type=5, point_range=(0, 99)),
            id="generated 6-axis",
            marks=pytest.mark.slow,
        ),
    ],
)
def test_disaster_recovery_drill_a_blank_controller_gets_its_backup_back(
    repo: Path, capsys: pytest.CaptureFixture[str], state: Callable[[], SimState]
) -> None:
    """Issue 20 item 6, over real TCP: back up; the controller comes up blank; push
    the backup; diff is clean and the simulator holds what it held."""
    original = state()
    sim = Simulator(original.copy(), execution_time=0.0)
    project = repo / "cell"
    with sim.serve() as server:
        assert cli.main(["pull", str(project), "--family", "epson", "--port", server.url]) == 0
    clean(sim)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    blank = Simulator(_blank(original), execution_time=0.0)
    with blank.serve() as server:
        edit(project, repo, "robot.yaml", sim_url := _port_of(project), server.url)
        assert sim_url != server.url
        capsys.readouterr()
        assert cli.main(["diff", str(project)]) == 1  # the memory lost
        assert cli.main(["push", str(project), "--yes", "--reason", "restore"]) == 0
        out = capsys.readouterr().out
        assert "wrote and verified" in out
        assert cli.main(["diff", str(project)]) == 0
    clean(blank)
    restored = blank.stations[1]
    assert memory_of(restored) == memory_of(original)  # what survives a power cycle
    for table in ("accel", "accel_s", "accel_r", "speed", "speed_s", "speed_r", "limz"):
        assert getattr(restored, table) == getattr(original, table), table


def _port_of(project: Path) -> str:
    line = next(t for t in (project / "robot.yaml").read_text().splitlines() if "port:" in t)
    return line.split("port:", 1)[1].strip()


def _left_in_use(sim: Simulator) -> None:
    """What a harlsync killed mid-command leaves: ExtCmdSet 1 on a command the
    controller took (ExtCmdGet 1), never cleared."""
    station = sim._controllers[1]
    station.write_holding(0, [0b100])  # ExtCmdReset 1
    station.write_holding(1, [2153, 0, 0, 0, 0, 0, 0, 0])  # read the robot type
    station.write_holding(0, [0b101])  # ExtCmdSet 1, and the process is gone
    station.read_input(0, 9)  # the controller takes it


def test_issue_34_a_function_left_in_use_is_reset_by_the_command_refused_never_by_a_pull(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 34 item 5: a push killed in the middle of a point left the function in
    use, and the next push advised 'harlsync pull DIR --reset-function', which saves
    the robot's half-written point over the committed edit.  Each command refused
    names itself: push, diff and plan; following the advice completes the point."""
    sim, url = robot
    project = pulled(repo, url)
    edit_p12(project, repo)
    _left_in_use(sim)
    for command, code in (("push", 3), ("diff", 2), ("plan", 2)):
        capsys.readouterr()
        args = [command, str(project), *(["--yes"] if command == "push" else [])]
        assert cli.main(args) == code
        err = capsys.readouterr().err
        assert f"'harlsync {command} DIR --reset-function'" in err, err
        assert "harlsync pull" not in err, err
        assert len(err.strip().splitlines()) == 1, err
    assert written(sim) == []  # nothing was written while the function was in use
    assert cli.main(["push", str(project), "--yes", "--reset-function"]) == 0
    assert cli.main(["diff", str(project)]) == 0  # the committed edit, not the robot's
    assert numbers(written(sim)) == [1204, 1206]


def test_a_nightly_backup_recovers_a_function_left_in_use_by_a_dead_harlsync(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 22 item 8: every later night failed that robot until a person ran
    pull --reset-function."""
    sim, url = robot
    project = pulled(repo, url)
    _left_in_use(sim)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 2  # a person is asked, nothing is reset
    assert "the Remote Control function is in use (ExtCmdSet 1, ExtCmdGet 1)" in (
        capsys.readouterr().err
    )
    report = backup([repo])
    assert report.ok, report.render()
    note = (
        "the Remote Control function was found in use (ExtCmdSet 1, ExtCmdGet 1) with no "
        "harlsync on the line and the robot at rest (Running, Paused, EStopOn and Error 0, "
        "Ready 1): left by a harlsync that is gone; reset (manual 6.5.2) before the backup"
    )
    assert f"note: cell-3: {note}" in report.render()
    (record,) = [r for r in audit.read() if r.event == "recover"]
    assert record.note == note and record.robot is not None and record.robot.name == "cell-3"
    assert audit.results() == []  # no push or rollback
    (dropped,) = sim.remote().reset_drops  # the simulator saw one reset, at rest
    assert not any(dropped[s] for s in ("Running", "Paused", "EStopOn", "Error"))
    assert dropped["Ready"]
    assert cli.main(["diff", str(project)]) == 0


def test_issue_22_a_function_reset_is_in_the_audit_log_and_the_report_when_the_pull_then_fails(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    """Review finding 5: the note was recorded only after the read succeeded, so a
    reset followed by a failed read (here a point taught past last_point since)
    changed the robot and left no record of it."""
    sim, url = robot
    pulled(repo, url)
    st = sim.stations[1]
    st.points[40] = st.points[12]  # taught past last_point 29 since the last pull
    _left_in_use(sim)
    report = backup([repo])
    assert not report.ok
    (cell,) = report.robots
    assert "defined past controller.last_point 29" in (cell.error or "")
    assert len(sim.remote().reset_drops) == 1  # the robot was reset ...
    (record,) = [r for r in audit.read() if r.event == "recover"]  # ... and it says so
    assert record.note and record.note.startswith("the Remote Control function was found in use")
    assert record.robot is not None and record.robot.name == "cell-3"
    assert cell.notes == [record.note]
    assert f"note: cell-3: {record.note}" in report.render()


def test_issue_22_a_function_reset_begun_and_not_finished_is_in_the_audit_log_and_the_report(
    robot: tuple[Simulator, str], repo: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Review finding 5, its last gap: a reset that drops ExtCmdReset and then never
    sees the function ready fails the connection itself, before any driver holds a
    note.  The error carries the note, so the record still says the robot was reset."""
    from harlsync.families.epson import handshake as hs
    from harlsync.families.epson.steps import HandshakeTimeout, Step

    sim, url = robot
    pulled(repo, url)
    _left_in_use(sim)
    real = hs.Handshake.reset_function

    def not_ready_after(self: hs.Handshake, **kwargs: bool) -> None:
        real(self, **kwargs)  # ExtCmdReset dropped and raised again, on the simulator
        raise HandshakeTimeout(
            "the function is not ready after its reset",
            port=self.label,
            command="function reset",
            step=Step.FUNCTION_READY,
            acquired=False,
        )

    monkeypatch.setattr(hs.Handshake, "reset_function", not_ready_after)
    report = backup([repo])
    (cell,) = report.robots
    # The first attempt failed on the reset; the next found the function idle again.
    assert "not ready after its reset" in cell.attempts[0] and report.ok
    assert len(sim.remote().reset_drops) == 1  # the robot was reset ...
    (record,) = [r for r in audit.read() if r.event == "recover"]  # ... and it says so
    assert record.note and "a reset (manual 6.5.2) was begun and did not finish" in record.note
    assert cell.notes == [record.note]
    assert f"note: cell-3: {record.note}" in report.render()


@pytest.mark.parametrize(
    ("verb", "signal"), [("pause", "Paused 1"), ("estop", "EStopOn 1"), ("error", "Error 1")]
)
def test_issue_22_a_nightly_backup_never_resets_the_function_of_a_robot_not_at_rest(
    robot: tuple[Simulator, str], repo: Path, verb: str, signal: str
) -> None:
    """Review finding 1: Running 0 is not enough.  Dropping ExtCmdReset aborts a
    paused task, and a robot in an emergency stop or an error wants a person, so
    the function is left as found and the robot fails, naming why."""
    sim, url = robot
    pulled(repo, url)
    _left_in_use(sim)
    apply_command(sim, verb)
    report = backup([repo])
    apply_command(sim, "stop")
    assert not report.ok
    error = report.robots[0].error or ""
    assert "the Remote Control function is in use (ExtCmdSet 1, ExtCmdGet 1)" in error
    assert f"on a robot not at rest ({signal}" in error
    assert "'harlsync pull --reset-function' clears it" in error
    assert sim.remote().reset_drops == []  # ExtCmdReset never dropped
    assert [r for r in audit.read() if r.event == "recover"] == []
    assert report.robots[0].notes == []


def test_a_nightly_backup_leaves_a_function_in_use_on_a_running_robot_alone(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    _left_in_use(sim)
    apply_command(sim, "run")
    report = backup([repo])
    assert not report.ok
    assert "the Remote Control function is in use" in (report.robots[0].error or "")
    assert [r for r in audit.read() if r.event == "recover"] == []
    apply_command(sim, "stop")
    assert sim.stations[1].points and project.exists()


def test_issue_24_review_a_dirty_project_is_refused_before_the_connection_drives_a_signal(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    """Epson's connection drives its handshake inputs when it starts (and with
    --reset-function resets the function): a pull of a project with uncommitted edits
    is refused before it connects, not once the line is open as a HARL-U2's is."""
    sim, url = robot
    project = pulled(repo, url)
    (project / "robot.yaml").write_text((project / "robot.yaml").read_text())  # unchanged
    points = next(p for p in sorted(project.rglob("*.yaml")) if p.name != "robot.yaml")
    points.write_text(points.read_text() + "# checked by hand\n")
    before = sim.accesses()
    assert cli.main(["pull", str(project), "--reset-function"]) == EXIT_REFUSED
    assert sim.accesses() == before  # not a register read, not a signal driven


def test_a_modbus_port_implies_the_epson_family(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """(Issue 22 item 11, from tests/test_rough_edges_22.py.)"""
    sim = Simulator(SimState.from_data(sample_data()), execution_time=0.0)
    with sim.serve() as server:
        assert server.url.startswith("modbus://")
        assert cli.main(["pull", str(repo / "cell-3"), "--port", server.url]) == 0
    assert "family: epson" in (repo / "cell-3" / "robot.yaml").read_text()
