"""robot.yaml's data, once read and checked by the layout, as a
:class:`~harlsync.project.robot.Robot`."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ...project.robot import Robot, build_serial, build_windows
from ...settings import SerialSettings

__all__ = ["build_robot"]


def build_robot(data: Mapping[str, Any]) -> Robot:
    """The robot of a valid robot.yaml's ``data``."""
    connection = data["connection"]
    return Robot(
        family=str(data.get("family", "harl-u2")),
        name=data["name"],
        port=connection["port"],
        station=int(connection.get("station", 1)),
        serial=build_serial(connection, SerialSettings()),
        windows=build_windows(data),
        keep_registers=bool(data.get("keep_registers", False)),
        description=data.get("description"),
        options=_options(data),
    )


def _options(data: Mapping[str, Any]) -> dict[str, object]:
    """The HARL-U2's own settings robot.yaml gives: ``offset_tables``, ``no_such_table``."""
    options: dict[str, object] = {}
    if "offset_tables" in data:
        options["offset_tables"] = int(data["offset_tables"])
    if "no_such_table" in data:
        options["no_such_table"] = str(data["no_such_table"])
    return options
