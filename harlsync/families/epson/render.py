"""Writing an Epson project's files (:mod:`.layout` says what each holds): robot.yaml,
settings.yaml and points.yaml one item a line, controller.yaml, each as its schema
has it, in one text a save can compare byte for byte."""

from __future__ import annotations

from functools import partial
from typing import Any

from yaml.nodes import Node

from ...project import yamlio as y
from ...project.files import (
    numbered,
    robot_items,
)
from ...project.robot import Robot
from .layout import (
    CONTROLLER_FILE,
    FILES,
    FIRST_PULL,
    connection,
    point_range,
    point_table_end,
)
from .map_form import map_to_dict
from .model import (
    ATTRIBUTE_NAMES,
    KINDS,
    POINT,
    UNSTATED,
    EpsonData,
    Kind,
    Point,
    PointTable,
    SettingKey,
    TableKey,
    coordinate_names,
    covered_text,
)
from .profile import RegisterMap

__all__ = [
    "render_controller",
    "render_files",
    "render_points",
    "render_robot",
    "render_settings",
    "value_node",
]


def _seconds(value: float) -> Node:
    return y.scalar_for(repr(float(value)))


def _map_node(register_map: RegisterMap) -> Node:
    data = map_to_dict(register_map)
    signals = data.pop("signals")
    assert isinstance(signals, dict)
    items: list[tuple[str, Node]] = [(key, y.num(str(value))) for key, value in data.items()]
    items.append(
        (
            "signals",
            y.mapping(
                [
                    (
                        name,
                        y.null()
                        if bit is None
                        else y.mapping(
                            [
                                ("register", y.num(str(bit["register"]))),
                                ("bit", y.num(str(bit["bit"]))),
                            ],
                            flow=True,
                        ),
                    )
                    for name, bit in signals.items()
                ]
            ),
        )
    )
    return y.mapping(items)


def render_robot(robot: Robot, data: EpsonData | None = None) -> str:
    """robot.yaml; the manipulator type is ``data``'s when robot.yaml gives none
    (a first pull writes what it read)."""
    o = robot.options
    link = connection(robot)
    conn: list[tuple[str, Node]] = [
        ("port", y.text(robot.port)),
        ("unit", y.num(str(robot.station))),
        ("timeout", _seconds(link.timeout)),
        ("retries", y.num(str(link.retries))),
        ("poll_interval", _seconds(link.poll_interval)),
        ("deadline", _seconds(link.deadline)),
        ("writes_whole", y.boolean(link.writes_whole)),
        *(
            [("write_without", y.sequence([y.text(n) for n in o["write_without"]], flow=True))]
            if o.get("write_without")
            else []
        ),
        ("map", _map_node(link.register_map)),
    ]
    controller: list[tuple[str, Node]] = []
    robot_type = o.get("type") or (data.type_name if data is not None else None)
    if robot_type:
        controller.append(("type", y.text(str(robot_type))))
    if o.get("axes"):
        controller.append(("axes", y.num(str(o["axes"]))))
    first, last = point_range(robot)
    if o.get(FIRST_PULL) and data is not None and data.taken_in is not None:
        first, last = min(first, data.taken_in[0]), max(last, data.taken_in[1])
    controller += [
        ("first_point", y.num(str(first))),
        ("last_point", y.num(str(last))),
        ("point_table_end", y.num(str(point_table_end(robot)))),
    ]
    return FILES.document("robot", "robot.yaml", robot_items(robot, conn, controller))


def render_controller(table: PointTable) -> str:
    """controller.yaml: what the point table showed."""
    items: list[tuple[str, Node]] = [
        ("end", y.num(str(table.end))),
        ("past_end", y.text(str(table.past_end))),
    ]
    if table.not_defined is not None:
        items.append(("not_defined", y.text(str(table.not_defined))))
    return FILES.document(
        "controller",
        CONTROLLER_FILE,
        [("points", y.mapping(items, flow=True))],
        {
            "points": "what the controller answered (1222) past its point table and for a "
            "point not defined, each asked twice"
        },
    )


def _number(text: str | int) -> Node:
    return y.num(str(text))


def value_node(kind: Kind, value: Any) -> Node:
    """One item's value as its line in settings.yaml or points.yaml."""
    if kind.shape == "record":
        return y.mapping([(f, _number(getattr(value, f))) for f in kind.fields], flow=True)
    if kind.shape in ("real", "integer"):
        return _number(value)
    if kind.shape == "joints":
        return y.sequence([_number(v) for v in value], flow=True)
    if kind.shape == "coords":
        return y.mapping(list(zip(coordinate_names(len(value)), map(_number, value))), flow=True)
    if kind.shape == "limits":
        return y.mapping(
            [
                (axis, y.sequence([_number(lim.lower), _number(lim.upper)], flow=True))
                for axis, lim in zip("xyz", value)
            ],
            flow=True,
        )
    point: Point = value
    items = list(zip(coordinate_names(len(point.coords)), map(_number, point.coords)))
    for name, names in ATTRIBUTE_NAMES.items():
        code = point.attribute(name)
        items.append((name, y.text(names[code]) if names else _number(code)))
    items += [(name, _number(text)) for name, text in point.extras()]
    return y.mapping(items, flow=True)


def _comment(kind: Kind) -> str:
    """``volatile: cleared at ...``, ``persistent: on the ...``, ``volatility not stated
    by the manual``."""
    if kind.volatility == UNSTATED:
        return f"volatility {kind.volatility} {kind.why}"
    return f"{kind.volatility}: {kind.why}"


def render_settings(data: EpsonData) -> str:
    items: list[tuple[str, Node]] = [
        (
            "manipulator",
            y.mapping(
                [
                    ("type", y.text(data.type_name)),
                    ("axes", y.num(str(data.axes))),
                    ("model", y.text(data.model)),
                ],
                flow=True,
            ),
        )
    ]
    for kind in KINDS.values():
        if kind.numbered:
            values = {
                k.number: v
                for k, v in data.items.items()
                if isinstance(k, TableKey | SettingKey)
                and k.kind == kind.key
                and k.number is not None
            }
            node: Node = numbered(values, partial(value_node, kind))
        else:
            node = value_node(kind, data.items[SettingKey(kind.key)])
        items.append((kind.key, node))
    comments = {k.key: _comment(k) for k in KINDS.values()}
    comments["manipulator"] = "read only: what the controller reports (2153, 2154)"
    return FILES.document("settings", "settings.yaml", items, comments)


def render_points(data: EpsonData) -> str:
    """points.yaml; its comment records the range a pull covered (robot.yaml's
    first_point to last_point, and how far it found no point past it)."""
    node = numbered(data.points(), lambda p: value_node(POINT, p))
    comment = _comment(POINT)
    if data.covered is not None:
        comment = f"{covered_text(data)} when pulled; {comment}"
    return FILES.document("points", "points.yaml", [("points", node)], {"points": comment})


def render_files(robot: Robot, data: EpsonData) -> dict[str, str]:
    """Every file of the project, by relative path, in a fixed order."""
    files = {
        "robot.yaml": render_robot(robot, data),
        "settings.yaml": render_settings(data),
        "points.yaml": render_points(data),
    }
    if data.table is not None:
        files[CONTROLLER_FILE] = render_controller(data.table)
    return files
