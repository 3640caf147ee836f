"""An IAI robot's project files: their names, their text, and checking a set of them.

::

    robot.yaml         family: iai, connection (station in hex), controller model,
                       axes and position range, maintenance windows (user-edited)
    controller.yaml    what 201H reports (model and unit codes, version, build date)
    positions.yaml     the position table, one defined position per line:

        positions:
          1: {axes: [1, 2, 3], coords: [100.000, -1.000, 0.000], acc: 0.30, dec: 0.30, speed: 100}
          7: {axes: [1, 2], coords: [0.000, 25.500], acc: 0.00, dec: 0.00, speed: 0, arm1: right}

Numbers are kept as the exact decimal text the controller's units give
(coordinates three decimals, acc/dec two), so a review reads what the robot
holds.  A number written any other way (``0012.5``, ``-0.000``) is refused with
its one form in the message, so a push always converges.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ...project import yamlio as y
from ...project.files import (
    FileSet,
    build_serial,
    build_windows,
    numbered,
    numbers,
    serial_items,
    text_of,
    unique,
    window_nodes,
)
from ...project.robot import Robot
from ...project.schema import Issue, SchemaSet, show
from ..base import Analysis
from . import profile
from .codec import SETTINGS
from .model import ARM_NAMES, Position, Version, canonical_coord, canonical_g

__all__ = [
    "FILES",
    "FORMAT",
    "ROOT_FILES",
    "IaiData",
    "analyse",
    "render_files",
]

#: The format number this harlsync reads and writes for IAI projects.
FORMAT = 1
ROOT_FILES = {
    "robot.yaml": "robot",
    "controller.yaml": "controller",
    "positions.yaml": "positions",
}
SCHEMAS = SchemaSet(
    f"{__package__}.schemas",
    ROOT_FILES.values(),
    {
        "iai-coord": re.compile(r"[-+]?[0-9]+(\.[0-9]+)?"),
        "iai-g": re.compile(r"[0-9]+(\.[0-9]+)?"),
    },
)
FILES = FileSet(SCHEMAS, FORMAT)

_ARMS = {name: n for n, name in ARM_NAMES.items()}
_STATION = re.compile(r"[0-9A-Fa-f]{2}")


@dataclass
class IaiData:
    """What a backup of an IAI controller holds: its version and its position table.

    ``model`` is the controller model the buffer sizes come from (robot.yaml's,
    not read from the controller); it sizes the writes of a plan.
    """

    version: Version
    positions: dict[int, Position] = field(default_factory=dict)
    model: str = profile.DEFAULT_MODEL


# -- rendering --------------------------------------------------------------------------


def render_robot(robot: Robot) -> str:
    options = robot.options
    connection = [
        ("port", y.text(robot.port)),
        ("station", y.quoted(f"{robot.station:02X}")),
        *serial_items(robot.serial),
    ]
    controller: list[tuple[str, Any]] = [
        ("model", y.text(str(options.get("model", profile.DEFAULT_MODEL))))
    ]
    if options.get("axes"):
        controller.append(
            ("axes", y.sequence([y.num(str(a)) for a in options["axes"]], flow=True))
        )
    first, last = position_range(robot)
    controller += [
        ("first_position", y.num(str(first))),
        ("last_position", y.num(str(last))),
    ]
    items: list[tuple[str, Any]] = [("family", y.text("iai")), ("name", y.text(robot.name))]
    if robot.description is not None:
        items.append(("description", y.text(robot.description)))
    items += [
        ("connection", y.mapping(connection)),
        ("controller", y.mapping(controller)),
        ("maintenance_windows", window_nodes(robot)),
    ]
    return FILES.document("robot", "robot.yaml", items)


def render_controller(version: Version) -> str:
    node = y.mapping(
        [
            ("unit_type", y.num(str(version.unit_type))),
            ("device", y.num(str(version.device))),
            ("model_code", y.quoted(version.model_code)),
            ("unit_code", y.quoted(version.unit_code)),
            ("version", y.quoted(version.version)),
            ("built", y.quoted(version.built)),
        ]
    )
    return FILES.document("controller", "controller.yaml", [("version", node)])


def position_node(position: Position) -> Any:
    items: list[tuple[str, Any]] = [
        ("axes", y.sequence([y.num(str(a)) for a in position.axes], flow=True)),
        ("coords", y.sequence([y.num(c) for c in position.coords], flow=True)),
        ("acc", y.num(position.acc)),
        ("dec", y.num(position.dec)),
        ("speed", y.num(str(position.speed))),
    ]
    for name, arm in (("arm1", position.arm1), ("arm2", position.arm2)):
        if arm:
            items.append((name, y.text(ARM_NAMES.get(arm, str(arm)))))
    return y.mapping(items, flow=True)


def render_positions(positions: Mapping[int, Position]) -> str:
    return FILES.document(
        "positions", "positions.yaml", [("positions", numbered(positions, position_node))]
    )


def render_files(robot: Robot, data: IaiData) -> dict[str, str]:
    """Every file of the project, by relative path, in a fixed order."""
    return {
        "robot.yaml": render_robot(robot),
        "controller.yaml": render_controller(data.version),
        "positions.yaml": render_positions(data.positions),
    }


def position_range(robot: Robot) -> tuple[int, int]:
    """The first and last position number of the robot's table."""
    first, last = profile.DEFAULT_POSITION_RANGE
    return int(robot.options.get("first", first)), int(robot.options.get("last", last))


# -- reading and checking ---------------------------------------------------------------


def analyse(files: Mapping[str, bytes]) -> Analysis:
    """Read and check an IAI project's files (path relative to the project -> content).

    Every file is checked even when others are broken; the positions are checked
    against the robot's axes and position range when robot.yaml is valid.
    ``data`` is set only when there is no issue at all.
    """
    issues: list[Issue] = []
    docs: dict[str, y.Parsed] = {}
    valid: set[str] = set()
    for name, kind in ROOT_FILES.items():
        if name not in files:
            issues.append(Issue(name, None, None, "missing", fatal=True))
            continue
        doc, ok = FILES.read(name, kind, files[name], issues)
        if doc is not None:
            docs[name] = doc
        if ok:
            valid.add(name)

    result = Analysis(issues=issues)
    if "robot.yaml" in valid:
        result.robot = _build_robot(docs["robot.yaml"], issues)
    if "positions.yaml" in valid:
        _check_positions(docs["positions.yaml"], result.robot, issues)
    if not issues and result.robot is not None:
        result.data = IaiData(
            version=_build_version(docs["controller.yaml"].data["version"]),
            positions=_build_positions(docs["positions.yaml"].data["positions"]),
            model=str(result.robot.options.get("model", profile.DEFAULT_MODEL)),
        )
    result.issues = unique(issues, list(ROOT_FILES))
    return result


def _build_robot(doc: y.Parsed, issues: list[Issue]) -> Robot | None:
    data = doc.data
    connection = data["connection"]
    station = text_of(connection.get("station", f"{profile.DEFAULT_STATION:02X}"))
    if not _STATION.fullmatch(station):
        issues.append(Issue(
            "robot.yaml", doc.line(("connection", "station")), "connection.station",
            f"{show(connection['station'])} is not a station (allowed: two hex digits, 00-FF; "
            "99 by default)",
        ))
        return None
    controller = data.get("controller", {})
    options: dict[str, Any] = {"model": str(controller.get("model", profile.DEFAULT_MODEL))}
    if "axes" in controller:
        axes = sorted(int(a) for a in controller["axes"])
        options["axes"] = tuple(axes)
    first, last = profile.DEFAULT_POSITION_RANGE
    options["first"] = int(controller.get("first_position", first))
    options["last"] = int(controller.get("last_position", last))
    if options["first"] > options["last"]:
        issues.append(Issue(
            "robot.yaml", doc.line(("controller", "last_position")), "controller.last_position",
            f"{options['last']} is before first_position {options['first']} "
            "(allowed: a number at or after first_position)",
        ))
        return None
    return Robot(
        family="iai",
        name=data["name"],
        port=connection["port"],
        station=int(station, 16),
        serial=build_serial(connection, SETTINGS),
        windows=build_windows(data),
        description=data.get("description"),
        options=options,
    )


def _check_positions(doc: y.Parsed, robot: Robot | None, issues: list[Issue]) -> None:
    """What the schema cannot say: the coordinates against the axes, canonical
    numbers, and the robot's axes and range."""
    table = doc.data["positions"]
    first, last = position_range(robot) if robot is not None else (1, 0xFFFF)
    axes_allowed = robot.options.get("axes") if robot is not None else None
    for key, n in numbers(table):
        entry = table[key]
        at = ("positions", key)

        def issue(message: str, *where: Any, at: tuple[str, str] = at) -> None:
            path = at + where
            name = ".".join(str(p) for p in path)
            issues.append(Issue("positions.yaml", doc.line(path), name, message))

        if not first <= n <= last:
            issue(f"position {show(y.Number(key))} is outside the robot's table "
                      f"(allowed: {first}-{last}, robot.yaml controller.first_position/"
                      "last_position)")
        axes = [int(a) for a in entry["axes"]]
        if axes != sorted(axes):
            issue(f"{axes} are not in ascending order (allowed: ascending, "
                          f"{sorted(axes)})", "axes")
        if axes_allowed is not None and not set(axes) <= set(axes_allowed):
            extra = sorted(set(axes) - set(axes_allowed))
            issue(f"axis {', '.join(map(str, extra))} is not one of the robot's "
                          f"(allowed: {', '.join(map(str, axes_allowed))}, robot.yaml "
                          "controller.axes)", "axes")
        coords = entry["coords"]
        if len(coords) != len(axes):
            issue(f"{len(coords)} coordinate(s) for {len(axes)} axis/axes "
                            "(allowed: one coordinate per axis in axes)", "coords")
        for i, value in enumerate(coords):
            _canonical(issue, text_of(value), canonical_coord, "coords", i)
        for name in ("acc", "dec"):
            _canonical(issue, text_of(entry[name]), canonical_g, name)


def _canonical(
    issue: Callable[..., None], text: str, canonical: Callable[[str], str], *where: Any
) -> None:
    try:
        one = canonical(text)
    except ValueError as exc:
        issue(f"{text}: {exc}", *where)
        return
    if one != text:
        issue(f"{text} is not written in its one form (write {one}: the controller reads "
              "it back so, and a push would never converge)", *where)


def _build_version(data: Mapping[str, Any]) -> Version:
    return Version(
        unit_type=int(data["unit_type"]),
        device=int(data["device"]),
        model_code=str(data["model_code"]),
        unit_code=str(data["unit_code"]),
        version=str(data["version"]),
        built=str(data["built"]),
    )


def _build_positions(table: Mapping[str, Any]) -> dict[int, Position]:
    out: dict[int, Position] = {}
    for key in sorted(table, key=int):
        entry = table[key]
        out[int(key)] = Position(
            number=int(key),
            axes=tuple(int(a) for a in entry["axes"]),
            acc=text_of(entry["acc"]),
            dec=text_of(entry["dec"]),
            speed=int(entry["speed"]),
            coords=tuple(text_of(c) for c in entry["coords"]),
            arm1=_ARMS[entry.get("arm1", "none")],
            arm2=_ARMS[entry.get("arm2", "none")],
        )
    return out
