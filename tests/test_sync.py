"""The sync engine end to end: pull, diff, plan, push, rollback against the simulator
over a real pty and a real TCP socket, asserting on what the simulator received."""

from __future__ import annotations

import dataclasses
import json
import shutil
from collections.abc import Iterator
from datetime import datetime, tzinfo
from decimal import Decimal
from pathlib import Path

import pytest
from conftest import git
from simline import DuplicatingLine

from harlsync.cli import main
from harlsync.errors import (
    InterlockError,
    LinkTimeout,
    PolicyError,
    PortBusyError,
    ProjectError,
    ProjectInvalid,
    StalePlanError,
    VerifyError,
)
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.project import load_project, save_project, validate_project
from harlsync.sim import Faults, Received
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.sync import PushFailed, PushOptions, engine, writes
from harlsync.sync import audit as audit_log
from harlsync.sync import git as git_ops
from harlsync.sync import snapshots as snapshot_store

SMALL = Config(
    ProgramArea(1, 8), ProgramArea(2, 12), ProgramArea(2, 8), ProgramArea(1, 6), 4, 16, 4
)


def same_robot(a: SimState, b: SimState) -> bool:
    x, y = a.data, b.data
    return (x.config, x.parameters, x.programs, x.offsets, x.timers) == (
        y.config,
        y.parameters,
        y.programs,
        y.offsets,
        y.timers,
    )


@pytest.fixture(params=["tcp", "pty"])
def served(request: pytest.FixtureRequest) -> Iterator[tuple[Simulator, str]]:
    sim = Simulator(SimState.generate(11, SMALL))
    server = TcpServer(sim) if request.param == "tcp" else PtyServer(sim)
    url = server.start()
    yield sim, url
    server.stop()


def pulled(repo: Path, url: str) -> Path:
    """A project pulled from ``url`` and committed."""
    project = repo / "cell"
    engine.pull(project, port=url)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    return project


def blank_like(sim: Simulator) -> Simulator:
    return Simulator(SimState.blank(sim.stations[1].data.config))


def serve(sim: Simulator) -> TcpServer:
    server = TcpServer(sim)
    server.start()
    return server


def short_deadline(project: Path) -> None:
    """A reply deadline of 0.2 s in robot.yaml, for a command that must time out."""
    robot = project / "robot.yaml"
    text = robot.read_text()
    assert "timeout: 1.0" in text
    robot.write_text(text.replace("timeout: 1.0", "timeout: 0.2"))


def edit_timer(project: Path, number: int, value: str, repo: Path | None = None) -> None:
    text = (project / "timers.yaml").read_text()
    lines = [
        f"  {number}: {value}" if line.startswith(f"  {number}: ") else line
        for line in text.splitlines()
    ]
    (project / "timers.yaml").write_text("\n".join(lines) + "\n")
    if repo is not None:
        git(repo, "commit", "-qam", f"timer {number}")


def set_step(
    project: Path, ptype: ProgramType, number: int, step: int, text: str, repo: Path | None = None
) -> None:
    """Edit one step the way an engineer's change would land: through the project files."""
    loaded = load_project(project)
    loaded.data.programs[(ptype, number)][step] = Step.parse(text)
    save_project(project, loaded)
    if repo is not None:
        git(repo, "commit", "-qam", f"{ptype.value} {number} step {step}")


YES = PushOptions(yes=True)


def test_pull_then_push_to_a_blank_controller_gives_identical_state(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    blank = blank_like(sim)
    with serve(blank) as target:
        result = engine.push(project, YES, port=target.url)
    assert result.ok and result.written
    assert same_robot(blank.stations[1], sim.stations[1])
    letters = {r.command for r in blank.writes_received()}
    assert letters <= {"SNE", "SNL", "SNT", "SNA", "SNM", "SNS", "SNH"}
    assert not letters & {"SNOB", "SNOD", "SNBB", "SNBD", "SND", "SNX"}


def test_push_writes_only_what_differs_in_the_safe_order(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 2, "7.25", repo)
    set_step(project, ProgramType.MAIN, 1, 11, "MOVE P999 S20", repo)
    before = len(sim.received)
    engine.push(project, YES, port=url)
    writes = [r.payload for r in sim.received[before:] if r.is_write]
    assert writes == ["SNT 2 7.25", "SNM 1 11 MOVE P999 S20"]
    assert sim.stations[1].data.timers[2] == "7.25"


def test_diff_exit_codes_are_0_identical_1_different_2_error(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    assert main(["diff", str(project), "--port", url]) == 0
    edit_timer(project, 1, "9.99")
    capsys.readouterr()
    assert main(["diff", str(project), "--port", url]) == 1
    out = capsys.readouterr().out
    assert "@@ timers @@" in out and "+1: 9.99" in out
    assert f"-1: {sim.stations[1].data.timers[1]}" in out
    short_deadline(project)  # station 3 never answers: fail in 0.8 s, not 4
    assert main(["diff", str(project), "--port", url, "--station", "3"]) == 2
    assert "station 3" in capsys.readouterr().err


def test_diff_json_matches_items_by_identity(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    in_project = load_project(project).data.programs[(ProgramType.SUB, 1)][0].text
    state = sim.stations[1].data
    state.programs[(ProgramType.SUB, 1)][0] = Step.parse("WAIT DI3 ON")
    del state.programs[(ProgramType.MAIN, 0)][1]
    capsys.readouterr()
    assert main(["diff", str(project), "--port", url, "--format", "json"]) == 1
    report = json.loads(capsys.readouterr().out)
    restored = load_project(project).data.programs[(ProgramType.MAIN, 0)][1].text
    assert report["changes"] == [
        {
            "kind": "step",
            "item": "MAIN program 0 step 1",
            "program_type": "MAIN",
            "program": 0,
            "step": 1,
            "fields": [{"field": None, "old": None, "new": restored}],
        },
        {
            "kind": "step",
            "item": "SUB program 1 step 0",
            "program_type": "SUB",
            "program": 1,
            "step": 0,
            "fields": [{"field": None, "old": "WAIT DI3 ON", "new": in_project}],
        },
    ]


def test_plan_prints_the_commands_and_sends_none(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50")
    before = len(sim.received)
    assert main(["plan", str(project), "--port", url]) == 0
    assert "+0: 0.50" in capsys.readouterr().out  # as diff shows it
    assert main(["plan", str(project), "--port", url, "-v"]) == 0
    assert "# timer 0: SNT 0 0.50" in capsys.readouterr().out  # the wire with -v
    assert not [r for r in sim.received[before:] if r.is_write]


def test_push_to_a_robot_in_automatic_operation_sends_no_sn_command(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50", repo)
    sim.stations[1].start_task(3, "MAIN", 1, 7)
    assert main(["push", str(project), "--port", url, "--yes"]) == 3
    err = capsys.readouterr().err
    assert "task 3 in execution: MAIN program 1 step 7" in err
    assert sim.writes_received() == []


@pytest.mark.parametrize("live_tuning", [False, True])
def test_a_suspended_task_also_blocks_every_write(
    served: tuple[Simulator, str], repo: Path, live_tuning: bool
) -> None:
    sim, url = served
    project = pulled(repo, url)
    set_step(project, ProgramType.MAIN, 0, 11, "MOVE P999 S20", repo)
    sim.stations[1].start_task(0)
    sim.stations[1].suspend_task(0)
    with pytest.raises(PushFailed) as failed:
        engine.push(project, PushOptions(yes=True, allow_live_tuning=live_tuning), port=url)
    assert isinstance(failed.value.cause, InterlockError)
    assert sim.writes_received() == []


def test_a_robot_that_goes_automatic_mid_push_gets_no_unsafe_write_after(repo: Path) -> None:
    source = Simulator(SimState.generate(5, SMALL))
    with serve(source) as server:
        project = pulled(repo, server.url)
    target = blank_like(source)
    target.busy_after_writes = 4
    with serve(target) as server, pytest.raises(PushFailed) as failed:
        engine.push(project, YES, port=server.url)
    assert isinstance(failed.value.cause, InterlockError)
    assert len(target.writes_received()) == 4
    assert target.unsafe_in_automatic() == []
    assert all(not r.busy for r in target.writes_received())
    assert len(failed.value.result.written) == 4


def test_live_tuning_writes_timers_and_offsets_while_running_but_never_programs(repo: Path) -> None:
    source = Simulator(SimState.generate(5, SMALL))
    with serve(source) as server:
        project = pulled(repo, server.url)
        edit_timer(project, 1, "4.44", repo)
        source.stations[1].start_task(0)
        engine.push(project, PushOptions(yes=True, allow_live_tuning=True), port=server.url)
        assert [r.payload for r in source.writes_received()] == ["SNT 1 4.44"]
        set_step(project, ProgramType.MAIN, 0, 11, "MOVE P999 S20", repo)
        with pytest.raises(PushFailed):
            engine.push(project, PushOptions(yes=True, allow_live_tuning=True), port=server.url)
    assert [r.payload for r in source.writes_received()] == ["SNT 1 4.44"]


def test_faults_during_pull_still_give_an_exact_backup(tmp_path: Path) -> None:
    sim = Simulator(SimState.generate(3, SMALL))
    project = tmp_path / "noisy"
    with serve(sim) as server:
        engine.pull(project, port=server.url)
        robot = project / "robot.yaml"
        robot.write_text(robot.read_text().replace("timeout: 1.0", "timeout: 0.2"))
        state = sim.stations[1].data
        state.timers[2] = "5.55"
        state.programs[(ProgramType.HAND, 0)][3] = Step.parse("OUT DO7 ON")
        # Each lost reply costs the 0.2 s deadline: rates that lose some 20, not 50.
        sim.faults = Faults(noise=0.2, drop=0.02, bad_checksum=0.02, fragment=0.3, seed=9)
        engine.pull(project, port=server.url)
    assert sum(not r.answered for r in sim.received) > 0  # the faults did happen
    clean = load_project(project).data
    assert clean.programs == state.programs
    assert clean.offsets == state.offsets and clean.timers == state.timers
    assert clean.parameters == state.parameters and clean.config == state.config


def test_a_pull_that_fails_leaves_the_previous_backup_untouched(tmp_path: Path) -> None:
    sim = Simulator(SimState.generate(3, SMALL))
    project = tmp_path / "cell"
    with serve(sim) as server:
        engine.pull(project, port=server.url)
        short_deadline(project)  # nothing will answer: fail in 0.8 s, not 4
        before = {p: p.read_bytes() for p in project.rglob("*.yaml")}
        sim.stations[1].data.timers[0] = "9.99"
        sim.faults = Faults(drop=1.0)
        with pytest.raises(LinkTimeout):
            engine.pull(project, port=server.url)
    assert {p: p.read_bytes() for p in project.rglob("*.yaml")} == before


def test_issue_11_a_pull_over_a_line_that_repeats_replies_fails_and_the_backup_stays(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = Simulator(SimState.generate(3, SMALL))
    project = tmp_path / "cell"
    with serve(sim) as server:
        engine.pull(project, port=server.url)
    before = every_file(project)
    sim.stations[1].data.timers[0] = "9.99"
    with serve(DuplicatingLine(sim.stations[1])) as server:
        assert main(["pull", str(project), "--port", server.url]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(
        f"harlsync: error: port {server.url}, station 1: the line delivers "
        "replies nobody asked for ("
    )
    assert every_file(project) == before


def every_file(project: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in project.rglob("*") if p.is_file()}


@pytest.mark.parametrize(
    "file,bad,expect",
    [
        ("timers.yaml", "  0: 12.5\n", "timers.yaml:"),
        ("programs/main-00.yaml", "  3: [broken\n", "programs/main-00.yaml:"),
        ("offsets.yaml", None, "offsets.yaml:"),
    ],
    ids=["out of range", "broken yaml", "bad offset"],
)
def test_an_invalid_project_is_refused_before_any_write(
    served: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    file: str,
    bad: str | None,
    expect: str,
) -> None:
    sim, url = served
    project = pulled(repo, url)
    path = project / file
    if bad is None:
        path.write_text(path.read_text().replace("x: 0.00", "x: 10000.00", 1))
    else:
        path.write_text(path.read_text() + bad)
    git(repo, "commit", "-qam", "broken")
    before = len(sim.received)
    assert main(["push", str(project), "--port", url, "--yes"]) == 2
    assert expect in capsys.readouterr().err
    assert sim.received[before:] == []  # the port was not even used


def test_a_configuration_change_is_refused_unless_allowed_and_then_rewrites_every_program(
    repo: Path,
) -> None:
    source = Simulator(SimState.generate(8, SMALL))
    with serve(source) as server:
        project = pulled(repo, server.url)
    other = SMALL.__class__(
        ProgramArea(1, 8), ProgramArea(3, 16), ProgramArea(2, 8), ProgramArea(1, 6), 4, 16, 4
    )
    target = Simulator(SimState.generate(99, other))
    with serve(target) as server:
        with pytest.raises(PushFailed) as failed:
            engine.push(project, YES, port=server.url)
        assert isinstance(failed.value.cause, PolicyError)
        assert "--allow-reconfigure" in str(failed.value)
        assert target.writes_received() == []
        engine.push(project, PushOptions(yes=True, allow_reconfigure=True), port=server.url)
    writes = [r.payload for r in target.writes_received()]
    assert writes[0] == "SNX 1 8 2 12 2 8 1 6"
    assert same_robot(target.stations[1], source.stations[1])


def test_a_stale_plan_is_refused(served: tuple[Simulator, str], repo: Path, tmp_path: Path) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50", repo)
    planfile = tmp_path / "plan.json"
    assert main(["plan", str(project), "--port", url, "--out", str(planfile)]) == 0
    sim.stations[1].data.offsets[3] = dataclasses.replace(sim.stations[1].data.offsets[3], x="1.00")
    with pytest.raises(PushFailed) as failed:
        engine.push(project, PushOptions(yes=True, plan_file=planfile), port=url)
    assert isinstance(failed.value.cause, StalePlanError)
    assert sim.writes_received() == []


def test_a_fresh_plan_is_pushed(served: tuple[Simulator, str], repo: Path, tmp_path: Path) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50", repo)
    planfile = tmp_path / "plan.json"
    assert main(["plan", str(project), "--port", url, "--out", str(planfile)]) == 0
    assert main(["push", str(project), "--port", url, "--yes", "--plan", str(planfile)]) == 0
    assert [r.payload for r in sim.writes_received()] == ["SNT 0 0.50"]


def test_rollback_restores_the_snapshot(served: tuple[Simulator, str], repo: Path) -> None:
    sim, url = served
    project = pulled(repo, url)
    original = SimState.from_robot_data(sim.stations[1].data)
    edit_timer(project, 3, "3.33")
    set_step(project, ProgramType.SUB, 1, 7, "MOVE P999 S20", repo)
    result = engine.push(project, YES, port=url)
    assert result.snapshot is not None and sim.stations[1].data.timers[3] == "3.33"
    assert main(["rollback", str(project), "--port", url, "--yes"]) == 0
    assert same_robot(sim.stations[1], original)


def test_rollback_is_interlocked_too(served: tuple[Simulator, str], repo: Path) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 3, "3.33", repo)
    engine.push(project, YES, port=url)
    sim.stations[1].start_task(1)
    writes = len(sim.writes_received())
    with pytest.raises(PushFailed) as failed:
        engine.rollback(project, YES, port=url)
    assert isinstance(failed.value.cause, InterlockError)
    assert len(sim.writes_received()) == writes


def test_the_audit_log_records_every_push_with_its_items(
    served: tuple[Simulator, str], repo: Path, tmp_path: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    old = sim.stations[1].data.timers[2]
    edit_timer(project, 2, "2.22", repo)
    engine.push(project, PushOptions(yes=True, reason="cycle time tuning"), port=url)
    sim.stations[1].start_task(0)
    edit_timer(project, 2, "2.23", repo)
    with pytest.raises(PushFailed):
        engine.push(project, YES, port=url)
    records = audit_log.results(tmp_path / "audit.jsonl")
    assert [r.result for r in records] == ["ok", "refused"]
    ok = records[0]
    assert ok.action == "push" and ok.reason == "cycle time tuning"
    assert ok.user and ok.host and ok.time
    assert ok.commit == git(repo, "rev-parse", "HEAD~1").strip()
    assert ok.robot is not None
    assert ok.robot.to_json() == {"name": "cell", "port": url, "station": 1}
    assert ok.plan == ["SNT 2 2.22"]
    assert [w.to_json() for w in ok.done] == [
        {
            "item": "timer 2",
            "command": "SNT 2 2.22",
            "old": old,
            "new": "2.22",
            "changes": [{"item": "timer 2", "field": None, "old": old, "new": "2.22"}],
        }
    ]
    assert records[1].error and "task 0 in execution" in records[1].error
    assert records[1].written == []


def test_a_dirty_project_or_one_outside_git_is_refused(
    served: tuple[Simulator, str], repo: Path, tmp_path: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50")  # not committed
    with pytest.raises(PolicyError, match="uncommitted"):
        engine.push(project, YES, port=url)
    loose = tmp_path / "loose"
    engine.pull(loose, port=url)
    with pytest.raises(PolicyError, match="not in a git repository"):
        engine.push(loose, YES, port=url)
    engine.push(project, PushOptions(yes=True, allow_dirty=True), port=url)
    assert [r.payload for r in sim.writes_received()] == ["SNT 0 0.50"]


@pytest.mark.parametrize("object_format", ["sha1", "sha256"])
def test_git_tells_which_files_a_commit_holds_byte_for_byte(
    tmp_path: Path, object_format: str
) -> None:
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q", f"--object-format={object_format}")
    names = ["a [x]*.yaml", "b.yaml", "c.yaml", "d.yaml"]  # pathspec magic is a name here
    for name in names:
        (root / name).write_bytes(b"same\r\n")
    (root / ".gitignore").write_text("d.yaml\n")
    git(root, "add", "a [x]*.yaml", "b.yaml", ".gitignore")
    git(root, "commit", "-qm", "two")
    files = {name: (root / name).read_bytes() for name in names}
    files["b.yaml"] += b"x"
    assert git_ops.not_in_commit(root, git_ops.head(root), files) == {
        "b.yaml": "differs",
        "c.yaml": "missing",
        "d.yaml": "ignored",
    }
    assert git_ops.not_in_commit(root, None, {"a [x]*.yaml": b"same\r\n"}) == {
        "a [x]*.yaml": "missing"
    }


class Numeric(Simulator):
    """A controller that keeps numbers, not the text they were written in, as a real
    one does: an offset, a timer, a register, M and F read back in their one form
    (offsets with no leading zeros and no minus zero, registers four digits).  Steps
    and parameters are kept as written, as the profile says.  Written by hand here,
    not with harlsync's own functions."""

    def handle(self, state: SimState, payload: str) -> str:
        letters, *args = payload.split(" ")
        try:
            if letters == "SNL" and len(args) == 9:
                args = [args[0], *map(hundredths, args[1:7]), *(str(int(a)) for a in args[7:])]
            elif letters == "SNT" and len(args) == 2:
                args[1] = hundredths(args[1])
            elif letters == "SND" and len(args) == 2:
                args[1] = f"{int(args[1]):04d}"
        except ArithmeticError:  # not a number: the controller refuses it as before
            pass
        return super().handle(state, " ".join([letters, *args]))


def hundredths(text: str) -> str:
    n = int(Decimal(text) * 100)
    return f"{'-' if n < 0 else ''}{abs(n) // 100}.{abs(n) % 100:02d}"


def table_3(x: str = "0.00", y: str = "0.00", m: str = "0") -> str:
    return f"  3: {{x: {x}, y: {y}, z: 0.00, w: 0.00, r: 0.00, c: 0.00, m: {m}, f: 0}}"


#: an edit (file, the line that replaces the one with its key) -> the one form
#: validate asks for instead (None: the edit is valid as written)
EDITS = {
    "offset 0012.50": ("offsets.yaml", table_3(x="0012.50"), "12.50"),
    "offset 12.50": ("offsets.yaml", table_3(x="12.50"), None),
    "offset -0000.00": ("offsets.yaml", table_3(y="-0000.00"), "0.00"),
    "offset -0.05": ("offsets.yaml", table_3(y="-0.05"), None),
    "M 07": ("offsets.yaml", table_3(m="07"), "7"),
    "M 7": ("offsets.yaml", table_3(m="7"), None),
    "timer 0.80": ("timers.yaml", "  1: 0.80", None),
    "register 0012": ("registers.yaml", "  1: 0012", None),
    "parameter 51": ("parameters.yaml", "pull_rate: 51", None),
    "step": ("programs/main-00.yaml", "  - MOVE P010 S50", None),  # step 1
}


@pytest.mark.parametrize("edit", list(EDITS))
def test_issue_11_a_push_of_a_validated_project_converges_on_a_controller_that_keeps_numbers(
    repo: Path, edit: str
) -> None:
    # Issue 11: an offset written 0012.50 passed validate; the controller read it back
    # as 12.50, so the push failed its verification and every rerun wrote it again.
    sim = Numeric(SimState.generate(11, SMALL))
    with serve(sim) as server:
        project = pulled(repo, server.url)
        robot_yaml = project / "robot.yaml"
        robot_yaml.write_text(
            robot_yaml.read_text().replace("keep_registers: false", "keep_registers: true")
        )
        engine.pull(project)
        file, line, one = EDITS[edit]
        path = project / file
        text = path.read_text()
        lines = text.splitlines()
        if line.startswith("  - "):  # a step: the list's second item is step 1
            at = [i for i, old in enumerate(lines) if old.startswith("  - ")][1]
        else:
            key = line.split(":")[0] + ":"
            assert f"\n{key} " in text, f"{key} not in {file}"
            at = next(i for i, old in enumerate(lines) if old.startswith(key + " "))
        lines[at] = line
        path.write_text("\n".join(lines) + "\n")
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", edit)
        issues = validate_project(project)
        opts = PushOptions(yes=True, registers=True)
        if not issues:  # whatever validate lets through, a push makes the robot equal
            assert engine.push(project, opts).written
            sent = len(sim.writes_received())
            engine.push(project, opts)
            assert len(sim.writes_received()) == sent  # the second push wrote nothing
            assert engine.compare(project, registers=True).changes == []
        if one is None:
            assert issues == []
        else:
            [issue] = issues
            assert f"is not written in its one form (write {one}: " in issue
            with pytest.raises(ProjectInvalid):
                engine.push(project, opts)
            assert sim.writes_received() == []


def test_a_push_outside_the_maintenance_window_is_refused_unless_explained(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    robot_yaml = project / "robot.yaml"
    text = robot_yaml.read_text().replace(
        "maintenance_windows: []",
        "maintenance_windows:\n  - {days: [sat], start: '22:00', end: '04:00'}",
    )
    assert "maintenance_windows:\n  - " in text, "robot.yaml layout changed"
    robot_yaml.write_text(text)
    edit_timer(project, 0, "0.50")
    git(repo, "commit", "-qam", "window")
    tuesday_noon = datetime(2026, 11, 24, 12, 0)
    with pytest.raises(PushFailed) as failed:
        engine.push(project, PushOptions(yes=True, now=tuesday_noon), port=url)
    assert "outside its maintenance windows" in str(failed.value)
    assert sim.writes_received() == []
    saturday_night = datetime(2026, 11, 28, 23, 0)
    engine.push(project, PushOptions(yes=True, now=saturday_night), port=url)
    edit_timer(project, 0, "0.60", repo)
    engine.push(
        project, PushOptions(yes=True, now=tuesday_noon, outside_window="line down"), port=url
    )
    assert [r.payload for r in sim.writes_received()] == ["SNT 0 0.50", "SNT 0 0.60"]


def test_a_write_that_does_not_read_back_fails_the_push_and_names_the_item(
    repo: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    source = Simulator(SimState.generate(4, SMALL))
    with serve(source) as server:
        project = pulled(repo, server.url)
        edit_timer(project, 1, "1.11", repo)
        real = Simulator.handle

        def forgetful(self: Simulator, state: SimState, payload: str) -> str:
            return "0" if payload.startswith("SNT") else real(self, state, payload)

        monkeypatch.setattr(Simulator, "handle", forgetful)
        with pytest.raises(PushFailed) as failed:
            engine.push(project, YES, port=server.url)
    assert isinstance(failed.value.cause, VerifyError)
    assert "timer 1" in str(failed.value)


def test_a_link_lost_mid_push_reports_what_was_written_and_a_rerun_converges(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = Simulator(SimState.generate(6, SMALL))
    with serve(source) as server:
        project = pulled(repo, server.url)
    target = blank_like(source)

    def cut_after_five_writes(record: Received) -> None:
        if record.is_write and len(target.writes_received()) >= 5:
            target.faults = Faults(drop=1.0)

    target.listeners.append(cut_after_five_writes)
    with serve(target) as server:
        assert main(["push", str(project), "--port", server.url, "--yes"]) == 2
        err = capsys.readouterr().err
        assert "push stopped: wrote 4 of" in err and "not written:" in err and "unknown:" in err
        target.listeners.clear()
        target.faults = Faults()
        assert main(["push", str(project), "--port", server.url, "--yes"]) == 0
    assert same_robot(target.stations[1], source.stations[1])


def test_the_lock_holds_a_second_harlsync_off_the_line(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50", repo)
    holder = Link(url, 1)
    holder.open()
    try:
        with pytest.raises(PushFailed) as failed:
            engine.push(project, PushOptions(yes=True, lock_timeout=0.2), port=url)
        assert isinstance(failed.value.cause, PortBusyError)
    finally:
        holder.close()
    assert sim.writes_received() == []


@pytest.mark.parametrize("command", ["push", "rollback"])
def test_push_without_yes_and_without_a_terminal_refuses_before_reading_the_robot(
    served: tuple[Simulator, str],
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    command: str,
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "0.50", repo)
    assert main(["push", str(project), "--port", url, "--yes"]) == 0  # a snapshot to roll back to
    edit_timer(project, 0, "0.60", repo)
    capsys.readouterr()
    sim.received.clear()
    monkeypatch.setattr("sys.stdin.isatty", lambda: False)
    assert main([command, str(project), "--port", url]) == 3
    review = f"review it with 'harlsync plan {project}', then " * (command == "push")
    assert capsys.readouterr().err == (
        f"harlsync: refused: nobody to confirm the {command} (no terminal to ask on) and no "
        f"--yes: nothing was read or written; {review}give --yes\n"
    )
    assert sim.received == []  # issue 14: not minutes of reading the robot first


def test_pull_commit_says_what_changed_and_skips_an_empty_commit(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    sim.stations[1].data.timers[1] = "8.88"
    sim.stations[1].data.programs[(ProgramType.MAIN, 0)][10] = Step.parse("END")
    result = engine.pull(project, port=url, commit=True)
    assert result.commit is not None
    message = git(repo, "log", "-1", "--format=%B")
    assert message.startswith(  # names each item (issue 22), then the summary
        "pull cell: timer 1; MAIN program 0 step 10\n\n1 program (1 step), 1 timer:\n"
    )
    head = git(repo, "rev-parse", "HEAD")
    assert engine.pull(project, port=url, commit=True).commit is None
    assert git(repo, "rev-parse", "HEAD") == head


def test_a_first_pull_without_a_port_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ProjectError, match="give --port"):
        engine.pull(tmp_path / "new")


def test_pull_refuses_to_overwrite_uncommitted_edits_but_not_robot_yaml(
    served: tuple[Simulator, str], repo: Path
) -> None:
    _, url = served
    project = pulled(repo, url)
    robot = project / "robot.yaml"
    robot.write_text(robot.read_text().replace("timeout: 1.0", "timeout: 0.5"))
    engine.pull(project)  # an edited robot.yaml is never overwritten: no refusal
    edit_timer(project, 1, "9.99")
    with pytest.raises(PolicyError, match="timers.yaml"):
        engine.pull(project)
    assert "  1: 9.99" in (project / "timers.yaml").read_text()
    engine.pull(project, allow_dirty=True)
    assert "  1: 9.99" not in (project / "timers.yaml").read_text()


def test_a_push_refused_before_the_port_is_audited_too(
    served: tuple[Simulator, str], repo: Path, tmp_path: Path
) -> None:
    _, url = served
    project = pulled(repo, url)
    edit_timer(project, 0, "12.5", repo)
    with pytest.raises(ProjectError):
        engine.push(project, PushOptions(yes=True, reason="try"), port=url)
    [record] = audit_log.results(tmp_path / "audit.jsonl")
    assert record.result == "refused" and record.error and "timers.yaml" in record.error
    assert record.reason == "try" and record.written == []


def test_a_first_pull_from_a_relative_sim_path_saves_it_absolute(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(Path(__file__).parents[1])
    engine.pull(tmp_path / "demo", port="sim://projects/pick-and-place")
    robot = (tmp_path / "demo" / "robot.yaml").read_text()
    assert f"sim://{Path('projects/pick-and-place').resolve()}" in robot
    monkeypatch.chdir(tmp_path)
    assert engine.compare(tmp_path / "demo").changes == []


def test_a_backup_commit_never_takes_the_leftovers_of_a_save_in_progress(tmp_path: Path) -> None:
    from harlsync.sync import git as git_module

    git(tmp_path, "init", "-q")
    cell = tmp_path / "cell"
    (cell / "programs").mkdir(parents=True)
    (cell / "timers.yaml").write_text("format: 1\n")
    (cell / ".timers.yaml.harlsync-new-4242-9f3ab2c1").write_text("half a save\n")
    (cell / "programs" / ".main-00.yaml.harlsync-old-4242-0c77e1d4").write_text("old\n")
    (cell / ".harlsync-save.json").write_text("{}\n")
    assert git_module.commit([cell], "backup") is not None
    assert git(tmp_path, "show", "--name-only", "--format=", "HEAD").split() == ["cell/timers.yaml"]


class Clock(datetime):
    """The machine's clock, set by the test: it jumps where a real one might."""

    at = datetime(2026, 11, 24, 12, 0)

    @classmethod
    def now(cls, tz: tzinfo | None = None) -> datetime:  # type: ignore[override]  # a plain datetime
        return cls.at.replace(tzinfo=tz)


def test_issue_11_rollback_restores_the_state_before_the_last_push_whatever_the_clock_did(
    served: tuple[Simulator, str], repo: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    sim, url = served
    project = pulled(repo, url)
    monkeypatch.setattr(snapshot_store, "datetime", Clock)
    Clock.at = datetime(2027, 3, 1, 12, 0)  # a year ahead
    edit_timer(project, 1, "1.11", repo)
    engine.push(project, YES, port=url)
    before_the_last_push = SimState.from_robot_data(sim.stations[1].data)
    Clock.at = datetime(2026, 3, 1, 12, 0)  # set right again: the clock fell back a year
    edit_timer(project, 1, "2.22", repo)
    engine.push(project, YES, port=url)
    assert len(engine.snapshots(project)) == 2
    engine.rollback(project, YES, port=url)
    assert same_robot(sim.stations[1], before_the_last_push)


def test_issue_11_snapshots_named_by_an_older_harlsync_are_still_listed_and_come_first(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    edit_timer(project, 1, "1.11", repo)
    engine.push(project, YES, port=url)
    [taken] = engine.snapshots(project)
    legacy = taken.with_name("20991231T235959.000000Z-push")  # an old name, from a fast clock
    taken.rename(legacy)
    assert engine.snapshots(project) == [legacy]
    edit_timer(project, 1, "2.22", repo)
    engine.push(project, YES, port=url)
    [older, newer] = engine.snapshots(project)
    assert older == legacy and load_project(newer).data.timers[1] == "1.11"
    engine.rollback(project, YES, port=url)
    assert sim.stations[1].data.timers[1] == "1.11"
    engine.rollback(project, YES, port=url, snapshot=legacy)
    assert sim.stations[1].data.timers[1] == load_project(legacy).data.timers[1] != "1.11"


def test_issue_11_a_push_stops_before_the_first_write_after_its_maintenance_window_closes(
    served: tuple[Simulator, str],
    repo: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    sim, url = served
    project = pulled(repo, url)
    robot_yaml = project / "robot.yaml"
    robot_yaml.write_text(
        robot_yaml.read_text().replace(
            "maintenance_windows: []",
            "maintenance_windows:\n  - {days: [sat], start: '22:00', end: '04:00'}",
        )
    )
    for timer, value in ((0, "0.11"), (1, "1.11"), (2, "2.22")):
        edit_timer(project, timer, value)
    git(repo, "commit", "-qam", "three timers, a window")

    class WindowClosesAfterTwoWrites(datetime):
        @classmethod
        def now(cls, tz: tzinfo | None = None) -> datetime:  # type: ignore[override]  # a plain datetime
            inside, after = datetime(2026, 11, 28, 23, 0), datetime(2026, 11, 29, 4, 0)
            return (inside if len(sim.writes_received()) < 2 else after).replace(tzinfo=tz)

    monkeypatch.setattr(writes, "datetime", WindowClosesAfterTwoWrites)
    capsys.readouterr()
    assert main(["push", str(project), "--port", url, "--yes"]) == 3
    err = capsys.readouterr().err
    assert [r.payload for r in sim.writes_received()] == ["SNT 0 0.11", "SNT 1 1.11"]
    assert "push stopped: wrote 2 of 3 item(s)" in err
    assert "  not written: timer 2\n" in err and "unknown:" not in err  # -v adds the SN
    assert err.splitlines()[-1].startswith(
        "harlsync: refused: robot cell: Sun 04:00 is outside its maintenance windows "
        "(sat 22:00-04:00); stopped before writing timer 2"
    )
    [record] = audit_log.results()
    assert record.result == "refused" and len(record.done) == 2


#: The example project, and the same robot as format 1 wrote it (steps keyed by number).
EXAMPLE = Path(__file__).resolve().parent.parent / "projects" / "pick-and-place"
FORMAT_1 = Path(__file__).resolve().parent / "fixtures" / "format-1" / "pick-and-place"


@pytest.mark.parametrize("command", ["pull", "backup"])
def test_issue_34_item_4_a_format_1_project_migrated_by_a_commit_is_committed_and_said(
    repo: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    project = repo / "cell"
    shutil.copytree(FORMAT_1, project)
    robot_yaml = project / "robot.yaml"  # the robot the example project is a backup of
    robot_yaml.write_text(
        robot_yaml.read_text().replace("sim://projects/pick-and-place", f"sim://{EXAMPLE}?baud=0")
    )
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "as format 1 wrote it")
    head = git(repo, "rev-parse", "HEAD").strip()
    capsys.readouterr()
    assert main([command, str(project), "--commit"]) == 0
    out = capsys.readouterr().out
    # The robot holds what the backup holds: only the format changed, and it is committed:
    # by a pull on the branch, by a backup on its own (issue 30: never over the approved
    # branch and the working tree, which keep format 1 until an engineer pulls).
    branch = "HEAD" if command == "pull" else "harlsync/backup"
    [commit] = git(repo, "rev-list", f"{head}..{branch}").split()
    assert git(repo, "status", "--porcelain") == ""
    migrated = sorted(
        p.relative_to(FORMAT_1).as_posix()
        for p in FORMAT_1.rglob("*.yaml")
        if p.name != "robot.yaml"
    )
    assert len(migrated) == 17
    committed = git(repo, "show", "--name-only", "--format=", branch).split()
    assert {f"cell/{name}" for name in migrated} <= set(committed)
    assert "cell/robot.yaml" not in committed  # a person's file, never rewritten
    for name in migrated:
        kept = git(repo, "show", f"{branch}:cell/{name}").encode()
        assert kept == (EXAMPLE / name).read_bytes(), name
        if command == "backup":
            assert (project / name).read_bytes() == (FORMAT_1 / name).read_bytes(), name
    said = "17 files migrated from format 1 to format 2"
    assert said in git(repo, "log", "-1", "--format=%B", branch)
    assert said in out and commit[:10] in out
