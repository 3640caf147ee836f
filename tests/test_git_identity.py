"""``pull --commit`` and ``backup --commit`` under cron or systemd: no git identity
configured, HOME an empty directory, no GIT_* variables (issue 22 item 9); and the
commit messages name what changed and who pushed since the last backup.  The robot is
the toy family's (conftest's ``toy_installed``, which the harlsync processes find as an
installed family): who commits, and what a message says, is the engine's."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git
from toyfamily.sim import SimState, Simulator

from harlsync.sim.serve import TcpServer
from harlsync.sync import engine
from harlsync.sync.engine import PushOptions

HARLSYNC = str(Path(sys.executable).parent / "harlsync")


@pytest.fixture
def served() -> Iterator[tuple[Simulator, str]]:
    sim = Simulator({1: SimState.generate(7)})
    server = TcpServer(sim)
    url = server.start()
    yield sim, url
    server.stop()


def cron_env(tmp_path: Path, toy_installed: dict[str, str]) -> dict[str, str]:
    """What cron gives a job: PATH, an empty HOME; no git identity anywhere (and the
    toy family installed)."""
    home = tmp_path / "home"
    home.mkdir(exist_ok=True)
    return {
        "PATH": os.environ["PATH"],
        "HOME": str(home),
        "GIT_CONFIG_NOSYSTEM": "1",  # as on a host whose /etc/gitconfig names nobody
        "HARLSYNC_AUDIT_LOG": os.environ["HARLSYNC_AUDIT_LOG"],
        "HARLSYNC_LOCK_DIR": os.environ["HARLSYNC_LOCK_DIR"],
        **toy_installed,
    }


def run(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [HARLSYNC, *args], env=env, capture_output=True, text=True, timeout=60, check=False
    )


def test_pull_and_backup_commit_with_no_git_identity(
    served: tuple[Simulator, str], repo: Path, tmp_path: Path, toy_installed: dict[str, str]
) -> None:
    sim, url = served
    env = cron_env(tmp_path, toy_installed)
    project = repo / "press"
    done = run(env, "pull", str(project), "--port", url, "--family", "toy", "--commit")
    assert done.returncode == 0, done.stderr
    author = git(repo, "log", "-1", "--format=%an <%ae>|%cn <%ce>").strip()
    assert re.fullmatch(r"harlsync \((\S+)@(\S+)\) <\1@\2>\|harlsync \(\1@\2\) <\1@\2>", author)

    sim.stations[1].slots[1] = 6666
    done = run(env, "backup", str(repo), "--commit")
    assert done.returncode == 0, done.stdout + done.stderr
    # Issue 30: on the backup branch, by the same identity.
    assert git(repo, "log", "-1", "--format=%s", "harlsync/backup").strip() == (
        "backup: press: slot 1"
    )
    author = git(repo, "log", "-1", "--format=%an <%ae>|%cn <%ce>", "harlsync/backup").strip()
    assert re.fullmatch(r"harlsync \((\S+)@(\S+)\) <\1@\2>\|harlsync \(\1@\2\) <\1@\2>", author)


def test_a_configured_identity_wins(
    served: tuple[Simulator, str], repo: Path, tmp_path: Path, toy_installed: dict[str, str]
) -> None:
    _, url = served
    env = cron_env(tmp_path, toy_installed) | {
        "GIT_AUTHOR_NAME": "Plant Backup",
        "GIT_AUTHOR_EMAIL": "b@plant",
    }
    git(repo, "config", "user.name", "Repo Owner")
    git(repo, "config", "user.email", "owner@plant")
    done = run(env, "pull", str(repo / "press"), "--port", url, "--family", "toy", "--commit")
    assert done.returncode == 0, done.stderr
    assert git(repo, "log", "-1", "--format=%an <%ae>|%cn <%ce>").strip() == (
        "Plant Backup <b@plant>|Repo Owner <owner@plant>"
    )


def test_commit_messages_name_the_items_and_who_pushed_since_the_last_backup(
    served: tuple[Simulator, str], repo: Path, toy_installed: dict[str, str]
) -> None:
    sim, url = served
    git(repo, "config", "user.name", "t")
    git(repo, "config", "user.email", "t@t")
    project = repo / "press"
    engine.pull(project, port=url, commit=True, family="toy")
    slots = project / "slots.yaml"
    slots.write_text(re.sub(r"(?m)^  2: .*$", "  2: 80", slots.read_text()))
    git(repo, "commit", "-qam", "faster")
    engine.push(project, PushOptions(yes=True, reason="faster pick"))
    sim.stations[1].slots[1] = 6666
    done = run(os.environ | toy_installed, "pull", str(project), "--commit")
    assert done.returncode == 0, done.stderr
    message = git(repo, "log", "-1", "--format=%B")
    subject, body = message.split("\n", 1)
    assert subject == "pull press: slot 1"
    assert "  slot 1\n" in body
    assert re.search(
        r'pushed since the last backup:\n  push ok \S+ by \S+@\S+: "faster pick"', body
    )
