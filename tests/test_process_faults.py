"""Process faults: the promises hold whatever happens to the processes.

Two promises (issue 6, "Prove the promises"): no SN command reaches a robot
while a task runs, and no backup is lost or corrupted, whatever the line, the
process or the input does.  These tests run the real CLI as subprocesses
against a real ``harlsync sim`` subprocess over TCP, and kill one or the other
(SIGKILL: no clean-up code runs) at a point chosen by waiting on what the
simulator has received (``--record``), never by sleeping:

- a pull killed, or cut off from its line, mid-read: the previous backup is
  byte-identical, every file of the project (``.harlsync/`` included), and no
  temporary file is left; a pull killed while it replaces the files (the
  command kills itself there): the next command puts the previous backup back,
  byte-identical, and the next pull works;
- a push killed mid-write: the audit log shows what it wrote, the next diff and
  push warn about it, and running the push again converges; a push killed while
  it saves its snapshot has written nothing and leaves no half snapshot;
- the simulator restarted mid-push (its memory is battery-backed, ``--state``):
  the push fails naming what it wrote, a robot that comes back in automatic gets
  no write at all, and running the push again converges;
- two harlsync on one robot at once: one gets the line, the other a one-line
  "in use" error naming the port, and the simulator never sees their requests
  interleaved.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import pytest
from conftest import git, until

from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.protocol import Request
from harlsync.families.harl_u2.sim import SimState
from harlsync.project import Project, load_project, new_robot, save_project
from harlsync.sync import audit, engine

pytestmark = pytest.mark.skipif(os.name != "posix", reason="SIGKILL and ptys are POSIX")

#: A pull of it is 130 requests (101 of them the offset tables and the probe past them).
SMALL = Config(ProgramArea(1, 4), ProgramArea(2, 6), ProgramArea(1, 4), ProgramArea(1, 2), 4, 16, 4)
HARLSYNC = [sys.executable, "-m", "harlsync"]
DEADLINE = 30.0
#: Names a save, the history file or a snapshot give their temporary files.
TEMP_MARKS = (".harlsync-new-", ".harlsync-old-", ".tmp", ".harlsync-save")


def run(*args: str, timeout: float = DEADLINE) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*HARLSYNC, *args],
        check=False,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        timeout=timeout,
    )


def start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [*HARLSYNC, *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def files_of(root: Path) -> dict[str, bytes]:
    """Every file under ``root``, hidden ones and ``.harlsync/`` included, by path."""
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def temp_files(root: Path) -> list[str]:
    return [name for name in files_of(root) if any(mark in name for mark in TEMP_MARKS)]


def sigkill(process: subprocess.Popen[str]) -> None:
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=DEADLINE)
    assert process.returncode == -signal.SIGKILL


# --- the simulator as a process -----------------------------------------------------------


@dataclass
class SimProcess:
    """``harlsync sim`` serving a project over TCP, recording every request it receives."""

    project: Path
    memory: Path
    record: Path
    options: tuple[str, ...] = ()
    port: int = 0
    process: subprocess.Popen[str] | None = None
    url: str = ""
    seen: int = 0  # requests received before the last mark()

    def start(self, *options: str) -> SimProcess:
        """Start it (again, on the same TCP port after the first time)."""
        self.record.unlink(missing_ok=True)
        self.seen = 0
        self.process = subprocess.Popen(
            [
                *HARLSYNC,
                "sim",
                "--project",
                str(self.project),
                "--state",
                str(self.memory),
                "--no-pty",
                "--listen",
                f"127.0.0.1:{self.port}",
                "--record",
                str(self.record),
                *self.options,
                *options,
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self.process.stdout is not None
        for line in self.process.stdout:
            if line.startswith("tcp: "):
                self.url = line.split()[1]
                self.port = int(self.url.rsplit(":", 1)[1])
            if line.startswith("stations:"):
                return self
        raise AssertionError(f"harlsync sim exited with {self.process.wait()}")

    def control(self, command: str) -> str:
        """Send a mode command (``auto``, ``stop``...) on its input; its answer."""
        assert self.process is not None and self.process.stdin and self.process.stdout
        self.process.stdin.write(command + "\n")
        self.process.stdin.flush()
        return self.process.stdout.readline()

    def mark(self) -> None:
        """From now on, :meth:`requests` shows only the requests received after this."""
        self.seen += len(self.requests())

    def requests(self) -> list[dict[str, object]]:
        if not self.record.exists():
            return []
        lines = self.record.read_text().splitlines(keepends=True)[self.seen :]
        return [json.loads(line) for line in lines if line.endswith("\n")]

    def writes(self) -> list[str]:
        return [str(r["payload"]) for r in self.requests() if str(r["payload"]).startswith("SN")]

    def unsafe_in_automatic(self) -> list[str]:
        return [
            str(r["payload"])
            for r in self.requests()
            if r["busy"] and Request(str(r["payload"]).split(" ", 1)[0]).unsafe
        ]

    def kill(self) -> None:
        assert self.process is not None
        sigkill(self.process)

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait(timeout=DEADLINE)


@dataclass
class Plant:
    """A robot served by ``harlsync sim`` and its backup, committed in a git repository."""

    root: Path
    cell: Path
    sim: SimProcess
    full_pull: int  # requests a whole pull of this robot takes

    def edit(self, timers: dict[int, str], steps: dict[tuple[int, int], str], message: str) -> None:
        """Change the backup and commit it: the robot no longer matches it."""
        loaded = load_project(self.cell)
        loaded.data.timers.update(timers)
        for (program, step), text in steps.items():
            loaded.data.programs[(ProgramType.MAIN, program)][step] = Step.parse(text)
        save_project(self.cell, loaded)
        git(self.root, "commit", "-qam", message)


@pytest.fixture
def plant(tmp_path: Path) -> Iterator[Plant]:
    source = tmp_path / "robot"
    data = SimState.generate(31, SMALL).data
    save_project(source, Project(source, new_robot("robot", "sim://robot", 1), data))
    sim = SimProcess(
        source,
        tmp_path / "memory",
        tmp_path / "requests.jsonl",
        ("--baud", "0", "--turnaround", "0.004"),
    ).start()
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q")
    cell = root / "cell"
    engine.pull(cell, port=sim.url)
    git(root, "add", "-A")
    git(root, "commit", "-qm", "first backup")
    plant = Plant(root, cell, sim, len(sim.requests()))
    sim.mark()
    yield plant
    sim.stop()


class Edits(TypedDict):
    """What :meth:`Plant.edit` changes: timers by number, MAIN steps by (program, step)."""

    timers: dict[int, str]
    steps: dict[tuple[int, int], str]


EIGHT_EDITS: Edits = {
    "timers": {0: "0.99", 1: "1.11", 2: "2.22", 3: "3.33"},
    "steps": {
        (0, 1): "MOVE P901 S20",
        (0, 3): "MOVE P903 S20",
        (1, 2): "MOVE P902 S20",
        (1, 5): "MOVE P905 S20",
    },
}


# --- a pull: the previous backup survives -------------------------------------------------


@pytest.mark.parametrize("what", ["the pull is killed", "the line is lost"])
def test_a_pull_stopped_mid_read_leaves_the_previous_backup_byte_identical(
    plant: Plant, what: str
) -> None:
    plant.edit({1: "9.99"}, {(0, 1): "MOVE P999 S20"}, "a backup the robot no longer matches")
    before = files_of(plant.cell)
    pull = start("pull", str(plant.cell))
    until(lambda: len(plant.sim.requests()) >= plant.full_pull // 2, "half the pull")
    if what == "the pull is killed":
        sigkill(pull)
    else:
        plant.sim.kill()
        _, err = pull.communicate(timeout=DEADLINE)
        assert pull.returncode == 2
        assert err.startswith("harlsync: error: port socket://127.0.0.1:") and err.count("\n") == 1
    assert len(plant.sim.requests()) < plant.full_pull, "the pull finished before it was stopped"
    assert files_of(plant.cell) == before
    if what == "the line is lost":
        plant.sim.start()
    # Nothing left behind stops the next backup (a stray file would make the tree dirty).
    assert run("pull", str(plant.cell)).returncode == 0
    assert files_of(plant.cell) != before and temp_files(plant.cell) == []


#: ``python -c`` this, then the harlsync arguments: the command SIGKILLs itself just
#: before it replaces the Nth file of a save (N is the first argument).
KILLED_AT_REPLACE = """
import os, signal, sys
from harlsync.cli import main
real, count, kill_at = os.replace, 0, int(sys.argv.pop(1))
def replace(src, dst):
    global count
    if ".harlsync-new-" in str(src):
        count += 1
        if count == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)
    real(src, dst)
os.replace = replace
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("kill_at", [1, 3], ids=["before the first file", "at the third file"])
def test_a_pull_killed_while_it_replaces_the_files_is_undone_by_the_next_command(
    plant: Plant, kill_at: int
) -> None:
    plant.edit(
        {1: "9.99"},
        {(0, 1): "MOVE P999 S20", (1, 1): "MOVE P998 S20"},
        "three files the robot no longer matches",
    )
    before = files_of(plant.cell)
    killed = subprocess.run(
        [sys.executable, "-c", KILLED_AT_REPLACE, str(kill_at), "pull", str(plant.cell)],
        check=False,
        capture_output=True,
    )
    assert killed.returncode == -signal.SIGKILL
    assert files_of(plant.cell) != before  # killed mid-save: a journal and temporaries
    assert run("validate", str(plant.cell)).returncode == 0  # any load undoes the save
    assert files_of(plant.cell) == before
    assert run("pull", str(plant.cell)).returncode == 0
    assert files_of(plant.cell) != before and temp_files(plant.cell) == []


# --- a push: audited as it goes, finished by running it again -----------------------------


def test_a_push_killed_mid_write_is_audited_and_running_it_again_converges(plant: Plant) -> None:
    plant.edit(**EIGHT_EDITS, message="eight edits")
    push = start("push", str(plant.cell), "--yes", "--reason", "eight edits")
    until(lambda: len(plant.sim.writes()) >= 3, "the third write")
    sigkill(push)
    sent = plant.sim.writes()
    assert 3 <= len(sent) < 8

    [record] = audit.results()
    assert record.result == "unfinished" and record.reason == "eight edits"
    written = [w.command for w in record.done]
    # The audit never claims less than was verified, nor more than was sent.
    assert written == sent[: len(written)] and len(written) >= len(sent) - 1
    assert record.failed_item is not None
    assert len(record.plan or []) == 8 and record.snapshot

    diff = run("diff", str(plant.cell))
    assert diff.returncode == 1
    warning = diff.stderr.splitlines()[0]
    assert warning.startswith("harlsync: warning: an earlier push to this robot did not finish")
    assert record.time is not None
    assert f"by {record.user} on {record.host}" in warning and record.time in warning
    assert f"wrote {len(written)} of 8 item(s)" in warning
    assert all(w.item is not None and w.item in warning for w in record.done)

    again = run("push", str(plant.cell), "--yes")
    assert again.returncode == 0, again.stderr
    assert "did not finish" in again.stderr  # said once more, then settled
    assert run("diff", str(plant.cell)).returncode == 0
    assert "did not finish" not in run("diff", str(plant.cell)).stderr
    assert [r.result for r in audit.results()] == ["unfinished", "ok"]
    assert plant.sim.unsafe_in_automatic() == []
    assert temp_files(plant.cell) == []


def test_a_push_killed_while_it_saves_its_snapshot_writes_nothing_and_leaves_no_half_snapshot(
    plant: Plant,
) -> None:
    plant.edit(**EIGHT_EDITS, message="eight edits")
    killed = subprocess.run(
        [sys.executable, "-c", KILLED_AT_REPLACE, "2", "push", str(plant.cell), "--yes"],
        check=False,
        capture_output=True,
    )
    assert killed.returncode == -signal.SIGKILL
    assert plant.sim.writes() == []
    assert engine.snapshots(plant.cell) == []  # rollback cannot pick a half snapshot
    assert "no snapshot to roll back to" in run("rollback", str(plant.cell), "--yes").stderr
    assert run("push", str(plant.cell), "--yes").returncode == 0
    assert len(engine.snapshots(plant.cell)) == 1 and temp_files(plant.cell) == []


def test_a_simulator_restarted_mid_push_fails_the_push_loudly_and_a_rerun_converges(
    plant: Plant,
) -> None:
    plant.edit(**EIGHT_EDITS, message="eight edits")
    push = start("push", str(plant.cell), "--yes")
    until(lambda: len(plant.sim.writes()) >= 2, "the second write")
    plant.sim.kill()
    _, err = push.communicate(timeout=DEADLINE)
    assert push.returncode == 2
    lines = err.splitlines()
    assert lines[0].startswith("harlsync: push stopped: wrote ")
    assert any(line.startswith("  written:     ") for line in lines)
    assert any(line.startswith("  not written: ") for line in lines)
    assert "run the same push again to finish" in err
    assert lines[-1].startswith("harlsync: error: port socket://")

    # The controller comes back holding what was written (battery-backed), in automatic.
    kept = load_project(plant.sim.memory / "station-1").data.timers
    assert kept[1] == "1.11"
    plant.sim.start("--auto")
    refused = run("push", str(plant.cell), "--yes")
    assert refused.returncode == 3 and "task 0 in execution" in refused.stderr
    assert plant.sim.writes() == []

    plant.sim.control("stop")
    assert run("push", str(plant.cell), "--yes").returncode == 0
    assert run("diff", str(plant.cell)).returncode == 0
    assert plant.sim.unsafe_in_automatic() == []


# --- two harlsync on one robot ------------------------------------------------------------


@dataclass
class Prompted:
    """A push waiting at its confirmation prompt, on a terminal: it holds the line."""

    process: subprocess.Popen[bytes]
    terminal: int
    output: bytearray

    def read_until(self, text: bytes) -> None:
        def seen() -> bool:
            ready, _, _ = select.select([self.terminal], [], [], 0.05)
            if ready:
                try:
                    self.output += os.read(self.terminal, 4096)
                except OSError:  # the push exited: its side of the terminal is closed
                    return True
            return text in self.output

        until(seen, f"{text!r} from the push")
        assert text in self.output, self.output.decode(errors="replace")

    def answer(self, text: str) -> int:
        os.write(self.terminal, text.encode() + b"\n")
        self.read_until(b"push: wrote and verified")
        code = self.process.wait(timeout=DEADLINE)
        os.close(self.terminal)
        return code


def prompted_push(cell: Path) -> Prompted:
    terminal, side = os.openpty()
    # input() prompts on stderr when it reads a terminal: all three on it.
    process = subprocess.Popen([*HARLSYNC, "push", str(cell)], stdin=side, stdout=side, stderr=side)
    os.close(side)
    prompted = Prompted(process, terminal, bytearray())
    prompted.read_until(b"[y/N]")
    return prompted


@pytest.mark.parametrize("second", ["push", "pull", "backup"])
def test_two_harlsync_on_one_robot_one_gets_the_line_the_other_a_one_line_busy_error(
    plant: Plant, second: str
) -> None:
    plant.edit(**EIGHT_EDITS, message="eight edits")
    # The second command works on another backup of the same robot: the project
    # lock does not meet it, the line lock must.
    other_cell = plant.root / "cell-2"
    engine.pull(other_cell, port=plant.sim.url)
    git(plant.root, "add", "-A")
    git(plant.root, "commit", "-qm", "a second backup of the robot")
    plant.sim.mark()
    first = prompted_push(plant.cell)
    args = {
        "push": ["push", str(other_cell), "--yes", "--lock-timeout", "0"],
        "pull": ["pull", str(other_cell), "--lock-timeout", "0"],
        "backup": ["backup", str(other_cell), "--lock-timeout", "0", "--attempts", "1"],
    }[second]
    other = run(*args)
    assert first.answer("y") == 0
    if second == "backup":
        assert other.returncode == 1
        message = next(line for line in other.stdout.splitlines() if line.startswith("cell"))
        assert "FAILED" in message
    else:
        assert other.returncode == 2
        [message] = other.stderr.splitlines()
    assert f"port {plant.sim.url}" in message and "in use by another harlsync (pid" in message
    clients = [r["client"] for r in plant.sim.requests()]
    assert len(set(clients)) == 1  # one connection: the other never reached the line
    assert len(plant.sim.writes()) == 8 and plant.sim.unsafe_in_automatic() == []
    assert run("diff", str(plant.cell)).returncode == 0


@pytest.mark.parametrize("second", ["pull over another line", "backup"])
def test_issue_11_a_command_saving_a_project_holds_it_against_any_other_for_its_whole_run(
    plant: Plant, tmp_path: Path, second: str
) -> None:
    # Two pulls of one directory over two lines each read their own robot and saved,
    # leaving a project mixed from both. A push waiting at its prompt holds the
    # project as long as any command does: nothing else may save it meanwhile.
    other = tmp_path / "other-robot"
    save_project(
        other,
        Project(other, new_robot("other", "sim://other", 1), SimState.generate(32, SMALL).data),
    )
    other_sim = SimProcess(
        other, tmp_path / "other-memory", tmp_path / "other.jsonl", ("--baud", "0")
    ).start()
    try:
        plant.edit(**EIGHT_EDITS, message="eight edits")
        before = files_of(plant.cell)
        first = prompted_push(plant.cell)
        args = {
            "pull over another line": [
                "pull",
                str(plant.cell),
                "--port",
                other_sim.url,
                "--lock-timeout",
                "0",
            ],
            "backup": ["backup", str(plant.cell), "--lock-timeout", "0", "--attempts", "1"],
        }[second]
        refused = run(*args)
        assert files_of(plant.cell) == before
        assert first.answer("y") == 0
    finally:
        other_sim.stop()
    says = (
        f"project {plant.cell} is in use by pid {first.process.pid} (harlsync push); "
        "wait for it to finish"
    )
    if second == "backup":
        assert refused.returncode == 1
        [row] = [line for line in refused.stdout.splitlines() if line.startswith("cell ")]
        assert row.split()[1] == "FAILED" and says in row
    else:
        assert refused.returncode == 2
        [line] = refused.stderr.splitlines()
        assert line.startswith(f"harlsync: error: {says}")
    assert other_sim.requests() == []
    assert len(plant.sim.writes()) == 8
    assert run("diff", str(plant.cell)).returncode == 0


#: ``python -c`` this, then the harlsync arguments: the command SIGKILLs itself when it
#: is about to commit, after its save (as a power cut would).
KILLED_AT_COMMIT = """
import os, signal, sys
from harlsync.cli import main
from harlsync.sync import git
git.commit = lambda *args, **kwargs: os.kill(os.getpid(), signal.SIGKILL)
sys.exit(main(sys.argv[1:]))
"""


def test_issue_11_a_pull_killed_between_its_save_and_its_commit_is_committed_by_the_next(
    plant: Plant,
) -> None:
    plant.sim.stop()
    memory = load_project(plant.sim.memory / "station-1")
    memory.data.timers[2] = "4.44"  # the robot changed (on the pendant)
    save_project(plant.sim.memory / "station-1", memory)
    plant.sim.start()
    killed = subprocess.run(
        [sys.executable, "-c", KILLED_AT_COMMIT, "pull", str(plant.cell), "--commit"],
        check=False,
        capture_output=True,
    )
    assert killed.returncode == -signal.SIGKILL
    assert git(plant.root, "status", "--porcelain").split() == ["M", "cell/timers.yaml"]
    again = run("pull", str(plant.cell), "--commit")
    assert again.returncode == 0, again.stderr
    assert git(plant.root, "status", "--porcelain") == ""
    assert git(plant.root, "log", "-1", "--format=%s") == (
        "pull cell: no change; with an earlier pull's backup, never committed (timers.yaml)\n"
    )
    assert "  2: 4.44\n" in git(plant.root, "show", "HEAD:cell/timers.yaml")
