"""What ``harlsync --help`` imports: every family's declaration, and nothing of
its catalogue, layout, protocol or the project store (issue 24 item 1: start-up
pays only for what the command uses)."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
from datetime import time
from pathlib import Path

import pytest

#: ``--help`` of every command, then the modules it left imported.
HELP = """
import contextlib, io, json, sys
from harlsync.cli import build_parser
parser = build_parser()
for argv in (["--help"], ["pull", "--help"], ["push", "--help"], ["backup", "--help"]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        parser.parse_args(argv)
print(json.dumps(sorted(m for m in sys.modules if m.startswith(("harlsync", "yaml")))))
"""


def test_help_imports_the_families_declarations_and_not_their_catalogues() -> None:
    done = subprocess.run([sys.executable, "-c", HELP], capture_output=True, text=True, check=True)
    loaded = json.loads(done.stdout)
    assert {"harlsync.families.epson.family", "harlsync.families.iai.family"} <= set(loaded)
    assert "harlsync.families.harl_u2.family" in loaded
    heavy = [
        m
        for m in loaded
        if m.startswith(("yaml", "harlsync.project"))
        or m.rsplit(".", 1)[-1] in ("catalogue", "layout", "model", "protocol", "codec")
    ]
    assert heavy == []


#: A pull's engine imported, then what of the push machinery came with it.
PULL = """
import json, sys
from harlsync.sync import pulling
print(json.dumps(sorted(m for m in sys.modules if m.startswith("harlsync.sync."))))
"""


def test_issue_24_the_pull_engine_imports_none_of_the_push_plan_and_comparison_machinery() -> None:
    done = subprocess.run([sys.executable, "-c", PULL], capture_output=True, text=True, check=True)
    loaded = set(json.loads(done.stdout))
    assert "harlsync.sync.pulling" in loaded
    assert loaded.isdisjoint(
        {
            "harlsync.sync.comparison",
            "harlsync.sync.deploy",
            "harlsync.sync.plan",
            "harlsync.sync.writes",
        }
    )


#: The package's names, looked up with the module that defines one failing to import.
FAILING = """
import importlib.abc, sys

class Broken(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "harlsync.sync.deploy":
            raise ImportError("deploy is broken here")
        return None

sys.meta_path.insert(0, Broken())
import harlsync.sync as sync
print(sync.pull.__module__, sync.plan.__module__, flush=True)
sync.PushOptions
"""


def test_issue_24_a_name_whose_module_fails_to_import_raises_that_import_error() -> None:
    done = subprocess.run(
        [sys.executable, "-c", FAILING], capture_output=True, text=True, check=False
    )
    assert done.stdout == "harlsync.sync.pulling harlsync.sync.comparison\n"
    assert done.returncode == 1
    assert done.stderr.rstrip().endswith("ImportError: deploy is broken here")


def test_issue_24_a_pull_process_still_takes_the_line_lock_and_says_so_in_one_line(
    tmp_path: Path,
) -> None:
    from harlsync.families.harl_u2.link import Link
    from harlsync.families.harl_u2.sim import SimState, Simulator
    from harlsync.sim.serve import PtyServer

    locks = tmp_path / "locks"
    env = dict(os.environ, HARLSYNC_LOCK_DIR=str(locks))
    server = PtyServer(Simulator(SimState.generate(1)))
    with server, Link(server.device, 1, lock_dir=locks):  # another harlsync on the line
        done = subprocess.run(
            [sys.executable, "-m", "harlsync", "pull", str(tmp_path / "cell")]
            + ["--port", server.device, "--lock-timeout", "0"],
            capture_output=True,
            text=True,
            env=env,
            check=False,
        )
    assert done.returncode == 2
    assert done.stderr.startswith(f"harlsync: error: port {server.device}: in use by ")
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert not (tmp_path / "cell" / "robot.yaml").exists()


#: ``harlsync pull`` in this process, noting the modules it had imported when it
#: first wrote to the port (argv[1]), in the file argv[2].
AT_FIRST_WRITE = """
import json, os, sys
port, out = os.path.realpath(sys.argv[1]), sys.argv[2]
write = os.write

def noted(fd, data):
    if not os.path.exists(out) and fd > 2 and os.isatty(fd) and os.ttyname(fd) == port:
        with open(out, "w") as f:
            json.dump(sorted(sys.modules), f)
    return write(fd, data)

os.write = noted
from harlsync.cli import main
sys.exit(main(["pull", *sys.argv[3:]]))
"""

#: What waits for the line to be open: jsonschema (a valid robot.yaml passes the
#: compiled check: jsonschema only words the errors of one it refuses), git's
#: answer, the audit log and history.  robot.yaml itself is read before, by its one
#: reader (the project store, PyYAML, the family's layout: issue 32).
AFTER_THE_FIRST_REQUEST = (
    "jsonschema",
    "filelock",
    "harlsync.sync.policy",
    "harlsync.sync.audit",
    "harlsync.sync.history",
    "harlsync.sync.items",
    "tqdm",
    "jinja2",
    "pymodbus",
)


def test_issue_24_a_pull_imports_the_link_and_codec_and_not_jsonschema_before_its_first_request(
    tmp_path: Path,
) -> None:
    from conftest import git

    from harlsync.families.harl_u2.layout import render_robot
    from harlsync.families.harl_u2.sim import SimState, Simulator
    from harlsync.project.robot import Robot, Window
    from harlsync.sim.serve import PtyServer

    git(tmp_path, "init", "-q")  # git is asked too: a pull checks for uncommitted edits
    project, noted = tmp_path / "cell", tmp_path / "modules.json"
    project.mkdir()
    server = PtyServer(Simulator(SimState.generate(3)))
    with server:
        robot = Robot(name="cell", port=server.device, description="Cell 3: the press")
        robot.windows.append(Window(("sat", "sun"), time(22, 0), time(6, 0)))
        (project / "robot.yaml").write_text(render_robot(robot))
        done = subprocess.run(
            [sys.executable, "-c", AT_FIRST_WRITE, server.device, str(noted), str(project)],
            capture_output=True,
            text=True,
            check=False,
        )
    assert done.returncode == 0, done.stderr
    loaded = json.loads(noted.read_text())
    assert {"harlsync.link.exchange", "harlsync.families.harl_u2.protocol.codec"} <= set(loaded)
    assert [m for m in loaded if m.startswith(AFTER_THE_FIRST_REQUEST)] == []
    assert (project / "controller.yaml").is_file()  # and the pull went on to save


#: Command lines of every command, as a person or cron writes them.
COMMAND_LINES = [
    ["pull", "cell"],
    ["-v", "pull", "cell", "--port", "/dev/ttyUSB0", "--station", "3", "--commit"],
    ["-vv", "pull", "cell", "--allow-dirty", "--new-robot", "--lock-timeout", "2", "-v"],
    ["--verbose", "diff", "cell", "--registers", "--format", "json"],
    ["diff", "cell", "--rev", "HEAD~1", "--rev", "2"],
    ["plan", "cell"],
    ["push", "cell", "--yes", "--reason", "new timers", "--reset-function"],
    ["rollback", "cell", "--yes"],
    ["backup", "plant", "--commit", "--jobs", "4"],
    ["status", "plant", "--format", "json"],
    ["log", "cell"],
    ["snapshots", "cell"],
    ["validate", "cell"],
    ["sim", "--family", "iai"],
]


def test_issue_24_the_parser_of_the_command_run_parses_as_the_whole_parser() -> None:
    from harlsync.cli import _command_of, build_parser

    whole = build_parser()
    for argv in COMMAND_LINES:
        command = _command_of(argv)
        assert command == next(word for word in argv if not word.startswith("-")), argv
        assert vars(build_parser(command).parse_args(argv)) == vars(whole.parse_args(argv))
        assert _help(build_parser(command), [command, "--help"]) == _help(
            whole, [command, "--help"]
        )


def _help(parser: argparse.ArgumentParser, argv: list[str]) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
        parser.parse_args(argv)
    return out.getvalue()


def test_issue_24_a_command_line_that_names_no_command_plainly_gets_the_whole_parser() -> None:
    from harlsync.cli import _command_of

    for argv in (
        [],
        ["--help"],
        ["--version"],
        ["pul", "cell"],
        ["--verb", "pull"],
        ["-x", "pull"],
    ):
        assert _command_of(argv) is None, argv


def test_issue_24_help_is_as_wide_as_shutil_measures_the_terminal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import shutil

    from harlsync.cli.common import _columns

    for columns in ("100", "0", "abc", None):
        if columns is None:
            monkeypatch.delenv("COLUMNS", raising=False)
        else:
            monkeypatch.setenv("COLUMNS", columns)
        assert _columns() == shutil.get_terminal_size().columns, columns


def _pulled(repo: Path, url: str) -> Path:
    from conftest import git

    from harlsync.sync import engine

    project = repo / "cell"
    engine.pull(project, port=url)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    return project


def _files(project: Path) -> dict[str, bytes]:
    return {str(p.relative_to(project)): p.read_bytes() for p in project.rglob("*") if p.is_file()}


def test_issue_24_a_dirty_project_is_refused_once_the_read_began_with_nothing_saved(
    repo: Path,
) -> None:
    from harlsync.errors import PolicyError
    from harlsync.families.harl_u2.sim import SimState, Simulator
    from harlsync.sim.protocol_sim import register, unregister
    from harlsync.sync import engine

    sim = Simulator(SimState.generate(5))
    url = register(sim)
    try:
        project = _pulled(repo, url)
        sim.stations[1].data.timers[1] = "7.77"  # a pull would change timers.yaml ...
        programs = project / "programs"
        edited = next(p for p in sorted(programs.iterdir()) if p.suffix == ".yaml")
        edited.write_text(edited.read_text() + "# checked by hand\n")  # ... over an edit
        before = _files(project)
        sim.received.clear()
        with pytest.raises(PolicyError) as refused:
            engine.pull(project)
    finally:
        unregister(url)
    assert str(refused.value) == (
        f"{project}: uncommitted changes a pull would overwrite "
        f"(cell/programs/{edited.name}); commit or stash them, or overwrite them with "
        f"'harlsync pull {project} --allow-dirty'"
    )
    assert _files(project) == before  # nothing saved, not even the pull's record
    # Refused after the first requests (git answered meanwhile), which were reads.
    assert sim.received and not any(r.is_write for r in sim.received)


def test_issue_24_without_git_a_pull_is_refused_in_one_line_and_saves_nothing(
    repo: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from harlsync.errors import SyncError
    from harlsync.families.harl_u2.sim import SimState, Simulator
    from harlsync.sim.protocol_sim import register, unregister
    from harlsync.sync import engine

    url = register(Simulator(SimState.generate(6)))
    try:
        project = _pulled(repo, url)
        before = _files(project)
        monkeypatch.setenv("PATH", str(repo / "no-git-here"))
        with pytest.raises(SyncError, match=r"^git is not installed: install git"):
            engine.pull(project)
    finally:
        unregister(url)
    assert _files(project) == before


def test_issue_24_review_a_git_that_cannot_be_started_is_one_line_not_a_traceback(
    repo: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A git on PATH that is not executable (or no process left to start it) is a
    SyncError in words, as a missing git is, not a thread's traceback and an
    IndexError."""
    from harlsync.errors import SyncError
    from harlsync.sync import git

    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "git").write_text("#!/bin/sh\n")  # mode 644: not executable
    monkeypatch.setenv("PATH", str(bin_dir))
    asked = git.Asked(repo)
    with pytest.raises(SyncError, match=r"^git could not be started \(Permission denied\)"):
        asked.changed_files()
    asked.close()
