"""``harlsync diff DIR --rev A [--rev B]``: the item-level diff between two backups (git
revisions) or a snapshot, without a robot (issue 22 item 10).  The robot is the toy
family's (conftest's ``toy``): what diff reads from git and snapshots is the engine's."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from conftest import git
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine
from harlsync.sync.engine import PushOptions

pytestmark = pytest.mark.usefixtures("toy")


def test_diff_between_two_backups_and_a_snapshot_needs_no_robot(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = Simulator({1: SimState.generate(7)})
    url = register(sim)
    project = repo / "press"
    engine.pull(project, port=url, commit=True, family="toy")
    before = sim.stations[1].slots[1]
    sim.stations[1].slots[1] = 6666
    engine.pull(project, commit=True)  # the night's backup finds the pendant's change
    slots = project / "slots.yaml"
    slots.write_text(re.sub(r"(?m)^  2: .*$", "  2: 80", slots.read_text()))
    git(repo, "commit", "-qam", "faster")
    engine.push(project, PushOptions(yes=True))  # snapshot 1: the robot before it
    unregister(url)  # no robot from here on: a command that opened its port would fail
    capsys.readouterr()

    assert main(["diff", str(project), "--rev", "HEAD~2", "--rev", "HEAD~1"]) == 1
    out = capsys.readouterr().out
    head = git(repo, "rev-parse", "HEAD~2").strip()[:10]
    assert out.startswith(f"--- HEAD~2 ({head})\n+++ HEAD~1 (")
    assert f"@@ slot @@\n-slot 1: {before}\n+slot 1: 6666\n" in out

    assert main(["diff", str(project), "--rev", "HEAD"]) == 0  # HEAD is what is on disk
    assert capsys.readouterr().out == ""

    assert main(["diff", str(project), "--rev", "1", "--format", "json"]) == 1
    found = json.loads(capsys.readouterr().out)
    assert found["old"] == "snapshot 1 (before a push)" and found["new"] == f"project {project}"
    assert [c["item"] for c in found["changes"]] == ["slot 2"]

    for bad in ("no-such-rev", "--all", "99"):
        assert main(["diff", str(project), f"--rev={bad}"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "neither a git revision" in err, err
    assert main(["diff", str(project), "--rev", "HEAD", "--port", url]) == 2
    assert "no --port" in capsys.readouterr().err


def test_issue_34_item_8_a_damaged_snapshot_is_named_not_the_projects_own_file(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = Simulator({1: SimState.generate(8)})
    url = register(sim)
    try:
        project = repo / "press"
        engine.pull(project, port=url, commit=True, family="toy")
        slots = project / "slots.yaml"
        slots.write_text(re.sub(r"(?m)^  2: .*$", "  2: 80", slots.read_text()))
        git(repo, "commit", "-qam", "faster")
        result = engine.push(project, PushOptions(yes=True))  # snapshot 1
        assert result.snapshot is not None
        snapshot = result.snapshot
        (snapshot / "slots.yaml").write_text("slots: [\n")  # damaged on disk
        received = len(sim.received)
        capsys.readouterr()

        for chosen in ([], ["--snapshot", "1"], ["--snapshot", str(snapshot)]):
            code = main(["rollback", str(project), "--yes", *chosen])
            err = capsys.readouterr().err
            assert code == 2 and err.count("\n") == 1, err
            assert f"snapshot 1 ({snapshot}) cannot be read: slots.yaml:2: " in err, err

        assert main(["diff", str(project), "--rev", "1"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert err.startswith(
            f"harlsync: error: {project}: snapshot 1 ({snapshot}) cannot be read: "
            "slots.yaml:2: not YAML"  # the family says what is wrong in its file
        ), err
        assert f"'harlsync snapshots {project}' lists the others" in err
        assert len(sim.received) == received  # no robot was read or written
    finally:
        unregister(url)
