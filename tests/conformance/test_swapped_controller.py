"""A swapped controller (another robot's controller on the port) is refused at its
first identity read, not after the whole read (issue 22 item 11): the simulator's
record shows only the identity requests before the refusal, and the backup is left
as it was."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
from plantsim import SMALL

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister

if TYPE_CHECKING:
    from harlsync.families.epson.sim import Simulator as EpsonSimulator
    from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
    from harlsync.families.iai.sim import Simulator as IaiSimulator


def since(sim: HarlSimulator | IaiSimulator, before: int) -> list[str]:
    """The requests the simulator received after the first ``before``, by name."""
    with sim.lock:
        return [r.command for r in sim.received[before:]]


@pytest.fixture
def harl_u2(repo: Path) -> Iterator[tuple[HarlSimulator, Path]]:
    from harlsync.families.harl_u2.sim import SimState, Simulator

    sim = Simulator({1: SimState.generate(7, SMALL)})
    url = register(sim)
    project = repo / "press"
    assert main(["pull", str(project), "--port", url, "--commit"]) == 0
    yield sim, project
    unregister(url)


@pytest.fixture
def iai(repo: Path) -> Iterator[tuple[IaiSimulator, Path]]:
    from harlsync.families.iai.sim import SimState, Simulator

    sim = Simulator({0x99: SimState.generate(5, position_range=(1, 20))})
    url = register(sim)
    project = repo / "gantry"
    assert main(["pull", str(project), "--port", url, "--family", "iai", "--commit"]) == 0
    yield sim, project
    unregister(url)


@pytest.fixture
def epson(repo: Path) -> Iterator[tuple[EpsonSimulator, Path]]:
    from families.epson.projects import saved
    from families.epson.sample import sample_data

    from harlsync.families.epson.sim import SimState, Simulator

    sim = Simulator(SimState.from_data(sample_data()), execution_time=0.0)
    with sim.serve() as server:
        yield sim, saved(repo, server.url, "scara")


def test_a_harl_u2_of_another_version_is_refused_after_lnx_and_lnv(
    harl_u2: tuple[HarlSimulator, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    sim, project = harl_u2
    before_files = {p: p.read_bytes() for p in project.rglob("*.yaml")}
    sim.stations[1].data.version = "9.99"  # another robot's controller on the port
    before = len(sim.received)
    capsys.readouterr()
    assert main(["pull", str(project)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not look like the robot backed up here" in err
    assert "version '9.99'" in err and "--new-robot" in err
    assert since(sim, before) == ["LNX", "LNV"]  # its identity, nothing more
    assert {p: p.read_bytes() for p in project.rglob("*.yaml")} == before_files


def test_an_iai_unit_of_another_model_is_refused_after_201h(
    iai: tuple[IaiSimulator, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    sim, project = iai
    versions = sim.stations[0x99].versions
    for key, version in versions.items():
        versions[key] = dataclasses.replace(version, model_code="3A")
    before = len(sim.received)
    capsys.readouterr()
    assert main(["pull", str(project)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "model code '3A'" in err, err
    assert since(sim, before) == ["201"]


@pytest.mark.parametrize("command", ["pull", "diff", "plan", "push"])
def test_an_epson_of_another_model_is_refused_after_2153_and_2154(
    epson: tuple[EpsonSimulator, Path], command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, project = epson
    sim.stations[1].model = "G3-301S"
    before = len(sim.commands())
    capsys.readouterr()
    code = main([command, str(project), *(["--yes"] if command == "push" else [])])
    err = capsys.readouterr().err
    assert code == {"pull": 3, "diff": 2, "plan": 2, "push": 3}[command], err
    assert err.count("\n") == 1, err
    assert re.search(r"G3-301S", err) and "LS6-B602S" in err, err
    numbers = [c.number for c in sim.commands()[before:]]
    if command == "push":  # its interlock first (issue 34: the control device, the error)
        assert numbers[:2] == [2156, 2155], numbers
        numbers = numbers[2:]
    # the type, the model one character a command, and (issue 29) the point past the
    # point table twice and its last point, part of the identity too: a few reads
    assert numbers[: 1 + len("G3-301S")] == [2153, *[2154] * len("G3-301S")], numbers
    assert numbers[1 + len("G3-301S") :] == [1222] * 3, numbers


@pytest.mark.parametrize("command", ["diff", "plan", "push"])
def test_issue_34_item_17_a_harl_u2_of_another_version_is_refused_by_diff_plan_and_push(
    harl_u2: tuple[HarlSimulator, Path], command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # A pull refused a swapped controller, a push did not: it read the robot, planned
    # and wrote the project's items to another robot's controller.
    sim, project = harl_u2
    before_files = {p: p.read_bytes() for p in project.rglob("*.yaml")}
    sim.stations[1].data.version = "9.99"  # another robot's controller on the port
    sim.stations[1].data.timers[0] = "7.77"  # what a push would write back
    before = len(sim.received)
    capsys.readouterr()
    code = main([command, str(project), *(["--yes"] if command == "push" else [])])
    err = capsys.readouterr().err
    assert code == {"diff": 2, "plan": 2, "push": 3}[command], err
    assert err.count("\n") == 1, err
    assert "version '9.99' (LNV), the project is of version '5.00'" in err, err
    assert "--new-robot" in err
    asked = since(sim, before)
    # its identity, after the interlock's two LNR for a push, and nothing more
    assert asked == (["LNR", "LNR"] if command == "push" else []) + ["LNX", "LNV"], asked
    assert not sim.writes_received()
    assert {p: p.read_bytes() for p in project.rglob("*.yaml")} == before_files
