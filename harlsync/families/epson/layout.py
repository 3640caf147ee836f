"""An Epson robot's project files, their names and what robot.yaml says of the
connection and the points (:mod:`.render` writes the files, :mod:`.analysis` reads
and checks them).

::

    robot.yaml       family: epson, connection (modbus://HOST:PORT, unit id, Modbus
                     timeout and retries, poll interval, command deadline, the
                     register map RC+ assigned), the manipulator type and axes,
                     the points backed up, maintenance windows (user-edited)
    settings.yaml    the settings, one per line keyed by name and number, each
                     top-level key commented with its volatility:

        manipulator: {type: SCARA, axes: 4, model: LS6-B602S}  # read only: ...
        accel:  # volatile: cleared at power-off and reset (§9.1); ...
          0: {accel: 100, decel: 100}
        accel_s:  # volatile: ...
          3: {accel: 100.123, decel: 200.000}
        ...
        box:  # persistent: kept on the controller's memory card: ...
          1: {x: [0.000, 0.000], y: [0.000, 0.000], z: [0.000, 0.000]}
        limz: 0.000  # volatile: 0 again at power-on, Motor On, SFree, SLock and reset

    controller.yaml  what the controller answered where the manual is silent, at the
                     last pull (issue 29): where its point table ends, what the
                     point after it answers (asked twice), what a point not
                     defined answers:

        points: {end: 999, past_end: 2004/0000, not_defined: 2004/0000}

    points.yaml      the defined points of the range, one per line:

        points:  # not stated: ...
          12: {x: 1.000, y: 400.000, z: -10.500, u: 0.000, hand: Righty, elbow: Above,
               wrist: NoFlip, j4flag: 0, j6flag: 0, local: 0}

Reals are the exact decimal text the controller gives back, three decimals
(``100.123``); a number written any other way (``12.5``, ``-0.000``, ``007``) is
refused with its one form in the message, so a push always converges.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, replace

from ...project.files import FileSet
from ...project.robot import Robot
from ...project.schema import SchemaSet
from . import profile
from .map_form import map_from_dict, map_to_dict
from .profile import RegisterMap

__all__ = [
    "CONTROLLER_FILE",
    "FILES",
    "FIRST_PULL",
    "FORMAT",
    "LINE_DEFAULTS",
    "ROOT_FILES",
    "SCHEMAS",
    "Connection",
    "connection",
    "new_options",
    "point_range",
    "point_table_end",
]

#: The format number this harlsync reads and writes for Epson projects.
FORMAT = 1
ROOT_FILES = {
    "robot.yaml": "robot",
    "settings.yaml": "settings",
    "points.yaml": "points",
}
#: What the controller answered where the manual is silent (issue 29): written by
#: every pull; a project pulled before it existed has none (nothing recorded yet).
CONTROLLER_FILE = "controller.yaml"
SCHEMAS = SchemaSet(
    f"{__package__}.schemas",
    [*ROOT_FILES.values(), "controller"],
    {"epson-real": re.compile(r"[-+]?[0-9]+(\.[0-9]+)?")},
)
FILES = FileSet(SCHEMAS, FORMAT)
#: The robot option of a first pull's robot (no robot.yaml yet): its point range is
#: the default, and the points the pull finds past it are taken in.  Never written.
FIRST_PULL = "first_pull"

#: robot.yaml connection keys beyond port, unit and map -> their profile default.
LINE_DEFAULTS: Mapping[str, float] = {
    "timeout": profile.MODBUS_TIMEOUT,
    "retries": profile.MODBUS_RETRIES,
    "poll_interval": profile.POLL_INTERVAL,
    "deadline": profile.COMMAND_DEADLINE,
}


# -- the robot's connection ------------------------------------------------------------


@dataclass(frozen=True)
class Connection:
    """How to reach the robot's Remote Control function, from robot.yaml."""

    register_map: RegisterMap
    timeout: float
    retries: int
    poll_interval: float
    deadline: float
    #: whether the Modbus slave applies a write of several registers whole
    writes_whole: bool = profile.BLOCK_WRITE_WHOLE


def new_options() -> dict[str, object]:
    """A first pull's robot options: the profile's map, line settings and points."""
    first, last = profile.DEFAULT_POINT_RANGE
    return {
        "map": map_to_dict(RegisterMap()),
        **LINE_DEFAULTS,
        "first": first,
        "last": last,
        FIRST_PULL: True,
    }


def connection(robot: Robot) -> Connection:
    """The robot's map and line settings.  Raises RegisterMapInvalid (a map a
    valid robot.yaml cannot give)."""
    o = robot.options
    return Connection(
        replace(
            map_from_dict(o.get("map")),
            write_without=frozenset(o.get("write_without", ())),
        ),
        float(o.get("timeout", profile.MODBUS_TIMEOUT)),
        int(o.get("retries", profile.MODBUS_RETRIES)),
        float(o.get("poll_interval", profile.POLL_INTERVAL)),
        float(o.get("deadline", profile.COMMAND_DEADLINE)),
        bool(o.get("writes_whole", profile.BLOCK_WRITE_WHOLE)),
    )


def point_range(robot: Robot) -> tuple[int, int]:
    """The first and last point a pull reads."""
    first, last = profile.DEFAULT_POINT_RANGE
    return int(robot.options.get("first", first)), int(robot.options.get("last", last))


def point_table_end(robot: Robot) -> int:
    """The last point of the controller's point table: robot.yaml's
    ``controller.point_table_end``, else the profile's (P999)."""
    return int(robot.options.get("point_table_end", profile.POINT_PROBE_END))
