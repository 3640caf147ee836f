"""Issue 24, item 3: ``harlsync backup`` spread over worker processes.

The robots are simulators served in this process over TCP (and one ``sim://@name``
only this process can open), so a worker process reads them as it would real
lines; a watch that notes which thread told it a robot started shows where each
was read: a worker's events reach this process on a thread of their own.
"""

from __future__ import annotations

import itertools
import json
import logging
import os
import re
import shutil
import signal
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import pytest
from conftest import git
from ptyscreen import run

from harlsync.cli import main
from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.link.lock import LineLock, lock_path, take_lock_file
from harlsync.sim import Faults
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sim.serve import TcpServer
from harlsync.sync import engine, fleet, history
from harlsync.sync.backup import RobotOutcome, backup, find_projects, lines_of

SMALL = Config(ProgramArea(1, 6), ProgramArea(2, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)
#: The thread that tells this process what a worker process does.
IN_A_WORKER = "fleet-worker"


@dataclass
class Plant:
    root: Path
    sims: dict[str, Simulator]
    ports: dict[str, str]


class Where:
    """A backup watch noting where each robot was read: ``here`` or in a ``worker``."""

    def __init__(self) -> None:
        self.of: dict[str, str] = {}

    def started(self, path: Path, name: str) -> None:
        thread = threading.current_thread().name
        self.of[name] = "worker" if thread == IN_A_WORKER else "here"

    def progress(self, path: Path, done: int, total: int) -> None:
        pass

    def finished(self, outcome: RobotOutcome) -> None:
        pass


@pytest.fixture
def plant(tmp_path: Path) -> Iterator[Plant]:
    """Six robots first backed up: ``local`` on a sim://@ port of this process, ``a``-``d``
    each on a TCP line of its own, ``st-1`` and ``st-2`` two stations of one TCP line
    (named ``localhost`` for one, ``127.0.0.1`` for the other: one line all the same)."""
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q")
    shared = Simulator({1: SimState.generate(51, SMALL), 2: SimState.generate(52, SMALL)})
    sims = {n: Simulator(SimState.generate(seed, SMALL)) for seed, n in enumerate("abcd", 40)}
    sims |= {"local": Simulator(SimState.generate(50, SMALL)), "st-1": shared, "st-2": shared}
    servers = {n: TcpServer(sims[n]) for n in "abcd"}
    ports = {n: server.start() for n, server in servers.items()}
    line = TcpServer(shared)
    servers["st"] = line
    ports["st-1"] = line.start()
    ports["st-2"] = line.url.replace("127.0.0.1", "localhost")
    ports["local"] = register(sims["local"], f"fleet-{tmp_path.name}")
    for name, url in ports.items():
        engine.pull(root / name, port=url, station=2 if name == "st-2" else 1)
        robot = root / name / "robot.yaml"
        robot.write_text(robot.read_text().replace("timeout: 1.0", "timeout: 0.2"))
    git(root, "add", "-A")
    git(root, "commit", "-qm", "first backup")
    yield Plant(root, sims, ports)
    unregister(ports["local"])
    for server in servers.values():
        server.stop()


def files_of(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and ".git" not in p.parts
    }


def in_a_worker(plant: Plant, workers: int) -> list[str]:
    """The robots, alone on their line, that a backup of ``workers`` reads in a worker
    process (by the plan, which the run's watch then confirms)."""
    return [name for share in worker_shares(plant, workers) for name in share if "-" not in name]


def worker_shares(plant: Plant, workers: int) -> list[list[str]]:
    """The robots of each worker's share, by the plan a backup of ``workers`` makes."""
    here: set[str] = set()
    lines = lines_of(find_projects([plant.root]), here)
    shares = fleet.plan(lines, workers, here, fleet.weights(lines))
    return [[p.name for k in share for p in lines[k]] for share in shares[1:]]


def test_the_plan_keeps_a_line_whole_and_gives_the_heaviest_first_to_the_lightest_worker() -> None:
    lines = {
        k: [Path(f"{k}{n}") for n in range(size)] for k, size in zip("uvwxyz", (1, 3, 1, 2, 1, 1))
    }
    # By robots (no weight): v 3, x 2, then w, y, z 1 each, each to the lighter worker.
    shares = fleet.plan(lines, 2, here=["u"])
    assert shares == [["u"], ["v", "y"], ["x", "w", "z"]]  # 4 robots and 4
    assert sorted(itertools.chain(*shares)) == sorted(lines)  # every line once
    # By exchanges: the heavy line alone, the others together.
    weight = {"u": 1.0, "v": 100.0, "w": 500.0, "x": 50.0, "y": 60.0, "z": 300.0}
    assert fleet.plan(lines, 2, ["u"], weight) == [["u"], ["w"], ["z", "v", "y", "x"]]
    assert fleet.plan(lines, 16) == [[], ["v"], ["x"], ["u"], ["w"], ["y"], ["z"]]  # a line each
    assert fleet.plan(lines, 1, here=["u"]) == [["u", "v", "w", "x", "y", "z"]]  # all here
    assert fleet.plan({"u": [], "v": []}, 4, here=["u"]) == [["u", "v"]]  # one line to spread
    assert fleet.plan({}, 4) == [[]]
    assert fleet.in_process("sim://@fleet-1") and fleet.in_process("loop://")
    assert not fleet.in_process("socket://127.0.0.1:4001") and not fleet.in_process("/dev/ttyS0")


#: A robot of about twice a SMALL one's exchanges (296 against 140).
BIG = Config(
    ProgramArea(1, 16), ProgramArea(4, 32), ProgramArea(2, 16), ProgramArea(1, 8), 8, 16, 8
)


def shares_read(caplog: pytest.LogCaptureFixture) -> list[list[str]]:
    """The lines each worker read in the last run, as its debug record says."""
    figures = [getattr(r, "fleet", None) for r in caplog.records]
    return [f["keys"] for f in figures if f and f["process"].startswith("worker")]


def test_a_backup_weighs_the_next_ones_shares_by_the_exchanges_each_robot_made(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    root = tmp_path / "plant"
    sims = {"big": Simulator(SimState.generate(60, BIG))}
    sims |= {f"small-{n}": Simulator(SimState.generate(60 + n, SMALL)) for n in range(1, 5)}
    servers = [TcpServer(sim) for sim in sims.values()]
    line = {}
    try:
        for (name, sim), server in zip(sims.items(), servers):
            url = server.start()
            engine.pull(root / name, port=url)  # a pull counts no exchanges: no weight yet
            line[lines_of([root / name]).popitem()[0]] = name
        caplog.set_level(logging.DEBUG, logger="harlsync.sync.fleet")

        def run() -> tuple[dict[str, int], list[int]]:
            """Each robot's exchanges, as its simulator answered them, and each worker's."""
            before = {n: len(sim.received) for n, sim in sims.items()}
            caplog.clear()
            watch = Where()
            report = backup([root], workers=2, watch=watch)
            assert report.ok, report.render()
            assert set(watch.of.values()) == {"worker"}  # this process only coordinates
            made = {n: len(sim.received) - before[n] for n, sim in sims.items()}
            shares = shares_read(caplog)
            assert sorted(line[k] for share in shares for k in share) == sorted(sims)
            return made, sorted(sum(made[line[k]] for k in share) for share in shares)

        made, first = run()
        for name, count in made.items():  # each robot's record: what its simulator answered
            assert history.read(root / name)["last_exchanges"] == count
        assert made["big"] > 2 * made["small-1"]
        # By robots (none had a count): big and two small against two small.
        assert first == sorted([made["big"] + 2 * made["small-1"], 2 * made["small-1"]])

        made, second = run()
        # By exchanges: big and one small against three small, within one robot's.
        assert second == sorted([made["big"] + made["small-1"], 3 * made["small-1"]])
        assert second[1] - second[0] < first[1] - first[0]
        assert second[1] - second[0] <= made["small-1"]
    finally:
        for server in servers:
            server.stop()


def test_a_robot_never_backed_up_weighs_what_the_others_did_on_average(tmp_path: Path) -> None:
    lines = {}
    for name, count in (("a", 100), ("b", 300), ("c", None)):
        project = tmp_path / name
        project.mkdir()
        if count is not None:
            history.record(project, ok=True, exchanges=count)
        lines[name] = [project]
    lines["ab"] = [tmp_path / "a", tmp_path / "b"]  # two stations of one line
    assert fleet.weights(lines) == {"a": 100, "b": 300, "c": 200, "ab": 400}
    history.record(tmp_path / "a", ok=False, error="no reply")  # a failure keeps the count
    history.record(tmp_path / "b", ok=True)  # as does a good one that did not count
    assert fleet.weights(lines)["ab"] == 400
    (tmp_path / "b" / ".harlsync" / "backup.json").write_text('{"last_exchanges": "many"}')
    assert fleet.weights({"a": [tmp_path / "a"], "b": [tmp_path / "b"]}) == {"a": 100, "b": 100}
    assert fleet.weights({"c": [tmp_path / "c"], "d": [tmp_path / "d"]}) == {"c": 1, "d": 1}


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="finds the workers in /proc")
def test_workers_left_without_a_share_end_and_one_line_is_read_here(
    plant: Plant, caplog: pytest.LogCaptureFixture
) -> None:
    """Workers are started for the two stations' projects before their line is known:
    one line, nothing to spread, read here; the workers end at once."""
    caplog.set_level(logging.DEBUG, logger="harlsync.sync.fleet")
    watch = Where()
    report = backup([plant.root / "st-1", plant.root / "st-2"], workers=4, watch=watch)
    assert report.ok, report.render()
    assert watch.of == {"st-1": "here", "st-2": "here"}
    [this] = [
        vars(r)["fleet"] for r in caplog.records if getattr(r, "fleet", {}).get("process") == "this"
    ]
    assert this["workers"] == 2 and this["lines"] == 1 and not shares_read(caplog)
    assert _children() == []  # every worker ended, and was waited for


def _children() -> list[int]:
    """This process's children (workers, or a git a pull runs)."""
    return [
        int(child)
        for task in Path(f"/proc/{os.getpid()}/task").iterdir()
        for child in (task / "children").read_text().split()
    ]


def test_every_robot_of_a_process_starts_at_once_and_none_once_stopped(
    tmp_path: Path,
) -> None:
    root = tmp_path / "plant"
    servers = [TcpServer(Simulator(SimState.generate(70 + n, SMALL))) for n in range(9)]
    try:
        for n, server in enumerate(servers):
            engine.pull(root / f"r{n}", port=server.start())
        watch = Where()
        report = backup([root], workers=1, watch=watch)  # nine lines, one process
        assert report.ok, report.render()
        assert len(watch.of) == 9

        stop = threading.Event()
        stop.set()
        watch = Where()
        task = fleet.Task(1, 0.0, lambda: datetime.now(timezone.utc))
        task.line([root / "r0", root / "r1"], watch, stop)
        assert watch.of == {}  # not started
    finally:
        for server in servers:
            server.stop()


def test_one_worker_and_two_give_the_same_report_files_and_commit(plant: Plant) -> None:
    plant.sims["a"].stations[1].data.timers[1] = "6.66"
    plant.sims["st-2"].stations[2].data.programs[(ProgramType.MAIN, 1)][7] = Step.parse(
        "MOVE P123 S80"
    )
    plant.sims["local"].stations[1].data.timers[2] = "1.25"
    plant.sims["d"].faults = Faults(drop=1.0)
    twin = plant.root.parent / "twin"
    shutil.copytree(plant.root, twin)

    #: where each robot was read, the report's robots (JSON), the commit's message and
    #: files, and the files kept
    Result = tuple[dict[str, str], list[dict[str, Any]], str, list[str], dict[str, bytes]]

    def result(root: Path, workers: int) -> Result:
        watch = Where()
        report = backup([root], workers=workers, commit=True, attempts=1, watch=watch)
        listed = report.to_json()["robots"]
        assert isinstance(listed, list)
        robots = [
            {k: v for k, v in r.items() if k not in ("duration", "last_success", "path")}
            | {"standing": r["standing"] and r["standing"]["drift"]}  # its commits differ
            for r in listed
        ]
        # Issue 30: committed on the backup branch, not over the approved one.
        message = git(root, "log", "-1", "--format=%B", "harlsync/backup")
        names = git(root, "show", "--name-only", "--format=", "harlsync/backup").split()
        kept = {
            k: v
            for k, v in files_of(root).items()
            if not k.endswith(("backup.json", "states.json"))
        }
        return watch.of, robots, message, names, kept

    one, two = result(plant.root, 1), result(twin, 2)
    alone, spread = one[0], two[0]
    assert set(alone.values()) == {"here"}
    assert set(spread.values()) == {"here", "worker"}, spread
    assert spread["local"] == "here"  # its port is this process's
    assert one[1:] == two[1:]
    robots = {r["name"]: r for r in one[1]}
    assert [n for n, r in robots.items() if not r["ok"]] == ["d"]
    assert robots["a"]["changed"] and robots["st-2"]["changed"] and robots["local"]["changed"]


def test_a_robot_failed_in_a_worker_is_one_row_of_the_one_report_commit_and_metrics(
    plant: Plant, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    failing = in_a_worker(plant, 2)[0]
    plant.sims[failing].faults = Faults(drop=1.0)
    plant.sims["local"].stations[1].data.timers[1] = "6.66"
    changed = "st-2"  # a station of the shared line, which the plan gives a worker too
    plant.sims[changed].stations[2].data.timers[3] = "3.21"
    head = git(plant.root, "rev-parse", "HEAD").strip()
    metrics = tmp_path / "harlsync.prom"
    code = main(
        ["backup", str(plant.root), "--workers", "2", "--commit", "--attempts", "1"]
        + ["--metrics", str(metrics), "--format", "json"]
    )
    assert code == 1
    report = json.loads(capsys.readouterr().out)
    rows = {r["name"]: r for r in report["robots"]}
    assert len(report["robots"]) == 7
    assert [n for n, r in rows.items() if not r["ok"]] == [failing]
    assert "station 1" in rows[failing]["error"]
    # Issue 30: on the backup branch; HEAD stays.
    assert git(plant.root, "rev-list", f"{head}..harlsync/backup").split() == [report["commit"]]
    assert git(plant.root, "rev-parse", "HEAD").strip() == head
    message = git(plant.root, "log", "-1", "--format=%B", "harlsync/backup")
    assert message.startswith(
        f"backup: 2 of 7 robot(s) changed: {', '.join(sorted([changed, 'local']))}"
    )
    assert f"Not backed up:\n- {failing}: " in message
    text = metrics.read_text()
    assert len(re.findall(r"^harlsync_backup_success\{", text, re.MULTILINE)) == 7
    assert f'harlsync_backup_success{{project="{failing}",robot="{failing}"}} 0' in text
    assert f'harlsync_backup_success{{project="{changed}",robot="{changed}"}} 1' in text
    # And the failure was read in a worker, as the plan said.
    watch = Where()
    backup([plant.root], workers=2, attempts=1, watch=watch)
    assert watch.of[failing] == watch.of[changed] == "worker" and watch.of["local"] == "here"


def test_two_robots_on_one_line_in_a_worker_are_read_in_turn_and_its_line_lock_holds(
    plant: Plant,
) -> None:
    shared = plant.sims["st-1"]
    before = len(shared.received)
    watch = Where()
    report = backup([plant.root], workers=2, watch=watch)
    assert report.ok, report.render()
    assert watch.of["st-1"] == watch.of["st-2"] == "worker"
    stations = [r.station for r in shared.received[before:]]
    assert set(stations) == {1, 2}
    assert sum(a != b for a, b in itertools.pairwise(stations)) == 1  # never interleaved

    # This process holds a worker's line: that robot waits, then fails naming us.
    busy = in_a_worker(plant, 2)[0]
    held = LineLock(plant.ports[busy], lock_path(plant.ports[busy]))
    held.acquire(0)
    try:
        watch = Where()
        report = backup([plant.root], workers=2, attempts=1, lock_timeout=0, watch=watch)
    finally:
        held.release()
    assert watch.of[busy] == "worker"
    rows = {r.name: r for r in report.robots}
    assert [n for n, r in rows.items() if not r.ok] == [busy]
    assert f"in use by another harlsync (pid {os.getpid()})" in (rows[busy].error or "")


pty_only = pytest.mark.skipif(sys.platform == "win32", reason="a pty is POSIX")


@pty_only
def test_ctrl_c_during_a_backup_in_two_workers_leaves_no_partial_file_and_no_lock_held(
    repo: Path, lock_dir: Path
) -> None:
    names = ("loader", "press", "welder", "sealer")
    for seed, name in enumerate(names, 1):  # about 30 s each at 9600: ^C comes long before
        project = repo / name
        engine.pull(project, port=f"sim://?seed={seed}&baud=0")
        robot = project / "robot.yaml"
        robot.write_text(robot.read_text().replace("baud=0", "baud=9600"))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "first backups")
    before = files_of(repo)
    status = git(repo, "status", "--porcelain", "--ignored")

    def every_robot_reading(screen: list[str]) -> bool:
        return all(
            any(re.match(rf"{name}: +\d+%\|.*\| [1-9]\d*/\d+ exchanges", line) for line in screen)
            for name in names
        )

    seen = run("backup", ".", "--workers", "2", cwd=repo, interrupt_when=every_robot_reading)
    assert seen.code == 130, seen.raw
    assert seen.screen[-1] == "harlsync: interrupted", seen.screen
    assert "Traceback" not in seen.raw.decode()
    assert not [line for line in seen.screen if "FAILED" in line]  # stopped, as in one process
    assert files_of(repo) == before  # every backup, and its record, as it was
    assert git(repo, "status", "--porcelain", "--ignored") == status
    assert not list(lock_dir.glob("*.owner"))  # every holder gave its lock back
    # a released lock removes its file (issue 22: lock files do not pile up), so
    # what is left is a lock some process still holds, or one it left behind
    locks = sorted(lock_dir.glob("*.lock"))
    taken = [take_lock_file(path, 0) for path in locks]  # nobody holds any: every worker ended
    for lock in taken:
        lock.release()


class KillsTheWorker(Where):
    """Kills one of this process's workers as soon as a worker says it started a robot."""

    def __init__(self) -> None:
        super().__init__()
        self.killed: list[int] = []

    def started(self, path: Path, name: str) -> None:
        super().started(path, name)
        if self.of[name] == "worker" and not self.killed:
            children = _children()  # the workers, and any git a pull of this process runs
            pid = min(pid for pid in children if b"harlsync.sync.fleet" in _cmdline(pid))
            os.kill(pid, signal.SIGKILL)
            self.killed.append(pid)


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:  # a git that ended meanwhile
        return b""


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="finds the worker in /proc")
def test_a_worker_killed_mid_run_fails_its_robots_and_the_run_goes_on(plant: Plant) -> None:
    plant.sims["local"].stations[1].data.timers[1] = "6.66"
    before = files_of(plant.root)
    watch = KillsTheWorker()
    report = backup([plant.root], workers=2, commit=True, watch=watch)
    assert watch.killed
    rows = {r.name: r for r in report.robots}
    failed = sorted(n for n, r in rows.items() if not r.ok)
    assert failed in [sorted(share) for share in worker_shares(plant, 2)]  # its whole share
    for name in failed:
        assert rows[name].error == (
            "the backup's worker process ended before this robot was backed up (killed by "
            "SIGKILL); its previous backup is kept"
        )
        # Its backup kept; its record says the attempt failed (issue 34 item 2), and
        # keeps when the last good one was.
        record = f"{name}/.harlsync/backup.json"
        assert {k: v for k, v in files_of(plant.root / name).items()} == {
            k.removeprefix(f"{name}/"): v
            for k, v in before.items()
            if k.startswith(f"{name}/") and k != record
        } | {".harlsync/backup.json": (plant.root / record).read_bytes()}
        was, now = json.loads(before[record]), history.read(plant.root / name)
        assert now["last_result"] == "failed" and now["last_success"] == was["last_success"]
    assert rows["local"].ok and rows["local"].changed  # this process's share went on
    assert all(rows[n].ok for share in worker_shares(plant, 2) for n in share if n not in failed)
    assert report.commit and git(
        plant.root, "show", "--name-only", "--format=", "harlsync/backup"
    ).split() == ["local/timers.yaml"]


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="finds the worker in /proc")
def test_issue_34_item_2_robots_of_a_killed_worker_are_recorded_failed_and_status_says_so(
    plant: Plant, capsys: pytest.CaptureFixture[str]
) -> None:
    # Last night's backup (the plant's first pull) recorded every robot ok.
    assert {history.read(plant.root / name).get("last_result") for name in plant.sims} == {"ok"}
    watch = KillsTheWorker()
    report = backup([plant.root], workers=2, watch=watch)
    assert watch.killed
    failed = sorted(r.name for r in report.robots if not r.ok)
    assert failed in [sorted(share) for share in worker_shares(plant, 2)]
    for name in plant.sims:
        record = history.read(plant.root / name)
        assert record["last_result"] == ("failed" if name in failed else "ok"), name
        if name in failed:
            said = "the backup's worker process ended before this robot was backed up"
            assert said in (record["last_error"] or "")
    capsys.readouterr()
    assert main(["status", str(plant.root), "--format", "json"]) == 1
    states = {r["name"]: r["state"] for r in json.loads(capsys.readouterr().out)["robots"]}
    assert sorted(name for name, state in states.items() if state == "failed") == failed


def test_workers_below_one_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["backup", str(tmp_path), "--workers", "0"]) == 2
    err = capsys.readouterr().err
    assert err.splitlines() == [err.strip()] and "--workers 0: give 1 or more processes" in err
