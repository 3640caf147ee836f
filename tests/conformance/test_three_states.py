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
        written = {change.name for write in result.written for change in write.items}
        assert written == {seen.item for seen in standing.pending}  # the pending, only them
        assert comparison.compare(project).changes == []
        deployed = git(project, "rev-parse", f"{backupref.deployed_ref('cell')}:cell")
        assert deployed == git(project, "rev-parse", "HEAD:cell")


def test_issue_30_a_pendant_edit_is_kept_on_the_backup_branch_as_drift_not_over_the_approved_files(
    name: str, tmp_path: Path
) -> None:
    with served(name, 32) as (device, station, url):
        project = set_up_plant(tmp_path, name, url, station)
        head = git(project, "rev-parse", "HEAD")
        approved = files_of(project)
        said = HARNESSES[name].edit(device.stations[station], random.Random(6))

        # The first backup under the three-state model: no deployed ref yet, so the
        # last backup an older harlsync committed is what the robot was deployed.
        report = backup.backup([project.parent], commit=True, workers=1)

        assert report.ok, report.render()
        assert git(project, "rev-parse", "HEAD") == head
        assert files_of(project) == approved
        assert git(project, "status", "--porcelain") == ""
        standing = report.robots[0].compared
        assert standing is not None and standing.drift and not standing.pending, said
        text = report.render()
        assert f"drift {len(standing.drift)} item" in text
        assert f"drift: {standing.drift[0].item} (first seen " in text
        assert f"set up {backupref.deployed_ref('cell')}: the last backup commit" in text
        # The backup branch holds what the robot holds, its commit naming the items.
        kept = git(project, "show", f"{backupref.BACKUP_BRANCH}:cell/robot.yaml")
        assert kept == (project / "robot.yaml").read_text()
        message = git(project, "log", "-1", "--format=%B", backupref.BACKUP_BRANCH)
        assert message.startswith(f"backup: cell: {report.robots[0].items[0]}")
        assert f"- cell: drift {len(standing.drift)} item" in message
        git(project, "checkout", "-q", backupref.BACKUP_BRANCH)
        assert comparison.compare(project).changes == []  # the robot, as the backup kept it
        git(project, "checkout", "-q", "-")

        # The next night, the same drift: reported again, first seen the night before.
        again = backup.backup([project.parent], commit=True, workers=1)
        assert again.ok and again.commit is None  # nothing new to keep
        later = again.robots[0].compared
        assert later is not None and later.drift == standing.drift
        assert git(project, "rev-parse", "HEAD") == head and files_of(project) == approved
        assert writes_since(device, 0) == []


def test_issue_30_adopt_writes_the_robots_change_into_the_project_and_a_push_says_it_reverts_one(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with served(name, 33) as (device, station, url):
        project = set_up_plant(tmp_path, name, url, station)
        assert backup.backup([project.parent], commit=True, workers=1).ok  # sets deployed up
        HARNESSES[name].edit(device.stations[station], random.Random(7))
        night = backup.backup([project.parent], commit=True, workers=1)
        drift = night.robots[0].compared
        assert drift is not None and drift.drift
        head = git(project, "rev-parse", "HEAD")

        # A plan names the items a push would revert, and when the robot changed.
        capsys.readouterr()
        assert cli.main(["plan", str(project)]) == 0
        out = capsys.readouterr().out
        when = drift.drift[0].first_seen[:10]
        assert f"# {drift.drift[0].item}: reverts a change made on the robot on {when}" in out

        # A push says so before its first write.
        told: list[tuple[str, int]] = []
        first = len(device.received)
        options = PushOptions(
            yes=True, told=lambda line: told.append((line, len(writes_since(device, first))))
        )
        result = deploy.push(project, options)
        assert result.ok and writes_since(device, first)
        assert told and all(count == 0 for _, count in told)
        assert "reverts a change made on the robot on" in told[0][0]
        assert comparison.compare(project).changes == []  # reverted: the robot is approved

        # The pendant edit again; this time the engineer adopts it.
        HARNESSES[name].edit(device.stations[station], random.Random(7))
        assert backup.backup([project.parent], commit=True, workers=1).robots[0].compared
        capsys.readouterr()
        assert cli.main(["adopt", str(project)]) == 0
        out = capsys.readouterr().out
        assert out.startswith("adopted ") and "review with 'git diff" in out
        assert git(project, "rev-parse", "HEAD") == head  # nothing committed for them
        assert comparison.compare(project).changes == []  # the project holds the robot's
        git(project, "commit", "-qam", "adopt the pendant edit")
        night = backup.backup([project.parent], commit=True, workers=1)
        after = night.robots[0].compared
        assert after is not None and after.verdict == "same as approved"
        assert cli.main(["adopt", str(project)]) == 0
        assert capsys.readouterr().out.startswith("nothing to adopt")
