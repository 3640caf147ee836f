"""The Epson "Try it" (docs/families/epson.md) runs as written (issue 34 item 12): the commands are
read from the page itself, so the test fails when the page and the simulator's
default robot part ways."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from simprocess import harlsync_sim

from harlsync import cli
from harlsync.families.epson.sim import SimState
from harlsync.project import load_project

DOCS = Path(__file__).resolve().parents[3] / "docs"
#: The Epson page: the "Try it", the signals a write needs (was the README's section).
EPSON = DOCS / "families" / "epson.md"
#: What a backup holds, per family (was the README's section).
COVERAGE = DOCS / "coverage.md"


def try_it() -> tuple[list[str], list[str]]:
    """The ``harlsync sim`` and ``harlsync pull`` commands of the README's Epson
    "Try it", as argument lists (without ``harlsync``)."""
    section = EPSON.read_text(encoding="utf-8")
    bullet = section[section.index("- **Try it**") :]
    bullet = " ".join(bullet[: bullet.index("\n\n")].split())
    commands = [c.split()[1:] for c in re.findall(r"`(harlsync [^`]+)`", bullet)]
    sim = next(c for c in commands if c[0] == "sim")
    pull = next(c for c in commands if c[0] == "pull")
    return sim, pull


def test_issue_34_the_readme_epson_try_it_pulls_the_simulators_default_robot(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, pull = try_it()
    listen = sim[sim.index("--listen") + 1]
    sim[sim.index("--listen") + 1] = "127.0.0.1:0"  # a free port, not the README's 5020
    port = pull.index("--port") + 1
    assert pull[port] == f"modbus://{listen}"  # the pull asks the simulator the README starts
    seed = int(sim[sim.index("--seed") + 1])
    monkeypatch.chdir(tmp_path)
    with harlsync_sim(*sim[1:], lines=2) as (_, lines):
        pull[port] = lines["tcp"]
        capsys.readouterr()
        assert cli.main(pull) == 0, capsys.readouterr().err
    held = SimState.generate(seed).points
    assert max(held) > 99  # what the README says of its robot
    project = tmp_path / pull[1]
    assert set(load_project(project).data.points()) == set(held)
    assert f"  last_point: {max(held)}\n" in (project / "robot.yaml").read_text()


def epson_coverage() -> str:
    """The "What a backup holds" section for Epson (docs/coverage.md)."""
    text = COVERAGE.read_text(encoding="utf-8")
    start = text.index("## Epson\n")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else None]


def numbers_in(text: str) -> set[int]:
    """Every command number the text names: ``2155``, and each of ``56-58``."""
    found: set[int] = set()
    for low, high in re.findall(r"\b(\d+)(?:-(\d+))?\b", text):
        found.update(range(int(low), int(high or low) + 1))
    return found


def test_issue_34_the_readme_names_every_read_a_backup_leaves_out() -> None:
    """Issue 34 item 19: the README said a backup held "everything the Remote Control
    commands can read back", while 558, 2155 and 2156 were not read.  Every read of
    the digest's safe-read list that a backup does not make is named there, with why."""
    from harlsync.families.epson import protocol as p

    from .test_protocol import SAFE_READS

    section = epson_coverage()
    assert "Everything the Remote Control commands can read back" not in section
    left_out = SAFE_READS - p.BACKUP_READS
    assert 558 in left_out
    assert left_out - numbers_in(section) == set()
    assert {2155, 2156} <= numbers_in(section)  # read by the interlock, not kept: said so


def test_issue_34_the_readme_keeps_fine_where_the_backup_keeps_it() -> None:
    """Issue 34 item 19: Fine was called "not worth keeping" and is kept."""
    from harlsync.families.epson.model import KINDS

    assert "fine" in KINDS  # the backup keeps Fine (settings.yaml)
    rows = [line.split(" | ") for line in epson_coverage().splitlines() if line.startswith("| ")]
    held = " ".join(row[0] for row in rows)
    not_held = " ".join(row[-1] for row in rows)
    assert "Fine" in held and "Fine" not in not_held


def test_issue_34_the_readme_names_every_signal_an_epson_write_needs() -> None:
    """Issue 34 item 19: Error was missing from the README's list of the signals
    without which a robot is never written."""
    from harlsync.families.epson import profile

    text = " ".join(EPSON.read_text(encoding="utf-8").split())
    found = re.search(r"A robot whose map lacks ([A-Za-z, ]+?) is backed up and compared", text)
    assert found is not None
    named = set(re.split(r", | or ", found.group(1)))
    assert named == set(profile.REQUIRED_FOR_WRITES)
    assert " or ".join(profile.WRITE_WITHOUT) == "Ready or SafeguardOn"
    assert "One whose map lacks Ready or SafeguardOn is not written either" in text
