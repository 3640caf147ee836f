"""An Epson robot's project files: their names, their text, and checking a set of them.

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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

from ...project import yamlio as y
from ...project.files import (
    FileSet,
    Flaws,
    build_windows,
    canonical_integer,
    check_canonical,
    numbered,
    numbers,
    robot_items,
    text_of,
    unique,
)
from ...project.robot import Robot
from ...project.schema import Issue, SchemaSet, show
from ..base import Analysis
from . import profile
from .model import (
    ATTRIBUTE_NAMES,
    ATTRIBUTES,
    EXTRA_ATTRIBUTES,
    KINDS,
    POINT,
    UNSTATED,
    EpsonData,
    Kind,
    NotThere,
    Point,
    PointKey,
    PointTable,
    SettingKey,
    TableKey,
    axes_of_type,
    coordinate_names,
    covered_text,
    type_attributes,
    type_code,
)
from .profile import RegisterMap, RegisterMapInvalid
from .protocol import ROBOT_TYPES, Limits, canonical_real
from .protocol.reads import fewest_response_words

__all__ = [
    "CONTROLLER_FILE",
    "FILES",
    "FIRST_PULL",
    "FORMAT",
    "ROOT_FILES",
    "Connection",
    "analyse",
    "connection",
    "new_options",
    "point_range",
    "point_table_end",
    "render_files",
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
_LINE_DEFAULTS: Mapping[str, float] = {
    "timeout": profile.MODBUS_TIMEOUT,
    "retries": profile.MODBUS_RETRIES,
    "poll_interval": profile.POLL_INTERVAL,
    "deadline": profile.COMMAND_DEADLINE,
}
_MAP_KEYS = (
    "in_base",
    "out_base",
    "command_base",
    "command_words",
    "response_base",
    "response_words",
    "signals",
)


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


def new_options() -> dict[str, Any]:
    """A first pull's robot options: the profile's map, line settings and points."""
    first, last = profile.DEFAULT_POINT_RANGE
    return {
        "map": RegisterMap().to_dict(),
        **_LINE_DEFAULTS,
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
            RegisterMap.from_dict(o.get("map")),
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


# -- rendering --------------------------------------------------------------------------


def _seconds(value: float) -> Any:
    return y.scalar_for(repr(float(value)))


def _map_node(register_map: RegisterMap) -> Any:
    data = register_map.to_dict()
    signals = data.pop("signals")
    assert isinstance(signals, dict)
    items: list[tuple[str, Any]] = [(key, y.num(str(value))) for key, value in data.items()]
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
    conn: list[tuple[str, Any]] = [
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
    controller: list[tuple[str, Any]] = []
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
    items: list[tuple[str, Any]] = [
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


def _number(text: str | int) -> Any:
    return y.num(str(text))


def value_node(kind: Kind, value: Any) -> Any:
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
    items: list[tuple[str, Any]] = [
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
            node = numbered(values, partial(value_node, kind))
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


# -- reading and checking ---------------------------------------------------------------


def analyse(files: Mapping[str, bytes]) -> Analysis:
    """Read and check an Epson project's files (path relative to the project -> content).

    Every file is checked even when others are broken; the settings and points
    are checked against the manipulator's axes and robot.yaml's type, axes and
    point range when those files are valid.  ``data`` is set only when there is
    no issue at all.
    """
    issues: list[Issue] = []
    docs: dict[str, y.Parsed] = {}
    valid: set[str] = set()
    flaws: dict[str, Flaws] = {}
    for name, kind in ROOT_FILES.items():
        if name not in files:
            issues.append(Issue(name, None, None, "missing", fatal=True))
            continue
        before = len(issues)
        doc, ok = FILES.read(name, kind, files[name], issues)
        if doc is not None:
            docs[name] = doc
            flaws[name] = Flaws.of(issues[before:], name)
        if ok:
            valid.add(name)

    result = Analysis(issues=issues)
    if "robot.yaml" in valid:
        result.robot = _build_robot(docs["robot.yaml"], issues, result.notes)
    axes = None
    if "settings.yaml" in valid:
        axes = _check_settings(docs["settings.yaml"], result.robot, issues)
    elif "settings.yaml" in docs:  # a schema error must not hide the other items' checks
        try:
            axes = _check_settings(docs["settings.yaml"], result.robot, issues, partly=True)
        except _UNCHECKABLE:  # the manipulator itself is broken: the schema said how
            pass
    if axes is None and result.robot is not None:
        axes = result.robot.options.get("axes")
    if "points.yaml" in docs:  # each point the schema passed, whatever the others hold
        robot_type = None
        if "settings.yaml" in docs and flaws["settings.yaml"].sound("manipulator", "type"):
            robot_type = type_code(docs["settings.yaml"].data["manipulator"]["type"])
        _check_points(
            docs["points.yaml"], flaws["points.yaml"], result.robot, axes, issues, robot_type
        )
    table = None
    if CONTROLLER_FILE in files:
        doc, ok = FILES.read(CONTROLLER_FILE, "controller", files[CONTROLLER_FILE], issues)
        if doc is not None and ok:
            table = _build_table(doc, issues)
    if not issues and result.robot is not None:
        data = _build_data(docs["settings.yaml"].data, docs["points.yaml"].data)
        data.covered, data.probed_to = _covered(files["points.yaml"])
        data.table = table
        result.data = data
    result.issues = unique(issues, [*ROOT_FILES, CONTROLLER_FILE])
    return result


def _build_table(doc: y.Parsed, issues: list[Issue]) -> PointTable | None:
    """controller.yaml's point table (the schema has checked its form)."""
    points = doc.data["points"]
    answers: dict[str, NotThere] = {}
    for key in ("past_end", "not_defined"):
        if key in points:
            try:
                answers[key] = NotThere.parse(str(points[key]))
            except ValueError as exc:
                issues.append(
                    Issue(CONTROLLER_FILE, doc.line(("points", key)), f"points.{key}", str(exc))
                )
    if "past_end" not in answers:
        return None
    return PointTable(int(points["end"]), answers["past_end"], answers.get("not_defined"))


#: The comment :func:`render_points` writes of the range a pull covered.
_COVERED = re.compile(
    rb"^points: +# P(\d+)-P(\d+) read(?:, none defined (P\d+-P\d+(?: and P\d+-P\d+)?))? "
    rb"when pulled;",
    re.MULTILINE,
)


def _covered(text: bytes) -> tuple[tuple[int, int] | None, int | None]:
    """The range the pull that wrote points.yaml covered, read back from its comment,
    so that a project loaded and saved again keeps the record."""
    found = _COVERED.search(text)
    if found is None:
        return None, None
    last = int(found.group(2))
    probed = found.group(3)
    ends = [int(end) for end in re.findall(rb"-P(\d+)", probed)] if probed else []
    return (int(found.group(1)), last), max([last, *ends]) if ends else None


def _plain(value: Any) -> Any:
    """YAML data as plain Python: whole numbers as int (the register map's form)."""
    if isinstance(value, y.Number):
        return int(value) if value.integral else value
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _map_issue(doc: y.Parsed, message: str) -> Issue:
    """A register map problem (:class:`RegisterMapInvalid`'s words) at its line."""
    at: tuple[str, ...] = ("connection", "map")
    head, sep, rest = message.partition(": ")
    if sep and head in _MAP_KEYS:
        at += (head,)
        message = rest
        if head == "signals":  # at the last signal named that the file gives
            given = doc.data["connection"]["map"].get("signals", {})
            named = [name for name in re.findall(r"[A-Za-z]+", rest) if name in given]
            if named:
                at += (named[-1],)
    return Issue("robot.yaml", doc.line(at), ".".join(at), message)


def _too_few_words(doc: y.Parsed, register_map: RegisterMap) -> list[Issue]:
    """A map whose response words are fewer than a backup's reads need: every pull,
    diff and push of the robot would stop at that read (the schema allows what the
    manual does, 3-8; harlsync's reads need more)."""
    widest = fewest_response_words()
    need, have = widest.response_words, register_map.response_words
    if have >= need:
        return []
    return [
        _map_issue(
            doc,
            f"response_words: {have} words are fewer than harlsync's reads need: {widest} "
            f"answers in {need} (allowed: {need}-{profile.WORDS_RANGE[1]}, as many "
            "assigned in RC+)",
        )
    ]


def _build_robot(doc: y.Parsed, issues: list[Issue], notes: list[str]) -> Robot | None:
    data = doc.data
    conn = data["connection"]
    options: dict[str, Any] = {
        key: _plain(conn.get(key, default)) for key, default in _LINE_DEFAULTS.items()
    }
    options["map"] = _plain(conn.get("map", {}))
    if "writes_whole" in conn:
        options["writes_whole"] = bool(conn["writes_whole"])
    found: list[Issue] = []
    if "write_without" in conn:
        options["write_without"] = sorted(set(conn["write_without"]))
    try:
        register_map = RegisterMap.from_dict(options["map"])
    except RegisterMapInvalid as exc:
        found += [_map_issue(doc, message) for message in exc.issues]
    else:
        register_map = replace(
            register_map, write_without=frozenset(options.get("write_without", ()))
        )
        note = register_map.unwritable or register_map.ready_note
        if note is not None:
            notes.append(f"robot.yaml: connection.map: {note}")
        found += _too_few_words(doc, register_map)
    controller = data.get("controller", {})
    first, last = profile.DEFAULT_POINT_RANGE
    options["first"] = int(controller.get("first_point", first))
    options["last"] = int(controller.get("last_point", last))
    if "point_table_end" in controller:
        options["point_table_end"] = int(controller["point_table_end"])
        if options["last"] > options["point_table_end"]:
            found.append(
                Issue(
                    "robot.yaml",
                    doc.line(("controller", "last_point")),
                    "controller.last_point",
                    f"{options['last']} is past point_table_end {options['point_table_end']}, "
                    "the controller's last point (allowed: at most point_table_end)",
                )
            )
    if options["first"] > options["last"]:
        found.append(
            Issue(
                "robot.yaml",
                doc.line(("controller", "last_point")),
                "controller.last_point",
                f"{options['last']} is before first_point {options['first']} (allowed: a number "
                "at or after first_point)",
            )
        )
    if "type" in controller:
        options["type"] = str(controller["type"])
    if "axes" in controller:
        options["axes"] = int(controller["axes"])
        implied = axes_of_type(type_code(options["type"])) if "type" in options else None
        if implied is not None and implied != options["axes"]:
            found.append(
                Issue(
                    "robot.yaml",
                    doc.line(("controller", "axes")),
                    "controller.axes",
                    f"{options['axes']} axes for a {options['type']} robot (allowed: {implied}, "
                    "or leave axes out)",
                )
            )
    if found:
        issues += found
        return None
    return Robot(
        family="epson",
        name=data["name"],
        port=conn["port"],
        station=int(conn.get("unit", profile.DEFAULT_UNIT)),
        windows=build_windows(data),
        description=data.get("description"),
        options=options,
    )


#: A number's path within one value, its text and whether it is a real.
_Leaf = tuple[tuple[str | int, ...], str, bool]


def _leaves(kind: Kind, raw: Any) -> list[_Leaf]:
    """Every number of one value of a schema-valid file, for the canonical check."""
    shape = kind.shape
    if shape == "record":
        return [((f,), text_of(raw[f]), kind.real) for f in kind.fields]
    if shape in ("real", "integer"):
        return [((), text_of(raw), shape == "real")]
    if shape == "joints":
        return [((i,), text_of(v), False) for i, v in enumerate(raw)]
    if shape == "coords":
        return [((c,), text_of(v), True) for c, v in raw.items()]
    if shape == "limits":
        return [((a, i), text_of(raw[a][i]), True) for a in "xyz" for i in (0, 1)]
    coords: list[_Leaf] = [((c,), text_of(raw[c]), True) for c in coordinate_names(6) if c in raw]
    extras: list[_Leaf] = [
        ((a,), text_of(raw[a]), a == "j1angle") for a in EXTRA_ATTRIBUTES if a in raw
    ]
    return (
        coords
        + [((a,), text_of(raw[a]), False) for a in ATTRIBUTES if ATTRIBUTE_NAMES[a] is None]
        + extras
    )


def _real_form(text: str) -> str:
    """A real in its one form; ValueError says what is allowed (the schema has
    checked that it is a number within 32 bits of thousandths)."""
    try:
        return canonical_real(text)
    except ValueError:
        raise ValueError(
            "more than three decimals (allowed: thousandths, three decimals, "
            "as the controller gives them back)"
        ) from None


def _check_value(kind: Kind, raw: Any, axes: int | None, issue: Callable[..., None]) -> None:
    for where, text, real in _leaves(kind, raw):
        check_canonical(issue, text, _real_form if real else canonical_integer, *where)
    if axes is None:
        return
    wanted = coordinate_names(axes)
    if kind.shape in ("coords", "point"):
        have = [c for c in coordinate_names(6) if c in raw]
        extra = [c for c in have if c not in wanted]
        missing = [c for c in wanted if c not in have]
        allowed = f"allowed: {', '.join(wanted)} on a {axes}-axis robot"
        if extra:
            issue(f"{', '.join(extra)}: for a 6-axis robot ({allowed})", extra[0])
        elif missing:
            issue(f"{', '.join(missing)} missing ({allowed})")
    elif kind.shape == "joints" and len(raw) != axes:
        issue(f"{len(raw)} joints (allowed: one value per joint, {axes} on a {axes}-axis robot)")


#: What checking a value the schema refused can raise: that value is skipped (the
#: schema's issue names it), the others are still checked.
_UNCHECKABLE = (KeyError, IndexError, TypeError, ValueError, AttributeError, ArithmeticError)


def _check_settings(
    doc: y.Parsed, robot: Robot | None, issues: list[Issue], *, partly: bool = False
) -> int:
    """What the schema cannot say: the numbers' one form, coordinates and joints
    against the manipulator's axes, which agree with its type and robot.yaml.
    Returns the axes.  ``partly``: the file has schema errors; a setting that
    cannot be checked is skipped, and the others are."""
    data = doc.data

    def issue_at(*at: str | int) -> Callable[..., None]:
        def issue(message: str, *where: str | int) -> None:
            path = at + where
            issues.append(
                Issue("settings.yaml", doc.line(path), ".".join(str(p) for p in path), message)
            )

        return issue

    manipulator = data["manipulator"]
    axes = int(manipulator["axes"])
    implied = axes_of_type(type_code(manipulator["type"]))
    if implied is not None and implied != axes:
        issue_at("manipulator", "axes")(
            f"{axes} axes for a {manipulator['type']} robot (allowed: {implied})"
        )
    if robot is not None:
        for key, have in (("type", manipulator["type"]), ("axes", axes)):
            wanted = robot.options.get(key)
            if wanted is not None and wanted != have:
                issue_at("manipulator", key)(
                    f"{have}, but robot.yaml controller.{key} says {wanted} (allowed: "
                    f"{wanted}: this project is of another robot, or robot.yaml is wrong)"
                )
    for kind in KINDS.values():
        try:
            raw = data[kind.key]
            if not kind.numbered:
                _check_value(kind, raw, axes, issue_at(kind.key))
                continue
            for key, n in numbers(raw):
                if kind.key == "jrange" and n > axes:
                    issue_at(kind.key, key)(f"joint {n} of a {axes}-axis robot (allowed: 1-{axes})")
                try:
                    _check_value(kind, raw[key], axes, issue_at(kind.key, key))
                except _UNCHECKABLE:
                    if not partly:
                        raise
        except _UNCHECKABLE:
            if not partly:
                raise
    return axes


def _check_points(
    doc: y.Parsed,
    flaws: Flaws,
    robot: Robot | None,
    axes: int | None,
    issues: list[Issue],
    robot_type: int | None = None,
) -> None:
    """What the schema cannot say of each point it passed: the robot's range, the
    coordinates against the axes, the type's own attributes."""
    table: Any = doc.data.get("points") if isinstance(doc.data, dict) else None
    first, last = point_range(robot) if robot is not None else (0, 0xFFFF)
    for key, n in numbers(table):
        at = ("points", key)
        if not flaws.sound(*at):
            continue

        def issue(message: str, *where: str | int, at: tuple[str, str] = at) -> None:
            path = at + where
            issues.append(
                Issue("points.yaml", doc.line(path), ".".join(str(p) for p in path), message)
            )

        if not first <= n <= last:
            issue(
                f"P{show(y.Number(key))} is outside the robot's range (allowed: "
                f"{first}-{last}, robot.yaml controller.first_point/last_point)"
            )
        _check_value(POINT, table[key], axes, issue)
        if robot_type is not None:
            _check_extras(table[key], robot_type, issue)


def _check_extras(raw: Mapping[str, Any], robot_type: int, issue: Callable[..., None]) -> None:
    """A point has the attributes of its manipulator's type (J1Flag and J2Flag on a
    6-axis robot, J1Angle on an RS), and no other type's."""
    wanted = type_attributes(robot_type)
    name = ROBOT_TYPES.get(robot_type, str(robot_type))
    missing = [a for a in wanted if a not in raw]
    if missing:
        issue(
            f"{', '.join(missing)} missing: a {name} robot's points have "
            f"{' and '.join(wanted)} (manual 10.25); pull again to take "
            f"{'it' if len(missing) == 1 else 'them'} in"
        )
    for extra in (a for a in EXTRA_ATTRIBUTES if a in raw and a not in wanted):
        issue(f"a {name} robot's points have no {extra} (manual 10.25)", extra)


def _value(kind: Kind, raw: Any) -> Any:
    """One value of a valid file, in the codec's types."""
    shape = kind.shape
    if shape == "record":
        assert kind.record is not None
        convert: Callable[[Any], Any] = text_of if kind.real else int
        return kind.record(*(convert(raw[f]) for f in kind.fields))
    if shape == "real":
        return text_of(raw)
    if shape == "integer":
        return int(raw)
    if shape == "joints":
        return tuple(int(v) for v in raw)
    if shape == "coords":
        return tuple(text_of(raw[c]) for c in coordinate_names(6) if c in raw)
    if shape == "limits":
        return tuple(Limits(text_of(raw[a][0]), text_of(raw[a][1])) for a in "xyz")
    attributes: dict[str, Any] = {}
    for name, names in ATTRIBUTE_NAMES.items():
        attributes[name] = names.index(raw[name]) if names else int(raw[name])
    for name in EXTRA_ATTRIBUTES:
        if name in raw:
            attributes[name] = text_of(raw[name]) if name == "j1angle" else int(raw[name])
    return Point(tuple(text_of(raw[c]) for c in coordinate_names(6) if c in raw), **attributes)


def _build_data(settings: Mapping[str, Any], points: Mapping[str, Any]) -> EpsonData:
    manipulator = settings["manipulator"]
    data = EpsonData(
        type_code(manipulator["type"]), int(manipulator["axes"]), str(manipulator["model"])
    )
    for kind in KINDS.values():
        raw = settings[kind.key]
        if not kind.numbered:
            data.items[SettingKey(kind.key)] = _value(kind, raw)
            continue
        key_type = TableKey if kind.table else SettingKey
        for n in sorted(raw, key=int):
            data.items[key_type(kind.key, int(n))] = _value(kind, raw[n])
    for n in sorted(points["points"], key=int):
        data.items[PointKey("point", int(n))] = _value(POINT, points["points"][n])
    return data
