"""An Epson robot's data as a pull would read it, written out by hand."""

from __future__ import annotations

from harlsync.families.epson.model import EpsonData, Point, PointKey, SettingKey, TableKey
from harlsync.families.epson.protocol import (
    AccelPercent,
    AccelReal,
    Distances,
    Inertia,
    Limits,
    PulseLimits,
    SpeedPercent,
    SpeedReal,
    Weight,
)

OFF = Limits("0.000", "0.000")


def sample_data(axes: int = 4, *, rs: bool = False) -> EpsonData:
    """A SCARA (with ``rs`` an RS robot, or with ``axes`` 6 a 6-AXIS robot) with some
    of everything, the points with their type's own attributes."""
    zeros = ("0.000",) * axes
    robot_type = 5 if axes == 6 else 6 if rs else 3
    model = {3: "LS6-B602S", 5: "C4-A601S", 6: "RS4-551S"}[robot_type]
    data = EpsonData(robot_type, axes, model)
    items = data.items
    items[TableKey("accel", 0)] = AccelPercent(100, 100)
    items[TableKey("accel_s", 3)] = AccelReal("100.123", "200.000")
    items[TableKey("speed", 1)] = SpeedPercent(100, 80, 80)
    items[TableKey("speed_s", 2)] = SpeedReal("2000.000", "1500.500", "1000.000")
    items[TableKey("speed_r", 0)] = "720.000"
    for n in range(7):
        items[SettingKey("arch", n)] = Distances("30.000", "30.000")
    items[SettingKey("fine")] = (10000,) * axes
    items[SettingKey("weight")] = Weight("2.000", "0.000")
    items[SettingKey("inertia")] = Inertia("0.005", "0.000")
    items[SettingKey("tool")] = 0
    for n in range(1, 16):
        items[SettingKey("box", n)] = (OFF, OFF, OFF)
        items[SettingKey("plane", n)] = zeros
        items[SettingKey("local", n)] = zeros
    items[SettingKey("box", 5)] = (
        Limits("-10.000", "10.000"),
        Limits("-20.000", "20.000"),
        Limits("0.000", "50.000"),
    )
    items[SettingKey("plane", 2)] = ("100.000", "200.000", "-3.250", *("90.000",) * (axes - 3))
    items[SettingKey("xylim")] = (OFF, OFF, OFF)
    for joint in range(1, axes + 1):
        items[SettingKey("jrange", joint)] = PulseLimits(-100000, 100000)
    items[SettingKey("base")] = zeros
    items[SettingKey("limz")] = "-10.000"
    six = robot_type == 5
    flag = 0 if six else None  # J1Flag and J2Flag: a 6-axis robot's only
    angle = "0.000" if rs else None  # J1Angle: an RS robot's only
    items[PointKey("point", 0)] = Point(
        ("0.000", "400.000", *("0.000",) * (axes - 2)),
        hand=1,
        j1flag=flag,
        j2flag=flag,
        j1angle=angle,
    )
    items[PointKey("point", 12)] = Point(
        ("1.000", "400.000", "-10.500", *("90.000",) * (axes - 3)),
        elbow=1,
        j1flag=flag,
        j2flag=flag,
        j1angle=angle,
    )
    items[PointKey("point", 13)] = Point(
        ("-1.000", "300.000", *("0.000",) * (axes - 2)),
        hand=1,
        wrist=1,
        j4flag=1,
        j6flag=5,
        local=1,
        j1flag=1 if six else None,
        j2flag=1 if six else None,
        j1angle="-12.500" if rs else None,
    )
    return data
