"""Local state never crashes a command (issue 22 item 4): a malformed audit record,
backup.json, save record, journal, plan file or lock owner file gives one line naming
the file (and the line) and what to do, and the rest goes on: a plant's backup still
reports, commits and writes its metrics.  The robot is the toy family's (conftest's
``toy``): what harlsync keeps beside a project is the engine's, whatever the family."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import git
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine

DEEP = "[" * 100_000 + "]" * 100_000
#: Values of every JSON type, and some a reader can trip on.
ODD = [None, 0, -1, 1.5, True, "", "x", "2026-13-99", "2026-11-25T02:00:41", [], {}, [1], {"a": 1}]


@dataclass
class Plant:
    sim: Simulator
    url: str
    project: Path
    audit: Path


@pytest.fixture
def plant(repo: Path, tmp_path: Path, toy: str) -> Iterator[Plant]:
    sim = Simulator({1: SimState.generate(7)})
    url = register(sim)
    project = repo / "cell-1"
    engine.pull(project, port=url, commit=True, family=toy)
    yield Plant(sim, url, project, tmp_path / "audit.jsonl")
    unregister(url)


def audit_records(plant: Plant) -> list[str]:
    """Audit lines that are each malformed in a different way."""
    good = {
        "event": "end",
        "id": "a1",
        "action": "push",
        "time": "2026-11-24T20:23:50+00:00",
        "user": "alice",
        "host": "pc",
        "pid": 1,
        "robot": {"name": "cell-1", "port": plant.url, "station": 1},
        "project": str(plant.project.resolve()),
        "result": "ok",
        "written": [{"item": "slot 1", "command": "W 1 2000", "old": "1000", "new": "2000"}],
        "plan": ["W 1 2000"],
    }
    lines = [DEEP, "null", "[1, 2]", '"text"', "{bad json", "\xff\xfe"]
    for field in good:
        for value in ODD:
            lines.append(json.dumps({**good, field: value}))
    for value in ODD:
        lines.append(json.dumps({**good, "event": "start", "id": "s1", "snapshot": value}))
        lines.append(json.dumps({"event": "write", "id": "s1", "item": value, "command": value}))
        lines.append(
            json.dumps({**good, "robot": {"name": value, "port": value, "station": value}})
        )
        lines.append(json.dumps({**good, "written": [{"item": value, "old": value, "new": value}]}))
    return lines


def run(*args: str) -> int:
    return main(list(args))


def test_a_malformed_audit_log_never_crashes_pull_log_status_diff_or_backup(
    plant: Plant, repo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plant.audit.write_bytes(
        ("\n".join(audit_records(plant)) + "\n")
        .encode("utf-8", "surrogateescape")
        .replace("\xff\xfe".encode(), b"\xff\xfe")
    )
    project = str(plant.project)
    metrics, page = tmp_path / "m.prom", tmp_path / "p.html"
    first = f"{plant.audit}:1: not an audit record (nested more than 16 levels deep)"
    assert run("pull", project) == 0  # what it warns of, diff and push say
    assert "Traceback" not in capsys.readouterr().err
    for args in (
        ["diff", project],
        ["log"],
        ["log", project],
        ["log", project, "--format", "json"],
    ):
        assert run(*args) == 0, args
        err = capsys.readouterr().err
        assert first in err and "and " in err and "Traceback" not in err, args
        assert len(err.splitlines()) <= 6, err  # folded: "and 150 more malformed lines"
    assert run("status", str(repo), "--html", str(page)) in (0, 1)
    assert first in capsys.readouterr().out
    assert run("status", str(repo), "--format", "json") in (0, 1)
    plant.sim.stations[1].slots[1] = 6666
    code = run("backup", str(repo), "--commit", "--metrics", str(metrics), "--html", str(page))
    assert code == 0
    assert metrics.exists() and page.exists()
    assert "\n+  1: 6666\n" in git(repo, "show", "harlsync/backup")  # its commit (issue 30)
    assert "Traceback" not in capsys.readouterr().err


HISTORY_FIELDS = (
    "last_attempt", "last_result", "last_error", "last_success", "last_changed",
    "last_changes", "last_commit",
)  # fmt: skip
BAD_HISTORIES = [DEEP, "null", "[]", '"x"', "{", "\udcff", *(
    json.dumps({k: v}) for k in HISTORY_FIELDS for v in ODD
)]  # fmt: skip


def test_a_malformed_backup_json_is_named_by_status_and_never_crashes_it(
    plant: Plant, repo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = plant.project / ".harlsync" / "backup.json"
    page = tmp_path / "p.html"
    for text in BAD_HISTORIES:
        state.write_bytes(text.encode("utf-8", "surrogateescape"))
        assert run("status", str(repo), "--html", str(page)) in (0, 1), text[:40]
        out, err = capsys.readouterr()
        assert "Traceback" not in err
        if text in (DEEP, "null", "[]", "{", "\udcff"):
            assert f"warning: {state}: " in out and "writes it anew" in out, text[:40]
        assert run("status", str(repo), "--format", "json") in (0, 1)
        json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("text", [DEEP, "null", json.dumps({"last_success": "2026-11-25"})])
def test_a_malformed_backup_json_leaves_the_plant_backup_whole(
    plant: Plant, repo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    state = plant.project / ".harlsync" / "backup.json"
    state.write_text(text)
    metrics, page = tmp_path / "m.prom", tmp_path / "p.html"
    plant.sim.stations[1].slots[1] = 6666
    assert run("backup", str(repo), "--commit", "--metrics", str(metrics), "--html", str(page)) == 0
    assert (
        metrics.exists()
        and page.exists()
        and "\n+  1: 6666\n" in git(repo, "show", "harlsync/backup")
    )
    assert "Traceback" not in capsys.readouterr().err
    assert json.loads(state.read_text())["last_result"] == "ok"  # the run wrote it anew


@pytest.mark.parametrize(
    "text", [DEEP, "null", "[]", "{", "\udcff", '{"files": null}', '{"files": {"robot.yaml": 5}}']
)
def test_a_malformed_save_record_counts_every_file_as_edited_and_never_crashes_a_pull(
    plant: Plant, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    (plant.project / ".harlsync" / "saved.json").write_bytes(
        text.encode("utf-8", "surrogateescape")
    )
    assert run("pull", str(plant.project)) == 0
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize(
    "text", [DEEP, "null", "[]", "{", "\udcff", '{"pid": "x"}', '{"pid": 1, "files": [[1, 2, 3]]}']
)
def test_a_malformed_save_journal_is_named_in_one_line(
    plant: Plant, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    (plant.project / ".harlsync-save.json").write_bytes(text.encode("utf-8", "surrogateescape"))
    assert run("pull", str(plant.project)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert ".harlsync-save.json: the journal of an interrupted save cannot be read" in err
    assert "remove that file" in err


@pytest.mark.parametrize(
    "text",
    [DEEP, "null", "[]", "{", "\udcff", '{"format": 1}', '{"format": 1, "live_fingerprint": 5}'],
)
def test_a_malformed_plan_file_is_refused_in_one_line_before_anything_is_written(
    plant: Plant, tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    planned = tmp_path / "plan.json"
    planned.write_bytes(text.encode("utf-8", "surrogateescape"))
    plant.sim.stations[1].slots[1] = 6666  # a push would write it back
    before = dict(plant.sim.stations[1].slots)
    code = run("push", str(plant.project), "--yes", "--plan", str(planned))
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"{planned}: not " in err and "harlsync plan DIR --out FILE" in err
    assert plant.sim.stations[1].slots == before


def test_a_lock_owner_file_that_is_not_text_still_gives_the_busy_message(plant: Plant) -> None:
    from harlsync.project import lock

    path = lock.lock_path(plant.project)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.with_name(path.name + ".owner").write_bytes(b"\xff\xfe\x00")
    assert "is in use by another harlsync" in lock._busy_message(plant.project, path)
