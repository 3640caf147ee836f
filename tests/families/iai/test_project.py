"""IAI project files: they round-trip byte for byte, and every bad input is one
line naming file:line and the field, with what is allowed."""

from __future__ import annotations

from pathlib import Path

import pytest

from harlsync import families
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position, Version
from harlsync.project import Project, load_project, save_project, validate_project

VERSION = Version(0, 0, "12", "34", "0102", "2024-05-01 10:20:30")
TABLE = {
    1: Position(1, (1, 2, 3), "0.30", "0.30", 100, ("100.000", "-1.000", "0.000")),
    2: Position(2, (1, 2, 3), "0.30", "0.30", 100, ("100.000", "-2.000", "0.000")),
    7: Position(7, (1, 2), "0.00", "0.00", 0, ("0.000", "25.500"), 1, 2),
}


@pytest.fixture
def project(tmp_path: Path) -> Path:
    family = families.get("iai")
    robot = family.new_robot("cell-9", "sim://nowhere", None)
    robot.options["axes"] = (1, 2, 3)
    path = tmp_path / "cell-9"
    save_project(path, Project(path, robot, IaiData(VERSION, dict(TABLE))))
    return path


def test_an_iai_project_loads_as_it_was_saved_and_saves_byte_for_byte(project: Path) -> None:
    before = {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()}
    loaded = load_project(project)
    assert loaded.robot.family == "iai"
    assert loaded.robot.station == 0x99
    assert loaded.robot.options["axes"] == (1, 2, 3)
    assert loaded.data.positions == TABLE
    assert loaded.data.version == VERSION
    assert save_project(project, loaded) == []
    assert {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()} == before


def test_positions_are_one_per_line_keyed_by_number_with_exact_decimal_text(
    project: Path,
) -> None:
    lines = (project / "positions.yaml").read_text().splitlines()
    assert lines[0] == "# yaml-language-server: $schema=.schemas/positions.schema.json"
    assert lines[3:] == [
        (
            "  1: {axes: [1, 2, 3], coords: [100.000, -1.000, 0.000], acc: 0.30, dec: 0.30, "
            "speed: 100}"
        ),
        (
            "  2: {axes: [1, 2, 3], coords: [100.000, -2.000, 0.000], acc: 0.30, dec: 0.30, "
            "speed: 100}"
        ),
        (
            "  7: {axes: [1, 2], coords: [0.000, 25.500], acc: 0.00, dec: 0.00, speed: 0, "
            "arm1: right, arm2: left}"
        ),
    ]


def _edit(project: Path, old: str, new: str, file: str = "positions.yaml") -> None:
    path = project / file
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def assert_issue_after_edit(
    project: Path, old: str, new: str, expected: str, file: str = "positions.yaml"
) -> None:
    """Replace ``old`` by ``new`` in ``file``: validate finds an issue that starts with
    ``expected``, and every issue is one line."""
    _edit(project, old, new, file)
    issues = validate_project(project)
    assert any(issue.startswith(expected) for issue in issues), issues
    assert all("\n" not in issue for issue in issues)


BAD = [
    (
        "coords: [100.000, -1.000, 0.000]",
        "coords: [100.000, -1.000, 99999999.000]",
        (
            "positions.yaml:4: positions.1.coords.2: 99999999.000 is out of range "
            "(allowed: mm with three decimals, -2147483.648 to 2147483.647)"
        ),
    ),
    (
        "axes: [1, 2, 3], coords: [100.000, -1.000, 0.000]",
        "axes: [1, 2, 3, 4, 5, 6, 7, 8, 9], coords: [100.000, -1.000, 0.000]",
        "positions.yaml:4: positions.1.axes:",
    ),
    (
        "axes: [1, 2, 3], coords: [100.000, -1.000, 0.000]",
        "axes: [1, 2], coords: [100.000, -1.000, 0.000]",
        "positions.yaml:4: positions.1.coords: 3 coordinate(s) for 2 axis/axes",
    ),
    ("  2: {", "  1: {", "positions.yaml:5: positions.1: written twice (lines 4 and 5)"),
    (
        "speed: 100}",
        "speed: 100, colour: red}",
        "positions.yaml:4: positions.1.colour: unknown key",
    ),
    (
        "-1.000",
        "-01.0",
        (
            "positions.yaml:4: positions.1.coords.1: -01.0 is not written in its one form "
            "(write -1.000"
        ),
    ),
    (
        "acc: 0.30",
        "acc: 0.3",
        "positions.yaml:4: positions.1.acc: 0.3 is not written in its one form (write 0.30",
    ),
    (
        "axes: [1, 2], coords",
        "axes: [1, 4], coords",
        "positions.yaml:6: positions.7.axes: axis 4 is not one of the robot's (allowed: 1, 2, 3",
    ),
    (
        "  7: {",
        "  1007: {",
        (
            "positions.yaml:6: positions.1007: position 1007 is outside the robot's table "
            "(allowed: 1-1000"
        ),
    ),
    (
        "speed: 100}",
        "speed: 70000}",
        "positions.yaml:4: positions.1.speed: 70000 is out of range (allowed: mm/s, 0-65535",
    ),
]


@pytest.mark.parametrize(("old", "new", "expected"), BAD, ids=[b[2][:40] for b in BAD])
def test_a_bad_positions_file_names_file_line_field_and_what_is_allowed(
    project: Path, old: str, new: str, expected: str
) -> None:
    assert_issue_after_edit(project, old, new, expected)


def test_a_station_that_is_not_two_hex_digits_is_refused_with_the_range(project: Path) -> None:
    _edit(project, 'station: "99"', 'station: "9G"', "robot.yaml")
    issues = validate_project(project)
    assert issues == [
        (
            "robot.yaml:7: connection.station: '9G' is not a station (allowed: two hex "
            "digits, 00-FF; 99 by default)"
        )
    ]


def test_a_project_without_family_is_a_harl_u2_project_and_an_unknown_family_is_one_line(
    project: Path,
) -> None:
    _edit(project, "family: iai", "family: fanuc", "robot.yaml")
    with pytest.raises(Exception) as info:
        validate_project(project)
    assert str(info.value).endswith(
        "robot.yaml:3: family: unknown controller family 'fanuc' (known: harl-u2, iai, epson)"
    )
