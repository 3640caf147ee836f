"""Issue 30: what status, the report page, the metrics and a pull say of a robot's
pending and drifted items (the families' scenarios are in
tests/conformance/test_three_states.py).  The robot is the toy family's (conftest's
``toy``): a pending slot and a drifted one, the engine's states whatever the family."""

from __future__ import annotations

import re
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import backupref, engine
from harlsync.sync.states import date_of


def git(repo: Path, *args: str) -> str:
    return subprocess.run(
        ["git", "-c", "user.name=Alice Engineer", "-c", "user.email=alice@plant", *args],
        cwd=repo,
        check=True,
        capture_output=True,
        text=True,
    ).stdout


@dataclass
class Cell:
    sim: Simulator
    project: Path
    commit: str  # the engineer's


#: slots.yaml's lines: the engineer's slot 1, the pendant's slot 3
PENDING, DRIFT = "  1: 80", "  3: 6666"


@pytest.fixture
def cell(repo: Path, toy: str) -> Iterator[Cell]:
    """A robot backed up by an older harlsync (pull --commit on the branch), then an
    engineer's committed slot 1 (pending) and slot 3 set on its pendant (drift)."""
    sim = Simulator({1: SimState.generate(9)})
    url = register(sim)
    project = repo / "cell"
    engine.pull(project, port=url, commit=True, family=toy)
    slots = project / "slots.yaml"
    slots.write_text(re.sub(r"(?m)^  1: .*$", PENDING, slots.read_text()))
    git(repo, "commit", "-qam", "faster pick")
    sim.stations[1].slots[3] = 6666
    yield Cell(sim, project, git(repo, "rev-parse", "HEAD").strip())
    unregister(url)


def test_issue_30_status_the_report_page_and_the_metrics_show_pending_and_drift(
    cell: Cell, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    metrics, page = tmp_path / "harlsync.prom", tmp_path / "robots.html"
    plant = str(cell.project.parent)
    code = main(
        ["backup", plant, "--commit", "--workers", "1", "--metrics", str(metrics)]
        + ["--html", str(page)]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    today = date_of(
        git(cell.project, "show", "-s", "--format=%cI", backupref.BACKUP_BRANCH).strip()
    )
    by = f"by Alice Engineer, {cell.commit[:10]} "
    assert re.search(r"^cell +ok .* 1 slot; pending 1 item, drift 1 item$", out, re.MULTILINE), out
    assert f"cell: pending: slot 1 (first seen {today}, {by}" in out
    assert f"cell: drift: slot 3 (first seen {today})" in out

    text = metrics.read_text()
    assert 'harlsync_backup_pending_items{project="cell",robot="cell"} 1' in text
    assert 'harlsync_backup_drift_items{project="cell",robot="cell"} 1' in text
    assert "# TYPE harlsync_backup_drift_items gauge" in text

    html = page.read_text()
    assert "<th>pending</th><th>drift</th>" in html
    assert "slot 1 <span" in html and f"committed {by}" in html
    assert "slot 3 <span" in html and "Drift: changed on the robot" in html

    assert main(["status", plant]) == 0  # pending and drift are said, not an alarm
    shown = capsys.readouterr().out
    header, row = shown.splitlines()[:2]
    assert header.split()[-2:] == ["pending", "drift"]
    assert row.split()[-4:] == ["1", "item", "1", "item"]
    assert f"cell: pending: slot 1 (first seen {today}, {by}" in shown
    assert f"cell: drift: slot 3 (first seen {today})" in shown


def test_issue_30_a_pull_refuses_to_overwrite_a_pending_change_unless_told_to(
    cell: Cell, capsys: pytest.CaptureFixture[str]
) -> None:
    before = (cell.project / "slots.yaml").read_bytes()
    capsys.readouterr()
    assert main(["pull", str(cell.project)]) == 3
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err == (
        f"harlsync: refused: {cell.project}: approved changes not yet on the robot that a pull would "
        f"overwrite (slot 1); push them, or overwrite them with 'harlsync pull "
        f"{cell.project} --discard-pending'"
    )
    assert (cell.project / "slots.yaml").read_bytes() == before  # nothing saved

    assert main(["pull", str(cell.project), "--discard-pending"]) == 0
    assert (cell.project / "slots.yaml").read_bytes() != before  # the robot's slot now
    assert git(cell.project, "rev-parse", "HEAD").strip() == cell.commit  # nothing committed


def test_issue_30_adopt_takes_the_drift_and_leaves_the_pending_change_as_approved(
    cell: Cell, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["backup", str(cell.project.parent), "--commit", "--workers", "1"]) == 0
    slots = cell.project / "slots.yaml"
    assert PENDING in slots.read_text().splitlines() and DRIFT not in slots.read_text()
    adopted = re.sub(r"(?m)^  3: .*$", DRIFT, slots.read_text())  # the pending one stays
    capsys.readouterr()
    assert main(["adopt", str(cell.project), "slot 9", "slot 4"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.endswith(
        "slot 9, slot 4: not an item where the last backup differs from the project (those "
        "that do: slot 1, slot 3)"
    )

    assert main(["adopt", str(cell.project), "SLOT 3"]) == 0
    out = capsys.readouterr().out
    assert "adopted 1 item(s) from the backup of " in out and "  slot 3\n" in out
    assert slots.read_text() == adopted
    assert git(cell.project, "status", "--porcelain").split() == ["M", "cell/slots.yaml"]

    git(cell.project, "checkout", "-q", "--", ".")
    assert main(["adopt", str(cell.project)]) == 0  # by default: the drift, only it
    assert "  slot 3\n" in capsys.readouterr().out
    assert slots.read_text() == adopted
