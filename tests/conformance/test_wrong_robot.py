"""Issue 14, item 5: a pull from a controller that is not the robot backed up in DIR
(a wrong port or station, a swapped controller, a lost memory) refuses, names what
differs and how to accept it, and leaves the backup byte for byte as it was;
``backup`` reports such a robot as failed with the same words.  What identifies a
robot is the family's (Catalogue.robot_identity)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import git

from harlsync.cli import main
from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.model import Version
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine
from harlsync.sync.backup import backup

SMALL = Config(ProgramArea(1, 6), ProgramArea(2, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)
OTHER = Config(ProgramArea(1, 6), ProgramArea(3, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)


def files_of(project: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(project)): p.read_bytes()
        for p in sorted(project.rglob("*"))
        if p.is_file() and ".harlsync" not in p.parts
    }


@pytest.fixture
def served() -> Iterator[dict[str, Any]]:
    """Simulators by name, each served as ``sim://@name`` while the test runs."""
    sims: dict[str, Any] = {}
    yield sims
    for name in sims:
        unregister(f"sim://@{name}")


def serve(sims: dict[str, Any], name: str, sim: Any) -> str:
    sims[name] = sim
    return register(sim, name)


@pytest.fixture
def cell(repo: Path, served: dict[str, Any]) -> Path:
    """A committed backup of a HARL-U2 robot."""
    url = serve(served, "wrong-cell", HarlSimulator({1: HarlState.generate(5, SMALL)}))
    engine.pull(repo / "cell", port=url, commit=True)
    return repo / "cell"


def refusal(project: Path, url: str, capsys: pytest.CaptureFixture[str]) -> str:
    before = files_of(project)
    assert main(["pull", str(project), "--port", url]) == 3
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert files_of(project) == before  # not one byte of the backup replaced
    return err


def test_issue_14_a_controller_with_another_program_configuration_is_refused_naming_it(
    cell: Path,
    served: dict[str, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    url = serve(served, "wrong-other", HarlSimulator({1: HarlState.generate(5, OTHER)}))
    err = refusal(cell, url, capsys)
    assert err == (
        f"harlsync: refused: {cell}: the controller at port {url} station 1 does not look like "
        "the robot backed up here: program configuration 'START 1x6, MAIN 3x8, SUB 1x6, HAND "
        "1x4 (programs x steps), 4 timers, 16 memory bits, 4 registers' (the backup has 'START "
        "1x6, MAIN 2x8, SUB 1x6, HAND 1x4 (programs x steps), 4 timers, 16 memory bits, 4 "
        "registers'). The backup was left as it was. If this is the robot (replaced, "
        f"reconfigured, updated), accept it with 'harlsync pull {cell} --new-robot'\n"
    )
    assert main(["pull", str(cell), "--port", url, "--new-robot", "--commit"]) == 0
    assert (
        "MAIN 3x8"
        in engine.catalogue(engine.load_robot(cell)).robot_identity(engine.load_project(cell).data)[
            "program configuration"
        ]
    )


def test_issue_14_a_controller_with_another_version_is_refused_naming_it(
    cell: Path,
    served: dict[str, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    state = HarlState.generate(5, SMALL)
    state.data.version = "5.10"
    url = serve(served, "wrong-updated", HarlSimulator({1: state}))
    assert "version '5.10' (the backup has '5.00')." in refusal(cell, url, capsys)


def test_issue_14_a_controller_where_most_of_the_backup_would_change_looks_like_another_robot(
    cell: Path,
    served: dict[str, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    url = serve(served, "wrong-twin", HarlSimulator({1: HarlState.generate(6, SMALL)}))
    err = refusal(cell, url, capsys)
    assert re.search(
        r"here: [0-9]+ programs \([0-9]+ steps\) would change, [0-9]+ of the "
        r"[0-9]+ items of that kind: it looks like another robot, or one whose "
        r"memory was lost\. The backup was left as it was\.",
        err,
    ), err
    wiped = HarlState.blank(SMALL)  # the same robot after its battery died
    wiped.data.version = "5.00"
    url = serve(served, "wrong-wiped", HarlSimulator({1: wiped}))
    assert "one whose memory was lost" in refusal(cell, url, capsys)


def test_a_robot_whose_programs_changed_a_little_is_still_the_same_robot(
    cell: Path,
    served: dict[str, Any],
) -> None:
    program = served["wrong-cell"].stations[1].data.programs[(ProgramType.MAIN, 0)]
    program[1] = Step.parse("MOVE P777 S50")
    assert engine.pull(cell).summary == "1 program (1 step)"


def test_issue_14_an_iai_controller_with_other_201h_codes_is_refused_naming_them(
    repo: Path,
    served: dict[str, Any],
    capsys: pytest.CaptureFixture[str],
) -> None:
    state = IaiState.generate(3, position_range=(1, 40))
    url = serve(served, "wrong-iai", IaiSimulator({0x99: state}))
    engine.pull(repo / "axis", port=url, family="iai", commit=True)
    robot = repo / "axis" / "robot.yaml"
    robot.write_text(robot.read_text().replace("last_position: 1000", "last_position: 40"))
    git(repo, "commit", "-qam", "axis: the table it uses")
    for key, version in state.versions.items():
        state.versions[key] = Version(
            version.unit_type,
            version.device,
            "22",
            version.unit_code,
            version.version,
            version.built,
        )
    assert "model code '22' (the backup has '21')" in refusal(repo / "axis", url, capsys)


def test_issue_14_backup_reports_a_controller_that_is_not_the_robot_as_failed(
    cell: Path,
    repo: Path,
    served: dict[str, Any],
) -> None:
    url = serve(served, "wrong-fine", HarlSimulator({1: HarlState.generate(7, SMALL)}))
    engine.pull(repo / "fine", port=url, commit=True)
    served["wrong-cell"].stations[1] = HarlState.generate(5, OTHER)  # swapped overnight
    before = files_of(cell)
    report = backup([repo], commit=True)
    outcomes = {r.name: r for r in report.robots}
    assert outcomes["fine"].ok
    assert not outcomes["cell"].ok and len(outcomes["cell"].attempts) == 1  # never retried
    assert "does not look like the robot backed up here: program configuration" in (
        outcomes["cell"].error or ""
    )
    assert (outcomes["cell"].error or "").endswith(f"'harlsync pull {cell} --new-robot'")
    assert files_of(cell) == before


def test_an_epson_robot_is_its_manipulator_and_a_read_says_its_tables_settings_and_points() -> None:
    from harlsync.families.epson.catalogue import CATALOGUE as EPSON
    from harlsync.families.epson.model import EpsonData, PointKey, SettingKey, TableKey

    data = EpsonData(
        robot_type=1,
        axes=4,
        model="LS3-B401S",
        items={
            TableKey("accel_s", 3): None,
            SettingKey("weight"): None,
            SettingKey("box", 5): None,
            PointKey("point", 1): None,
        },
    )
    assert EPSON.robot_identity(data) == {
        "robot type": data.type_name,
        "axes": "4",
        "model": "LS3-B401S",
    }
    assert EPSON.contents(data, registers=False) == "1 table entry, 2 settings, 1 point"


def test_a_part_of_the_identity_the_controller_did_not_give_reads_none_not_python() -> None:
    from harlsync.sync.pulling import _identity_differs

    assert _identity_differs({"version": "5.00", "model": "21"}, {"model": "21"}) == [
        "version none (the backup has '5.00')"
    ]
