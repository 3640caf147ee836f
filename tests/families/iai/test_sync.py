"""An IAI robot through the whole workflow, over a real pty and a real TCP socket:
pull, diff, plan, push, rollback, the interlock, and a backup of a plant that
mixes IAI and HARL-U2 robots; the same for global flags and variables when the
project keeps them (``--registers``).  Every check of what reached the robot reads the
simulator's own record."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.families.harl_u2.model import Config, ProgramArea
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.model import Position
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import load_project
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.sync import PushFailed, PushOptions, engine
from harlsync.sync.backup import backup

STATION = 0x99
YES = PushOptions(yes=True)
SMALL = Config(ProgramArea(1, 6), ProgramArea(2, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)


def table(state: SimState) -> dict[int, Position]:
    return dict(state.positions)


@pytest.fixture(params=["tcp", "pty"])
def served(request: pytest.FixtureRequest) -> Iterator[tuple[Simulator, str]]:
    sim = Simulator({STATION: SimState.generate(5, position_range=(1, 120))})
    server = TcpServer(sim) if request.param == "tcp" else PtyServer(sim)
    url = server.start()
    yield sim, url
    server.stop()


def pulled(repo: Path, url: str, name: str = "cell-9") -> Path:
    project = repo / name
    assert (
        cli.main(["pull", str(project), "--family", "iai", "--port", url, "--station", "99"]) == 0
    )
    robot = project / "robot.yaml"
    robot.write_text(robot.read_text().replace("last_position: 1000", "last_position: 120"))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    return project


def move(project: Path, repo: Path, number: int, coord: str) -> None:
    """Change the first coordinate of a position, as an engineer's edit would."""
    path = project / "positions.yaml"
    lines = [
        re.sub(r"coords: \[[^,\]]+", f"coords: [{coord}", line, count=1)
        if line.startswith(f"  {number}: ")
        else line
        for line in path.read_text().splitlines()
    ]
    path.write_text("\n".join(lines) + "\n")
    git(repo, "commit", "-qam", f"move position {number}")


def writes(sim: Simulator) -> list[str]:
    return [r.payload for r in sim.received if r.is_write]


def keeping(repo: Path, url: str) -> Path:
    """A project that keeps registers: pulled, robot.yaml set to keep them, pulled again."""
    project = pulled(repo, url)
    robot = project / "robot.yaml"
    robot.write_text(robot.read_text() + "keep_registers: true\n")
    assert cli.main(["pull", str(project)]) == 0
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "keep flags and variables")
    return project


def set_values(project: Path, repo: Path, values: dict[int, str]) -> None:
    """Change flags and variables in variables.yaml by number, as an engineer's edit would
    (the default ranges do not overlap)."""
    path = project / "variables.yaml"
    lines = path.read_text().splitlines()
    for i, line in enumerate(lines):
        number = line.split(":")[0].strip()
        if line.startswith("  ") and int(number) in values:
            lines[i] = f"  {number}: {values[int(number)]}"
    path.write_text("\n".join(lines) + "\n")
    git(repo, "commit", "-qam", "set flags and variables")


def held(state: SimState) -> tuple[dict[int, bool], dict[int, int], dict[int, str]]:
    """The simulator's flags and variables in the default ranges, as a project keeps them."""
    return (
        {n: n in state.flags for n in range(600, 900)},
        {n: state.integers.get(n, 0) for n in range(200, 300)},
        {n: repr(state.reals.get(n, 0.0)) for n in range(300, 400)},
    )


def edited(repo: Path, url: str, registers: bool) -> Path:
    """A project with a committed change to push: a position moved, or (``registers``)
    an integer variable and two flags set."""
    if registers:
        project = keeping(repo, url)
        set_values(project, repo, {200: "5", 600: "true", 601: "true"})
    else:
        project = pulled(repo, url)
        move(project, repo, min(load_project(project).data.positions), "3.000")
    return project


def test_a_pull_backs_up_every_position_exactly_and_diff_finds_no_difference(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    loaded = load_project(project)
    assert loaded.robot.family == "iai" and loaded.robot.station == STATION
    held = {n: p for n, p in table(sim.stations[STATION]).items() if n <= 120}
    assert loaded.data.positions == held
    assert cli.main(["diff", str(project)]) == 0
    assert not writes(sim) and not sim.off_list()


def test_push_writes_only_the_changed_positions_and_rollback_restores_them(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    before = table(sim.stations[STATION])
    numbers = sorted(load_project(project).data.positions)[:2]
    for n in numbers:
        move(project, repo, n, "1.500")
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    shown = capsys.readouterr().out
    assert f"+{numbers[0]}: axes [" in shown and "coords [1.500" in shown
    assert cli.main(["push", str(project), "--yes"]) == 0
    said = capsys.readouterr().out
    assert "flash ROM" in said  # the positions are in working memory only
    after = table(sim.stations[STATION])
    assert {n for n in after if after[n] != before.get(n)} == set(numbers)
    assert all(after[n].coords[0] == "1.500" for n in numbers)
    assert all(w.startswith("291") for w in writes(sim))
    assert cli.main(["diff", str(project)]) == 0
    assert cli.main(["rollback", str(project), "--yes"]) == 0
    assert table(sim.stations[STATION]) == before
    assert not sim.off_list() and not sim.writes_while_busy()


def test_plan_prints_each_291h_field_by_field_and_sends_nothing(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    n = min(load_project(project).data.positions)
    move(project, repo, n, "2.000")
    capsys.readouterr()
    sent = len(sim.received)
    assert cli.main(["plan", str(project)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "@@ positions @@" and lines[1].startswith(f"-{n}: axes ")
    assert "coords [2.000" in lines[2] and lines[3].startswith("# 1 item(s) to ")
    assert "291H" not in "".join(lines)  # the wire only with -v (issue 22)
    assert cli.main(["plan", str(project), "-v"]) == 0
    [command] = [line for line in capsys.readouterr().out.splitlines() if "291H" in line]
    assert command.startswith(f"# position {n}: 291H 00 {n:04X} 0001 | ")
    assert "000007D0" in command  # 2.000 mm in 0.001 mm, two's complement
    assert not [r for r in sim.received[sent:] if r.is_write]


@pytest.mark.parametrize(
    ("verb", "named"),
    [
        ("run", "program running (215H status byte 2 bit 5)"),
        ("manual", "MANUAL mode"),
        ("estop", "emergency stop"),
        ("flash", "flash ROM write in progress"),
        ("hold", "axis 1 servo axis in use"),
    ],
)
@pytest.mark.parametrize("registers", [False, True], ids=["positions", "variables"])
def test_a_push_to_a_controller_that_is_not_idle_is_refused_naming_the_bit(
    served: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    verb: str,
    named: str,
    registers: bool,
) -> None:
    sim, url = served
    project = edited(repo, url, registers)
    sim.control(verb, sim.stations[STATION], [])
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes", *["--registers"] * registers]) == 3
    err = capsys.readouterr().err
    assert named in err and len(err.strip().splitlines()) == 1
    assert not writes(sim)


def test_a_position_on_the_robot_the_project_lacks_is_shown_and_refused(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    n = max(load_project(project).data.positions)
    path = project / "positions.yaml"
    path.write_text(
        "".join(
            line
            for line in path.read_text().splitlines(keepends=True)
            if not line.startswith(f"  {n}: ")
        )
    )
    git(repo, "commit", "-qam", "drop a position")
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    assert f"-{n}: axes [" in capsys.readouterr().out
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert f"position {n}: defined on the robot but not in the project" in err
    assert not writes(sim)


@pytest.mark.parametrize("registers", [False, True], ids=["positions", "variables"])
def test_a_program_started_mid_push_gets_no_write_after_it(repo: Path, registers: bool) -> None:
    sim = Simulator({STATION: SimState.generate(8, position_range=(1, 120))})
    server = TcpServer(sim)
    try:
        if registers:
            project = keeping(repo, server.start())
            set_values(project, repo, {200: "5", 220: "6", 300: "1.5"})  # 24CH, 24CH, 24DH
        else:
            project = pulled(repo, server.start())
            positions = sorted(load_project(project).data.positions)
            for n in positions[:: max(1, len(positions) // 4)][:4]:  # scattered: several 291H
                move(project, repo, n, "4.000")
        sim.busy_after_writes = sim.writes + 1
        with pytest.raises(PushFailed) as failed:
            engine.push(project, PushOptions(yes=True, registers=registers))
        assert "program running" in str(failed.value)
        assert len(writes(sim)) == 1 and not sim.writes_while_busy()
    finally:
        server.stop()


def test_a_mixed_plant_is_backed_up_in_one_run_and_committed(repo: Path) -> None:
    iai = Simulator({STATION: SimState.generate(9, position_range=(1, 60))})
    harl = HarlSimulator(HarlState.generate(3, SMALL))
    servers: list[TcpServer | PtyServer] = [TcpServer(iai), PtyServer(harl)]
    try:
        iai_url, harl_url = (s.start() for s in servers)
        pulled(repo, iai_url, "iai-cell")
        robot = repo / "iai-cell" / "robot.yaml"
        robot.write_text(robot.read_text().replace("last_position: 120", "last_position: 60"))
        engine.pull(repo / "press", port=harl_url)
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "first backup")
        first = min(iai.stations[STATION].positions)
        iai.stations[STATION].positions.pop(first)  # changed on the controller
        report = backup([repo], commit=True)
        assert report.ok, report.render()
        by_name = {r.name: r for r in report.robots}
        assert by_name["iai-cell"].changed and not by_name["press"].changed
        assert by_name["iai-cell"].summary == "1 position"
        # Issue 30: kept on the backup branch; the approved files stay as committed.
        kept = git(repo, "show", "harlsync/backup:iai-cell/positions.yaml")
        assert f"  {first}: " not in kept
        assert f"  {first}: " in (repo / "iai-cell" / "positions.yaml").read_text()
        assert "iai-cell" in git(repo, "log", "-1", "--format=%B", "harlsync/backup")
        assert not iai.writes_while_busy() and not iai.off_list()
    finally:
        for server in servers:
            server.stop()


def test_the_audit_record_of_an_iai_push_carries_the_flash_notice(
    served: tuple[Simulator, str], repo: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "audit.jsonl"
    monkeypatch.setenv("HARLSYNC_AUDIT_LOG", str(log))
    _, url = served
    project = pulled(repo, url)
    move(project, repo, min(load_project(project).data.positions), "5.000")
    engine.push(project, YES)
    records = [json.loads(line) for line in log.read_text().splitlines()]
    end = [r for r in records if r.get("result") == "ok"][-1]
    assert "flash ROM" in end["notes"][0]
    assert end["written"][0]["command"].startswith("291H 00 ")


BAD_EDITS = [
    ("coords: [", "coords: [99999999.000, ", "is out of range"),
    ("axes: [", "axes: [1, 2, 3, 4, 5, 6, 7, 8, 9, ", "axes"),
    ("coords: [", "coords: [0.000, ", "coordinate(s) for"),
    ("speed: ", "colour: red, speed: ", "unknown key"),
]


@pytest.mark.parametrize(("old", "new", "said"), BAD_EDITS, ids=[b[2] for b in BAD_EDITS])
def test_a_bad_positions_file_is_one_line_with_file_and_line_exit_2_and_nothing_sent(
    served: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    old: str,
    new: str,
    said: str,
) -> None:
    sim, url = served
    project = pulled(repo, url)
    path = project / "positions.yaml"
    lines = path.read_text().splitlines(keepends=True)
    lines[3] = lines[3].replace(old, new, 1)
    path.write_text("".join(lines))
    git(repo, "commit", "-qam", "a bad edit")
    before = {p: p.read_bytes() for p in project.rglob("*") if p.is_file()}
    sent = len(sim.received)
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "positions.yaml:4: positions." in err[0] and said in err[0]
    assert len(sim.received) == sent
    assert {p: p.read_bytes() for p in project.rglob("*") if p.is_file()} == before


def test_a_duplicate_position_is_one_line_exit_2_and_nothing_sent(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    path = project / "positions.yaml"
    lines = path.read_text().splitlines(keepends=True)
    number = lines[3].split(":")[0].strip()
    lines[4] = f"  {number}:" + lines[4].split(":", 1)[1]
    path.write_text("".join(lines))
    git(repo, "commit", "-qam", "a position twice")
    sent = len(sim.received)
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"positions.yaml:5: positions.{number}: written twice" in err[0]
    assert len(sim.received) == sent


# --- global flags and variables: only when the project keeps them ---------------------------


def test_a_pull_that_keeps_registers_backs_up_flags_and_variables_exactly(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = keeping(repo, url)
    data = load_project(project).data
    assert (data.flags, data.integers, data.reals) == held(sim.stations[STATION])
    assert any(data.flags.values()) and any(data.integers.values())
    flag_queries = [r.payload for r in sim.received if r.command == "20D"]
    assert flag_queries and all(int(q[5:9], 16) % 8 == 0 for q in flag_queries)
    assert cli.main(["diff", str(project), "--registers"]) == 0
    assert not writes(sim) and not sim.off_list()


def test_a_positions_only_pull_reads_no_flag_or_variable(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    assert not (project / "variables.yaml").exists()
    assert {r.command for r in sim.received} <= {"201", "212", "22D"}  # 212H: its axes


def test_diff_shows_flags_and_variables_changed_on_the_robot_only_with_registers(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = keeping(repo, url)
    state = sim.stations[STATION]
    _, integers, reals = held(state)
    state.flags ^= {650}
    state.integers[250] = integers[250] + 77
    state.reals[350] = float(reals[350]) + 2.5
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 0
    assert cli.main(["diff", str(project), "--registers"]) == 1
    shown = capsys.readouterr().out
    on, was = ("true", "false") if 650 in state.flags else ("false", "true")
    assert f"@@ flags @@\n-650: {on}\n+650: {was}\n" in shown
    assert f"@@ integer variables @@\n-250: {integers[250] + 77}\n+250: {integers[250]}\n" in shown
    assert f"@@ real variables @@\n-350: {state.reals[350]!r}\n+350: {reals[350]}\n" in shown


def test_push_registers_writes_only_the_changed_ones_in_runs_and_converges(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = keeping(repo, url)
    state = sim.stations[STATION]
    flags, _, _ = held(state)
    set_values(
        project,
        repo,
        {
            600: str(not flags[600]).lower(),
            601: str(not flags[601]).lower(),
            200: "-1000",
            201: "1",
            202: "2",
            210: "2147483647",
            399: "0.1",
        },
    )
    assert cli.main(["push", str(project), "--yes"]) == 0  # without --registers: nothing
    assert not writes(sim)
    capsys.readouterr()
    assert cli.main(["plan", str(project), "--registers", "-v"]) == 0  # -v: the wire
    commands = [
        line.split(": ", 1)[1]
        for line in capsys.readouterr().out.splitlines()
        if line.startswith("# ") and ": 24" in line
    ]
    assert commands[:5] == [
        "24CH 00 0C8 03 | FFFFFC18 | 00000001 | 00000002  # unsafe in automatic operation",
        "24CH 00 0D2 01 | 7FFFFFFF  # unsafe in automatic operation",
        "24DH 00 18F 01 | 3FB999999999999A  # unsafe in automatic operation",
        f"24BH 00 0258 {int(not flags[600])}  # unsafe in automatic operation",
        f"24BH 00 0259 {int(not flags[601])}  # unsafe in automatic operation",
    ]
    assert cli.main(["push", str(project), "--registers", "--yes"]) == 0
    assert writes(sim) == [
        "24C000C803FFFFFC180000000100000002",
        "24C000D2017FFFFFFF",
        "24D0018F013FB999999999999A",
        f"24B000258{int(not flags[600])}",
        f"24B000259{int(not flags[601])}",
    ]
    assert (state.integers[200], state.integers[201], state.integers[202]) == (-1000, 1, 2)
    assert state.reals[399] == 0.1 and (600 in state.flags) != flags[600]
    assert cli.main(["diff", str(project), "--registers"]) == 0
    assert not sim.writes_while_busy() and not sim.off_list()


def test_rollback_registers_restores_the_flags_and_variables(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = keeping(repo, url)
    before = held(sim.stations[STATION])
    set_values(project, repo, {700: str(not before[0][700]).lower(), 250: "9", 350: "-2.5"})
    assert cli.main(["push", str(project), "--registers", "--yes"]) == 0
    assert held(sim.stations[STATION]) != before
    assert cli.main(["rollback", str(project), "--registers", "--yes"]) == 0
    assert held(sim.stations[STATION]) == before


def test_push_registers_for_a_project_that_does_not_keep_them_is_refused(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    capsys.readouterr()
    assert cli.main(["push", str(project), "--registers", "--yes"]) == 3
    assert (
        "flags, integers, reals: the project does not keep them; set keep_registers: true in "
        "robot.yaml and pull"
    ) in capsys.readouterr().err
    assert not writes(sim)


def test_issue_22_a_291h_the_controller_refuses_is_not_written_in_words_with_no_hex(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Position 150 is inside robot.yaml's range but outside the controller's table:
    # it answers the 291H with & (its code for a number out of range).
    sim, url = served
    project = pulled(repo, url)
    robot = project / "robot.yaml"
    robot.write_text(robot.read_text().replace("last_position: 120", "last_position: 200"))
    with (project / "positions.yaml").open("a") as f:
        f.write("  150: {axes: [1], coords: [1.000], acc: 0.30, dec: 0.30, speed: 100}\n")
    git(repo, "commit", "-qam", "a position past the controller's table")
    capsys.readouterr()

    assert cli.main(["push", str(project), "--yes"]) == 2
    err = capsys.readouterr().err
    assert [r.command for r in sim.received if r.is_write] == ["291"]  # sent once, refused
    assert "not written (position 150): the controller refused it with error code 0B4H" in err
    assert "may or may not" not in err and "unknown" not in err
    assert not re.search(r"[0-9A-F]{16}", err), err  # no frame outside -vv
    assert cli.main(["log", str(project)]) == 0
    shown = capsys.readouterr().out
    assert "may or may not" not in shown and "not written (position 150)" in shown
    assert 150 not in sim.stations[STATION].positions
