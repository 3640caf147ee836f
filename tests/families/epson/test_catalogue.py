"""The Epson catalogue: item names as a diff shows them, fields as exact text, the
cleared label of a volatile table, the push order, and what a plan can and cannot
write."""

from __future__ import annotations

from dataclasses import replace

from harlsync.families.base import PlanShape
from harlsync.families.epson.catalogue import CATALOGUE, CLEARED, Key, PointWrite, point_fields
from harlsync.families.epson.model import EpsonData, Point, PointKey, SettingKey, TableKey
from harlsync.families.epson.protocol import AccelReal, Limits, Weight
from harlsync.sync.items import diff, render_text

from .sample import sample_data


def test_items_are_named_as_the_manual_writes_them() -> None:
    keys: list[Key] = [
        TableKey("accel_s", 3),
        TableKey("speed_r", 0),
        SettingKey("box", 5),
        SettingKey("jrange", 2),
        SettingKey("arch", 0),
        SettingKey("weight"),
        SettingKey("limz"),
        PointKey("point", 12),
        PointWrite("point", 12, ("x",)),
    ]
    names = {key: CATALOGUE.describe(key) for key in keys}
    assert list(names.values()) == [
        "AccelS 3",
        "SpeedR 0",
        "Box 5",
        "JRange 2",
        "Arch 0",
        "Weight",
        "LimZ",
        "P12",
        "P12",
    ]
    assert CATALOGUE.identity(TableKey("accel_s", 3)) == {"kind": "accel_s", "number": 3}
    assert CATALOGUE.identity(SettingKey("weight")) == {"kind": "weight", "number": None}


def test_each_group_says_the_kinds_volatility() -> None:
    assert CATALOGUE.group(TableKey("accel_s", 3)) == "AccelS (volatile)"
    assert CATALOGUE.group(SettingKey("limz")) == "LimZ (volatile)"
    assert CATALOGUE.group(SettingKey("box", 5)) == "Box (persistent)"
    assert CATALOGUE.group(SettingKey("arch", 1)) == "Arch"  # the manual does not say
    assert CATALOGUE.group(PointKey("point", 3)) == "points"


def test_a_changed_entry_shows_only_the_fields_that_differ_as_exact_text() -> None:
    key = TableKey("accel_s", 3)
    old, new = AccelReal("100.123", "200.000"), AccelReal("100.123", "250.000")
    assert CATALOGUE.fields(key, old, new) == [("decel", "200.000", "250.000")]
    assert CATALOGUE.label(key, "decel") == "AccelS 3 decel"
    box = SettingKey("box", 5)
    off = Limits("0.000", "0.000")
    assert CATALOGUE.fields(box, (off, off, off), (off, Limits("0.000", "1.500"), off)) == [
        ("y upper", "0.000", "1.500")
    ]
    assert CATALOGUE.fields(SettingKey("limz"), "0.000", "-10.000") == [("", "0.000", "-10.000")]
    assert CATALOGUE.label(SettingKey("limz"), "") == "LimZ"
    assert CATALOGUE.fields(SettingKey("fine"), (1, 2, 3, 4), (1, 2, 5, 4)) == [
        ("joint 3", "3", "5")
    ]
    p, q = (
        Point(("1.000", "2.000", "3.000", "4.000")),
        Point(("1.000", "2.500", "3.000", "4.000"), hand=1),
    )
    assert CATALOGUE.fields(PointKey("point", 7), p, q) == [
        ("y", "2.000", "2.500"),
        ("hand", "Lefty", "Righty"),
    ]


def test_a_table_entry_the_robot_lost_reads_cleared_and_a_point_it_lacks_does_not() -> None:
    assert CATALOGUE.fields(TableKey("speed_r", 0), None, "720.000") == [
        ("", "not registered: cleared, e.g. by a power cycle", "720.000")
    ]
    assert CLEARED == "not registered: cleared, e.g. by a power cycle"
    point = Point(("1.000", "2.000", "3.000", "4.000"), j6flag=3)
    assert CATALOGUE.fields(PointKey("point", 7), None, point) == [
        (
            "",
            None,
            (
                "{x: 1.000, y: 2.000, z: 3.000, u: 4.000, hand: Lefty, elbow: Above, "
                "wrist: NoFlip, j4flag: 0, j6flag: 3, local: 0}"
            ),
        )
    ]
    assert CATALOGUE.fields(SettingKey("box", 5), (Limits("0.000", "1.000"),) * 3, None) == [
        ("", "{x: [0.000, 1.000], y: [0.000, 1.000], z: [0.000, 1.000]}", None)
    ]


def test_diff_text_of_a_changed_entry_and_of_cleared_tables() -> None:
    live, project = sample_data(), sample_data()
    project.items[TableKey("accel_s", 3)] = AccelReal("100.123", "250.000")
    changes = diff(CATALOGUE, live, project)
    assert render_text(changes, "robot r", "project p") == (
        "--- robot r\n+++ project p\n"
        "@@ AccelS (volatile) @@\n"
        "-AccelS 3 decel: 200.000\n"
        "+AccelS 3 decel: 250.000\n"
    )
    for key in [k for k in live.items if isinstance(k, TableKey)]:
        del live.items[key]  # a power cycle
    changes = diff(CATALOGUE, live, sample_data())
    assert render_text(changes, "robot r", "project p") == (
        "--- robot r\n+++ project p\n"
        "@@ Accel (volatile) @@\n"
        "-Accel 0: not registered: cleared, e.g. by a power cycle\n"
        "+Accel 0: {accel: 100, decel: 100}\n"
        "@@ AccelS (volatile) @@\n"
        "-AccelS 3: not registered: cleared, e.g. by a power cycle\n"
        "+AccelS 3: {accel: 100.123, decel: 200.000}\n"
        "@@ Speed (volatile) @@\n"
        "-Speed 1: not registered: cleared, e.g. by a power cycle\n"
        "+Speed 1: {speed: 100, depart: 80, approach: 80}\n"
        "@@ SpeedS (volatile) @@\n"
        "-SpeedS 2: not registered: cleared, e.g. by a power cycle\n"
        "+SpeedS 2: {speed: 2000.000, depart: 1500.500, approach: 1000.000}\n"
        "@@ SpeedR (volatile) @@\n"
        "-SpeedR 0: not registered: cleared, e.g. by a power cycle\n"
        "+SpeedR 0: 720.000\n"
    )
    assert CATALOGUE.summary([(c.key, c.old, c.new) for c in changes]) == "5 table entries"


def test_the_push_order_is_load_limits_frames_tool_motion_tables_then_points() -> None:
    keys: list[Key] = [
        PointKey("point", 1),
        TableKey("speed", 0),
        SettingKey("local", 1),
        SettingKey("base"),
        SettingKey("weight"),
        SettingKey("box", 2),
        SettingKey("limz"),
        TableKey("accel", 3),
        SettingKey("jrange", 1),
        SettingKey("tool"),
    ]
    ordered = [CATALOGUE.describe(k) for k in sorted(keys, key=CATALOGUE.order)]
    assert ordered == [
        "Weight",
        "JRange 1",
        "Box 2",
        "Base",
        "Local 1",
        "Tool",
        "LimZ",
        "Accel 3",
        "Speed 0",
        "P1",
    ]


def test_counts_and_summary_are_in_table_entries_settings_and_points() -> None:
    changes = [
        (TableKey("accel", 0), None, 1),
        (TableKey("accel", 1), None, 1),
        (SettingKey("weight"), 1, 2),
        (PointKey("point", 3), 1, 2),
    ]
    assert CATALOGUE.counts(changes) == {"table entries": 2, "settings": 1, "points": 1}
    assert CATALOGUE.summary(changes) == "2 table entries, 1 setting, 1 point"
    assert CATALOGUE.summary([]) == "no change"


def _plan(live: EpsonData, project: EpsonData) -> PlanShape[Key]:
    changes = [(c.key, c.old, c.new) for c in diff(CATALOGUE, live, project)]
    return CATALOGUE.plan(live, project, changes, registers=False)


def test_a_plan_writes_what_changed_and_names_the_persistent_items_it_writes() -> None:
    live, project = sample_data(), sample_data()
    project.items[SettingKey("weight")] = Weight("2.500", "0.000")
    project.items[SettingKey("box", 5)] = (Limits("0.000", "1.000"),) * 3
    project.items[TableKey("accel_s", 3)] = AccelReal("1.000", "2.000")
    shape = _plan(live, project)
    assert [CATALOGUE.describe(k) for k, _, _ in shape.wanted] == ["Weight", "Box 5", "AccelS 3"]
    assert shape.unwritable == []
    assert shape.notes == [
        (
            "written to the controller's memory card (persistent; its life "
            "shortens with each write): Weight, Box 5"
        )
    ]


def test_a_plan_writes_a_points_changed_fields_only_and_a_new_point_whole() -> None:
    live, project = sample_data(), sample_data()
    old = live.items[PointKey("point", 12)]
    project.items[PointKey("point", 12)] = replace(old, coords=("1.500", *old.coords[1:]), hand=1)
    project.items[PointKey("point", 40)] = Point(("1.000", "2.000", "3.000", "4.000"))
    shape = _plan(live, project)
    assert [k for k, _, _ in shape.wanted] == [
        PointWrite("point", 12, ("x", "hand")),
        PointWrite("point", 40, ("x", "y", "z", "u", "hand", "elbow", "wrist", "j4flag", "j6flag")),
    ]
    assert "harlsync never saves them to Points.pts (command 2052)" in shape.notes[0]
    assert point_fields(old, old) == ()


def test_what_no_command_can_do_is_unwritable_with_what_to_do() -> None:
    live, project = sample_data(), sample_data()
    live.items[TableKey("accel", 5)] = live.items[TableKey("accel", 0)]
    live.items[TableKey("speed_r", 9)] = "1.000"
    live.items[PointKey("point", 50)] = Point(("0.000",) * 4)
    project.items[PointKey("point", 13)] = replace(project.items[PointKey("point", 13)], local=0)
    shape = _plan(live, project)
    assert shape.unwritable == [
        (
            "P13 local: Local 1 on the robot, none in the project, and no Remote Control command "
            "sets a point back to no Local; change it on the controller (or give it a Local in "
            "the project)"
        ),
        (
            "Accel 5, SpeedR 9: registered on the robot but not in the project, and no Remote "
            "Control command unregisters a table entry; pull to take them in, or clear the tables "
            "on the controller (a power cycle or a reset does) and run again"
        ),
        (
            "P50: defined on the robot but not in the project, and no Remote Control command "
            "deletes a point; pull to take it in, or delete it on the controller and run again"
        ),
    ]
    assert shape.wanted == []


def test_a_robot_of_other_axes_or_an_unwritable_map_gets_no_plan() -> None:
    live, project = sample_data(axes=6), sample_data()
    live.unwritable = "the register map has no Running signal: ..."
    shape = _plan(live, project)
    assert shape.unwritable[:2] == [
        "the register map has no Running signal: ...",
        (
            "the project is of a SCARA robot with 4 axes, the controller reports a 6-AXIS with 6: "
            "check the port (or pull into a new project)"
        ),
    ]


def test_a_setting_the_project_lacks_is_unwritable_too() -> None:
    live, project = sample_data(), sample_data()
    del project.items[SettingKey("plane", 3)]
    assert _plan(live, project).unwritable == [
        (
            "Plane 3: on the robot but not in settings.yaml, and no Remote Control command removes "
            "a setting; pull to take it in"
        )
    ]
