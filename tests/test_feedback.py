"""Issue 14, item 3: what a person at a terminal sees while harlsync works, and that
cron (no terminal) still sees nothing but what it asked for.

Each command runs on a real pseudo-terminal and its output is played through a
VT100 emulator (:mod:`ptyscreen`): the assertions are on the screen left at the end,
after every bar was redrawn and erased, and a ^C is one typed on that terminal.
"""

from __future__ import annotations

import io
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import git
from ptyscreen import run

from harlsync.families.harl_u2.catalogue import CATALOGUE as HARL_U2
from harlsync.families.harl_u2.model import OffsetEnd
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.iai.catalogue import CATALOGUE as IAI
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.sync import engine
from harlsync.terminal import Feedback

#: The robot ``sim://?seed=N`` generates: 1082 exchanges read it whole (with the three
#: that find where the offset tables end, issue 29).
TABLES = "100 offset tables (0-99, no table 100: E21 twice)"
CONTENTS = {
    1: f"13 programs (162 steps used), {TABLES}, 16 timers",
    2: f"13 programs (199 steps used), {TABLES}, 16 timers",
}
READ = r"read {contents} in [0-9.]+ s \(1082 exchanges with the controller\)"
BAR_MARKS = ("exchanges with the controller [", "%|")

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="a pty is POSIX")


def robot_at(root: Path, name: str, seed: int, baud: int) -> Path:
    """A committed backup of ``sim://?seed=SEED``, served at ``baud`` (0: no wire time)."""
    project = root / name
    engine.pull(project, port=f"sim://?seed={seed}&baud=0")
    robot = project / "robot.yaml"
    robot.write_text(robot.read_text().replace("baud=0", f"baud={baud}"))
    git(root, "add", "-A")
    git(root, "commit", "-qm", f"{name}: first backup")
    return project


@pytest.fixture
def plant(repo: Path) -> Path:
    robot_at(repo, "loader", 1, 0)
    robot_at(repo, "press", 2, 0)
    return repo


def no_bar_left(lines: list[str]) -> None:
    for line in lines:
        assert not any(mark in line for mark in BAR_MARKS), lines


def test_issue_14_pull_diff_and_plan_end_with_what_they_read_how_long_and_what_differs(
    repo: Path,
) -> None:
    seen = run("pull", "cell", "--port", "sim://?seed=1&baud=0", "--commit", cwd=repo)
    assert seen.code == 0, seen.raw
    no_bar_left(seen.screen)
    assert re.fullmatch(
        rf"harlsync: pull cell: {READ.format(contents=re.escape(CONTENTS[1]))}", seen.screen[0]
    ), seen.screen
    assert re.fullmatch(r"cell: first backup, committed [0-9a-f]{10}", seen.screen[1])

    seen = run("diff", "cell", cwd=repo)
    assert seen.code == 0
    assert seen.screen == [seen.screen[0]] and seen.screen[0].endswith("; no differences")
    timers = repo / "cell" / "timers.yaml"
    timers.write_text(re.sub(r"(?m)^  3: .*$", "  3: 0.80", timers.read_text()))
    for command, code in (("diff", 1), ("plan", 0)):
        seen = run(command, "cell", cwd=repo)
        assert seen.code == code, seen.raw
        no_bar_left(seen.screen)
        summary = [
            line
            for line in seen.screen
            if line.startswith("harlsync:") and not line.startswith("harlsync: warning:")
        ]  # plan also warns of the uncommitted edit (issue 22)
        assert len(summary) == 1 and re.fullmatch(
            rf"harlsync: {command} cell: {READ.format(contents=re.escape(CONTENTS[1]))}; "
            r"1 item differs \(1 timer\)",
            summary[0],
        ), seen.screen


def test_issue_14_off_a_terminal_pull_diff_and_plan_print_no_bar_and_no_summary(
    plant: Path,
) -> None:
    for command in (["pull", "loader"], ["diff", "loader"], ["plan", "loader"]):
        done = subprocess.run(
            [sys.executable, "-m", "harlsync", *command],
            cwd=plant,
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
            check=False,
        )
        assert (done.returncode, done.stderr) == (0, ""), command


def test_issue_14_backup_shows_a_live_line_per_robot_and_a_result_line_as_each_ends(
    repo: Path,
) -> None:
    robot_at(repo, "loader", 1, 115200)
    robot_at(repo, "press", 2, 115200)
    seen = run("backup", ".", cwd=repo)
    assert seen.code == 0, seen.raw
    drawn = seen.raw.decode()
    for name in ("loader", "press"):  # each had its own live line, with rate and time left
        assert re.search(
            rf"{name}: +[0-9]+%\|[^|]*\| [0-9]+/1082 exchanges with the controller "
            r"\[[0-9:]+<[0-9:?]+, [0-9.?]+/s\]",
            drawn,
        ), name
    no_bar_left(seen.screen)
    results = [
        line for line in seen.screen if re.fullmatch(r"\w+: ok, no change \([0-9.]+ s\)", line)
    ]
    assert sorted(line.split(":")[0] for line in results) == ["loader", "press"]
    assert seen.screen[-1] == "2 of 2 robot(s) backed up, 0 changed"


def test_issue_14_backup_off_a_terminal_stays_quiet(plant: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "harlsync", "backup", "."],
        cwd=plant,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        check=False,
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert "exchanges" not in done.stdout


@pytest.mark.parametrize(
    "command",
    [["pull", "loader"], ["diff", "loader"], ["push", "loader", "--yes"], ["backup", "."]],
)
def test_issue_14_ctrl_c_leaves_no_bar_on_the_screen_and_exits_130(
    repo: Path,
    command: list[str],
) -> None:
    robot_at(repo, "loader", 1, 9600)  # about 30 s to read: ^C comes long before the end
    robot_at(repo, "press", 2, 9600)
    before = git(repo, "status", "--porcelain", "--ignored")
    seen = run(*command, cwd=repo, interrupt_when="exchanges with the controller [")
    assert seen.code == 130, seen.raw
    no_bar_left(seen.screen)
    assert seen.screen[-1] == "harlsync: interrupted", seen.screen
    assert git(repo, "status", "--porcelain", "--ignored") == before  # nothing half saved


def test_each_family_says_what_a_read_found_in_its_own_words() -> None:
    # as a read finds it: where the offset tables end (issue 29)
    harl = replace(HarlState.generate(1).data, offset_end=OffsetEnd(100, "E21"))
    assert HARL_U2.contents(harl, registers=False) == CONTENTS[1]
    assert HARL_U2.contents(harl, registers=True) == CONTENTS[1] + ", 16 registers"
    state = IaiState.generate(3, position_range=(1, 40))
    data = IaiData(version=next(iter(state.versions.values())), positions=state.positions)
    assert IAI.contents(data, registers=False) == f"{len(state.positions)} positions"
    data.flags, data.integers, data.reals = {600: True}, {200: 1, 201: 2}, {}
    assert IAI.contents(data, registers=True) == (
        f"{len(state.positions)} positions, 2 integer variables, 0 real variables, 1 flag"
    )


class _CountedStream(io.StringIO):
    """stderr off a terminal, counting how often it is asked whether it is one."""

    asked = 0

    def isatty(self) -> bool:
        self.asked += 1
        return False


def test_issue_24_off_a_terminal_the_progress_asks_once_not_per_exchange(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    stream = _CountedStream()
    monkeypatch.setattr(sys, "stderr", stream)
    progress = Feedback("pull")
    for done in range(1, 101):
        progress(done, 100)
    progress.close()
    assert stream.asked == 1 and stream.getvalue() == "" and progress.exchanges == 100


@pytest.mark.parametrize("command", [["pull", "loader"], ["backup", "."]])
def test_issue_22_a_warning_while_a_bar_is_drawn_goes_above_it_and_leaves_no_remnant(
    repo: Path, command: list[str]
) -> None:
    for name, seed in (("loader", 1), ("press", 2)):  # replies lost: the link warns, retries
        project = robot_at(repo, name, seed, 115200)
        robot = project / "robot.yaml"
        text = robot.read_text().replace("baud=115200", "baud=115200&drop=0.03")
        robot.write_text(text.replace("timeout: 1.0", "timeout: 0.05"))
    git(repo, "commit", "-qam", "lossy lines")
    seen = run(*command, cwd=repo)
    assert seen.code == 0, seen.raw
    no_bar_left(seen.screen)
    assert not any(line.endswith(": connecting") for line in seen.screen), seen.screen
    warnings = [line for line in seen.screen if "WARNING" in line]
    assert warnings, seen.screen  # some replies were lost: the test saw what it is about
    for line in warnings:  # each whole, on a line of its own, not after a bar's remnant
        assert re.fullmatch(r"harlsync: WARNING: .*retry \d/3 after no reply within 0\.05 s", line)
