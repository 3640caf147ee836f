"""An Epson robot's items: the settings and points, their names as a diff shows
them, the order a push writes them in, and how a plan writes them.

::

    TableKey("accel_s", 3)        AccelS 3     one table entry; register command 53
    SettingKey("box", 5)          Box 5        one Box area; 600 for X, Y, Z (Rn)
    SettingKey("weight")          Weight       the hand weight and arm length; 300
    PointKey("point", 12)         P12          one point (diff, read, verify)
    PointWrite("point", 12, ("x", "hand"))     what a plan writes of P12: one 1204 per
                                               coordinate, then one of 1206-1214 per
                                               attribute, only the fields that changed

A diff shows each changed field with its exact text (``-AccelS 3 decel: 200.000``)
under a group that says the kind's volatility (``@@ AccelS (volatile) @@``); a
table entry the robot no longer has reads ``not registered: cleared, e.g. by a
power cycle``, and a push registers it again.  Push order: the load (Weight,
Inertia), the limits and areas (JRange, XYLim, Box, Plane), the frames (Base
before Local: changing Base moves every Local), Tool, Arch, Fine, LimZ, the six
tables, then points (a point may name a Local).  No Remote Control command
unregisters a table entry, deletes a point or removes a setting, nor sets a
point back to no Local: a plan that would need one is refused with what to do.
A plan names the persistent items it writes (the controller's memory card).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

from ..base import Catalogue, PlanShape
from .model import (
    ATTRIBUTES,
    KINDS,
    PAST_TABLE,
    PERSISTENT,
    POINT,
    UNSTATED,
    EpsonData,
    Kind,
    Point,
    PointKey,
    SettingKey,
    TableKey,
    coordinate_names,
    covered_text,
    field_texts,
    table_notes,
    value_text,
)

__all__ = ["CATALOGUE", "CLEARED", "EpsonCatalogue", "Key", "PointWrite", "point_fields"]


class PointWrite(NamedTuple):
    """The fields of one point a plan writes (coordinates, then attributes)."""

    kind: str  # "point"
    number: int
    fields: tuple[str, ...]


Key = TableKey | SettingKey | PointKey | PointWrite

#: The safe push order, by kind.
PUSH_ORDER = (
    "weight",
    "inertia",
    "jrange",
    "xylim",
    "box",
    "plane",
    "base",
    "local",
    "tool",
    "arch",
    "fine",
    "limz",
    "accel",
    "accel_s",
    "accel_r",
    "speed",
    "speed_s",
    "speed_r",
    "point",
)
_RANK = {kind: i for i, kind in enumerate(PUSH_ORDER)}
#: What a diff says of a table entry the robot does not have.
CLEARED = "not registered: cleared, e.g. by a power cycle"
#: A plan's note on points (the manual does not say how long point edits live).
POINTS_NOTE = (
    "points are written to the controller's point memory only: harlsync never "
    "saves them to Points.pts (command 2052), and the manual does not say whether "
    "they survive a power-off; save them on the controller (RC+ or SavePoints)"
)


def _kind(key: Key) -> Kind:
    return POINT if key.kind == "point" else KINDS[key.kind]


def point_fields(old: Point | None, new: Point) -> tuple[str, ...]:
    """The fields of ``new`` a write must send over ``old``: every coordinate and
    attribute of a point not yet defined (but for Local 0, which is what a new point
    has and 1214 cannot set), else only those that differ, coordinates first."""
    names = coordinate_names(len(new.coords))
    extras = tuple(name for name, _ in new.extras())
    if old is None:
        return (*names, *(a for a in ATTRIBUTES if a != "local" or new.local), *extras)
    coords = tuple(c for c, a, b in zip(names, old.coords, new.coords) if a != b)
    return (
        coords
        + tuple(a for a in ATTRIBUTES if old.attribute(a) != new.attribute(a))
        + tuple(a for a in extras if getattr(old, a) != getattr(new, a))
    )


def _counted(count: dict[str, int], *, zeros: bool) -> str:
    one = {"table entries": "table entry", "settings": "setting", "points": "point"}
    return ", ".join(
        f"{n} {one[name] if n == 1 else name}" for name, n in count.items() if n or zeros
    )


class EpsonCatalogue(Catalogue[Key, EpsonData]):
    #: No Epson write is sent while the robot runs (the handshake refuses it too).
    live_tuning: frozenset[str] = frozenset()

    def items(self, data: EpsonData, *, registers: bool = False) -> dict[Key, Any]:
        """Every setting and point; there is no runtime data to add for ``registers``."""
        return {key: value for key, value in data.items.items()}

    def with_items(self, data: EpsonData, values: Mapping[Key, Any]) -> EpsonData:
        items = dict(data.items)
        for key, value in values.items():
            if value is None:
                items.pop(key, None)
            else:
                items[key] = value
        return dataclasses.replace(data, items=items)

    def order(self, key: Key) -> tuple[Any, ...]:
        return (_RANK[key.kind], -1 if key.number is None else key.number)

    def describe(self, key: Key) -> str:
        """``AccelS 3``, ``Box 5``, ``Weight``, ``P12``."""
        if key.kind == "point":
            return f"P{key.number}"
        name = KINDS[key.kind].name
        return name if key.number is None else f"{name} {key.number}"

    def group(self, key: Key) -> str:
        kind = _kind(key)
        title = "points" if kind is POINT else kind.name
        if kind.volatility == UNSTATED:
            return title
        return f"{title} ({kind.volatility})"

    def label(self, key: Key, field: str) -> str:
        name = self.describe(key)
        return f"{name} {field}" if field else name

    def fields(self, key: Key, old: Any, new: Any) -> list[tuple[str, str | None, str | None]]:
        kind = _kind(key)
        if old is None or new is None:
            if old is None and new is None:
                return []
            before = (
                value_text(kind, old)
                if old is not None
                else (CLEARED if isinstance(key, TableKey) else None)
            )
            return [("", before, None if new is None else value_text(kind, new))]
        if kind is POINT and len(old.coords) != len(new.coords):
            a, b = value_text(kind, old), value_text(kind, new)
            return [] if a == b else [("", a, b)]
        return [
            (name, a, b)
            for (name, a), (_, b) in zip(field_texts(kind, old), field_texts(kind, new))
            if a != b
        ]

    def identity(self, key: Key) -> dict[str, Any]:
        ident: dict[str, Any] = key._asdict()
        return ident

    def counts(self, changes: Iterable[tuple[Any, Any, Any]]) -> dict[str, int]:
        """Table entries, other settings and points that differ."""
        count = {"table entries": 0, "settings": 0, "points": 0}
        for key, _, _ in changes:
            if key.kind == "point":
                count["points"] += 1
            elif isinstance(key, TableKey):
                count["table entries"] += 1
            else:
                count["settings"] += 1
        return count

    def summary(self, changes: Iterable[tuple[Any, Any, Any]]) -> str:
        """``"3 table entries, 1 setting, 2 points"``, or ``"no change"``."""
        return _counted(self.counts(changes), zeros=False) or "no change"

    def version(self, data: EpsonData) -> str:
        return f"{data.type_name} {data.model} ({data.axes} axes)"

    def robot_identity(self, data: EpsonData) -> dict[str, str]:
        """The manipulator the controller reports (2153's type and axes, 2154's model),
        and what a point past its point table answers (controller.yaml, when recorded):
        a pull whose controller answers it otherwise is refused naming both."""
        found = {"robot type": data.type_name, "axes": str(data.axes), "model": data.model}
        if data.table is not None:
            found[PAST_TABLE] = data.table.past_end.describe()
        return found

    def contents(self, data: EpsonData, *, registers: bool) -> str:
        """``"12 table entries, 20 settings, 150 points (P0-P199 read, none defined
        P200-P999)"``: the points' range when a pull read it."""
        text = _counted(
            self.counts((key, None, value) for key, value in data.items.items()), zeros=True
        )
        if data.covered is not None:
            text += f" ({covered_text(data)})"
        return "; ".join([text, *table_notes(data)])

    def other_identity(self, now: Mapping[str, str], project: EpsonData) -> str | None:
        """Why the controller that reports ``now`` (:meth:`robot_identity`) is not the
        project's robot: another manipulator type, axis count or model (2153,
        2154); None when it is."""
        if (now["robot type"], now["axes"]) != (project.type_name, str(project.axes)):
            return (
                f"the project is of a {project.type_name} robot with {project.axes} axes, the "
                f"controller reports a {now['robot type']} with {now['axes']}: check the port "
                "(or pull into a new project)"
            )
        recorded = project.table.past_end.describe() if project.table is not None else None
        answer = now.get(PAST_TABLE)
        if recorded is not None and answer is not None and answer != recorded:
            return (
                f"the controller answers a point past its point table with {answer}, where "
                f"controller.yaml records {recorded} (the last pull's): another controller, "
                "or one updated; check the port, or accept it with 'harlsync pull DIR "
                "--new-robot'"
            )
        if now["model"] != project.model:
            return (
                f"the project is of a {project.model}, the controller reports a {now['model']} "
                "(2154): another robot, or a replaced one; check the port, or accept it with "
                "'harlsync pull DIR --new-robot'"
            )
        return None

    def other_robot(self, live: EpsonData, project: EpsonData) -> str | None:
        """Another manipulator, model or answer past the point table
        (:meth:`other_identity`), or a point not defined that answers otherwise than
        the project recorded (controller.yaml ``points.not_defined``), which the
        read learns only when it meets one; None when it is the robot."""
        other = super().other_robot(live, project)
        was = None if project.table is None else project.table.not_defined
        now = None if live.table is None else live.table.not_defined
        if other is not None or was is None or now is None or now == was:
            return other
        return (
            f"a point not defined now answers {now.describe()}, where controller.yaml "
            f"points.not_defined records {was.describe()} (the last pull's): another "
            "controller, or one updated; check the port, or accept it with 'harlsync "
            "pull DIR --new-robot'"
        )

    def plan(
        self,
        live: EpsonData,
        project: EpsonData,
        changes: list[tuple[Any, Any, Any]],
        *,
        registers: bool,
    ) -> PlanShape[Key]:
        unwritable: list[str] = []
        if live.unwritable is not None:
            unwritable.append(live.unwritable)
        other = self.other_robot(live, project)
        if other is not None:
            unwritable.append(other)
        wanted: list[tuple[Any, Any, Any]] = []
        card: list[str] = []
        points = False
        lacking: list[Key] = []
        for key, old, new in changes:
            if new is None:
                lacking.append(key)
            elif isinstance(key, PointKey):
                if old is not None and old.local and not new.local:
                    unwritable.append(
                        f"{self.describe(key)} local: Local {old.local} on the robot, none in "
                        "the project, and no Remote Control command sets a point back to no "
                        "Local; change it on the controller (or give it a Local in the project)"
                    )
                    continue
                fields = point_fields(old, new)
                if fields:
                    wanted.append((PointWrite("point", key.number, fields), old, new))
                    points = True
            else:
                wanted.append((key, old, new))
                if KINDS[key.kind].volatility == PERSISTENT:
                    card.append(self.describe(key))
        unwritable += self._lacking(lacking)
        notes = [] if live.map_note is None else [live.map_note]
        if card:
            notes.append(
                "written to the controller's memory card (persistent; its life "
                f"shortens with each write): {', '.join(card)}"
            )
        if points:
            notes.append(POINTS_NOTE)
        return PlanShape(wanted=wanted, unwritable=unwritable, notes=notes)

    def _lacking(self, keys: list[Key]) -> list[str]:
        """Why items on the robot that the project lacks cannot be pushed: one
        sentence for the table entries, one for the points, one for the rest."""
        tables = [self.describe(k) for k in keys if isinstance(k, TableKey)]
        points = [self.describe(k) for k in keys if k.kind == "point"]
        others = [
            self.describe(k) for k in keys if not isinstance(k, TableKey) and k.kind != "point"
        ]
        out = []
        if tables:
            out.append(
                f"{', '.join(tables)}: registered on the robot but not in the project, "
                "and no Remote Control command unregisters a table entry; pull to take "
                f"{_them(tables)} in, or clear the tables on the controller (a power "
                "cycle or a reset does) and run again"
            )
        if points:
            out.append(
                f"{', '.join(points)}: defined on the robot but not in the project, and "
                "no Remote Control command deletes a point; pull to take "
                f"{_them(points)} in, or delete {_them(points)} on the controller and "
                "run again"
            )
        if others:
            out.append(
                f"{', '.join(others)}: on the robot but not in settings.yaml, and no "
                f"Remote Control command removes a setting; pull to take {_them(others)} "
                "in"
            )
        return out


def _them(names: list[str]) -> str:
    return "it" if len(names) == 1 else "them"


CATALOGUE = EpsonCatalogue()
