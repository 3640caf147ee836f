"""Saving a project is all or nothing, leaves robot.yaml to the user, and writes only changes."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from harlsync.model import ProgramArea, ProgramType, Step
from harlsync.project import Project, load_project, new_robot, save_project, store, validate_project

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


@pytest.mark.parametrize("failing_call", [1, 2, 3, 4, 5])
def test_a_save_that_fails_while_replacing_files_restores_the_previous_project(
    root: Path, monkeypatch: pytest.MonkeyPatch, failing_call: int
) -> None:
    before = snapshot(root)
    project = changed_project(root)
    monkeypatch.setattr(os, "replace", fail_on_call(os.replace, failing_call))
    with pytest.raises(OSError, match="No space left"):
        save_project(root, project)
    assert snapshot(root) == before


@pytest.mark.parametrize("failing_call", [1, 2, 3])
def test_a_save_that_fails_while_writing_temporary_files_touches_nothing(
    root: Path, monkeypatch: pytest.MonkeyPatch, failing_call: int
) -> None:
    before = snapshot(root)
    project = changed_project(root)
    monkeypatch.setattr(store, "_write_temp", fail_on_call(store._write_temp, failing_call))
    with pytest.raises(OSError, match="No space left"):
        save_project(root, project)
    assert snapshot(root) == before


def test_a_failed_first_save_into_a_new_directory_leaves_no_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    project = load_project(EXAMPLE)
    monkeypatch.setattr(os, "replace", fail_on_call(os.replace, 7))
    with pytest.raises(OSError):
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
