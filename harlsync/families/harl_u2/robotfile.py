"""robot.yaml's data as a :class:`~harlsync.project.robot.Robot`: what the layout's
full reading and the quick one before a pull's first request
(:mod:`harlsync.project.quick`) share.  Neither PyYAML nor the project store."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ...project import quick
from ...project.robot import Robot, build_serial, build_windows
from ...settings import SerialSettings

__all__ = ["SCHEMA", "build_robot", "quick_robot"]

#: robot.yaml's schema, the same file the layout's :data:`~.layout.SCHEMAS` reads.
SCHEMA = Path(__file__).with_name("schemas") / "robot.schema.json"


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


def _options(data: Mapping[str, Any]) -> dict[str, Any]:
    """The HARL-U2's own settings robot.yaml gives: ``offset_tables``, ``no_such_table``."""
    options: dict[str, Any] = {}
    if "offset_tables" in data:
        options["offset_tables"] = int(data["offset_tables"])
    if "no_such_table" in data:
        options["no_such_table"] = str(data["no_such_table"])
    return options


def quick_robot(data: Mapping[str, Any]) -> Robot | None:
    """The robot of robot.yaml's ``data`` as :func:`harlsync.project.quick.parse`
    gives it, when it passes the schema for sure; None: read the file the whole way."""
    return build_robot(data) if quick.valid(quick.schema(SCHEMA), data) else None
