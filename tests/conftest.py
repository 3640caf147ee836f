"""Shared test helpers."""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest


def git(repo: Path, *args: str) -> str:
    """Run git in ``repo`` with a throwaway identity; its standard output."""
    return subprocess.run(
        ["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
        cwd=repo,
        check=True,
        capture_output=True,
        text=True,
    ).stdout


def until(condition: Callable[[], object], what: str, deadline: float = 30.0) -> None:
    """Wait for ``condition`` to hold, polling; fail naming ``what`` after ``deadline`` s
    (tests never sleep to wait for something)."""
    end = time.monotonic() + deadline
    while not condition():
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.005)


@pytest.fixture(autouse=True)
def lock_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Every test gets its own line locks and audit log, never the user's."""
    path = tmp_path / "locks"
    monkeypatch.setenv("HARLSYNC_LOCK_DIR", str(path))
    monkeypatch.setenv("HARLSYNC_AUDIT_LOG", str(tmp_path / "audit.jsonl"))
    return path


@pytest.fixture
def repo(tmp_path: Path) -> Path:
    """An empty git repository, as a plant's backups live in."""
    root = tmp_path / "plant"
    root.mkdir()
    git(root, "init", "-q")
    return root
