"""Issue 30: the approved version, the deployed one and the robot's own, for every
registered family (the toy too): a nightly backup never reverts a change waiting
for its window, a pendant edit is kept apart and reported as drift, and adopting
it or reverting it is an engineer's decision.  What the controller received is
taken from the simulator's own record.  Run one family with ``-k <name>``.
"""

from __future__ import annotations

import copy
import random
import subprocess
from pathlib import Path
from typing import Any

import pytest

from harlsync import cli, families
from harlsync.sync import backup, backupref, comparison, deploy, pulling
from harlsync.sync.deploy import PushOptions

from .harness import HARNESSES, join, names, served


def git(repo: Path, *args: str) -> str:
    return subprocess.run(
        ["git", "-c", "user.name=Alice Engineer", "-c", "user.email=alice@plant", *args],
        cwd=repo,
        check=True,
        capture_output=True,
        text=True,
    ).stdout


def files_of(project: Path) -> dict[str, bytes]:
    return {
        p.relative_to(project).as_posix(): p.read_bytes()
        for p in sorted(project.rglob("*"))
        if p.is_file() and ".harlsync" not in p.parts
    }


def writes_since(device: Any, first: int) -> list[Any]:
    return [r for r in device.received[first:] if r.is_write]


@pytest.fixture(params=names())
def name(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    join(request.param, monkeypatch)
    HARNESSES[request.param].quick(monkeypatch)
    return str(request.param)


def set_up_plant(tmp_path: Path, name: str, url: str, station: int) -> Path:
    """A plant repository with one robot, first backed up and committed as an older
    harlsync did it (``pull --commit`` on the approved branch)."""
    plant = tmp_path / "plant"
    plant.mkdir()
    git(plant, "init", "-q")
    git(plant, "config", "user.name", "Plant backup")
    git(plant, "config", "user.email", "backup@plant")
    project = plant / "cell"
    pulling.pull(project, port=url, station=station, family=families.get(name), commit=True)
    return project


def engineer_commits(project: Path, device: Any, station: int, name: str, seed: int) -> str:
    """An engineer's change to the project, committed, not on the robot: made as the
    harness would make it at a controller, read into the project, and the controller
    put back as it was."""
    before = copy.deepcopy(device.stations[station])
    said = HARNESSES[name].edit(device.stations[station], random.Random(seed))
    pulling.pull(project)
    device.stations[station] = before
    git(project, "commit", "-qam", f"engineer: {said}")
    assert git(project, "status", "--porcelain") == ""
    return said


def test_issue_30_a_committed_change_survives_the_nightly_backup_and_the_push_deploys_it(
    name: str, tmp_path: Path
) -> None:
    with served(name, 31) as (device, station, url):
        project = set_up_plant(tmp_path, name, url, station)
        engineer_commits(project, device, station, name, 5)
        head = git(project, "rev-parse", "HEAD")
        approved = files_of(project)

        report = backup.backup([project.parent], commit=True, workers=1)

        assert report.ok, report.render()
        assert git(project, "rev-parse", "HEAD") == head  # the approved branch did not move
        assert files_of(project) == approved  # nor did the working tree
        assert git(project, "status", "--porcelain") == ""
        assert git(project, "rev-parse", backupref.BACKUP_BRANCH).strip() == report.commit
        standing = report.robots[0].compared
        assert standing is not None and standing.pending and not standing.drift
        assert standing.pending[0].by and "Alice Engineer" in standing.pending[0].by
        assert writes_since(device, 0) == []  # a backup never writes

        first = len(device.received)
        result = deploy.push(project, PushOptions(yes=True))

        assert result.ok and result.written
        assert writes_since(device, first)  # the simulator received the engineer's change
        assert comparison.compare(project).changes == []
        deployed = git(project, "rev-parse", f"{backupref.deployed_ref('cell')}:cell")
        assert deployed == git(project, "rev-parse", "HEAD:cell")
