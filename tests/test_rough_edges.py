"""Issue 14, item 6: the rough edges a new user hits, each through the real command.

Every error is one line on stderr and the documented exit code; nothing waits with
a sleep (``until`` polls a condition against a deadline).
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import git, until

from harlsync import families
from harlsync.cli import main
from harlsync.errors import ProjectError
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.model import Config, ProgramArea
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.project import load_robot, validate_project
from harlsync.settings import SerialSettings
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine

HARLSYNC = [sys.executable, "-m", "harlsync"]
DEADLINE = 30.0

pytestmark = pytest.mark.skipif(
    os.name != "posix", reason="ptys, job control and signals are POSIX"
)


def run(*args: str, stdin: int | None = subprocess.DEVNULL) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*HARLSYNC, *args],
        check=False,
        capture_output=True,
        text=True,
        stdin=stdin,
        timeout=DEADLINE,
    )


def one_line(text: str) -> str:
    """The only line of ``text`` (an error must be one line, never a traceback)."""
    lines = text.splitlines()
    assert len(lines) == 1, text
    return lines[0]


def version_at(url: str) -> str:
    """LNV from the simulated HARL-U2 at ``url``: proof that it serves."""
    controller = Controller.from_url(url, 1, SerialSettings(timeout=2.0, retries=0))
    try:
        return controller.version()
    finally:
        controller.close()


# --- harlsync sim ------------------------------------------------------------------------


@pytest.fixture
def port_in_use() -> Iterator[int]:
    with socket.create_server(("127.0.0.1", 0)) as taken:
        yield taken.getsockname()[1]


def test_issue_14_sim_listen_on_an_address_in_use_is_one_line_and_exit_2(port_in_use: int) -> None:
    done = run("sim", "--listen", f"127.0.0.1:{port_in_use}")
    assert done.returncode == 2
    assert one_line(done.stderr) == (
        f"harlsync sim: --listen 127.0.0.1:{port_in_use}: cannot listen there: "
        "Address already in use"
    )
    assert done.stdout == ""  # no pty was opened and left behind


@pytest.mark.parametrize("listen", ["localhost", "127.0.0.1:", "127.0.0.1:http", ":70000"])
def test_issue_14_sim_listen_without_a_port_is_one_line_and_exit_2(listen: str) -> None:
    done = run("sim", "--listen", listen)
    assert done.returncode == 2
    assert one_line(done.stderr) == (
        f"harlsync sim: --listen: {listen!r} is not HOST:PORT (e.g. 127.0.0.1:5020; port 0 "
        "picks a free one)"
    )


#: Run ``bash -c ARGV[1]`` with standard input (a pty) as its controlling terminal, as a
#: login shell has it: a new session (start_new_session) takes it with TIOCSCTTY.
IN_A_SHELL_ON_THIS_TERMINAL = (
    "import fcntl, os, sys, termios; fcntl.ioctl(0, termios.TIOCSCTTY, 0); "
    "os.execvp('bash', ['bash', '-c', sys.argv[1]])"
)


def _served_url(read: Callable[[], str]) -> str:
    """The ``socket://`` URL a starting ``harlsync sim`` prints."""
    lines: list[str] = []

    def has_url() -> bool:
        lines[:] = read().splitlines()  # the whole output so far, a line each
        return any(line.startswith("tcp: ") for line in lines)

    until(has_url, "the sim's tcp: line")
    return next(line for line in lines if line.startswith("tcp: "))[len("tcp: ") :].strip()


def test_issue_14_sim_no_input_serves_without_a_terminal_until_sigterm() -> None:
    proc = subprocess.Popen(
        [*HARLSYNC, "sim", "--no-pty", "--listen", "127.0.0.1:0", "--baud", "0", "--no-input"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = _served_url(proc.stdout.readline)
        assert version_at(url) == "5.00"  # its input is long over: it still serves
        assert proc.poll() is None
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=DEADLINE) == 0
    finally:
        proc.kill()


def test_issue_14_sim_started_with_ampersand_from_a_terminal_is_not_stopped_by_it(
    tmp_path: Path,
) -> None:
    """A shell with job control on a real pty runs ``harlsync sim ... &``: a read of the
    terminal by a background job stops it (SIGTTIN), so it must not read."""
    out = tmp_path / "sim.out"
    pid_file = tmp_path / "sim.pid"
    sim = " ".join([*HARLSYNC, "sim", "--no-pty", "--listen", "127.0.0.1:0", "--baud", "0"])
    script = f"set -m; {sim} > {out} 2>&1 & echo $! > {pid_file}; wait"
    controller, terminal = os.openpty()
    shell = subprocess.Popen(
        [sys.executable, "-c", IN_A_SHELL_ON_THIS_TERMINAL, script],
        stdin=terminal,
        stdout=terminal,
        stderr=terminal,
        start_new_session=True,
    )
    os.close(terminal)
    try:
        url = _served_url(lambda: out.read_text() if out.exists() else "")
        until(
            lambda: "started in the background: not reading commands" in out.read_text(),
            "the sim to say it reads no commands",
        )
        assert version_at(url) == "5.00"
        os.kill(int(pid_file.read_text()), signal.SIGTERM)
        assert shell.wait(timeout=DEADLINE) == 0
    finally:
        if pid_file.exists():
            try:
                os.kill(int(pid_file.read_text()), signal.SIGKILL)
            except ProcessLookupError:
                pass
        shell.kill()
        os.close(controller)


# --- -v ---------------------------------------------------------------------------------


@pytest.fixture
def plant(tmp_path: Path) -> Path:
    """Two robots, each its own simulated line (sim://?seed=N, made again by every
    process that opens it), backed up and committed."""
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q")
    for seed, name in ((1, "loader"), (2, "press")):
        done = run("pull", str(root / name), "--port", f"sim://?seed={seed}&baud=0")
        assert done.returncode == 0, done.stderr
    git(root, "add", "-A")
    git(root, "commit", "-qm", "first backup")
    return root


def test_issue_14_backup_v_names_the_robot_of_every_line_and_no_python_repr(plant: Path) -> None:
    done = run("backup", str(plant), "-v")
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert lines
    for line in lines:
        assert line.startswith(("harlsync: INFO: loader: ", "harlsync: INFO: press: ")), line
        assert "SerialSettings(" not in line
    assert (
        "harlsync: INFO: press: opened sim://?seed=2&baud=0 (station 1, 9600 8N1, no flow "
        "control, reply timeout 1.0 s, 3 retries)"
    ) in lines


# --- --station --------------------------------------------------------------------------

SMALL = Config(ProgramArea(1, 4), ProgramArea(2, 6), ProgramArea(1, 4), ProgramArea(1, 2), 4, 16, 4)


@pytest.fixture(params=["harl-u2", "iai"])
def robot(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[tuple[Path, Any]]:
    """A committed backup of a robot of each family, and its simulator (served as
    ``sim://@name`` in this process, so what it receives can be counted)."""
    sim: Any
    if request.param == "iai":
        sim = IaiSimulator({0x99: IaiState.generate(3, position_range=(1, 10))})
    else:
        sim = HarlSimulator({1: HarlState.generate(3, SMALL)})
    url = register(sim, f"rough-{request.param}")
    repo = tmp_path / "plant"
    repo.mkdir()
    git(repo, "init", "-q")
    try:
        engine.pull(repo / "cell", port=url, family=request.param)
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "backup")
        sim.received.clear()
        yield repo / "cell", sim
    finally:
        unregister(url)


BAD_STATIONS = {"harl-u2": ["0", "100", " 1", "+1", "x"], "iai": ["9", "100", "G1", "-1"]}


def test_issue_14_a_bad_station_is_refused_by_every_command_with_robot_yamls_message(
    robot: tuple[Path, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    project, sim = robot
    family = families.get(load_robot(project).family)
    robot_yaml = project / "robot.yaml"
    original = robot_yaml.read_text()
    for text in BAD_STATIONS[family.name]:
        with pytest.raises(ValueError) as refused:
            family.parse_station(text)
        message = str(refused.value)
        if text in ("0", "100", "x") or family.name == "iai":  # YAML reads " 1" as 1
            # robot.yaml holding the same value says the same, with the same range
            shown = f'"{text}"' if family.name == "iai" else text
            robot_yaml.write_text(re.sub(r"station: .*", f"station: {shown}", original))
            found = validate_project(project)
            robot_yaml.write_text(original)
            assert len(found) == 1, found
            assert found[0].endswith(message[message.index(" (allowed: ") :])
            if text != "x":  # the schema says 'x' is not an integer
                assert found[0].endswith(f"connection.station: {message}"), (found, message)
        for command in (["pull"], ["diff"], ["plan"], ["push", "--yes"], ["rollback", "--yes"]):
            code = main([*command, str(project), "--station", text])
            err = capsys.readouterr().err
            assert (code, err) == (2, f"harlsync: error: --station: {message}\n"), command
    assert sim.received == []  # not one byte for a station that is not one


def test_issue_14_a_station_in_range_is_read_as_its_family_writes_it() -> None:
    assert families.get("harl-u2").parse_station("07") == 7
    assert families.get("iai").parse_station("1a") == 0x1A
    with pytest.raises(ValueError, match=r"^0 is out of range \(allowed: 1-99\)$"):
        families.get("harl-u2").parse_station("0")
    with pytest.raises(ProjectError, match=r"^station: 0 is out of range \(allowed: 1-99\)$"):
        engine.station_number("harl-u2", 0)  # a number from a library caller too
    assert engine.station_number("iai", 0x99) == 0x99


# --- plan while the robot runs; pull --commit off a terminal -------------------------------


def test_issue_14_plan_warns_that_a_push_would_be_refused_while_the_robot_runs(
    robot: tuple[Path, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    project, sim = robot
    assert main(["plan", str(project)]) == 0
    assert capsys.readouterr().err == ""  # idle: nothing to warn about
    for state in sim.stations.values():
        sim.control(sim.family.busy_verb, state, ())
    assert main(["plan", str(project)]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[-1].startswith("# 0 item(s) to cell (port sim://@rough-")
    assert re.fullmatch(
        r"harlsync: warning: a push would be refused now: robot cell \(port "
        r"sim://@rough-\S+ station \w+\) is not idle: .+\n",
        err,
    ), err
    assert main(["push", str(project), "--yes"]) == 3  # as the warning said


def test_issue_14_pull_commit_off_a_terminal_still_prints_the_commit(
    robot: tuple[Path, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    project, _ = robot
    family = load_robot(project).family
    again = project.parent / "again"
    assert (
        main(
            ["pull", str(again), "--port", load_robot(project).port, "--family", family, "--commit"]
        )
        == 0
    )
    out, err = capsys.readouterr()
    head = git(project.parent, "rev-parse", "HEAD").strip()
    assert (out, err) == (f"again: first backup, committed {head[:10]}\n", "")
    assert main(["pull", str(again), "--commit"]) == 0  # nothing changed: no commit, quiet
    assert capsys.readouterr() == ("", "")


@pytest.mark.parametrize("command", ["diff", "validate", "plan", "push", "snapshots", "log"])
def test_issue_14_a_directory_that_is_not_a_project_is_named(
    tmp_path: Path,
    command: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    (tmp_path / "notes.txt").write_text("not a robot\n")
    assert main([command, str(tmp_path)]) == 2
    assert capsys.readouterr() == (
        "",
        (
            f"harlsync: error: {tmp_path}: not a robot project (no robot.yaml); a first "
            "'harlsync pull DIR --port URL' makes one\n"
        ),
    )


# --- --help -----------------------------------------------------------------------------


def help_of(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    assert done.value.code == 0
    return " ".join(capsys.readouterr().out.split())  # argparse wraps at the terminal width


@pytest.mark.parametrize("command", ["diff", "backup", "status", "log", "snapshots"])
def test_issue_14_format_says_what_each_choice_is_for(
    command: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert "--format {text,json} text for people (default), json for scripts" in help_of(
        command, capsys
    )


@pytest.mark.parametrize("command", ["validate", "status", "log", "snapshots"])
def test_issue_14_v_promises_no_wire_traffic_where_no_line_is_opened(
    command: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    text = help_of(command, capsys)
    assert "-v, --verbose more output: -v what it does" in text and "traffic" not in text


@pytest.mark.parametrize("command", ["pull", "diff", "plan", "push", "rollback", "backup", "sim"])
def test_v_on_a_command_that_opens_a_line_offers_its_traffic(
    command: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert "-v what it does, -vv raw traffic as hex" in help_of(command, capsys)
