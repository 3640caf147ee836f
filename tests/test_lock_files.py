"""Lock files do not pile up (issue 22 item 11): a released lock leaves no file in the
lock directory, and the lock of a process that died holding it is reclaimed."""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.errors import PortBusyError, PortError, ProjectError
from harlsync.link import lock as line_lock
from harlsync.link.lock import LineLock, LockFile, LockTimeout, WindowsLockFile, lock_path
from harlsync.project.lock import lock_path as project_lock_path
from harlsync.project.lock import project_lock
from harlsync.sim.protocol_sim import register, unregister

pytestmark = pytest.mark.skipif(os.name == "nt", reason="flock(2) locks; Windows has msvcrt's")

#: Takes a project's lock and a line's, says so, then waits for its standard input
#: to close, or is killed holding them.
HOLDER = textwrap.dedent(
    """
    import os, sys
    from harlsync.link.lock import LineLock, lock_path
    from harlsync.project.lock import project_lock
    with project_lock(sys.argv[1], command="pull"):
        line = LineLock(sys.argv[2], lock_path(sys.argv[2]))
        line.acquire(0)
        print("held", flush=True)
        if sys.argv[3] == "die":
            os.kill(os.getpid(), 9)
        sys.stdin.read()
        line.release()
    """
)


@pytest.fixture
def robot(repo: Path, toy: str) -> Iterator[tuple[str, Path]]:
    """A toy robot (what any family's commands do with locks is the engine's)."""
    sim = Simulator({1: SimState.generate(7)})
    url = register(sim)
    yield url, repo / "press"
    unregister(url)


def holder(project: Path, line: str, how: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(project), line, how],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None and process.stdout.readline() == "held\n"
    return process


def test_a_day_of_commands_leaves_no_lock_file_behind(
    robot: tuple[str, Path], lock_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, project = robot
    assert main(["pull", str(project), "--port", url, "--family", "toy", "--commit"]) == 0
    assert sorted(os.listdir(lock_dir)) == []
    slots = project / "slots.yaml"
    slots.write_text(re.sub(r"(?m)^  1: .*$", "  1: 80", slots.read_text()))
    git(project.parent, "commit", "-qam", "slot 1")
    assert main(["diff", str(project)]) == 1
    assert main(["push", str(project), "--yes"]) == 0
    assert main(["rollback", str(project), "--yes"]) == 0
    assert main(["backup", str(project.parent)]) == 0
    assert main(["status", str(project.parent)]) in (0, 1)
    capsys.readouterr()
    assert sorted(os.listdir(lock_dir)) == []


def test_the_locks_of_a_killed_harlsync_are_reclaimed_by_the_next_one(
    robot: tuple[str, Path], lock_dir: Path
) -> None:
    url, project = robot
    gone = project.parent / "a-project-never-used-again"
    process = holder(gone, "socket://192.0.2.7:4001", "die")
    assert process.wait(30) == -signal.SIGKILL
    left = sorted(os.listdir(lock_dir))
    assert len(left) == 4 and sum(name.endswith(".owner") for name in left) == 2, left
    assert main(["pull", str(project), "--port", url, "--family", "toy"]) == 0
    assert sorted(os.listdir(lock_dir)) == []


def test_a_live_holders_lock_is_left_alone_and_goes_when_it_ends(
    robot: tuple[str, Path], lock_dir: Path
) -> None:
    url, project = robot
    other = project.parent / "other"
    process = holder(other, "socket://192.0.2.7:4001", "wait")
    try:
        held = sorted(os.listdir(lock_dir))
        assert main(["pull", str(project), "--port", url, "--family", "toy"]) == 0
        assert sorted(os.listdir(lock_dir)) == held and len(held) == 4
        assert line_lock.reclaim_dead(lock_dir) == []
        with pytest.raises(ProjectError, match="in use by pid"), project_lock(other):
            pass  # it holds it still
    finally:
        assert process.stdin is not None
        process.stdin.close()
        assert process.wait(30) == 0
    assert sorted(os.listdir(lock_dir)) == []


def test_a_lock_whose_file_was_removed_as_it_was_locked_is_taken_again_on_the_new_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "line.lock"
    real = line_lock._open_lock_file
    stale: list[int | None] = []

    def open_a_file_its_last_holder_removes(path_: Path) -> int | None:
        if not stale:  # as a holder that removed it and released it just now
            fd = real(path_)
            path_.unlink()
            stale.append(fd)
            return fd
        return real(path_)

    monkeypatch.setattr(line_lock, "_open_lock_file", open_a_file_its_last_holder_removes)
    lock = LockFile.take(path, 5)
    try:
        assert lock._fd is not None
        assert os.path.samestat(os.stat(path), os.fstat(lock._fd))
        with pytest.raises(LockTimeout):  # the lock at the path is held: by this one
            LockFile.take(path, 0)
    finally:
        lock.release()
    assert not path.exists()


def test_a_line_lock_and_a_project_lock_go_with_their_owner_files(
    tmp_path: Path, lock_dir: Path
) -> None:
    line = LineLock("socket://192.0.2.7:4001", lock_path("socket://192.0.2.7:4001"))
    line.acquire(0)
    with project_lock(tmp_path / "p", command="pull"):
        assert project_lock_path(tmp_path / "p").exists() and line.path is not None
        assert line.path.with_name(line.path.name + ".owner").exists()
    line.release()
    assert os.listdir(lock_dir) == []


class FakeMsvcrt:
    """``msvcrt.locking`` as Windows answers it, over flock(2): what
    :class:`WindowsLockFile` calls, so that its waiting, timeout and clean-up run here."""

    LK_UNLCK, LK_NBLCK = 0, 2

    def locking(self, fd: int, mode: int, nbytes: int) -> None:
        import fcntl

        assert nbytes == 1
        try:
            fcntl.flock(
                fd, fcntl.LOCK_UN if mode == self.LK_UNLCK else fcntl.LOCK_EX | fcntl.LOCK_NB
            )
        except BlockingIOError:
            raise OSError(errno.EACCES, "Permission denied") from None


def test_issue_24_the_windows_lock_waits_times_out_and_removes_its_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "msvcrt", FakeMsvcrt())
    path = tmp_path / "COM3-0123456789ab.lock"
    lock = WindowsLockFile.take(path, 0)
    try:
        with pytest.raises(LockTimeout, match="COM3"):
            WindowsLockFile.take(path, 0)
        line = LineLock("COM3", path)
        with pytest.raises(PortBusyError, match=r"^port COM3: in use by another harlsync;"):
            monkeypatch.setattr(line_lock, "take_lock_file", WindowsLockFile.take)
            line.acquire(0)
    finally:
        lock.release()
    assert not path.exists()
    again = WindowsLockFile.take(path, 0)  # released: free to take
    again.release()
    lock.release()  # twice: nothing
    assert os.listdir(tmp_path) == []


def test_issue_24_without_any_file_locking_a_line_lock_says_so_in_one_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "msvcrt", None)  # import msvcrt: ImportError
    monkeypatch.setattr(line_lock, "take_lock_file", WindowsLockFile.take)
    line = LineLock("COM3", tmp_path / "COM3.lock")
    with pytest.raises(PortError, match="neither flock.2. nor msvcrt.locking"):
        line.acquire(0)
