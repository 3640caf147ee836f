"""Saving a project is all or nothing, leaves robot.yaml to the user, and writes only changes."""

from __future__ import annotations

import itertools
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from fsfaults import disk_full, read_only

from harlsync.errors import ProjectError
from harlsync.families.harl_u2.model import ProgramArea, ProgramType, Step
from harlsync.project import (
    Project,
    atomic,
    load_project,
    new_robot,
    save_project,
    store,
    validate_project,
)

EXAMPLE = Path(__file__).resolve().parent.parent / "projects" / "pick-and-place"


@pytest.fixture
def root(tmp_path: Path) -> Path:
    target = tmp_path / "cell"
    shutil.copytree(EXAMPLE, target)
    return target


def snapshot(root: Path) -> dict[str, bytes]:
    """Every file under ``root``, dotfiles and leftovers included."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def changed_project(root: Path) -> Project:
    """A pull's result: new timers, a changed step, and two MAIN programs fewer."""
    project = load_project(root)
    data = project.data
    data.timers[3] = "2.00"
    data.programs[(ProgramType.START, 0)][0] = Step.parse("CALLS S03")
    data.config = replace(data.config, main=ProgramArea(2, 64))
    del data.programs[(ProgramType.MAIN, 2)], data.programs[(ProgramType.MAIN, 3)]
    return project


def fail_on_call(real: Callable[..., Any], n: int) -> Callable[..., Any]:
    """``real``, except that its ``n``-th call raises OSError (disk full)."""
    calls = 0

    def fake(*args: Any, **kwargs: Any) -> Any:
        nonlocal calls
        calls += 1
        if calls == n:
            raise OSError(28, "No space left on device")
        return real(*args, **kwargs)

    return fake


def save_fails_and_changes_nothing(
    root: Path, fault: Callable[[pytest.MonkeyPatch], object], match: str
) -> ProjectError:
    """Save :func:`changed_project` to ``root`` with ``fault`` applied to the file
    system: it must fail with a ProjectError matching ``match`` and leave every file
    under ``root`` as it was, no leftover added.  Returns the error."""
    before = snapshot(root)
    project = changed_project(root)
    with pytest.MonkeyPatch.context() as patch, pytest.raises(ProjectError, match=match) as failed:
        fault(patch)
        save_project(root, project)
    assert snapshot(root) == before
    return failed.value


def test_a_save_writes_only_what_changed_and_removes_programs_no_longer_configured(
    root: Path,
) -> None:
    assert save_project(root, changed_project(root)) == [
        "controller.yaml",
        "programs/main-02.yaml",
        "programs/main-03.yaml",
        "programs/start.yaml",
        "timers.yaml",
    ]
    assert not (root / "programs" / "main-02.yaml").exists()
    assert validate_project(root) == []
    assert load_project(root).data.timers[3] == "2.00"
    assert not [name for name in snapshot(root) if ".harlsync-" in name]


@pytest.mark.parametrize("failing_call", [1, 2, 3, 4])
def test_a_save_that_fails_while_replacing_files_restores_the_previous_project(
    root: Path, failing_call: int
) -> None:
    # Call 1 puts the journal in place, calls 2-4 replace the three changed files.
    save_fails_and_changes_nothing(
        root,
        lambda patch: patch.setattr(os, "replace", fail_on_call(os.replace, failing_call)),
        "No space left",
    )


def test_a_save_that_fails_while_removing_a_program_restores_the_previous_project(
    root: Path,
) -> None:
    real = Path.unlink

    def unlink(self: Path, missing_ok: bool = False) -> None:
        if self.name == "main-03.yaml":
            raise OSError(30, "Read-only file system")
        real(self, missing_ok=missing_ok)

    save_fails_and_changes_nothing(
        root, lambda patch: patch.setattr(Path, "unlink", unlink), "Read-only"
    )


@pytest.mark.parametrize("failing_call", [1, 2, 3])
def test_a_save_that_fails_while_writing_temporary_files_touches_nothing(
    root: Path, failing_call: int
) -> None:
    save_fails_and_changes_nothing(
        root,
        lambda patch: patch.setattr(
            atomic, "_write_temp", fail_on_call(atomic._write_temp, failing_call)
        ),
        "No space left",
    )


def test_a_failed_first_save_into_a_new_directory_leaves_no_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    project = load_project(EXAMPLE)
    monkeypatch.setattr(os, "replace", fail_on_call(os.replace, 7))
    with pytest.raises(ProjectError):
        save_project(tmp_path / "new" / "robot", project)
    assert list(tmp_path.iterdir()) == []


def test_robot_yaml_is_written_when_created_and_otherwise_left_to_the_user(root: Path) -> None:
    edit = "# the cell next to the door\n"
    (root / "robot.yaml").write_text(
        (root / "robot.yaml")
        .read_text()
        .replace("keep_registers: false\n", "keep_registers: false\n" + edit)
    )
    project = load_project(root)
    project.robot.description = "changed in memory only"
    save_project(root, project)
    assert (root / "robot.yaml").read_text().endswith(edit)

    assert save_project(root, project, rewrite_robot=True) == ["robot.yaml"]
    assert "changed in memory only" in (root / "robot.yaml").read_text()
    assert edit not in (root / "robot.yaml").read_text()


def test_a_pull_into_a_new_directory_writes_a_complete_project(tmp_path: Path) -> None:
    data = load_project(EXAMPLE).data
    robot = new_robot("press-2", "socket://10.0.0.7:4001", 2)
    written = save_project(tmp_path / "press-2", Project(tmp_path / "press-2", robot, data))
    assert "robot.yaml" in written and "programs/start.yaml" in written
    assert ".schemas/program.schema.json" in written
    loaded = load_project(tmp_path / "press-2")
    assert loaded.robot == robot and loaded.data == data
    text = (tmp_path / "press-2" / "robot.yaml").read_text()
    assert "  port: socket://10.0.0.7:4001\n  station: 2\n" in text
    assert "maintenance_windows: []\n" in text


def test_registers_are_kept_only_when_the_robot_keeps_them(tmp_path: Path) -> None:
    project = load_project(EXAMPLE)
    project.data.registers = {n: "0012" for n in range(16)}
    save_project(tmp_path, project)
    assert not (tmp_path / "registers.yaml").exists()
    project.robot.keep_registers = True
    save_project(tmp_path, project, rewrite_robot=True)
    assert "  0: 0012\n" in (tmp_path / "registers.yaml").read_text()
    assert load_project(tmp_path).data.registers == project.data.registers
    project.data.registers = None  # a pull that did not read them keeps the old file
    assert "registers.yaml" not in save_project(tmp_path, project)
    assert (tmp_path / "registers.yaml").exists()


def test_a_step_with_data_but_no_command_is_refused(tmp_path: Path) -> None:
    project = load_project(EXAMPLE)
    project.data.programs[(ProgramType.MAIN, 3)][2] = Step(None, ("P001",))
    with pytest.raises(Exception, match="MAIN 3 step 2: data without a command"):
        save_project(tmp_path, project)
    assert list(tmp_path.iterdir()) == []


def saved_in_a_child_killed_at(root: Path, project: Project, kill_at: int) -> bool:
    """Save ``project`` to ``root`` in a forked child that SIGKILLs itself at its
    ``kill_at``-th file-system step (link, fsync, syncfs, rename, unlink).  Returns whether
    it was killed (False: the save ended before that step)."""
    child = os.fork()
    if child == 0:  # pragma: no cover - the child's exit status is the result
        calls = 0

        def deadly(real: Callable[..., Any]) -> Callable[..., Any]:
            def step(*args: Any, **kwargs: Any) -> Any:
                nonlocal calls
                calls += 1
                if calls == kill_at:
                    os.kill(os.getpid(), signal.SIGKILL)
                return real(*args, **kwargs)

            return step

        for name in ("link", "fsync", "replace", "unlink"):
            setattr(os, name, deadly(getattr(os, name)))
        atomic._syncfs = deadly(atomic._syncfs)
        try:
            save_project(root, project)
        finally:
            os._exit(0)
    _, status = os.waitpid(child, 0)
    return os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork()")
def test_a_save_killed_at_any_step_leaves_the_previous_project_or_the_whole_new_one(
    tmp_path: Path, root: Path
) -> None:
    before = snapshot(root)
    done = tmp_path / "done"
    shutil.copytree(root, done)
    save_project(done, changed_project(done))
    after = snapshot(done)
    outcomes = []
    for kill_at in itertools.count(1):
        cell = tmp_path / f"killed-{kill_at}"
        shutil.copytree(root, cell)
        if not saved_in_a_child_killed_at(cell, changed_project(cell), kill_at):
            break
        interrupted = (cell / store.JOURNAL).exists()
        load_project(cell)  # the next harlsync puts it right
        now = snapshot(cell)
        assert now in (before, after), f"killed at step {kill_at}: a mix of old and new files"
        assert now == before or not interrupted, f"killed at step {kill_at}"
        outcomes.append("before" if now == before else "after")
    # Killed at every step, from the first temporary to the last clean-up: the
    # journal was put back from, and the save ends up whole on the late kills.
    assert kill_at > 20 and outcomes[0] == "before" and outcomes[-1] == "after"
    assert snapshot(cell) == after


def test_a_save_in_progress_in_another_process_is_waited_for_not_undone(root: Path) -> None:
    before = snapshot(root)
    with subprocess.Popen([sys.executable, "-c", "input()"], stdin=subprocess.PIPE) as saver:
        journal = {"pid": saver.pid, "files": [["timers.yaml", None, None]], "made_dirs": []}
        (root / store.JOURNAL).write_text(json.dumps(journal))
        with pytest.raises(ProjectError, match=f"process {saver.pid} is saving this project"):
            load_project(root)
        assert (root / "timers.yaml").exists()
        saver.communicate(b"\n")
    # That process is gone without finishing: its journal is undone (timers.yaml was new).
    with pytest.raises(ProjectError):
        load_project(root)
    assert not (root / "timers.yaml").exists() and not (root / store.JOURNAL).exists()
    assert set(snapshot(root)) == set(before) - {"timers.yaml"}


# --- issue 11: a disk that fills up, a directory that is read-only --------------------------


@pytest.mark.parametrize("written_before", [0, 1, 2, 3], ids=lambda n: f"after {n} file(s)")
def test_issue_11_a_save_on_a_full_disk_is_one_line_and_leaves_no_file_behind(
    root: Path, written_before: int
) -> None:
    # Three changed files, then the journal: the disk fills up at each in turn.
    files: list[list[str]] = []  # what the full disk saw opened for writing
    failed = save_fails_and_changes_nothing(
        root,
        lambda disk: files.append(disk_full(disk, root, after=written_before)),
        "No space left",
    )
    assert len(files[0]) == written_before + 1
    message = str(failed)
    assert "\n" not in message
    assert message.startswith(f"{root}: cannot save the project (No space left on device): ")
    assert "free some space" in message


def test_issue_11_a_save_into_a_read_only_directory_is_one_line_and_changes_nothing(
    root: Path,
) -> None:
    save_fails_and_changes_nothing(
        root,
        lambda disk: read_only(disk, root),
        r"^[^\n]*cannot save the project \(Read-only file system\)",
    )


def test_issue_11_a_save_that_changes_nothing_writes_nothing(
    root: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Not even a journal: a pull of an unchanged robot works on a read-only backup.
    project = load_project(root)
    save_project(root, project)
    read_only(monkeypatch, root)
    assert save_project(root, project) == []


# --- issue 24: one sync for all the files, then the renames, then the directories ----------


def test_issue_24_a_save_syncs_every_file_at_once_before_the_first_rename_then_the_names(
    root: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if atomic._load_syncfs() is None:
        pytest.skip("no syncfs(2) here: each file is fsynced (the next test)")
    project = changed_project(root)
    steps: list[tuple[str, str]] = []
    real_fsync, real_replace, real_syncfs = os.fsync, os.replace, atomic._syncfs

    def fsync(fd: int) -> None:
        steps.append(("fsync dir" if stat.S_ISDIR(os.fstat(fd).st_mode) else "fsync file", ""))
        real_fsync(fd)

    def replace_(src: Any, dst: Any) -> None:
        steps.append(("rename", Path(dst).name))
        real_replace(src, dst)

    def syncfs(fd: int) -> None:
        steps.append(("syncfs", ""))
        real_syncfs(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace_)
    monkeypatch.setattr(atomic, "_syncfs", syncfs)
    written = save_project(root, project)

    kinds = [kind for kind, _ in steps]
    assert "fsync file" not in kinds
    renames = [i for i, (kind, name) in enumerate(steps) if kind == "rename"]
    # The journal is put in place before the one sync of every file, the files after it.
    assert steps[renames[0]] == ("rename", store.JOURNAL)
    assert renames[0] < kinds.index("syncfs") < renames[1]
    assert "syncfs" not in kinds[renames[1] : renames[-1]]
    assert {name for kind, name in steps[renames[1] :] if kind == "rename"} >= {
        Path(name).name for name in written if not name.startswith("programs/main-0")
    }
    # Then the new names, and the root once the journal is gone.
    assert kinds[renames[-1] + 1 :] == ["syncfs", "fsync dir"]
    assert load_project(root).data == project.data


def test_issue_24_without_syncfs_each_file_is_fsynced_as_before(
    root: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(atomic, "_load_syncfs", lambda: None)
    project = changed_project(root)
    files = 0
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        nonlocal files
        files += not stat.S_ISDIR(os.fstat(fd).st_mode)
        real_fsync(fd)

    temps: list[Path] = []
    real_write = atomic._write_temp

    def write_temp(target: Path, data: bytes, *, fsync: bool = True) -> Path:
        temps.append(target)
        return real_write(target, data, fsync=fsync)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(atomic, "_write_temp", write_temp)
    save_project(root, project)
    # Every file written (the local record too), and the journal, each on its own.
    assert root / store.JOURNAL in temps and root / "timers.yaml" in temps
    assert files == len(temps)
    assert load_project(root).data == project.data


def test_issue_24_a_sync_that_fails_leaves_the_previous_project_and_no_temporary(
    root: Path,
) -> None:
    def failing(fd: int) -> None:
        raise OSError(5, "Input/output error")

    def fault(patch: pytest.MonkeyPatch) -> None:
        patch.setattr(atomic, "_syncfs", failing)
        patch.setattr(atomic, "_load_syncfs", lambda: failing)

    save_fails_and_changes_nothing(root, fault, "Input/output error")
