"""Epson project files: they round-trip byte for byte, say each item's volatility,
and every bad input is one line naming file:line and the field, with what is allowed."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from harlsync import families
from harlsync.families.epson import layout
from harlsync.families.epson.model import KINDS, PERSISTENT, POINT, UNSTATED, VOLATILE
from harlsync.families.epson.profile import Bit, RegisterMap
from harlsync.project import Project, load_project, save_project, validate_project

from .sample import sample_data


@pytest.fixture
def project(tmp_path: Path) -> Path:
    robot = families.get("epson").new_robot("cell-3", "modbus://10.0.0.5", None)
    path = tmp_path / "cell-3"
    save_project(path, Project(path, robot, sample_data()))
    return path


def test_an_epson_project_loads_as_it_was_saved_and_saves_byte_for_byte(project: Path) -> None:
    before = {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()}
    assert sorted(before) == ["points.yaml", "robot.yaml", "settings.yaml"]
    loaded = load_project(project)
    assert loaded.robot.family == "epson"
    assert loaded.robot.station == 1  # the Modbus unit id
    assert loaded.robot.port == "modbus://10.0.0.5"
    assert loaded.robot.options["type"] == "SCARA"  # a first pull writes what it read
    assert layout.point_range(loaded.robot) == (0, 99)
    assert layout.connection(loaded.robot).register_map == RegisterMap()
    assert loaded.data.items == sample_data().items
    assert (loaded.data.robot_type, loaded.data.axes, loaded.data.model) == (3, 4, "LS6-B602S")
    assert save_project(project, loaded) == []
    assert {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()} == before


def test_a_six_axis_robot_round_trips_with_v_and_w(tmp_path: Path) -> None:
    robot = families.get("epson").new_robot("arm", "modbus://10.0.0.6:5020", 7)
    path = tmp_path / "arm"
    save_project(path, Project(path, robot, sample_data(axes=6)))
    loaded = load_project(path)
    assert loaded.data.items == sample_data(axes=6).items
    assert loaded.robot.station == 7
    assert (
        "  12: {x: 1.000, y: 400.000, z: -10.500, u: 90.000, v: 90.000, w: 90.000, "
        in (path / "points.yaml").read_text()
    )


def test_settings_are_one_per_line_keyed_by_name_and_number_with_their_volatility(
    project: Path,
) -> None:
    lines = (project / "settings.yaml").read_text().splitlines()
    assert lines[0] == "# yaml-language-server: $schema=.schemas/settings.schema.json"
    assert lines[2].startswith("manipulator: {type: SCARA, axes: 4, model: LS6-B602S}  # read")
    text = "\n".join(lines)
    for expected in [
        (
            "accel:  # volatile: cleared at power-off and reset (§9.1); a push registers it again\n"
            "  0: {accel: 100, decel: 100}\n"
        ),
        (
            "accel_s:  # volatile: cleared at power-off and reset (§9.1); a push registers it again\n"
            "  3: {accel: 100.123, decel: 200.000}\n"
        ),
        "accel_r: {}  # volatile: ",
        (
            "speed_r:  # volatile: cleared at power-off and reset (§9.1); a push registers it again\n"
            "  0: 720.000\n"
        ),
        "arch:  # volatility not stated by the manual\n  0: {depart: 30.000, approach: 30.000}\n",
        "fine: [10000, 10000, 10000, 10000]  # volatile: back to its defaults at Motor On",
        (
            "weight: {weight: 2.000, arm_length: 0.000}  # persistent: on the controller's memory "
            "card; a push writes it only when it changed\n"
        ),
        "  5: {x: [-10.000, 10.000], y: [-20.000, 20.000], z: [0.000, 50.000]}\n",
        "  2: {x: 100.000, y: 200.000, z: -3.250, u: 90.000}\n",
        (
            "jrange:  # persistent: on the controller's memory card; a push writes it only when it "
            "changed (encoder pulses)\n  1: {lower: -100000, upper: 100000}\n"
        ),
        "limz: -10.000  # volatile: 0 again at power-on, Motor On, SFree, SLock and reset",
    ]:
        assert expected in text
    points = (project / "points.yaml").read_text().splitlines()
    assert points[2] == (
        "points:  # volatility not stated by the manual; harlsync never saves "
        "points to Points.pts (command 2052)"
    )
    assert points[3:] == [
        (
            "  0: {x: 0.000, y: 400.000, z: 0.000, u: 0.000, hand: Righty, elbow: Above, "
            "wrist: NoFlip, j4flag: 0, j6flag: 0, local: 0}"
        ),
        (
            "  12: {x: 1.000, y: 400.000, z: -10.500, u: 90.000, hand: Lefty, elbow: Below, "
            "wrist: NoFlip, j4flag: 0, j6flag: 0, local: 0}"
        ),
        (
            "  13: {x: -1.000, y: 300.000, z: 0.000, u: 0.000, hand: Righty, elbow: Above, "
            "wrist: Flip, j4flag: 1, j6flag: 5, local: 1}"
        ),
    ]


def test_the_schemas_mark_each_setting_volatile_or_persistent_as_the_model_does(
    project: Path,
) -> None:
    settings = json.loads((project / ".schemas" / "settings.schema.json").read_text())
    marked = {
        name: p.get("x-volatility")
        for name, p in settings["properties"].items()
        if name not in ("format", "manipulator")
    }
    assert marked == {key: kind.volatility for key, kind in KINDS.items()}
    assert {k for k, v in marked.items() if v == VOLATILE} == {
        "accel",
        "accel_s",
        "accel_r",
        "speed",
        "speed_s",
        "speed_r",
        "limz",
        "fine",
    }
    assert {k for k, v in marked.items() if v == PERSISTENT} == {
        "weight",
        "inertia",
        "tool",
        "box",
        "plane",
        "xylim",
        "jrange",
        "base",
    }
    points = json.loads((project / ".schemas" / "points.schema.json").read_text())
    assert points["properties"]["points"]["x-volatility"] == POINT.volatility == UNSTATED


def test_robot_yaml_spells_out_the_register_map_and_a_moved_map_loads(project: Path) -> None:
    text = (project / "robot.yaml").read_text()
    assert (
        "  map:\n    command_base: 1\n    command_words: 8\n    response_base: 1\n"
        "    response_words: 8\n    signals:\n      ExtCmdSet: {register: 0, bit: 0}\n"
    ) in text
    assert "      Running: {register: 0, bit: 9}\n" in text
    assert "  timeout: 0.5\n  retries: 2\n  poll_interval: 0.005\n  deadline: 2.0\n" in text
    start = text.index("  map:\n")
    end = text.index("controller:\n")
    moved = (
        "  map:\n    in_base: 100\n    out_base: 200\n    command_words: 4\n"
        "    signals:\n      SafeguardOn: null\n      Running: {register: 300, bit: 0}\n"
    )
    (project / "robot.yaml").write_text(text[:start] + moved + text[end:])
    assert validate_project(project) == []
    m = layout.connection(load_project(project).robot).register_map
    assert (m.ext_cmd_reset, m.command_base, m.command_words) == (Bit(100, 2), 101, 4)
    assert (m.running, m.paused, m.safeguard_on) == (Bit(300, 0), Bit(200, 10), None)


def _edit(project: Path, file: str, old: str, new: str) -> None:
    path = project / file
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


SETTINGS = [
    (
        "decel: 200.000}",
        "decel: 200.0}",
        "settings.yaml:7: accel_s.3.decel: 200.0 is not written in its one form (write 200.000",
    ),
    (
        "decel: 200.000}",
        "decel: 200.0001}",
        (
            "settings.yaml:7: accel_s.3.decel: 200.0001: more than three decimals (allowed: "
            "thousandths"
        ),
    ),
    (
        "limz: -10.000",
        "limz: -0.000",
        "settings.yaml:82: limz: -0.000 is not written in its one form (write 0.000",
    ),
    (
        "  0: {accel: 100, decel: 100}",
        "  0: {accel: 0100, decel: 100}",
        "settings.yaml:5: accel.0.accel: 0100 is not written in its one form (write 100",
    ),
    (
        "  0: {accel: 100, decel: 100}",
        "  0: {accel: 0, decel: 100}",
        "settings.yaml:5: accel.0.accel: 0 is out of range (allowed: % of the maximum, 1-65535)",
    ),
    (
        "  0: {accel: 100, decel: 100}",
        "  16: {accel: 100, decel: 100}",
        "settings.yaml:5: accel.16: '16' is not a valid key (allowed: table numbers 0-15)",
    ),
    (
        "  1: {speed: 100, depart: 80, approach: 80}",
        "  1: {speed: 101, depart: 80, approach: 80}",
        "settings.yaml:10: speed.1.speed: 101 is out of range (allowed: %, 1-100)",
    ),
    (
        "  1: {speed: 100, depart: 80",
        "  1: {speed: 100, colour: red, depart: 80",
        "settings.yaml:10: speed.1.colour: unknown key (allowed: speed, depart, approach)",
    ),
    (
        "limz: -10.000",
        "limz: 2147484.000",
        (
            "settings.yaml:82: limz: 2147484.000 is out of range (allowed: a number with three "
            "decimals, -2147483.648 to 2147483.647)"
        ),
    ),
    (
        "tool: 0",
        "tool: 16",
        ("settings.yaml:26: tool: 16 is out of range (allowed: a tool number, 0-15)"),
    ),
    (
        "fine: [10000, 10000, 10000, 10000]",
        "fine: [10000, 10000, 10000, 10000, 10000]",
        "settings.yaml:23: fine: 5 joints (allowed: one value per joint, 4 on a 4-axis robot)",
    ),
    (
        "  2: {x: 100.000, y: 200.000, z: -3.250, u: 90.000}",
        "  2: {x: 100.000, y: 200.000, z: -3.250, u: 90.000, v: 0.000, w: 0.000}",
        (
            "settings.yaml:45: plane.2.v: v, w: for a 6-axis robot (allowed: x, y, z, u on a 4-axis "
            "robot)"
        ),
    ),
    (
        "  2: {x: 100.000, y: 200.000, z: -3.250, u: 90.000}",
        "  2: {x: 100.000, y: 200.000, z: -3.250}",
        "settings.yaml:45: plane.2.u: is missing",
    ),
    (
        "  5: {x: [-10.000, 10.000],",
        "  5: {x: [-10.000],",
        "settings.yaml:32: box.5.x: must not be empty",
    ),
    (
        "  4: {lower: -100000, upper: 100000}",
        "  5: {lower: -100000, upper: 100000}",
        "settings.yaml:80: jrange.5: joint 5 of a 4-axis robot (allowed: 1-4)",
    ),
    (
        "  3: {depart: 30.000",
        "  2: {depart: 30.000",
        "settings.yaml:19: arch.2: written twice (lines 18 and 19)",
    ),
    (
        "manipulator: {type: SCARA, axes: 4,",
        "manipulator: {type: SCARA, axes: 6,",
        "settings.yaml:3: manipulator.axes: 6 axes for a SCARA robot (allowed: 4)",
    ),
    (
        "manipulator: {type: SCARA, axes: 4,",
        "manipulator: {type: RS, axes: 4,",
        (
            "settings.yaml:3: manipulator.type: RS, but robot.yaml controller.type says SCARA "
            "(allowed: SCARA: this project is of another robot, or robot.yaml is wrong)"
        ),
    ),
]


POINTS = [
    (
        "12: {x: 1.000,",
        "12: {x: 1.5,",
        "points.yaml:5: points.12.x: 1.5 is not written in its one form (write 1.500",
    ),
    (
        "hand: Righty, elbow: Above, wrist: Flip",
        "hand: righty, elbow: Above, wrist: Flip",
        "points.yaml:6: points.13.hand: 'righty' is not allowed (allowed: Lefty, Righty)",
    ),
    (
        "j6flag: 5",
        "j6flag: 128",
        "points.yaml:6: points.13.j6flag: 128 is out of range (allowed: J6Flag, 0-127)",
    ),
    (
        "local: 1}",
        "local: 16}",
        (
            "points.yaml:6: points.13.local: 16 is out of range (allowed: the local number (0: none), "
            "0-15)"
        ),
    ),
    (
        "  13: {",
        "  100: {",
        (
            "points.yaml:6: points.100: P100 is outside the robot's range (allowed: 0-99, robot.yaml "
            "controller.first_point/last_point)"
        ),
    ),
    (
        "u: 0.000, hand: Righty, elbow: Above, wrist: Flip",
        "u: 0.000, v: 0.000, hand: Righty, elbow: Above, wrist: Flip",
        "points.yaml:6: points.13.v: v: for a 6-axis robot (allowed: x, y, z, u on a 4-axis robot)",
    ),
    ("  13: {", "  12: {", "points.yaml:6: points.12: written twice (lines 5 and 6)"),
    (
        "wrist: Flip, j4flag: 1",
        "wrist: Flip, j4flag: 1, speed: 3",
        "points.yaml:6: points.13.speed: unknown key",
    ),
]


ROBOT = [
    ("unit: 1", "unit: 300", "robot.yaml:7: connection.unit: 300 is out of range (allowed: 0-255)"),
    (
        "command_words: 8",
        "command_words: 9",
        (
            "robot.yaml:15: connection.map.command_words: 9 is out of range (allowed: 3-8, as "
            "assigned in RC+)"
        ),
    ),
    (
        "Paused: {register: 0, bit: 10}",
        "Paused: {register: 0, bit: 9}",
        (
            "robot.yaml:28: connection.map.signals.Paused: Running and Paused are both at register 0 "
            "bit 9"
        ),
    ),
    (
        "ExtCmdSet: {register: 0, bit: 0}",
        "ExtCmdSet: null",
        (
            "robot.yaml:19: connection.map.signals.ExtCmdSet: ExtCmdSet must be mapped: the Remote "
            "Control function needs all seven handshake signals"
        ),
    ),
    (
        "Ready: {register: 0, bit: 8}",
        "Ready: {register: 0, bit: 16}",
        "robot.yaml:26: connection.map.signals.Ready.bit: 16 is out of range (allowed: a bit, 0-15",
    ),
    (
        "Ready: {register: 0, bit: 8}",
        "Ready: on",
        (
            "robot.yaml:26: connection.map.signals.Ready: 'on' is not an integer or a mapping or "
            "nothing (allowed: a bit 0-15 of the base register, {register: N, bit: B}, or null"
        ),
    ),
    (
        "  first_point: 0",
        "  first_point: 100",
        (
            "robot.yaml:35: controller.last_point: 99 is before first_point 100 (allowed: a number at "
            "or after first_point)"
        ),
    ),
    (
        "  type: SCARA",
        "  type: SCARA\n  axes: 6",
        "robot.yaml:34: controller.axes: 6 axes for a SCARA robot (allowed: 4, or leave axes out)",
    ),
    (
        "  type: SCARA",
        "  type: Delta",
        (
            "robot.yaml:33: controller.type: 'Delta' is not allowed "
            "(allowed: Joint, Cartesian, SCARA, 6-AXIS, RS)"
        ),
    ),
]


BAD = (
    [("settings.yaml", *case) for case in SETTINGS]
    + [("points.yaml", *case) for case in POINTS]
    + [("robot.yaml", *case) for case in ROBOT]
)


@pytest.mark.parametrize(("file", "old", "new", "expected"), BAD, ids=[b[3][:60] for b in BAD])
def test_a_bad_file_names_file_line_field_and_what_is_allowed(
    project: Path, file: str, old: str, new: str, expected: str
) -> None:
    _edit(project, file, old, new)
    issues = validate_project(project)
    assert any(issue.startswith(expected) for issue in issues), issues
    assert all("\n" not in issue for issue in issues)


def test_validate_prints_one_line_per_problem_and_exits_1(
    project: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from harlsync import cli

    _edit(project, "points.yaml", "12: {x: 1.000,", "12: {x: 1.5,")
    _edit(project, "settings.yaml", "tool: 0", "tool: 16")
    assert cli.main(["validate", str(project)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert [line.split(": ")[0] for line in out] == ["settings.yaml:26", "points.yaml:5"]


@pytest.mark.parametrize(("text", "unit"), [("1", 1), ("0", 0), ("255", 255)])
def test_the_station_is_the_modbus_unit_id_in_decimal(text: str, unit: int) -> None:
    family = families.get("epson")
    assert family.parse_station(text) == unit
    assert family.format_station(unit) == text


@pytest.mark.parametrize("text", ["256", "-1", "0x10", "", "1.0"])
def test_a_unit_id_out_of_range_is_refused_with_the_range(text: str) -> None:
    with pytest.raises(ValueError, match=r"allowed: a Modbus unit id, 0-255; 1 by default"):
        families.get("epson").parse_station(text)
