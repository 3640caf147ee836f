"""What each pull and backup records, and the commands that show it without touching a
robot: status and its report page, log and snapshots."""

from __future__ import annotations

import json
import os
import pty
import re
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import serial
from browser import BROWSER, Table, dump_dom
from conftest import git
from plantsim import IAI_STATION, MARKUP, STATES, SimPlant, build
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.project import load_project
from harlsync.sim import Faults
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine
from harlsync.sync.backup import backup
from harlsync.sync.engine import PushOptions

HARLSYNC = str(Path(sys.executable).parent / "harlsync")


@pytest.fixture(scope="module")
def plant(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimPlant]:
    """The plant of plantsim.STATES, its robots then taken off the line: any port a
    command opened would fail."""
    root = tmp_path_factory.mktemp("status")
    with pytest.MonkeyPatch.context() as env:
        env.setenv("HARLSYNC_LOCK_DIR", str(root / "locks"))
        env.setenv("HARLSYNC_AUDIT_LOG", str(root / "audit.jsonl"))
        built = build(root / "plant")
    built.close()
    yield built


@pytest.fixture
def records(plant: SimPlant, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The plant's audit log for this test, and no port that opens."""
    log = plant.root.parent / "audit.jsonl"
    monkeypatch.setenv("HARLSYNC_AUDIT_LOG", str(log))

    def no_port(*args: Any, **kwargs: Any) -> None:
        raise AssertionError(f"a port was opened: {args}")

    monkeypatch.setattr(serial, "serial_for_url", no_port)
    monkeypatch.setattr(serial, "Serial", no_port)
    return log


def rows_of(text: str) -> dict[str, list[str]]:
    """The status table: robot -> its cells (split on runs of two spaces or more)."""
    lines = text.splitlines()
    table = lines[1 : lines.index("")]
    return {cells[0]: cells for cells in (re.split(r"\s{2,}", line) for line in table)}


def status_json(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, dict[str, Any]]:
    code = main(["status", *args, "--format", "json"])
    return code, json.loads(capsys.readouterr().out)


# --- what the engine records --------------------------------------------------------


@dataclass
class Robot:
    sim: Simulator
    url: str
    project: Path


@pytest.fixture
def robot(repo: Path, toy: str) -> Iterator[Robot]:
    """One simulated robot served as sim://, its first backup committed: the toy
    family's (conftest's ``toy``), as what is recorded of it is the engine's."""
    sim = Simulator({1: SimState.generate(7)})
    url = register(sim)
    project = repo / "cell-1"
    engine.pull(project, port=url, commit=True, family=toy)
    yield Robot(sim, url, project)
    unregister(url)


def head(repo: Path) -> str:
    return git(repo, "rev-parse", "HEAD").strip()


def test_each_backup_records_what_it_changed_and_the_commit_that_holds_it(
    robot: Robot, repo: Path
) -> None:
    sim, project = robot.sim, robot.project
    history = project / ".harlsync" / "backup.json"
    first = json.loads(history.read_text())
    assert first["last_result"] == "ok" and first["last_changed"] is True
    assert first["last_changes"] == "first backup" and first["last_commit"] == head(repo)

    report = backup([project], commit=True)  # nothing changed: git already holds it
    state = json.loads(history.read_text())
    assert report.commit is None and state["last_changed"] is False
    assert state["last_changes"] == "no change" and state["last_commit"] == head(repo)

    sim.stations[1].slots[1] = 6666
    report = backup([project], commit=True)
    state = json.loads(history.read_text())
    # Issue 30: the commit is on the backup branch; the approved one stays.
    kept = git(repo, "rev-parse", "harlsync/backup").strip()
    assert state["last_changes"] == "1 slot" and state["last_commit"] == report.commit == kept

    sim.faults = Faults(drop=1.0)
    backup([project], attempts=1)
    failed = json.loads(history.read_text())
    assert failed["last_result"] == "failed" and "no reply" in failed["last_error"]
    assert {k: failed[k] for k in ("last_success", "last_changes", "last_commit")} == {
        k: state[k] for k in ("last_success", "last_changes", "last_commit")
    }


def test_a_backup_nobody_committed_is_uncommitted_until_someone_commits_it(
    robot: Robot, repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, project = robot.sim, robot.project
    sim.stations[1].slots[2] = 2222
    engine.pull(project)  # no --commit
    main(["status", str(project)])
    assert rows_of(capsys.readouterr().out)["cell-1"][6] == "uncommitted"
    git(repo, "commit", "-qam", "by hand")
    code, seen = status_json(capsys, str(project))
    assert code == 0 and seen["robots"][0]["last_commit"] == head(repo)
    assert seen["robots"][0]["state"] == "changed"


# --- status -------------------------------------------------------------------------


def test_status_shows_every_state_of_a_mixed_plant_and_opens_no_port(
    plant: SimPlant, records: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["status", str(plant.root)])
    out = capsys.readouterr().out
    assert code == 1  # failed, stale, never backed up, unfinished push
    rows = rows_of(out)
    assert {name: cells[1] for name, cells in rows.items()} == STATES
    assert rows["cell-9"][2:5] == ["iai", plant.urls["cell-9"], "1A"]  # hex, as IAI writes it
    assert rows["press"][2:5] == ["harl-u2", plant.urls["press"], "1"]
    last = git(plant.root, "log", "-1", "--format=%H", "harlsync/backup", "--", "press").strip()
    assert rows["press"][6] == last[:10] and rows["press"][7] == "1 program (1 step)"
    assert rows["cell-9"][7] == "1 position"
    assert rows["spare"][5] == "never"
    assert rows["welder"][8].endswith("failed") and rows["loader"][9].endswith("push ok")
    assert "welder: failed: port " + plant.urls["welder"] in out
    assert "gripper: an earlier push to this robot did not finish" in out
    assert "loader: last push ok " in out and f'"faster pick {MARKUP}"' in out
    assert out.rstrip().endswith(
        "7 robot(s): 1 unfinished push, 1 never backed up, 1 failed, 1 stale, 2 changed, 1 ok"
    )
    assert "\x1b[" not in out  # no colour off a terminal


@pytest.mark.parametrize("shape", ["offset as text", "pair as a bare number", "writes as text"])
def test_issue_34_an_index_entry_of_the_wrong_shape_is_built_again_and_status_says_the_same(
    plant: SimPlant, records: Path, capsys: pytest.CaptureFixture[str], shape: str
) -> None:
    code = main(["status", str(plant.root)])
    before = capsys.readouterr()
    index = records.with_name(records.name + ".index")
    saved = json.loads(index.read_text())
    for entry in saved["keys"].values():
        if shape == "offset as text":
            entry[0] = [[seq, str(offset)] for seq, offset in entry[0]]
        elif shape == "pair as a bare number":
            entry[0] = [seq for seq, _ in entry[0]]
    for entry in saved["open"].values():
        if shape == "writes as text":
            entry["writes"] = [str(offset) for offset in entry["writes"]]
    index.write_text(json.dumps(saved))
    assert main(["status", str(plant.root)]) == code
    after = capsys.readouterr()
    assert (after.out, after.err) == (before.out, before.err)
    assert json.loads(index.read_text()) != saved  # built again, and saved


def test_status_json_carries_the_last_push_and_the_unfinished_one(
    plant: SimPlant, records: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, seen = status_json(capsys, str(plant.root))
    robots = {r["name"]: r for r in seen["robots"]}
    assert code == 1 and seen["ok"] is False
    assert seen["counts"] == {
        "unfinished push": 1,
        "never backed up": 1,
        "failed": 1,
        "stale": 1,
        "changed": 2,
        "ok": 1,
    }
    push = robots["loader"]["last_push"]
    assert push["action"] == "push" and push["result"] == "ok"
    assert push["reason"] == f"faster pick {MARKUP}" and push["user"] and push["host"]
    assert [w["item"] for w in push["written"]] == ["timer 1"]
    gripper = robots["gripper"]
    assert (
        gripper["station"] == f"{IAI_STATION:X}" and gripper["last_push"]["result"] == "unfinished"
    )
    assert "new tool" in gripper["unfinished"][0]
    assert robots["old-press"]["stale"] and robots["spare"]["never_backed_up"]
    assert robots["welder"]["last_result"] == "failed" and robots["welder"]["last_success"]
    assert robots["loader"]["snapshots"] == 1


def test_status_exits_0_when_every_robot_is_ok_or_changed(
    plant: SimPlant, records: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, seen = status_json(capsys, str(plant.root / "loader"), str(plant.root / "press"))
    assert code == 0 and seen["counts"] == {"changed": 1, "ok": 1}
    # A robot is stale by the hours the caller gives, as backup's --stale-after.
    code, seen = status_json(capsys, str(plant.root / "loader"), "--stale-after", "0")
    assert code == 1 and seen["robots"][0]["state"] == "stale"


def run_on_a_terminal(args: list[str], env: dict[str, str]) -> str:
    """Run harlsync with its standard output on a pty; what it printed."""
    main_end, child_end = pty.openpty()
    child = subprocess.Popen(
        [HARLSYNC, *args], stdout=child_end, stderr=subprocess.DEVNULL, env=env
    )
    os.close(child_end)
    out = b""
    try:
        while chunk := os.read(main_end, 65536):
            out += chunk
    except OSError:  # EIO: the child closed its end and everything was read
        pass
    finally:
        os.close(main_end)
    assert child.wait(timeout=60) == 1
    return out.decode()


def test_status_colours_the_states_on_a_terminal_unless_no_color(
    plant: SimPlant, records: Path
) -> None:
    env = {k: v for k, v in os.environ.items() if k != "NO_COLOR"}
    coloured = run_on_a_terminal(["status", str(plant.root)], env)
    assert "\x1b[1;31mfailed" in coloured and "\x1b[32mok" in coloured
    plain = run_on_a_terminal(["status", str(plant.root)], {**env, "NO_COLOR": "1"})
    assert "\x1b[" not in plain and "failed" in plain


def test_a_project_that_cannot_be_read_is_failed_and_the_others_are_still_shown(
    robot: Robot, repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    broken = repo / "broken"
    broken.mkdir()
    (broken / "robot.yaml").write_text("family: [unclosed\n")
    assert main(["status", str(repo)]) == 1
    out = capsys.readouterr().out
    rows = rows_of(out)
    assert rows["broken"][1:5] == ["failed", "?", "?", "?"]
    assert rows["cell-1"][1] == "changed"  # its first backup
    [said] = [line for line in out.splitlines() if line.startswith("broken: failed: ")]
    assert "robot.yaml" in said


def test_a_path_without_a_project_is_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["status", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no robot project here" in err


# --- the report page ----------------------------------------------------------------


def test_the_page_is_self_contained_and_shows_markup_as_text(
    plant: SimPlant, records: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    page = tmp_path / "status.html"
    assert main(["status", str(plant.root), "--html", str(page)]) == 1
    html = page.read_text()
    assert "<script" not in html and "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert not re.search(r"""(src|href)=["']?(https?:|//)""", html)  # no external asset
    assert "<link" not in html
    # The changes: the step changed on the pendant, the position, what the push wrote.
    # (a format-2 program's git diff: the step's line, a list item)
    assert "+  - MOVE &lt;script&gt;" in html and "cell-9/positions.yaml" in html
    assert re.search(r"timer 1: [0-9.]+ → 0.80", html)  # what it wrote, as diff shows it
    assert "position " in html and "may or may not have been written" in html


@pytest.mark.skipif(BROWSER is None, reason="no headless browser (apt-get install chromium)")
def test_a_browser_shows_every_robot_in_its_state(
    plant: SimPlant, records: Path, tmp_path: Path
) -> None:
    page = tmp_path / "status.html"
    assert main(["status", str(plant.root), "--html", str(page)]) == 1
    dom = Table(dump_dom(page), "robots")
    header, *rows = dom.rows
    assert header[:5] == ["robot", "state", "family", "port", "station"]
    assert {r[0]: r[1] for r in rows} == STATES
    by_name = {r[0]: r for r in rows}
    assert by_name["cell-9"][2:5] == ["iai", plant.urls["cell-9"], "1A"]
    assert " push ok by " in by_name["loader"][9]
    assert by_name["loader"][9].endswith(f": “faster pick {MARKUP}”")
    # The reason and the step were shown as text: the browser made no element of them.
    assert "script" not in dom.elements
    text = "".join(dom.text)
    assert f"- MOVE {MARKUP}" in text and f"faster pick {MARKUP}" in text


def test_backup_writes_the_page_at_the_end_of_its_run(robot: Robot, tmp_path: Path) -> None:
    sim, project = robot.sim, robot.project
    sim.stations[1].slots[3] = 3333
    page = tmp_path / "share" / "plant.html"
    page.parent.mkdir()
    assert main(["backup", str(project), "--commit", "--html", str(page)]) == 0
    html = page.read_text()
    assert ">changed<" in html and "1 slot" in html and "+  3: 3333" in html
    assert [p.name for p in page.parent.iterdir()] == ["plant.html"]  # no temporary left


def test_a_page_that_cannot_be_written_is_one_line_exit_2(
    plant: SimPlant, records: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "no-such-dir" / "status.html"
    assert main(["status", str(plant.root), "--html", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"cannot write the report page {target}" in err


# --- log and snapshots ----------------------------------------------------------------


def test_log_prints_a_robots_pushes_the_latest_first(
    plant: SimPlant, records: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["log", str(plant.root / "loader")]) == 0
    out = capsys.readouterr().out.splitlines()
    commit = git(plant.root, "log", "-1", "--format=%H", "--", "loader").strip()
    assert re.fullmatch(rf"\S+ \S+  loader  push ok  by \S+@\S+  commit {commit[:10]}", out[0])
    assert out[1] == f"    reason: faster pick {MARKUP}"
    assert re.fullmatch(r"    wrote timer 1: \S+ → 0\.80", out[2])
    assert len(out) == 3  # the other robots' pushes are not this robot's


def test_log_of_every_robot_and_as_json(
    plant: SimPlant, records: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["log"]) == 0
    out = capsys.readouterr().out
    assert out.index("gripper  push unfinished") < out.index("loader  push ok")
    assert "    unknown: position " in out
    assert main(["log", "--format", "json", "-n", "1"]) == 0
    [latest] = json.loads(capsys.readouterr().out)
    assert latest["robot"]["name"] == "gripper" and latest["result"] == "unfinished"
    assert latest["reason"] == "new tool" and latest["user"] and latest["host"]


def test_log_without_records_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["log"]) == 0
    assert capsys.readouterr().out.startswith("no push or rollback recorded in ")


def test_snapshots_lists_the_latest_first_and_marks_the_one_rollback_restores(
    robot: Robot, repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, project = robot.sim, robot.project
    for value in (1111, 2222):
        slots = project / "slots.yaml"
        slots.write_text(re.sub(r"(?m)^  1: .*$", f"  1: {value}", slots.read_text()))
        git(repo, "commit", "-qam", f"slot 1 {value}")
        engine.push(project, PushOptions(yes=True))
    engine.rollback(project, PushOptions(yes=True))
    assert main(["snapshots", str(project)]) == 0
    header, *rows = capsys.readouterr().out.splitlines()
    assert header.split() == ["number", "time", "action", "path"]
    assert [r.split()[0] for r in rows] == ["3", "2", "1"]
    assert [r.split()[3] for r in rows] == ["rollback", "push", "push"]
    [marked] = [r for r in rows if r.endswith("<- rollback restores this")]
    chosen = Path(marked.split()[4])
    assert marked.split()[0] == "2"
    sim.stations[1].slots[1] = 9999  # changed on the pendant since
    engine.rollback(project, PushOptions(yes=True))  # it restores the marked one
    assert sim.stations[1].slots[1] == load_project(chosen).data.slots[1] == 1111
    assert main(["snapshots", str(project), "--format", "json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [s["number"] for s in listed] == [4, 3, 2, 1]
    assert [s["rollback_restores"] for s in listed] == [False, False, True, False]


@pytest.mark.parametrize("command", ["snapshots", "log"])
def test_snapshots_and_log_of_a_directory_that_is_not_a_project_is_one_line_exit_2(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([command, str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(tmp_path) in err
