"""Shared test helpers."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import toyfamily
from hypothesis import HealthCheck, settings

from harlsync import families

# --- bytecode -----------------------------------------------------------------------------
#
# The suite writes and reads bytecode whatever the shell says: with PYTHONDONTWRITEBYTECODE
# set, every xdist worker rewrote every test module's asserts (5.5 s of CPU each) and every
# harlsync process a test starts compiled the modules pip's editable install had left
# uncompiled, a cost no installed harlsync pays.  What is written is __pycache__, which git
# ignores.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False

# --- hypothesis profiles ------------------------------------------------------------------
#
# "ci" is every run's, not only CI's: the examples are derandomized (a function of the
# test, not of the day), there is no deadline per example (a loaded machine is no bug)
# and no example database (nothing an earlier run left changes this one), so a run
# gives the same result on a developer's machine, in CI and under any load. With CI
# set it is the profile whatever HYPOTHESIS_PROFILE says.
#
# "long" explores: random examples, ten times as many, a failure kept in .hypothesis/
# to be tried first next time (print_blob says how to replay it). The README's long
# run selects it: ``pytest -m "slow or hypothesis" --hypothesis-profile=long``.
_SETTLED = settings(deadline=None, print_blob=True, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("ci", _SETTLED, derandomize=True, database=None)
settings.register_profile("long", _SETTLED, max_examples=1000)
settings.load_profile("ci" if os.environ.get("CI") else os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def examples(n: int) -> int:
    """A test's example count: ``n`` in the default run, as many times more as the
    profile runs more than hypothesis's 100 (ten times in "long"). Use it for
    ``@settings(max_examples=...)``: a bare number would override the profile."""
    return max(1, n * _profile().max_examples // 100)


def _profile() -> settings:
    """The profile loaded above."""
    loaded = settings.default
    assert loaded is not None
    return loaded


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: two workers a core, four more at the most.  A third of the suite's
    time is spent waiting (simulated lines, subprocesses, git), so a worker a core left
    the cores a third idle: on 2 cores the default run took 6 min 50 s with 2 workers
    (135 % CPU) and 5 min 33 s with 4 (191 %), every test passing both ways."""
    cores = os.cpu_count() or 1
    return cores + min(cores, 4)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The long profile's property runs take many times the 600 s a test may take."""
    if _profile().max_examples > 100:
        for item in items:
            if item.get_closest_marker("hypothesis"):
                item.add_marker(pytest.mark.timeout(3600))


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
def settled_heap() -> None:
    """Each test starts with what earlier tests left collected and frozen (``gc.freeze``):
    the collector then looks only at what this test makes.  A test that serves a
    simulated controller from a thread of its own process shares its collector pauses
    with the client: a full collection of a long-running worker's whole heap took up to
    2 s on a loaded machine, past a Modbus timeout of 0.5 s, and a reply was "lost"
    that no controller would have lost (the client of a real one is a process alone)."""
    gc.collect()
    gc.freeze()


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


@pytest.fixture
def toy(monkeypatch: pytest.MonkeyPatch) -> str:
    """The toy family (tests/toyfamily), registered in a copy of the registry that the
    test's end throws away: the robot of a test about the engine, whatever its family
    (the rest of the suite sees only the real families).  Its name."""
    monkeypatch.setattr(families, "FAMILIES", dict(families.FAMILIES))
    toyfamily.register()
    return toyfamily.NAME


@pytest.fixture
def toy_installed(tmp_path: Path, toy: str) -> dict[str, str]:
    """The toy family in this process (``toy``) and, for a harlsync run as a process of
    its own, installed as a site adds a family: a distribution on the ``PYTHONPATH``
    this returns declares it in the entry-point group ``harlsync.families``."""
    site = tmp_path / "site"
    info = site / "harlsync_toyfamily-0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: harlsync-toyfamily\nVersion: 0\n")
    (info / "entry_points.txt").write_text(f"[{families.ENTRY_POINTS}]\n{toy} = toyfamily\n")
    tests = Path(toyfamily.__file__).parent.parent
    return {"PYTHONPATH": os.pathsep.join([str(site), str(tests)])}
