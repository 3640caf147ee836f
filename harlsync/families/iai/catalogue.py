"""An IAI robot's items: its positions, and its global flags and variables when the
project keeps them; their keys, names and how a plan writes them.

::

    PositionKey("position", 12)          one position of the table (diff, read, verify)
    VariableKey("flag", 600)             one global flag (diff, and its own 24BH write)
    VariableKey("integer", 200)          one global integer variable (diff, read, verify)
    VariableKey("real", 300)             one global real variable (diff, read, verify)
    Run("positions", 12, 4)              positions 12-15 written by one 291H (plans only)
    Run("integers", 200, 3)              integer variables 200-202 by one 24CH (plans only)
    Run("reals", 300, 2)                 real variables 300-301 by one 24DH (plans only)
    RecordKey("string", 1)               string variable columns 1-32 (diff, and one 24EH)
    RecordKey("work", 1)                 work coordinate system 1 (diff only: read only)

A diff compares items one by one; flags and variables only when asked
(``registers``: runtime data, like the HARL-U2's registers), the records when
robot.yaml keeps them.  A plan writes each run of consecutive changed positions,
integer or real variables with one command, as long as the controller's receive
buffer takes it, each changed row of string variable columns with one 24EH, each
changed flag with its own 24BH, and never an item that did not change.  Push
order: positions, integer variables, real variables, string variables, then
flags (a flag is often the signal that the data beside it is ready).  A position
the robot has and the project lacks cannot be written: no message of protocol B
clears a position, so such a plan is refused with what to do; so is a plan with
flags and variables for a project that does not keep them, and one that would
change a coordinate system (no message harlsync sends writes one).
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from itertools import zip_longest
from typing import NamedTuple

from ..base import Catalogue, Change3, PlanShape
from .layout import IaiData
from .model import ARM_NAMES, VARIABLE_SECTIONS, Position, Version
from .protocol import max_positions_per_write, max_variables_per_write
from .tables import replies_differ

__all__ = [
    "CATALOGUE",
    "IaiCatalogue",
    "Key",
    "PositionKey",
    "RecordKey",
    "Run",
    "VariableKey",
    "identity_of",
    "runs",
]


class PositionKey(NamedTuple):
    """One position of the table."""

    kind: str  # "position"
    number: int


class VariableKey(NamedTuple):
    """One global flag, integer variable or real variable."""

    kind: str  # "flag" | "integer" | "real"
    number: int


class RecordKey(NamedTuple):
    """One read-only record: a work or tool coordinate system definition by number,
    or a row of string variable columns by its first column."""

    kind: str  # "work" | "tool" | "string"
    number: int


class Run(NamedTuple):
    """Consecutive items ``start`` .. ``start + size - 1`` written by one command."""

    kind: str  # "positions" (291H) | "integers" (24CH) | "reals" (24DH)
    start: int
    size: int

    @property
    def numbers(self) -> range:
        return range(self.start, self.start + self.size)


Key = PositionKey | VariableKey | RecordKey | Run

#: Item kind -> (the section of the data it is kept in, a person's name for one, for several).
_KINDS = {
    "position": ("positions", "position", "positions"),
    "integer": ("integers", "integer variable", "integer variables"),
    "real": ("reals", "real variable", "real variables"),
    "flag": ("flags", "flag", "flags"),
    # records: stored and diffed; coordinate systems never written, strings with 24EH
    "work": ("work_coordinates", "work coordinate system", "work coordinate systems"),
    "tool": ("tool_coordinates", "tool coordinate system", "tool coordinate systems"),
    "string": ("strings", "string variable row", "string variable rows"),
}
#: The record kinds, and the message that reads each.
_RECORD_KINDS = {"work": "2A0H", "tool": "2A0H", "string": "210H"}
#: The records no message harlsync sends writes (string variables it writes: 24EH, p.51).
_READ_ONLY_KINDS = {"work", "tool"}
#: The safe push order, by item kind (a flag last of what is written: it is often
#: the signal that the data beside it is ready); a run sorts with its items.
_ORDER = {
    kind: i
    for i, kind in enumerate(("position", "integer", "real", "string", "flag", "work", "tool"))
}
#: A run's kind -> its items' kind.
_ITEM_OF_RUN = {section: kind for kind, (section, _, _) in _KINDS.items()}


def _item_kind(key: Key) -> str:
    return _ITEM_OF_RUN[key.kind] if isinstance(key, Run) else key.kind


def runs(
    kind: str,
    numbers: Iterable[int],
    limit: int,
    live: Mapping[int, object],
    project: Mapping[int, object],
) -> list[tuple[Run, tuple[object, ...], tuple[object, ...]]]:
    """The writes of ``numbers`` (changed items of run kind ``kind``): one per run
    of consecutive numbers of at most ``limit``, as (run, old values, new values)."""
    found: list[list[int]] = []
    for n in sorted(numbers):
        if found and found[-1][-1] == n - 1 and len(found[-1]) < limit:
            found[-1].append(n)
        else:
            found.append([n])
    return [
        (
            Run(kind, run[0], len(run)),
            tuple(live.get(n) for n in run),
            tuple(project[n] for n in run),
        )
        for run in found
    ]


def position_text(position: Position | None) -> str | None:
    """A position on one line, as a diff shows it."""
    if position is None:
        return None
    text = (
        f"axes [{', '.join(map(str, position.axes))}] "
        f"coords [{', '.join(position.coords)}] "
        f"acc {position.acc} dec {position.dec} speed {position.speed}"
    )
    for name, arm in (("arm1", position.arm1), ("arm2", position.arm2)):
        if arm:
            text += f" {name} {ARM_NAMES.get(arm, arm)}"
    return text


def coordinates_text(value: tuple[str, ...] | None) -> str | None:
    """A coordinate system definition on one line: ``x 100.000 y 0.000 z 0.000 r 90.000``."""
    if value is None:
        return None
    return " ".join(f"{axis} {c}" for axis, c in zip("xyzr", value))


def string_text(value: str | None) -> str | None:
    """A row of string variable columns as readable, exact text: printable ASCII as
    itself (a backslash doubled), any other code as ``\\xNN``, trailing NULs
    counted (``"AB" and 30 x \\x00``)."""
    if value is None:
        return None
    codes = [int(value[i : i + 2], 16) for i in range(0, len(value), 2)]
    zeros = len(codes) - len(bytes(codes).rstrip(b"\0"))
    tail = f" and {zeros} x \\x00" if zeros > 1 else ""
    codes = codes[: len(codes) - zeros] if zeros > 1 else codes
    shown = "".join(
        "\\\\" if c == 0x5C else chr(c) if 0x20 <= c <= 0x7E else f"\\x{c:02X}" for c in codes
    )
    return f'"{shown}"{tail}'


def value_text(value: object) -> str | None:
    """A flag or variable as variables.yaml writes it: ``true``, ``-1000``, ``0.1``."""
    if value is None:
        return None
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def identity_of(v: Version) -> dict[str, str]:
    """The unit's identity (:meth:`IaiCatalogue.robot_identity`) from its 201H reply."""
    return {"model code": v.model_code, "unit code": v.unit_code, "version": v.version}


class IaiCatalogue(Catalogue[Key, IaiData]):
    #: No IAI write is allowed while a program runs.
    live_tuning: frozenset[str] = frozenset()

    def items(self, data: IaiData, *, registers: bool = False) -> dict[Key, object]:
        out: dict[Key, object] = {PositionKey("position", n): p for n, p in data.positions.items()}
        if registers:
            kept = data.variables()
            for kind, (section, _, _) in _KINDS.items():
                for n, value in kept.get(section, {}).items():
                    out[VariableKey(kind, n)] = value
        records = data.records()
        for kind in _RECORD_KINDS:
            for n, value in records.get(_KINDS[kind][0], {}).items():
                out[RecordKey(kind, n)] = value
        return out

    def with_items(self, data: IaiData, values: Mapping[Key, object]) -> IaiData:
        new = copy.deepcopy(data)
        for key, value in values.items():
            if isinstance(key, Run):  # a plan's, never an item of a diff
                raise NotImplementedError
            section = _KINDS[_item_kind(key)][0]
            table = getattr(new, section)
            if table is None:
                table = {}
                setattr(new, section, table)
            if value is None:
                table.pop(key.number, None)
            else:
                table[key.number] = value
        return new

    def order(self, key: Key) -> tuple[int, int]:
        number = key.start if isinstance(key, Run) else key.number
        return (_ORDER[_item_kind(key)], number)

    def describe(self, key: Key) -> str:
        _, one, several = _KINDS[_item_kind(key)]
        if isinstance(key, RecordKey) and key.kind == "string":
            return f"string variables from column {key.number}"
        if not isinstance(key, Run):
            return f"{one} {key.number}"
        if key.size == 1:
            return f"{one} {key.start}"
        return f"{several} {key.start}-{key.start + key.size - 1}"

    def group(self, key: Key) -> str:
        return _KINDS[_item_kind(key)][2]

    def label(self, key: Key, field: str) -> str:
        return str(key.start if isinstance(key, Run) else key.number)

    def fields(
        self, key: Key, old: object, new: object
    ) -> list[tuple[str, str | None, str | None]]:
        """An item's value as one field; a run's values (a tuple each, as one command
        writes them) compared one by one, a value one side lacks as none."""
        kind = _item_kind(key)
        show = (
            position_text
            if kind == "position"
            else string_text
            if kind == "string"
            else coordinates_text
            if kind in _RECORD_KINDS
            else value_text
        )
        if not isinstance(key, Run):
            old, new = (old,), (new,)
        pairs = zip_longest(*(v if isinstance(v, tuple) else () for v in (old, new)))
        texts = [(show(a), show(b)) for a, b in pairs]
        return [("", a, b) for a, b in texts if a != b]

    def identity(self, key: Key) -> dict[str, object]:
        ident: dict[str, object] = key._asdict()
        return ident

    def counts(self, changes: Iterable[Change3[Key]]) -> dict[str, int]:
        """Positions always; flags, integers and reals when any changed."""
        count = {section: 0 for section, _, _ in _KINDS.values()}
        for key, _, _ in changes:
            count[_KINDS[_item_kind(key)][0]] += 1
        return {name: n for name, n in count.items() if n or name == "positions"}

    def summary(self, changes: Iterable[Change3[Key]]) -> str:
        count = self.counts(changes)
        parts = [
            f"{count[section]} {one if count[section] == 1 else several}"
            for section, one, several in _KINDS.values()
            if count.get(section)
        ]
        return ", ".join(parts) or "no change"

    def robot_identity(self, data: IaiData) -> dict[str, str]:
        """What 201H says the unit is: its model and unit codes and its version."""
        return identity_of(data.version)

    def contents(self, data: IaiData, *, registers: bool) -> str:
        """Positions, and the flags and variables read with them, each with the
        range it covered when the read probed it: ``42 positions in 1-1000 (none
        defined outside it)``; a controller's table smaller than the range is said:
        ``42 positions in 1-600 (the controller's table ends at 600, inside
        robot.yaml's 1-1000; none defined outside it)``."""
        kept = data.variables() if registers else {}
        held = {"positions": data.positions, **kept}
        parts = []
        for section, one, several in _KINDS.values():
            if section not in held:
                continue
            text = f"{len(held[section])} {one if len(held[section]) == 1 else several}"
            covered = data.covered.get(section)
            if covered is not None:
                text += f" in {covered.read_first}-{covered.read_last}"
                said = []
                if (covered.read_first, covered.read_last) != (covered.first, covered.last):
                    ends = (
                        [f"starts at {covered.start}"] if covered.read_first > covered.first else []
                    )
                    if covered.read_last < covered.last:
                        ends.append(f"ends at {covered.end}")
                    said.append(
                        f"the controller's table {' and '.join(ends)}, inside robot.yaml's "
                        f"{covered.first}-{covered.last}"
                    )
                if section == "positions":
                    said.append("none defined outside it")
                if said:
                    text += f" ({'; '.join(said)})"
            parts.append(text)
        return ", ".join(parts)

    def other_robot(self, live: IaiData, project: IaiData) -> str | None:
        """A controller whose "not there" reply before or past a table differs from
        the one the project's pull recorded (controller.yaml ``covered``), for the
        same range: another controller, or one that now answers otherwise."""
        for section, now in live.covered.items():
            was = project.covered.get(section)
            if was is not None:
                why = replies_differ(section, was, now)
                if why is not None:
                    return (
                        f"{why}; if it is this robot (its firmware or parameters changed), "
                        "a pull with --new-robot takes it as it answers now"
                    )
        return None

    def version(self, data: IaiData) -> str:
        v = data.version
        return f"model {v.model_code} unit {v.unit_code} version {v.version} built {v.built}"

    def plan(
        self,
        live: IaiData,
        project: IaiData,
        changes: list[Change3[Key]],
        *,
        registers: bool,
    ) -> PlanShape[Key]:
        return PlanShape(
            wanted=_writes(live, project, changes),
            unwritable=self._unwritable(project, changes, registers=registers),
        )

    def _unwritable(
        self, project: IaiData, changes: list[Change3[Key]], *, registers: bool
    ) -> list[str]:
        """Why each difference no write can fix cannot be written, one sentence each."""
        kept = project.variables()
        unwritable = []
        lacking = [section for section in VARIABLE_SECTIONS if section not in kept]
        if registers and lacking:
            unwritable.append(
                f"{', '.join(lacking)}: the project does not keep them; set keep_registers: true "
                "in robot.yaml and pull, or push without --registers"
            )
        for key, _, new in changes:
            if key.kind in _READ_ONLY_KINDS:
                section = _KINDS[key.kind][0]
                unwritable.append(
                    f"{self.describe(key)}: differs on the robot, and no message harlsync "
                    f"sends writes it (it reads it with {_RECORD_KINDS[key.kind]} only); "
                    f"change it on the controller, or pull to take the robot's in "
                    f"(records.yaml {section})"
                )
                continue
            if new is not None:
                continue
            if key.kind == "string":
                unwritable.append(
                    f"{self.describe(key)}: on the robot but not in records.yaml; pull to take "
                    "it in, or narrow robot.yaml controller.strings"
                )
            if key.kind == "position":
                unwritable.append(
                    f"{self.describe(key)}: defined on the robot but not in the project, and no "
                    "IAI protocol B message clears a position; clear it with the controller's own "
                    "tools (or add it to the project) and run again"
                )
            elif _KINDS[key.kind][0] in kept:
                section = _KINDS[key.kind][0]
                unwritable.append(
                    f"{self.describe(key)}: on the robot but not in variables.yaml; pull to take "
                    f"it in, or narrow robot.yaml controller.{section}"
                )
        return unwritable


def _writes(live: IaiData, project: IaiData, changes: list[Change3[Key]]) -> list[Change3[Key]]:
    """The writes of a plan, unsorted: each run of consecutive changed positions,
    integer or real variables as long as the receive buffer takes it, each changed
    row of string variable columns, each changed flag."""
    kept = project.variables()
    changed: dict[str, list[int]] = {section: [] for section, _, _ in _KINDS.values()}
    for key, _, new in changes:
        if new is not None and key.kind not in _RECORD_KINDS:
            if isinstance(key, Run):  # a plan's, never an item of a diff
                raise NotImplementedError
            changed[_KINDS[key.kind][0]].append(key.number)
    rows = [
        (key, old, new) for key, old, new in changes if key.kind == "string" and new is not None
    ]
    wanted: list[Change3[Key]] = []
    wanted += runs(
        "positions",
        changed["positions"],
        max_positions_per_write(project.model),
        live.positions,
        project.positions,
    )
    for section in ("integers", "reals"):
        limit = max_variables_per_write(project.model, section)
        wanted += runs(
            section,
            changed[section],
            limit,
            live.variables().get(section, {}),
            kept.get(section, {}),
        )
    wanted += rows  # each changed row of string variable columns with its own 24EH
    wanted += [
        (key, old, new) for key, old, new in changes if key.kind == "flag" and new is not None
    ]
    return wanted


CATALOGUE = IaiCatalogue()
