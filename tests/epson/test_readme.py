"""The README's Epson "Try it" runs as written (issue 34 item 12): the commands are
read from the README itself, so the test fails when the README and the simulator's
default robot part ways."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from simprocess import harlsync_sim

from harlsync import cli
from harlsync.families.epson.sim import SimState
from harlsync.project import load_project

README = Path(__file__).resolve().parents[2] / "README.md"


def try_it() -> tuple[list[str], list[str]]:
    """The ``harlsync sim`` and ``harlsync pull`` commands of the README's Epson
    "Try it", as argument lists (without ``harlsync``)."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Epson controllers") :]
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
