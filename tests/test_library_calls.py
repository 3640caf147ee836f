"""What the command line did besides parsing and printing, a Python caller of the
library gets too (issue 32 item 2): a first contact's refusals before its line is
opened, a first pull's family from its port's own URL scheme, a backup's outputs
checked before any robot is read, the snapshots listed, a simulator served."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from harlsync import families
from harlsync.errors import ProjectError, ProjectFormatError, SyncError
from harlsync.sim.run import SimOptions, start
from harlsync.sync import pulling, snapshots
from harlsync.sync.backupoutputs import BackupOutputs
from harlsync.sync.firstcontact import candidates, first_contact


def test_a_first_contact_refuses_what_it_cannot_take_before_the_line_is_opened(
    tmp_path: Path,
) -> None:
    port = str(tmp_path / "no-such-device")  # opening it would fail otherwise
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "robot.yaml").write_text("")
    with pytest.raises(ProjectError, match="exists and is not empty"):
        first_contact(port, write=taken)
    with pytest.raises(ProjectError, match="--baud fast: give auto or a rate"):
        first_contact(port, baud="fast")
    with pytest.raises(ProjectError, match="--stations zz"):
        first_contact(port, stations="zz")
    serial = candidates(port)
    assert serial and not any(f.schemes for f in serial)
    own = next(f for f in families.every() if f.schemes)
    assert candidates(f"{own.schemes[0].name}://127.0.0.1:1") == [own]


def test_a_first_pull_from_python_is_of_the_family_whose_scheme_its_port_has(
    tmp_path: Path,
) -> None:
    own = next(f for f in families.every() if f.schemes)
    url = f"{own.schemes[0].name}://127.0.0.1:1"
    family, _ = pulling._robot_for(tmp_path / "cell", url, None, None)
    assert family.name == own.name
    family, _ = pulling._robot_for(tmp_path / "cell", "/dev/ttyUSB0", None, None)
    assert family.name == families.DEFAULT


def test_a_backups_outputs_are_checked_before_any_robot_is_read(tmp_path: Path) -> None:
    wrong = BackupOutputs(metrics=str(tmp_path / "no" / "dir" / "m.prom"), html=str(tmp_path))
    with pytest.raises(SyncError, match="no robot was read") as refused:
        wrong.check()
    assert "--metrics" in str(refused.value) and "report page" in str(refused.value)
    BackupOutputs(metrics=str(tmp_path / "m.prom")).check()  # nothing to say


def test_the_snapshots_listing_marks_the_one_a_rollback_restores(tmp_path: Path) -> None:
    with pytest.raises(ProjectFormatError, match="not a project directory"):
        snapshots.listing(tmp_path / "none")
    cell = tmp_path / "cell"
    cell.mkdir()
    (cell / "robot.yaml").write_text("")
    assert snapshots.listing(cell).lines() == [
        f"no snapshot in {cell}: a push takes one before its first write"
    ]
    for name in ("000001-20261124T202350.294650Z-push", "000002-20261124T212350.294650Z-rollback"):
        (cell / snapshots.SNAPSHOT_DIR / name).mkdir(parents=True)
    found = snapshots.listing(cell)
    assert [s["number"] for s in found.to_json()] == [2, 1]
    assert [s["rollback_restores"] for s in found.to_json()] == [False, True]
    lines = found.lines()
    assert lines[0].split() == ["number", "time", "action", "path"]
    assert lines[2].endswith("-push  <- rollback restores this") and len(lines) == 3


def test_a_simulator_is_served_and_takes_its_commands_from_python() -> None:
    running = start(SimOptions(pty=False, listen="127.0.0.1:0"))
    answers: list[str] = []
    ended = threading.Event()
    running.serve(threading.Event(), ["status\n", "nonsense\n"], answers.append, ended.set)
    assert ended.is_set() and len(answers) == 2
    assert answers[0].startswith("station ") and answers[1].startswith("error: ")
