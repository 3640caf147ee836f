"""``validate`` reports every problem in one run, and refuses what the controller would
refuse (issue 22 item 3): a schema error does not hide the range and cross-file checks
of other items; Epson AccelS/AccelR/SpeedS/SpeedR of 0 or less and a negative weight are
refused by the schema, as the manual's controller refuses them; and a push of a project
that does not validate writes nothing."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import git

from harlsync import cli, families
from harlsync.project import Project, save_project, validate_project
from tests.epson.sample import sample_data


@pytest.fixture
def epson(repo: Path) -> Path:
    robot = families.get("epson").new_robot("cell-3", "modbus://127.0.0.1:1", None)
    path = repo / "cell-3"
    save_project(path, Project(path, robot, sample_data()))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "cell-3")
    return path


def replace(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        (
            "3: {accel: 100.123, decel: 200.000}",
            "3: {accel: 0.000, decel: 200.000}",
            "accel_s.3.accel",
        ),
        (
            "3: {accel: 100.123, decel: 200.000}",
            "3: {accel: 1.000, decel: -2.000}",
            "accel_s.3.decel",
        ),
        ("2: {speed: 2000.000,", "2: {speed: 0.000,", "speed_s.2.speed"),
        ("  0: 720.000", "  0: -1.000", "speed_r.0"),
        ("weight: {weight: 2.000,", "weight: {weight: -0.001,", "weight.weight"),
    ],
)
def test_epson_values_the_controller_refuses_are_refused_by_validate(
    epson, capsys, old, new, said
) -> None:
    replace(epson / "settings.yaml", old, new)
    assert cli.main(["validate", str(epson)]) == 1
    out = capsys.readouterr().out
    assert f": {said}: " in out and "(allowed: " in out and ("above 0" in out or "0 or more" in out)


def test_a_schema_error_does_not_hide_the_checks_of_the_other_items(epson) -> None:
    settings = epson / "settings.yaml"
    replace(settings, "3: {accel: 100.123, decel: 200.000}", "3: {accel: fast, decel: 200.000}")
    replace(
        settings, "  4: {lower: -100000, upper: 100000}", "  5: {lower: -100000, upper: 100000}"
    )
    said = [str(issue) for issue in validate_project(epson)]
    assert any(": accel_s.3.accel: " in line for line in said), said
    assert any("jrange.5: joint 5 of a 4-axis robot (allowed: 1-4)" in line for line in said), said


def test_a_push_of_a_project_that_does_not_validate_writes_nothing(epson, capsys) -> None:
    replace(epson / "settings.yaml", "  0: 720.000", "  0: 0.000")
    git(epson.parent, "commit", "-qam", "speed_r 0")
    # No controller is listening: a push that tried to connect would say so instead.
    assert cli.main(["push", str(epson), "--yes"]) == 2
    err = capsys.readouterr().err
    assert "speed_r.0" in err and "connect" not in err.lower()


def test_an_iai_schema_error_does_not_hide_the_range_checks_of_the_other_positions(
    repo,
) -> None:
    import re

    from harlsync.families.iai.sim import SimState, Simulator
    from harlsync.sim.protocol_sim import register, unregister
    from harlsync.sync import engine

    url = register(Simulator({0x99: SimState.generate(5, position_range=(1, 20))}))
    try:
        project = repo / "cell-9"
        engine.pull(project, port=url, station=0x99, family="iai")
    finally:
        unregister(url)
    robot = project / "robot.yaml"
    robot.write_text(re.sub(r"last_position: \d+", "last_position: 10", robot.read_text()))
    positions = project / "positions.yaml"
    numbers = [int(n) for n in re.findall(r"(?m)^  (\d+): ", positions.read_text())]
    first = numbers[0]
    positions.write_text(
        re.sub(rf"(?m)^(  {first}: .*acc: )[0-9.]+", r"\g<1>fast", positions.read_text())
    )
    said = [str(issue) for issue in validate_project(project)]
    assert any(f": positions.{first}.acc: 'fast' is not a number" in line for line in said)
    beyond = [n for n in numbers if n > 10]
    assert beyond and all(
        any(f"position {n} is outside the robot's table (allowed: 1-10" in line for line in said)
        for n in beyond
    ), said
