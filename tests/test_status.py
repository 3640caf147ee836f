"""What each pull and backup records, and harlsync status, which shows it without
touching a robot."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import git

from harlsync.families.harl_u2.model import Config, ProgramArea
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim import Faults
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine
from harlsync.sync.backup import backup

SMALL = Config(ProgramArea(1, 6), ProgramArea(2, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)


# --- what the engine records --------------------------------------------------------


@dataclass
class Robot:
    sim: Simulator
    url: str
    project: Path


@pytest.fixture
def robot(repo: Path) -> Iterator[Robot]:
    """One simulated HARL-U2 robot served as sim://, its first backup committed."""
    sim = Simulator({1: SimState.generate(7, SMALL)})
    url = register(sim)
    project = repo / "cell-1"
    engine.pull(project, port=url, commit=True)
    yield Robot(sim, url, project)
    unregister(url)


def head(repo: Path) -> str:
    return git(repo, "rev-parse", "HEAD").strip()


def test_each_backup_records_what_it_changed_and_the_commit_that_holds_it(robot, repo) -> None:
    sim, project = robot.sim, robot.project
    history = project / ".harlsync" / "backup.json"
    first = json.loads(history.read_text())
    assert first["last_result"] == "ok" and first["last_changed"] is True
    assert first["last_changes"] == "first backup" and first["last_commit"] == head(repo)

    report = backup([project], commit=True)  # nothing changed: git already holds it
    state = json.loads(history.read_text())
    assert report.commit is None and state["last_changed"] is False
    assert state["last_changes"] == "no change" and state["last_commit"] == head(repo)

    sim.stations[1].data.timers[1] = "6.66"
    report = backup([project], commit=True)
    state = json.loads(history.read_text())
    assert state["last_changes"] == "1 timer" and state["last_commit"] == report.commit == head(repo)

    sim.faults = Faults(drop=1.0)
    fast = project / "robot.yaml"
    fast.write_text(fast.read_text().replace("timeout: 1.0", "timeout: 0.05"))
    backup([project], attempts=1)
    failed = json.loads(history.read_text())
    assert failed["last_result"] == "failed" and "no reply" in failed["last_error"]
    assert {k: failed[k] for k in ("last_success", "last_changes", "last_commit")} == {
        k: state[k] for k in ("last_success", "last_changes", "last_commit")
    }
