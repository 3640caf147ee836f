"""The nightly plant backup against several simulators at once.  The robots are the
toy family's (conftest's ``toy_installed``, found by the worker processes as an
installed family): a plant's night is the engine's, whatever its families (what a
HARL-U2's offset-table probe does to a backup is tests/families/harl_u2/'s)."""

from __future__ import annotations

import itertools
import json
import re
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import git
from fsfaults import read_only
from toyfamily.sim import SimState, Simulator
from typing_extensions import Unpack

from harlsync.cli import main
from harlsync.sim import Faults
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.sync import engine
from harlsync.sync.backup import backup, find_projects, line_of
from harlsync.sync.pulling import PullResult


def files_of(project: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(project)): p.read_bytes()
        for p in sorted(project.rglob("*"))
        if p.is_file() and ".harlsync" not in p.parts
    }


@dataclass
class Plant:
    root: Path
    sims: dict[str, Simulator]
    servers: list[TcpServer | PtyServer]


@pytest.fixture
def plant(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, toy_installed: dict[str, str]
) -> Iterator[Plant]:
    """Five robots: one on a pty, two stations sharing one TCP line, one that will stop
    answering and one that will answer garbage, all first backed up while healthy."""
    monkeypatch.setenv("PYTHONPATH", toy_installed["PYTHONPATH"])  # for worker processes
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q")
    shared = Simulator({1: SimState.generate(21), 2: SimState.generate(22)})
    sims = {
        "loader": Simulator({1: SimState.generate(20)}),
        "press-1": shared,
        "press-2": shared,
        "silent": Simulator({1: SimState.generate(23)}),
        "garbage": Simulator({1: SimState.generate(24)}),
    }
    pty = PtyServer(sims["loader"])
    servers: list[TcpServer | PtyServer] = [pty]
    ports = {"loader": (pty.start(), 1)}
    line = TcpServer(shared)
    servers.append(line)
    ports["press-1"] = (line.start(), 1)
    ports["press-2"] = (line.url, 2)
    for name in ("silent", "garbage"):
        server = TcpServer(sims[name])
        servers.append(server)
        ports[name] = (server.start(), 1)
    for name, (url, station) in ports.items():
        engine.pull(root / name, port=url, station=station, family="toy")
    git(root, "add", "-A")
    git(root, "commit", "-qm", "first backup")
    sims["silent"].faults = Faults(drop=1.0)
    sims["garbage"].faults = Faults(bad_checksum=1.0, noise=1.0, seed=1)
    yield Plant(root, sims, servers)
    for started in servers:
        started.stop()


def test_projects_are_found_below_a_path_and_lines_are_named_by_port(plant: Plant) -> None:
    names = [p.name for p in find_projects([plant.root])]
    assert names == ["garbage", "loader", "press-1", "press-2", "silent"]
    assert line_of("socket://127.0.0.1:4001?logging=debug") == line_of("socket://127.0.0.1:4001")
    assert line_of("spy:///dev/ttyS0?file=x.txt") == line_of("/dev/ttyS0")


def test_a_backup_run_reports_changes_and_failures_and_commits_once(
    plant: Plant, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plant.sims["loader"].stations[1].slots[1] = 6666
    shared = plant.sims["press-2"].stations[2]
    shared.slots[7] = 7777
    shared.slots[5] = 5555
    untouched = {n: files_of(plant.root / n) for n in ("silent", "garbage")}
    head = git(plant.root, "rev-parse", "HEAD")
    shared_line = plant.sims["press-1"]
    before = len(shared_line.received)

    metrics = tmp_path / "harlsync.prom"
    code = main(
        ["backup", str(plant.root), "--commit", "--jobs", "3", "--attempts", "2"]
        + ["--metrics", str(metrics)]
    )
    out = capsys.readouterr().out

    # The two stations on one line were pulled one after the other, never interleaved.
    stations = [r.station for r in shared_line.received[before:]]
    changes_of_station = sum(a != b for a, b in itertools.pairwise(stations))
    assert set(stations) == {1, 2} and changes_of_station == 1

    assert code == 1
    rows = {line.split()[0]: line for line in out.splitlines()[1:6]}
    assert rows["loader"].split()[1] == "ok" and "1 slot" in rows["loader"]
    assert rows["press-2"].split()[1] == "ok" and "2 slots" in rows["press-2"]
    assert "no change" in rows["press-1"]
    assert rows["silent"].split()[1] == "FAILED" and "station 01" in rows["silent"]
    assert rows["garbage"].split()[1] == "FAILED"
    assert "3 of 5 robot(s) backed up, 2 changed" in out
    for name, files in untouched.items():
        assert files_of(plant.root / name) == files
    # Issue 30: committed on the backup branch; the approved one and its files stay.
    assert git(plant.root, "rev-parse", "HEAD") == head
    assert git(plant.root, "status", "--porcelain") == ""
    log = git(plant.root, "log", "--format=%B", f"{head.strip()}..harlsync/backup")
    assert log.startswith("backup: 2 of 5 robot(s) changed: loader, press-2\n")
    assert "- loader: 1 slot:\n    slot " in log  # each item named (issue 22)
    assert "- press-2: 2 slots:\n    " in log
    assert "- silent:" in log and "- garbage:" in log  # the failures are in the message too
    # Items changed, as the metrics count them: steps, not the programs that hold them
    # (a family's group counts, Catalogue.group_counts, are no items).
    items_changed = dict(
        re.findall(
            r'^harlsync_backup_changed_items\{project="([^"]+)".*\} (\d+)$',
            metrics.read_text(),
            re.MULTILINE,
        )
    )
    assert items_changed == {
        "garbage": "0",
        "loader": "1",
        "press-1": "0",
        "press-2": "2",
        "silent": "0",
    }
    changed = git(plant.root, "show", "--name-only", "--format=", "harlsync/backup").split()
    assert sorted(changed) == ["loader/slots.yaml", "press-2/slots.yaml"]


def test_nothing_changed_means_no_commit_and_exit_0(plant: Plant) -> None:
    for name in ("silent", "garbage"):
        plant.sims[name].faults = Faults()
    head = git(plant.root, "rev-parse", "HEAD")
    report = backup([plant.root], commit=True)
    assert report.ok and report.commit is None and not report.changed
    assert git(plant.root, "rev-parse", "HEAD") == head
    assert main(["backup", str(plant.root), "--quiet"]) == 0


def test_the_json_report_records_attempts_staleness_and_never_backed_up(
    plant: Plant, capsys: pytest.CaptureFixture[str]
) -> None:
    assert (
        main(
            [
                "backup",
                str(plant.root / "loader"),
                str(plant.root / "silent"),
                "--format",
                "json",
                "--attempts",
                "2",
            ]
        )
        == 1
    )
    report = json.loads(capsys.readouterr().out)
    robots = {r["name"]: r for r in report["robots"]}
    assert robots["loader"]["ok"] and robots["loader"]["last_success"]
    assert not robots["loader"]["never_backed_up"]
    silent = robots["silent"]
    assert not silent["ok"] and len(silent["attempts"]) == 2
    assert all("station 01" in reason for reason in silent["attempts"])
    assert silent["last_success"] and not silent["never_backed_up"]  # the first pull counts
    assert report["ok"] is False
    (plant.root / "silent" / ".harlsync" / "backup.json").unlink()
    assert main(["backup", str(plant.root / "silent"), "--format", "json", "--attempts", "1"]) == 1
    [silent] = json.loads(capsys.readouterr().out)["robots"]
    assert silent["never_backed_up"] and silent["last_success"] is None


def test_issue_14_last_success_is_when_each_robot_was_backed_up_not_when_the_run_began(
    plant: Plant,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from datetime import datetime

    plant.sims["loader"].faults = Faults(slow=1.0, slow_delay=0.15)  # 18 replies: 2.7 s
    metrics = tmp_path / "backup.prom"
    assert (
        main(["backup", str(plant.root / "loader"), "--format", "json", "--metrics", str(metrics)])
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    [loader] = report["robots"]
    took = datetime.fromisoformat(loader["last_success"]) - datetime.fromisoformat(
        report["started"]
    )
    assert took.total_seconds() >= 2, (report["started"], loader["last_success"])
    stamp = datetime.fromisoformat(loader["last_success"]).timestamp()
    series = 'harlsync_backup_last_success_timestamp_seconds{project="loader",robot="loader"}'
    assert f"{series} {stamp:.0f}" in (metrics.read_text().splitlines())
    recorded = json.loads((plant.root / "loader" / ".harlsync" / "backup.json").read_text())
    assert recorded["last_success"] == loader["last_success"]
    assert "changed_items" not in loader  # the metrics' number, not the report's


def test_a_robot_with_no_good_backup_for_too_long_is_flagged_stale(plant: Plant) -> None:
    from datetime import datetime, timedelta, timezone

    plant.sims["silent"].faults = Faults()
    earlier = datetime.now(timezone.utc) - timedelta(days=3)
    backup([plant.root / "silent"], now=earlier)
    plant.sims["silent"].faults = Faults(drop=1.0)
    report = backup([plant.root / "silent"], attempts=1)
    [robot] = report.robots
    assert robot.stale and not robot.never_backed_up
    assert "stale: last good backup" in report.render()


def test_hooks_run_with_the_summary_and_metrics_are_written(plant: Plant, tmp_path: Path) -> None:
    plant.sims["loader"].stations[1].slots[2] = 1234
    changed_out = tmp_path / "changed.txt"
    failed_out = tmp_path / "failed.txt"
    metrics = tmp_path / "harlsync.prom"
    on_change = (
        f"{sys.executable} -c \"import os,sys; open({str(changed_out)!r},'w')"
        f".write(os.environ['HARLSYNC_CHANGED'] + '|' + sys.stdin.read())\""
    )
    on_failure = (
        f"{sys.executable} -c \"import os; open({str(failed_out)!r},'w')"
        f".write(os.environ['HARLSYNC_FAILED'])\""
    )
    code = main(
        [
            "backup",
            str(plant.root),
            "--attempts",
            "1",
            "--quiet",
            "--on-change",
            on_change,
            "--on-failure",
            on_failure,
            "--metrics",
            str(metrics),
        ]
    )
    assert code == 1
    names, summary = changed_out.read_text().split("|", 1)
    assert names == "loader" and "1 slot" in summary
    assert failed_out.read_text() == "garbage silent"
    text = metrics.read_text()
    assert 'harlsync_backup_success{project="loader",robot="loader"} 1' in text
    assert 'harlsync_backup_success{project="silent",robot="silent"} 0' in text
    assert 'harlsync_backup_failed_attempts{project="silent",robot="silent"} 1' in text


def test_issue_34_item_14_every_output_is_checked_before_a_robot_is_read_all_problems_at_once(
    plant: Plant, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plant.sims["loader"].stations[1].slots[2] = 1234  # a backup would change it
    metrics = tmp_path / "textfile" / "harlsync.prom"  # its directory was never made
    a_file = tmp_path / "www"
    a_file.write_text("not a directory\n")
    page = a_file / "plant.html"
    on_failure = "mial -s 'robots not backed up' maintenance@plant.example"  # mistyped
    on_change = "echo 'unclosed"
    records = {n: (plant.root / n / ".harlsync" / "backup.json").read_bytes() for n in plant.sims}
    received = {n: len(sim.received) for n, sim in plant.sims.items()}
    capsys.readouterr()
    code = main(
        ["backup", str(plant.root), "--metrics", str(metrics), "--html", str(page)]
        + ["--on-failure", on_failure, "--on-change", on_change]
    )
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"cannot write the metrics file {metrics} (no directory {metrics.parent})" in err
    assert f"cannot write the report page {page} (not a directory: {a_file})" in err
    assert f"--on-failure '{on_failure}': the shell finds no command mial" in err
    assert f"--on-change '{on_change}': the shell cannot read it (" in err
    assert err.rstrip().endswith("no robot was read")
    assert {n: len(sim.received) for n, sim in plant.sims.items()} == received
    assert records == {
        n: (plant.root / n / ".harlsync" / "backup.json").read_bytes() for n in plant.sims
    }
    assert not metrics.parent.exists()


def test_a_missing_port_fails_that_robot_only(plant: Plant) -> None:
    robot = plant.root / "loader" / "robot.yaml"
    text = robot.read_text()
    port_line = next(line for line in text.splitlines() if line.strip().startswith("port:"))
    robot.write_text(text.replace(port_line, "  port: /dev/does-not-exist-harlsync"))
    report = backup([plant.root / "loader", plant.root / "press-1"], attempts=1)
    outcome = {r.name: r for r in report.robots}
    assert not outcome["loader"].ok
    assert "/dev/does-not-exist-harlsync" in (outcome["loader"].error or "")
    assert outcome["press-1"].ok


def test_push_failure_is_reported_and_the_local_commit_kept(plant: Plant) -> None:
    git(plant.root, "remote", "add", "origin", str(plant.root / "no-such-remote.git"))
    plant.sims["loader"].stations[1].slots[4] = 3210
    report = backup([plant.root / "loader"], commit=True, push=True)
    assert report.commit is not None and report.pushed is False and report.push_error
    assert git(plant.root, "rev-parse", "harlsync/backup").strip() == report.commit
    assert "git push FAILED" in report.render()
    assert not report.ok  # a backup that never left the server is not a success


def test_a_failed_push_is_printed_even_with_quiet_and_exits_1(
    plant: Plant, capsys: pytest.CaptureFixture[str]
) -> None:
    git(plant.root, "remote", "add", "origin", str(plant.root / "no-such-remote.git"))
    plant.sims["loader"].stations[1].slots[4] = 3210
    assert main(["backup", str(plant.root / "loader"), "--commit", "--push", "--quiet"]) == 1
    assert "git push FAILED" in capsys.readouterr().out


def test_an_unexpected_error_costs_one_robot_not_the_night(
    plant: Plant, monkeypatch: pytest.MonkeyPatch
) -> None:
    from harlsync.sync import nightly

    real = nightly.read_robot

    def broken_for_the_loader(path: Path, **kwargs: Unpack[nightly.ReadOptions]) -> PullResult:
        if Path(path).name == "loader":
            raise RuntimeError("termios.error(5, 'Input/output error')")
        return real(path, **kwargs)

    monkeypatch.setattr(nightly, "read_robot", broken_for_the_loader)
    # The bug is patched into this process: a worker process would not have it.
    report = backup([plant.root / "loader", plant.root / "press-1"], attempts=1, workers=1)
    outcome = {r.name: r for r in report.robots}
    assert not outcome["loader"].ok and "RuntimeError" in (outcome["loader"].error or "")
    assert outcome["press-1"].ok


def test_the_documented_cron_line_runs_against_simulated_robots(
    plant: Plant, tmp_path: Path
) -> None:
    doc = (Path(__file__).parents[1] / "docs" / "backup.md").read_text()
    cron = next(line for line in doc.splitlines() if line.startswith("0 2 * * * "))
    command = cron.removeprefix("0 2 * * * ")
    bare = tmp_path / "remote.git"
    git(tmp_path, "init", "-q", "--bare", str(bare))
    git(plant.root, "remote", "add", "origin", str(bare))
    git(plant.root, "push", "-q", "-u", "origin", "HEAD")
    branch = git(plant.root, "rev-parse", "--abbrev-ref", "HEAD").strip()
    plant.sims["loader"].stations[1].slots[0] = 1
    harlsync = str(Path(sys.executable).parent / "harlsync")
    command = (
        command.replace("/srv/plant-robots", str(plant.root))
        .replace("/opt/harlsync/.venv/bin/harlsync", harlsync)
        .replace("/var/lib/node_exporter/textfile/harlsync.prom", str(tmp_path / "m.prom"))
        .replace(
            'mail -s "harlsync: robots not backed up" maintenance@plant.example',
            f"cat > {tmp_path / 'mail.txt'}",
        )
    )
    done = subprocess.run(["sh", "-c", command], capture_output=True, text=True, check=False)
    assert done.returncode == 1
    assert "silent" in done.stdout and "FAILED" in done.stdout  # --quiet prints on failure
    assert "silent" in (tmp_path / "mail.txt").read_text()
    assert "harlsync_backup_success" in (tmp_path / "m.prom").read_text()
    assert git(bare, "log", "-1", "--format=%s", branch) == "first backup\n"  # as approved
    pushed = git(bare, "log", "-1", "--format=%s", "harlsync/backup")  # issue 30
    assert re.fullmatch(r"backup: loader: slot \d+", pushed.strip())  # names what changed
    assert git(bare, "for-each-ref", "--format=%(refname)", "refs/harlsync/deployed/").split() == [
        f"refs/harlsync/deployed/{n}" for n in ("loader", "press-1", "press-2")
    ]  # set up by the first backup of each robot that answered


def test_a_wrong_combination_of_options_exits_2_not_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["backup", str(tmp_path), "--push"]) == 2
    assert "--push needs --commit" in capsys.readouterr().err


def test_issue_11_a_read_only_robot_directory_fails_that_robot_only_and_the_night_goes_on(
    plant: Plant, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("silent", "garbage"):
        plant.sims[name].faults = Faults()
    plant.sims["loader"].stations[1].slots[1] = 6666
    plant.sims["press-1"].stations[1].slots[1] = 7777
    loader = plant.root / "loader"
    before = {p: p.read_bytes() for p in loader.rglob("*") if p.is_file()}
    failed_out, metrics = tmp_path / "failed.txt", tmp_path / "harlsync.prom"
    on_failure = (
        f"{sys.executable} -c \"import os; open({str(failed_out)!r},'w')"
        f".write(os.environ['HARLSYNC_FAILED'])\""
    )
    with pytest.MonkeyPatch.context() as fs:
        read_only(fs, loader)
        code = main(
            [
                "backup",
                str(plant.root),
                "--workers",  # the fault is patched into this process only
                "1",
                "--commit",
                "--attempts",
                "2",
                "--metrics",
                str(metrics),
                "--on-failure",
                on_failure,
            ]
        )
    out, err = capsys.readouterr()
    assert code == 1 and "Traceback" not in err
    rows = {line.split()[0]: line for line in out.splitlines()[1:6]}
    assert rows["loader"].split()[1] == "FAILED"
    # Issue 30: a backup writes no project file, only its record in .harlsync.
    assert "/.harlsync/backup.json: cannot record the backup (Read-only file system)" in out
    assert rows["press-1"].split()[1] == "ok" and "1 slot" in rows["press-1"]
    assert "4 of 5 robot(s) backed up, 1 changed, commit " in out
    assert git(plant.root, "show", "--name-only", "--format=", "harlsync/backup").split() == [
        "press-1/slots.yaml"
    ]
    assert failed_out.read_text() == "loader"
    assert 'harlsync_backup_success{project="loader",robot="loader"} 0' in metrics.read_text()
    assert {p: p.read_bytes() for p in loader.rglob("*") if p.is_file()} == before


def test_issue_11_a_backup_whose_commit_failed_is_committed_by_the_next_night(
    plant: Plant, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("silent", "garbage"):
        plant.sims[name].faults = Faults()
    assert backup([plant.root], commit=True).ok  # issue 30: the backup branch set up
    plant.sims["loader"].stations[1].slots[1] = 6666
    head = git(plant.root, "rev-parse", "HEAD")
    kept = git(plant.root, "rev-parse", "harlsync/backup")
    # Left by a git killed mid-commit. The backup branch's commit needs no index
    # (issue 30), so a stale index.lock is no longer a failure; the branch's is.
    (plant.root / ".git" / "index.lock").write_text("")
    stale_lock = plant.root / ".git" / "refs" / "heads" / "harlsync" / "backup.lock"
    stale_lock.write_text("")
    assert main(["backup", str(plant.root), "--commit"]) == 1
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    assert "5 of 5 robot(s) backed up, 1 changed; git commit FAILED: " in out
    assert "backup.lock': File exists" in out
    assert git(plant.root, "rev-parse", "HEAD") == head
    assert git(plant.root, "rev-parse", "harlsync/backup") == kept

    stale_lock.unlink()  # someone clears it; the robots have not changed since
    report = backup([plant.root], commit=True)
    [loader] = [r for r in report.robots if r.name == "loader"]
    assert report.ok and loader.ok, loader.error
    assert loader.changed and loader.summary == "1 slot"
    assert git(plant.root, "show", "--name-only", "--format=", "harlsync/backup").split() == [
        "loader/slots.yaml"
    ]
    assert git(plant.root, "rev-parse", "HEAD") == head


def test_issue_11_a_user_edit_beside_an_uncommitted_backup_is_still_never_overwritten(
    plant: Plant,
) -> None:
    plant.sims["loader"].stations[1].slots[1] = 6666
    engine.pull(plant.root / "loader")  # saved, never committed (no --commit)
    robot_yaml = plant.root / "loader" / "robot.yaml"
    robot_yaml.write_text(robot_yaml.read_text() + "# checked by hand\n")
    edited = files_of(plant.root / "loader")
    report = backup([plant.root / "loader"], commit=True)
    [loader] = report.robots
    # Issue 30: a backup never writes the working tree, so it backs the robot up
    # onto its own branch and leaves the edit (and the uncommitted pull) alone.
    assert loader.ok, loader.error
    assert git(plant.root, "show", "harlsync/backup:loader/slots.yaml").count("6666") == 1
    assert files_of(plant.root / "loader") == edited
