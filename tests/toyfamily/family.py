"""The toy family as the engine sees it: sixteen numbered slots on a line.

Test-only: it proves that a family is one folder and one registry line.  Its
files are ``robot.yaml`` and ``slots.yaml``; its one write is ``W n v``.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib.resources import files as package_files
from typing import NamedTuple

import jsonschema

from harlsync.errors import InterlockError, LinkTimeout, ProjectError
from harlsync.families.base import (
    Analysis,
    Catalogue,
    Change3,
    Driver,
    Family,
    Help,
    PlanShape,
    Progress,
    Words,
)
from harlsync.link import Link
from harlsync.project import Robot, yamlio
from harlsync.project.robot import DAYS, build_windows
from harlsync.project.schema import Issue

from . import codec


class SlotKey(NamedTuple):
    kind: str  # "slot"
    number: int


@dataclass
class ToyData:
    version: str = ""
    slots: dict[int, int] = field(default_factory=dict)


class ToyCatalogue(Catalogue[SlotKey, ToyData]):
    def items(self, data: ToyData, *, registers: bool = False) -> dict[SlotKey, object]:
        return {SlotKey("slot", n): v for n, v in data.slots.items()}

    def with_items(self, data: ToyData, values: Mapping[SlotKey, object]) -> ToyData:
        slots = dict(data.slots)
        for key, value in values.items():
            if value is None:
                slots.pop(key.number, None)
            else:
                slots[key.number] = int(value)  # type: ignore[call-overload]
        return ToyData(data.version, slots)

    def order(self, key: SlotKey) -> tuple[int | str, ...]:
        return (key.number,)

    def describe(self, key: SlotKey) -> str:
        return f"slot {key.number}"

    def version(self, data: ToyData) -> str:
        return data.version

    def plan(
        self, live: ToyData, project: ToyData, changes: list[Change3[SlotKey]], *, registers: bool
    ) -> PlanShape[SlotKey]:
        """A slot cannot be emptied: only written."""
        return PlanShape(
            wanted=[c for c in changes if c[2] is not None],
            unwritable=[
                f"slot {key.number}: the project has none (a slot cannot be emptied)"
                for key, _, new in changes
                if new is None
            ],
        )


CATALOGUE = ToyCatalogue()


@dataclass(frozen=True)
class ToyStatus:
    running: bool

    @property
    def idle(self) -> bool:
        return not self.running

    def describe(self) -> str:
        return "a program running" if self.running else "idle"


class ToyDriver(Driver[SlotKey, ToyData]):
    def __init__(self, link: Link[codec.Frame]) -> None:
        self.link = link
        self.label = f"port {link.url} station {link.station:02d}"

    def _ask(self, request: codec.Request) -> str:
        reply = self.link.exchange(request)
        if reply == "ERR BUSY":
            raise InterlockError(f"{self.label} refused {request.payload}: a program runs")
        if reply.startswith("ERR"):
            raise ProjectError(f"{self.label} answered {reply} to {request.payload}")
        return reply

    def read_all(
        self, *, registers: bool, progress: Progress | None = None, whole: bool = False
    ) -> ToyData:
        version = self._ask(codec.VERSION)
        slots: dict[int, int] = {}
        for n in range(codec.SLOTS):
            value = self.read(SlotKey("slot", n))
            if isinstance(value, int):
                slots[n] = value
            if progress:
                progress(n + 1, codec.SLOTS)
        return ToyData(version, slots)

    def status(self) -> ToyStatus:
        return ToyStatus(self._ask(codec.STATUS) == "RUN")

    def read(self, key: SlotKey) -> object:
        text = self._ask(codec.read_slot(key.number)).split()[2]
        return None if text == "-" else int(text)

    def write(
        self, key: SlotKey, value: object, old: object = None, *, needs_idle: bool = True
    ) -> None:
        if not isinstance(value, int):
            raise ProjectError(f"slot {key.number}: {value!r} is not a number")
        request = codec.write_slot(key.number, value)
        try:
            self._ask(request)
        except LinkTimeout:  # lost reply: did it take?  Never again on a running robot.
            if self.read(key) == value:
                return
            if needs_idle and not self.status().idle:
                raise InterlockError(
                    f"{self.label}: a program runs; not sending {request.payload} again"
                ) from None
            self._ask(request)

    def command(self, key: SlotKey, value: object) -> str:
        return f"W {key.number} {value}"

    def close(self) -> None:
        self.link.close()


SCHEMA = package_files(__package__).joinpath("slots.schema.json").read_text()


def _plain(value: object) -> object:
    """A parsed YAML value as JSON data: numbers as int (or float)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, yamlio.Number):
        return int(value) if value == value.to_integral_value() else float(value)
    return value


def _windows(value: object) -> bool:
    """``maintenance_windows`` as every family's robot.yaml says them: a list of days,
    a start and an end (HH:MM) each."""
    clock = re.compile(r"([01][0-9]|2[0-3]):[0-5][0-9]")
    return isinstance(value, list) and all(
        isinstance(w, dict)
        and isinstance(w.get("days"), list)
        and bool(w["days"])
        and all(day in DAYS for day in w["days"])
        and all(isinstance(w.get(k), str) and clock.fullmatch(w[k]) for k in ("start", "end"))
        for w in value
    )


def _robot(doc: yamlio.Parsed, issues: list[Issue]) -> Robot | None:
    data = _plain(doc.data) if isinstance(doc.data, dict) else {}
    assert isinstance(data, dict)
    connection = data.get("connection")
    if not isinstance(data.get("name"), str) or not isinstance(connection, dict):
        issues.append(Issue("robot.yaml", doc.line(()), None, "needs name and connection"))
        return None
    port, station = connection.get("port"), connection.get("station", 1)
    if not isinstance(port, str) or not isinstance(station, int) or not 0 <= station <= 99:
        line = doc.line(("connection",))
        issues.append(Issue("robot.yaml", line, "connection", "needs port (text) and station 0-99"))
        return None
    if not _windows(data.get("maintenance_windows", [])):
        line = doc.line(("maintenance_windows",))
        what = "needs days, a start and an end (HH:MM) for each window"
        issues.append(Issue("robot.yaml", line, "maintenance_windows", what))
        return None
    windows = build_windows(data)
    return Robot(family="toy", name=data["name"], port=port, station=station, windows=windows)


class ToyFamily(Family[SlotKey, ToyData]):
    name = "toy"
    title = "Toy (a test family)"
    catalogue = CATALOGUE
    words = Words(state="the toy's run state")
    stations = range(100)
    help = Help(stations="0-99", pull="the slots", items="slot", commands="W n v")

    def analyse(self, files: Mapping[str, bytes]) -> Analysis:
        issues: list[Issue] = []
        docs: dict[str, yamlio.Parsed] = {}
        for name in ("robot.yaml", "slots.yaml"):
            if name not in files:
                issues.append(Issue(name, None, None, "missing", fatal=True))
                continue
            try:
                docs[name] = yamlio.parse(files[name].decode("utf-8"))
            except (UnicodeDecodeError, yamlio.YamlSyntaxError) as exc:
                line = getattr(exc, "line", None)
                issues.append(Issue(name, line, None, f"not YAML: {exc}", fatal=True))
        if "robot.yaml" not in docs:
            return Analysis(issues=issues)
        robot = _robot(docs["robot.yaml"], issues)  # alone too: what load_robot reads
        if "slots.yaml" not in docs:
            return Analysis(robot=robot, issues=issues)
        slots_doc = docs["slots.yaml"]
        plain = _plain(slots_doc.data)
        for error in jsonschema.Draft202012Validator(json.loads(SCHEMA)).iter_errors(plain):
            path = [str(p) for p in error.path]
            where = ".".join(str(p) for p in error.path) or None
            issues.append(Issue("slots.yaml", slots_doc.line(path), where, error.message))
        if issues or robot is None or not isinstance(plain, dict):
            return Analysis(robot=robot, issues=issues)
        data = ToyData(
            str(plain.get("version", "")), {int(k): v for k, v in plain["slots"].items()}
        )
        return Analysis(robot=robot, data=data)

    def render_files(self, robot: Robot, data: ToyData) -> dict[str, str]:
        robot_yaml = (
            f"family: toy\nname: {robot.name}\nconnection:\n"
            f"  port: {json.dumps(robot.port)}\n  station: {robot.station}\n"
        )
        if robot.windows:
            robot_yaml += "maintenance_windows:\n" + "".join(
                f"  - {{days: [{', '.join(w.days)}], "
                f'start: "{w.start:%H:%M}", end: "{w.end:%H:%M}"}}\n'
                for w in robot.windows
            )
        slots = "".join(f"  {n}: {v}\n" for n, v in sorted(data.slots.items()))
        head = f"format: 1\nversion: {json.dumps(data.version)}\n"
        slots_yaml = head + (f"slots:\n{slots}" if slots else "slots: {}\n")
        return {"robot.yaml": robot_yaml, "slots.yaml": slots_yaml}

    def schemas(self) -> dict[str, str]:
        return {"slots.schema.json": SCHEMA}

    def connect(
        self,
        robot: Robot,
        port: str | None,
        station: int | None,
        *,
        lock_timeout: float,
        **options: bool,
    ) -> ToyDriver:
        link = Link(
            port or robot.port,
            robot.station if station is None else station,
            codec=codec.CODEC,
            lock_timeout=lock_timeout,
        ).open()
        return ToyDriver(link)


FAMILY = ToyFamily()
