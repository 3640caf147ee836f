"""Safety regressions: no unsafe SN command reaches a robot in automatic operation,
whatever the line, the operator or the person at the keyboard does meanwhile.

Each test drives the real controller or push over a real pty or TCP socket and
asserts on what the simulator received (``Received.busy`` is whether some
task of that robot was in execution or suspended when the request arrived).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import git
from simline import Act, ScriptedSim, drop, slow

from harlsync.errors import InterlockError, PolicyError, PortBusyError, StalePlanError
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.driver import HarlU2Driver
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.protocol import lrc
from harlsync.families.harl_u2.sim import SimState
from harlsync.link import SerialSettings
from harlsync.link import lock as lockmod
from harlsync.project import load_project, save_project
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.sync import PushFailed, PushOptions, engine
from harlsync.sync import audit as audit_log

SMALL = Config(
    ProgramArea(1, 8), ProgramArea(2, 12), ProgramArea(2, 8), ProgramArea(1, 6), 4, 16, 4
)
FAST = SerialSettings(timeout=0.2, retries=2)
MAIN = ProgramType.MAIN
YES = PushOptions(yes=True)


@pytest.fixture
def sim() -> ScriptedSim:
    return ScriptedSim(SimState.generate(11, SMALL))


@pytest.fixture
def robot(sim: ScriptedSim) -> Iterator[Controller]:
    with PtyServer(sim) as server, Controller.from_url(server.device, 1, FAST) as controller:
        yield controller


@pytest.fixture
def line(sim: ScriptedSim) -> Iterator[str]:
    with TcpServer(sim) as server:
        yield server.url


@pytest.fixture
def project(tmp_path: Path, line: str) -> Path:
    """The robot pulled into a committed project, with a short reply deadline."""
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q")
    path = root / "cell"
    engine.pull(path, port=line)
    robot_yaml = path / "robot.yaml"
    robot_yaml.write_text(robot_yaml.read_text().replace("timeout: 1.0", "timeout: 0.2"))
    git(root, "add", "-A")
    git(root, "commit", "-qm", "backup")
    return path


def commit_step(project: Path, number: int, step: int, text: str) -> None:
    loaded = load_project(project)
    loaded.data.programs[(MAIN, number)][step] = Step.parse(text)
    save_project(project, loaded)
    git(project.parent, "commit", "-qam", f"MAIN {number} step {step}")


def operator_starts_the_robot(state: SimState) -> None:
    state.start_task(0, "MAIN", 0, 0)


# --- what LNR may answer ------------------------------------------------------------------

IDLE_TASK = "0 START 0 0"


@pytest.mark.parametrize(
    "reply",
    [
        "E21",
        " ".join([IDLE_TASK] * 4),
        " ".join([IDLE_TASK] * 4 + ["3 MAIN 0 0"]),
        " ".join([IDLE_TASK] * 4 + ["0 MAIN x 0"]),
        # Issue 19: a reply whose fields are not all well formed is not idle.
        " ".join([IDLE_TASK] * 4 + ["0 MAIM 0 0"]),
        " ".join([IDLE_TASK] * 4 + ["0 main 0 0"]),
        " ".join([IDLE_TASK] * 4 + ["0 MAIN 0 +7"]),
        " ".join([IDLE_TASK] * 4 + ["0 MAIN 0 1_0"]),
        " ".join([IDLE_TASK] * 4 + ["0 MAIN -1 0"]),
        " ".join([IDLE_TASK] * 4 + ["+0 MAIN 0 0"]),
        " ".join([IDLE_TASK] * 6),
    ],
    ids=[
        "error status",
        "four tasks",
        "two bits set",
        "unparsable",
        "not a program type",
        "program type in lower case",
        "signed step",
        "step with an underscore",
        "negative program number",
        "signed status",
        "six tasks",
    ],
)
def test_a_push_writes_nothing_unless_lnr_shows_five_known_idle_tasks(
    project: Path, sim: ScriptedSim, reply: str
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    sim.plan("LNR", *[Act(reply=reply)] * 20)
    with pytest.raises(PushFailed) as failed:
        engine.push(project, YES)
    assert isinstance(failed.value.cause, InterlockError)
    assert sim.writes_received() == []


def test_issue_19_one_lnr_reply_corrupted_past_the_lrc_does_not_clear_a_write(
    project: Path, sim: ScriptedSim
) -> None:
    """The LRC is an XOR: ``1 MAIN 0 0`` (task 0 in execution) with bit 0 flipped in
    its status and in its step arrives as ``0 MAIN 0 1``, LRC intact.  The second
    LNR before the write sees the task run."""
    commit_step(project, 1, 3, "MOVE P999 S20")
    running, fooled = "1 MAIN 0 0", "0 MAIN 0 1"
    assert lrc(running.encode()) == lrc(fooled.encode())
    answer = sim.handle
    corrupted: list[str] = []

    def once_past_the_lrc(state: SimState, payload: str) -> str:
        reply = answer(state, payload)
        if payload == "LNR" and reply.startswith(running) and not corrupted:
            corrupted.append(reply)
            return fooled + reply[len(running) :]
        return reply

    sim.handle = once_past_the_lrc  # type: ignore[method-assign]
    # The robot is started as the push reads step 3 for drift, just before the LNRs.
    sim.plan("LNM 1 3", Act(), Act(before=operator_starts_the_robot))
    with pytest.raises(PushFailed) as failed:
        engine.push(project, YES)
    assert corrupted, "the corrupted reply was never sent"
    assert isinstance(failed.value.cause, InterlockError)
    assert "task 0 in execution" in str(failed.value)
    assert sim.writes_received() == []


# --- the re-send after a lost reply -------------------------------------------------------


NEW_CONFIG = Config(
    ProgramArea(1, 4), ProgramArea(1, 4), ProgramArea(1, 4), ProgramArea(1, 4), 4, 16, 4
)

UNSAFE_WRITES: list[tuple[str, str, Callable[[Controller], None]]] = [
    ("SNM", "SNM 1 2", lambda c: c.write_step(MAIN, 1, 2, Step.parse("MOVE P777 S20"))),
    ("SNA", "SNA 0", lambda c: c.write_step(ProgramType.START, 0, 0, Step.parse("END"))),
    ("SNE", "SNE", lambda c: c.write_parameters(replace(c.read_parameters(), pull_rate="77"))),
    ("SNX", "SNX", lambda c: c.write_config(NEW_CONFIG)),
]


@pytest.mark.parametrize(
    "key,write", [(k, w) for _, k, w in UNSAFE_WRITES], ids=[n for n, _, _ in UNSAFE_WRITES]
)
def test_an_unsafe_write_is_not_resent_when_the_robot_went_automatic_after_the_lost_reply(
    robot: Controller, sim: ScriptedSim, key: str, write: Callable[[Controller], None]
) -> None:
    # The first send never took and its reply was lost; meanwhile the operator
    # pressed start.  The controller must not send it a second time.
    sim.plan(key, Act(apply=False, before=operator_starts_the_robot, wire=drop))
    with pytest.raises(InterlockError, match="task 0 in execution"):
        write(robot)
    assert len(sim.sent(key)) == 1
    assert sim.unsafe_in_automatic() == []


def test_an_unsafe_write_is_resent_after_a_fresh_status_read_shows_the_robot_idle(
    robot: Controller, sim: ScriptedSim
) -> None:
    sim.plan("SNM 1 2", Act(apply=False, wire=drop))
    old = sim.stations[1].data.programs[(MAIN, 1)].get(2, Step())
    robot.write_step(MAIN, 1, 2, Step.parse("MOVE P777 S20"), old=old)
    assert [r.payload for r in sim.received] == [
        "SNM 1 2 MOVE P777 S20",
        "LNM 1 2",
        "LNR",
        "LNR",  # IDLE_READS: two replies in a row must show every task idle
        "SNM 1 2 MOVE P777 S20",
    ]


def test_a_timer_write_is_still_resent_while_a_task_runs(
    robot: Controller, sim: ScriptedSim
) -> None:
    # SNT is allowed during automatic operation (live tuning): no status gate.
    sim.plan("SNT 1", Act(apply=False, before=operator_starts_the_robot, wire=drop))
    robot.write_timer(1, "7.25", old=sim.stations[1].data.timers[1])
    assert sim.sent("SNT 1") == ["SNT 1 7.25", "SNT 1 7.25"]
    assert sim.stations[1].data.timers[1] == "7.25"


def test_issue_6_a_timer_write_that_needs_an_idle_robot_is_not_resent_while_a_task_runs(
    robot: Controller, sim: ScriptedSim
) -> None:
    sim.plan("SNT 1", Act(apply=False, before=operator_starts_the_robot, wire=drop))
    with pytest.raises(InterlockError, match="task 0 in execution"):
        robot.write_timer(1, "7.25", old=sim.stations[1].data.timers[1], needs_idle=True)
    assert sim.sent("SNT 1") == ["SNT 1 7.25"]


def test_push_does_not_resend_a_step_to_a_robot_started_after_its_reply_was_lost(
    project: Path, sim: ScriptedSim
) -> None:
    commit_step(project, 1, 11, "MOVE P999 S20")
    sim.plan("SNM 1 11", Act(apply=False, before=operator_starts_the_robot, wire=drop))
    with pytest.raises(PushFailed) as failed:
        engine.push(project, YES)
    assert isinstance(failed.value.cause, InterlockError)
    assert sim.unsafe_in_automatic() == []
    assert sim.sent("SNM 1 11") == ["SNM 1 11 MOVE P999 S20"]


def test_issue_6_a_late_idle_lnr_reply_is_never_taken_for_the_retry_that_found_the_robot_running(
    project: Path, sim: ScriptedSim
) -> None:
    # Found by tests/families/harl_u2/test_interlock_property.py.  The LNR before the write is answered
    # "idle" after its deadline; the operator starts the robot; the retry is answered
    # "running".  The late "idle" must not pass for the retry's answer.
    commit_step(project, 1, 3, "MOVE P999 S20")
    sim.plan("LNR", Act(), Act(wire=slow(0.3)), Act(before=operator_starts_the_robot))
    with pytest.raises(PushFailed) as failed:
        engine.push(project, YES)
    assert isinstance(failed.value.cause, InterlockError)
    assert "task 0 in execution" in str(failed.value)
    assert sim.writes_received() == []


def commit_timer(project: Path, number: int, value: str) -> None:
    loaded = load_project(project)
    loaded.data.timers[number] = value
    save_project(project, loaded)
    git(project.parent, "commit", "-qam", f"timer {number}")


def commit_register_1(project: Path, *, timer_2: bool = False) -> None:
    """Keep registers, pull them, and commit a change of register 1 (and timer 2)."""
    robot_yaml = project / "robot.yaml"
    robot_yaml.write_text(
        robot_yaml.read_text().replace("keep_registers: false", "keep_registers: true")
    )
    engine.pull(project)
    loaded = load_project(project)
    assert loaded.data.registers is not None, "robot.yaml layout changed"
    loaded.data.registers[1] = "0042" if loaded.data.registers[1] != "0042" else "0043"
    if timer_2:
        loaded.data.timers[2] = "4.44" if loaded.data.timers[2] != "4.44" else "4.45"
    save_project(project, loaded)
    git(project.parent, "add", "-A")
    git(project.parent, "commit", "-qm", "register 1" + (", timer 2" if timer_2 else ""))


@pytest.mark.parametrize("live_tuning", [False, True], ids=["timer", "register, live tuning"])
def test_issue_6_a_push_resends_no_write_to_a_robot_started_after_its_reply_was_lost(
    project: Path, sim: ScriptedSim, live_tuning: bool
) -> None:
    # Found by tests/families/harl_u2/test_interlock_property.py.  The manual allows SNT and SND in
    # automatic operation, so the controller re-sends them without reading LNR; but a
    # push without --allow-live-tuning promises an idle robot for every write, and a
    # register never goes to a running program.  The first send is lost on the way in;
    # the operator presses start while the item is read back.
    if live_tuning:
        commit_register_1(project)
        key, readback = "SND 1", "LND 1"
    else:
        commit_timer(project, 1, "7.25" if sim.stations[1].data.timers[1] != "7.25" else "7.50")
        key, readback = "SNT 1", "LNT 1"
    sim.plan(key, Act(apply=False, wire=drop))
    # read in the pull, before the write (drift), then after the lost reply:
    sim.plan(readback, Act(), Act(), Act(before=operator_starts_the_robot))
    with pytest.raises(PushFailed) as failed:
        engine.push(
            project, PushOptions(yes=True, allow_live_tuning=live_tuning, registers=live_tuning)
        )
    assert isinstance(failed.value.cause, InterlockError)
    assert "task 0 in execution" in str(failed.value)
    assert len(sim.sent(key)) == 1
    assert [r.payload for r in sim.writes_received() if r.busy] == []


# --- the robot edited on the pendant after the read -------------------------------------


def test_a_step_edited_on_the_pendant_after_the_read_is_not_overwritten(
    project: Path, sim: ScriptedSim
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    commit_step(project, 1, 5, "MOVE P555 S20")
    programs = sim.stations[1].data.programs

    def reviewed_while_the_operator_edits(plan: object) -> bool:
        # The plan is on screen; meanwhile the operator teaches step 5 on the pendant.
        programs[(MAIN, 1)][5] = Step.parse("MOVE P123 S10")
        return True

    with pytest.raises(PushFailed) as failed:
        engine.push(project, PushOptions(confirm=reviewed_while_the_operator_edits))
    assert isinstance(failed.value.cause, StalePlanError)
    assert "MAIN program 1 step 5" in str(failed.value)
    assert programs[(MAIN, 1)][5] == Step.parse("MOVE P123 S10")  # the operator's edit survives
    assert sim.sent("SNM 1 5") == []
    assert [w.name for w in failed.value.result.written] == ["MAIN program 1 step 3"]
    assert failed.value.result.failed is None


# --- the audit record, whatever stops the push ----------------------------------------------


def test_ctrl_c_mid_push_still_leaves_an_audit_record_saying_what_was_written(
    project: Path, sim: ScriptedSim, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    commit_step(project, 1, 5, "MOVE P555 S20")
    real = HarlU2Driver.write
    calls = []

    def interrupted_on_the_second(self: HarlU2Driver, *args: object, **kwargs: object) -> None:
        calls.append(args)
        if len(calls) == 2:
            raise KeyboardInterrupt
        real(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(HarlU2Driver, "write", interrupted_on_the_second)
    with pytest.raises(PushFailed) as failed:
        engine.push(project, YES)
    assert "interrupted (Ctrl-C)" in str(failed.value)
    result = failed.value.result
    assert [w.name for w in result.written] == ["MAIN program 1 step 3"]
    assert result.failed is not None and result.failed.name == "MAIN program 1 step 5"
    [record] = audit_log.results(tmp_path / "audit.jsonl")
    assert record.result == "interrupted"
    assert [w.item for w in record.done] == ["MAIN program 1 step 3"]
    assert record.failed_item == "MAIN program 1 step 5"
    assert sim.sent("SNM 1 5") == []


def test_a_push_that_could_not_be_audited_is_refused_before_any_write(
    project: Path, sim: ScriptedSim, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    blocker = tmp_path / "not-a-directory"
    blocker.write_text("")
    monkeypatch.setenv("HARLSYNC_AUDIT_LOG", str(blocker / "audit.jsonl"))
    before = len(sim.received)
    with pytest.raises(PolicyError, match="audit"):
        engine.push(project, YES)
    assert sim.received[before:] == []


# --- live tuning -----------------------------------------------------------------------------


def test_live_tuning_does_not_write_registers_into_a_running_program(
    project: Path, sim: ScriptedSim
) -> None:
    commit_register_1(project, timer_2=True)
    sim.stations[1].start_task(0)
    with pytest.raises(PushFailed) as failed:
        engine.push(project, PushOptions(yes=True, allow_live_tuning=True, registers=True))
    assert isinstance(failed.value.cause, InterlockError)
    assert [r.command for r in sim.writes_received()] == []


# --- two harlsync on one line ---------------------------------------------------------------


def test_a_cron_job_without_a_login_session_is_held_off_the_line_a_shell_push_holds(
    project: Path, sim: ScriptedSim, line: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    monkeypatch.delenv("HARLSYNC_LOCK_DIR")
    # A machine with no /run/lock: the fixed fallback under /tmp, whatever the session.
    monkeypatch.setattr(lockmod, "SYSTEM_LOCK_DIRS", ())
    monkeypatch.setattr(lockmod, "FALLBACK_LOCK_DIR", tmp_path / "tmp" / "harlsync-locks")
    (tmp_path / "run-user-1000").mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path / "run-user-1000"))
    interactive = Link(line, 1).open()  # an engineer's push, from an SSH session
    try:
        monkeypatch.delenv("XDG_RUNTIME_DIR")  # cron has no login session
        before = len(sim.received)
        with pytest.raises(PushFailed) as failed:
            engine.push(project, PushOptions(yes=True, lock_timeout=0.2))
        assert isinstance(failed.value.cause, PortBusyError)
        assert sim.received[before:] == []
    finally:
        interactive.close()


# --- what no write can fix is refused, not crashed on -------------------------------------


@pytest.mark.parametrize(
    "timers,registers,expect",
    [
        (8, False, "timers: the robot has 8, the project 4"),
        (4, True, "registers: the project does not keep them"),
    ],
    ids=["timer count", "registers not kept"],
)
def test_what_no_write_can_fix_refuses_the_push_before_any_write(
    project: Path, tmp_path: Path, timers: int, registers: bool, expect: str
) -> None:
    target = ScriptedSim(SimState.generate(12, replace(SMALL, timers=timers)))
    with TcpServer(target) as server, pytest.raises(PushFailed) as failed:
        engine.push(project, PushOptions(yes=True, registers=registers), port=server.url)
    assert isinstance(failed.value.cause, PolicyError)
    assert expect in str(failed.value)
    assert target.writes_received() == []
    [record] = audit_log.results(tmp_path / "audit.jsonl")
    assert record.result == "refused"


# --- the start button pressed while a write is on the wire ---------------------------------


def test_a_robot_started_while_the_last_write_was_on_the_wire_is_reported_after_the_push(
    project: Path, sim: ScriptedSim, tmp_path: Path
) -> None:
    # No client can prevent this one (docs/SAFETY.md, limits): the status read before
    # the write found the robot idle, and the operator pressed start as the write
    # travelled.  The push must not stay silent about it.
    commit_step(project, 1, 3, "MOVE P999 S20")
    sim.plan("SNM 1 3", Act(before=operator_starts_the_robot))
    result = engine.push(project, YES)
    [warning] = result.warnings
    assert "is not idle at the end of the push: task 0 in execution" in warning
    assert "started after the status read before MAIN program 1 step 3" in warning
    assert "that write may have reached it while it ran" in warning
    [record] = audit_log.read(tmp_path / "audit.jsonl")[-1:]
    assert record.warnings == [warning]


def test_a_robot_started_between_two_writes_stops_the_push_naming_the_write_it_may_have_hit(
    project: Path, sim: ScriptedSim
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    commit_step(project, 1, 5, "MOVE P555 S20")
    sim.plan("SNM 1 3", Act(before=operator_starts_the_robot))
    with pytest.raises(PushFailed) as failed:
        engine.push(project, YES)
    assert isinstance(failed.value.cause, InterlockError)
    assert "before writing MAIN program 1 step 5" in str(failed.value)
    assert "status read before MAIN program 1 step 3: that write may have reached it" in str(
        failed.value
    )
    assert sim.sent("SNM 1 5") == []


def test_a_push_that_ends_with_the_robot_idle_warns_of_nothing(
    project: Path, sim: ScriptedSim
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    assert engine.push(project, YES).warnings == []
    assert [r.command for r in sim.received[-3:]] == ["LNM", "LNR", "LNR"]  # IDLE_READS


def test_a_parameters_write_followed_only_by_live_tuning_is_still_checked_after(
    project: Path, sim: ScriptedSim
) -> None:
    # Plan order: parameters (needs an idle robot), then a timer (live tuning: no
    # LNR before it).  The robot started as SNE travelled must still be reported.
    loaded = load_project(project)
    pull_rate = loaded.data.parameters.pull_rate
    loaded.data.parameters = replace(
        loaded.data.parameters, pull_rate="77" if pull_rate != "77" else "78"
    )
    loaded.data.timers[2] = "4.44" if loaded.data.timers[2] != "4.44" else "4.45"
    save_project(project, loaded)
    git(project.parent, "commit", "-qam", "parameters, timer 2")
    sim.plan("SNE", Act(before=operator_starts_the_robot))
    result = engine.push(project, PushOptions(yes=True, allow_live_tuning=True))
    [warning] = result.warnings
    assert "status read before expanded parameters: that write may have reached it" in warning


def test_an_audit_log_that_fails_at_the_end_does_not_hide_what_the_push_did(
    project: Path, sim: ScriptedSim, monkeypatch: pytest.MonkeyPatch
) -> None:
    commit_step(project, 1, 3, "MOVE P999 S20")
    real = audit_log.append

    def full_disk_at_the_end(record: audit_log.AuditRecord, path: Path | None = None) -> Path:
        if record.event == "end":
            raise OSError(28, "No space left on device")
        return real(record, path)

    monkeypatch.setattr(audit_log, "append", full_disk_at_the_end)
    result = engine.push(project, YES)
    assert [w.name for w in result.written] == ["MAIN program 1 step 3"]
    assert any("could not record the end of this push" in w for w in result.warnings)


def test_an_audit_record_is_appended_whole_even_when_the_disk_takes_it_in_pieces(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = os.write
    monkeypatch.setattr(os, "write", lambda fd, data: real(fd, data[:7]))
    log_file = tmp_path / "pieces.jsonl"
    audit_log.append(audit_log.AuditRecord(event="end", item="x" * 50), log_file)
    audit_log.append(audit_log.AuditRecord(event="end", item="y"), log_file)
    assert [r.item for r in audit_log.read(log_file)] == ["x" * 50, "y"]
