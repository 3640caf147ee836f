"""What the end to end against the Epson simulator (test_e2e.py) does not reach: the
function reset's register writes and a halt on the next command, over TCP against a
pymodbus server whose registers are a fake controller, and the controller's
handling of a lost or late answer in memory, on the fake's clock.  Every check of
what reached the robot reads the fake's own record of the commands it took."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import pytest

from harlsync import cli, families
from harlsync.errors import InterlockError, ProjectError
from harlsync.families.epson import protocol as p
from harlsync.families.epson.controller import Controller
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.model import PointKey, SettingKey, TableKey
from harlsync.families.epson.protocol import AccelReal
from harlsync.sync import engine

from .fakerobot import WRITES, FakeRobot, RobotState
from .modbus_server import ModbusServer, free_port
from .projects import edit, pulled


@pytest.fixture
def robot() -> Iterator[tuple[FakeRobot, str]]:
    fake = FakeRobot()
    with ModbusServer(bank=fake.bank) as server:
        yield fake, server.url
    assert fake.bank.function_errors == []  # a correct client never halts the function
    assert fake.busy_writes == []  # ... nor writes to a robot that is not idle
    assert {w[0] for w in fake.commands} <= set(p.COMMANDS)  # ... nor anything off the lists


def writes(fake: FakeRobot) -> list[tuple[int, ...]]:
    return [tuple(w[:1]) + tuple(w[1:]) for w in fake.written()]


def test_a_function_left_halted_is_reset_only_when_asked_and_only_on_an_idle_robot(
    robot: tuple[FakeRobot, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    fake.bank.fail_next = 0x0001  # the next command halts the function (9999/0001)
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 2
    err = capsys.readouterr().err
    assert "function error (ExtError 1): 9999 function error, detail 0001" in err
    assert "reset the function ('harlsync diff DIR --reset-function', on an idle robot)" in err
    fake.bank.function_errors.clear()  # that one was on purpose
    assert cli.main(["diff", str(project)]) == 2  # still halted: nothing resets it unasked
    fake.signal("Running")
    assert cli.main(["diff", str(project), "--reset-function"]) == 3
    assert "Running 1 (a task is executing): dropping ExtCmdReset would abort motion" in (
        capsys.readouterr().err
    )
    fake.signal("Running", False)
    assert cli.main(["diff", str(project), "--reset-function"]) == 0
    assert fake.bank.state == "idle"


def test_reset_function_leaves_an_idle_function_alone(
    robot: tuple[FakeRobot, str], repo: Path
) -> None:
    fake, url = robot
    project = pulled(repo, url)
    resets = len([op for op in fake.bank.writes() if op.address == 0 and not op.values[0] & 4])
    assert cli.main(["diff", str(project), "--reset-function"]) == 0
    assert (
        len([op for op in fake.bank.writes() if op.address == 0 and not op.values[0] & 4]) == resets
    )


def test_reset_function_is_refused_for_a_family_without_it(tmp_path: Path) -> None:
    robot = families.get("iai").new_robot("cell-9", "socket://127.0.0.1:1", None)
    with pytest.raises(
        ProjectError,
        match=r"--reset-function: the iai family has no such "
        r"option \(only epson\); leave it out",
    ):
        engine.connect(robot, options={"reset_function": True})
    engine_robot = families.get("harl-u2").new_robot("press", "/dev/null", None)
    with pytest.raises(ProjectError, match="the harl-u2 family has no such option"):
        engine.connect(engine_robot, options={"reset_function": True})


def test_a_refused_connection_is_one_line_without_pymodbus_s_own_log_lines(tmp_path: Path) -> None:
    port = free_port()
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "harlsync",
            "pull",
            str(tmp_path / "x"),
            "--family",
            "epson",
            "--port",
            f"modbus://127.0.0.1:{port}",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 2
    assert result.stderr.splitlines() == [
        (
            f"harlsync: error: port modbus://127.0.0.1:{port} unit 1: cannot connect: [Errno 111] "
            "Connection refused; check the controller is on, its Modbus TCP slave enabled and the "
            "port right"
        )
    ]


# --- a lost reply, in memory: the handshake's deadline on a fake clock ----------------------


def controller_of(fake: FakeRobot) -> Controller:
    handshake = Handshake(fake.bank, fake.bank.map, clock=fake.bank.clock)
    return Controller(handshake)


def test_a_write_answered_too_late_is_read_back_and_not_sent_again() -> None:
    fake = FakeRobot()
    c = controller_of(fake)
    key, old, new = (
        TableKey("accel_s", 3),
        AccelReal("100.123", "200.000"),
        AccelReal("1.000", "2.000"),
    )
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

    def withdraw(address: int, values: Sequence[int]) -> None:
        requested = fake.bank.state == "requested"
        write_holding(address, values)
        if requested and fake.bank.state == "idle":  # withdrawn at the deadline
            fake.bank.never_acquire = False
            if pause:
                fake.signal("Paused")  # an operator, between the write and its re-send

    fake.bank.write_holding = withdraw  # type: ignore[method-assign]
    fake.bank.never_acquire = True
    c.write(c.write_steps(key, "-5.000"), "-5.000", "-10.000")
    # read back, the status (issue 34: the control device and the controller's error
    # too, when the signals are idle), then sent once more
    assert [w[0] for w in fake.commands] == [1251, 2156, 2155, 1250]
    assert fake.state.limz == -5000

    fake.bank.never_acquire, pause = True, True
    with pytest.raises(InterlockError, match=r"Paused 1 .*not sending it again"):
        c.write(c.write_steps(key, "-6.000"), "-6.000", "-5.000")
    assert [w[0] for w in fake.commands] == [1251, 2156, 2155, 1250, 1251]
    assert fake.state.limz == -5000 and fake.busy_writes == []


def test_the_read_of_a_point_stops_at_its_first_coordinate_when_it_is_not_defined() -> None:
    fake = FakeRobot(RobotState.sample())
    c = controller_of(fake)
    c.identify()
    assert c.read_point(5) is None
    assert c.read_item(PointKey("point", 12)) is not None
    assert [w[:3] for w in fake.commands[-11:]][:1] == [(1222, 5, 0)]
    assert WRITES.isdisjoint(w[0] for w in fake.commands)


def test_a_map_without_ready_is_named_by_validate_and_plan(
    robot: tuple[FakeRobot, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 19 item 5: where a site's map has no Ready, plan and validate say so;
    issue 34 item 16: and the plan cannot write (robot.yaml may accept the risk)."""
    _, url = robot
    project = pulled(repo, url)
    edit(project, repo, "robot.yaml", "Ready: {register: 0, bit: 8}", "Ready: null")
    capsys.readouterr()
    assert cli.main(["validate", str(project)]) == 0
    out = capsys.readouterr().out
    assert "note: robot.yaml: connection.map: the register map has no Ready signal" in out
    assert cli.main(["plan", str(project)]) == 0
    assert "# cannot write: the register map has no Ready signal" in capsys.readouterr().out
