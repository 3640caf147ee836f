"""Robot content as items keyed by identity, and the differences between two robots.

An item is the smallest thing one write changes: the program configuration, the
parameter block, one offset table, one timer, one register, one program step.
Its key is its identity, never its position in a list::

    ("config",)  ("parameters",)  ("offset", 7)  ("timer", 3)  ("register", 1)
    ("step", "MAIN", 2, 3)

Two robots are compared item by item, matched by key, in push order:
configuration, parameters, tables, timers, registers, then programs (START, MAIN,
SUB, HAND, by number and step).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from ..families.harl_u2.model import OFFSET_FIELDS, Config, OffsetTable, Parameters, ProgramType, RobotData, Step

__all__ = [
    "Change",
    "Key",
    "describe",
    "diff",
    "items",
    "push_order",
    "render_text",
    "summarize",
    "to_json",
]

Key = tuple[Any, ...]

_KIND_ORDER = {"config": 0, "parameters": 1, "offset": 2, "timer": 3, "register": 4, "step": 5}
_TYPE_ORDER = {t.value: i for i, t in enumerate(ProgramType)}


def push_order(key: Key) -> tuple[int, ...]:
    """Sort key: configuration first, programs last (the safe order of a push)."""
    kind = key[0]
    if kind == "step":
        return (_KIND_ORDER[kind], _TYPE_ORDER[key[1]], key[2], key[3])
    return (_KIND_ORDER[kind], *key[1:])


def items(data: RobotData, *, registers: bool = True) -> dict[Key, Any]:
    """Every item of ``data`` by key; empty program steps are left out."""
    out: dict[Key, Any] = {("config",): data.config, ("parameters",): data.parameters}
    for n, table in data.offsets.items():
        out[("offset", n)] = table
    for n, value in data.timers.items():
        out[("timer", n)] = value
    if registers and data.registers is not None:
        for n, value in data.registers.items():
            out[("register", n)] = value
    for (ptype, number), steps in data.programs.items():
        for n, step in steps.items():
            if not step.empty:
                out[("step", ptype.value, number, n)] = step
    return out


def describe(key: Key) -> str:
    """A person's name for an item: ``MAIN program 2 step 3``, ``offset table 7``."""
    kind = key[0]
    if kind == "step":
        _, ptype, number, step = key
        return f"START program step {step}" if ptype == "START" else f"{ptype} program {number} step {step}"
    if kind == "offset":
        return f"offset table {key[1]}"
    if kind in ("timer", "register"):
        return f"{kind} {key[1]}"
    return {"config": "program configuration", "parameters": "expanded parameters"}[kind]


@dataclass(frozen=True)
class Change:
    """One item that differs: ``old`` is what the robot holds, ``new`` what the project says.

    ``None`` stands for an empty step (or an item the other side does not have).
    """

    key: Key
    old: Any
    new: Any

    @property
    def name(self) -> str:
        return describe(self.key)

    def fields(self) -> list[tuple[str, str | None, str | None]]:
        """The change field by field, ``(field, old text, new text)``, only what differs."""
        old, new = self.old, self.new
        if self.key[0] == "step":
            return [("", _text(old), _text(new))]
        if isinstance(new, OffsetTable) or isinstance(old, OffsetTable):
            pairs = [(f, _attr(old, f), _attr(new, f)) for f in OFFSET_FIELDS]
        elif isinstance(new, Parameters) or isinstance(old, Parameters):
            names = (new or old).as_dict().keys()
            pairs = [(f, _attr(old, f), _attr(new, f)) for f in names]
        elif isinstance(new, Config) or isinstance(old, Config):
            pairs = [(f, _config_field(old, f), _config_field(new, f)) for f in _CONFIG_FIELDS]
        else:
            pairs = [("", _text(old), _text(new))]
        return [(f, a, b) for f, a, b in pairs if a != b]


_CONFIG_FIELDS = tuple(
    f"{t.value.lower()}.{part}" for t in ProgramType for part in ("count", "steps")
) + ("timers", "memory_bits", "registers")


def _config_field(cfg: Config | None, name: str) -> str | None:
    if cfg is None:
        return None
    if "." in name:
        ptype, part = name.split(".")
        return str(getattr(cfg.area(ProgramType(ptype.upper())), part))
    return str(getattr(cfg, name))


def _attr(obj: Any, name: str) -> str | None:
    return None if obj is None else str(getattr(obj, name))


def _text(value: Any) -> str | None:
    if value is None:
        return None
    return value.text if isinstance(value, Step) else str(value)


def diff(live: RobotData, project: RobotData, *, registers: bool = False) -> list[Change]:
    """Every item that differs between the robot and the project, in push order.

    The version is the controller's own and is never compared.  Registers are
    compared only when asked (they are runtime data).
    """
    a = items(live, registers=registers)
    b = items(project, registers=registers)
    keys = sorted(a.keys() | b.keys(), key=push_order)
    return [Change(k, a.get(k), b.get(k)) for k in keys if a.get(k) != b.get(k)]


def summarize(changes: Iterable[Change]) -> dict[str, int]:
    """How much changed: programs, steps, tables, timers, registers, parameters, config."""
    changes = list(changes)
    programs = {c.key[1:3] for c in changes if c.key[0] == "step"}
    count = {"programs": len(programs), "steps": 0, "tables": 0, "timers": 0,
             "registers": 0, "parameters": 0, "config": 0}
    plural = {"step": "steps", "offset": "tables", "timer": "timers", "register": "registers"}
    for c in changes:
        kind = c.key[0]
        if kind in plural:
            count[plural[kind]] += 1
        else:
            count[kind] += len(c.fields())
    return count


def to_json(change: Change) -> dict[str, Any]:
    """A change as plain JSON data: identity fields, then old and new per field."""
    kind = change.key[0]
    ident: dict[str, Any] = {"kind": kind, "item": change.name}
    if kind == "step":
        ident.update(program_type=change.key[1], program=change.key[2], step=change.key[3])
    elif kind in ("offset", "timer", "register"):
        ident["number"] = change.key[1]
    ident["fields"] = [
        {"field": f or None, "old": old, "new": new} for f, old, new in change.fields()
    ]
    return ident


def _group(key: Key) -> str:
    kind = key[0]
    if kind == "step":
        return "START program" if key[1] == "START" else f"{key[1]} program {key[2]}"
    return {"timer": "timers", "register": "registers"}.get(kind, describe(key))


def _label(change: Change, field: str) -> str:
    kind = change.key[0]
    if kind == "step":
        return str(change.key[3])
    if kind in ("timer", "register"):
        return str(change.key[1])
    return field


def render_text(changes: list[Change], old_label: str, new_label: str) -> str:
    """The changes as a unified-diff-like text: ``-`` the robot, ``+`` the project."""
    lines = [f"--- {old_label}", f"+++ {new_label}"]
    group = None
    for change in changes:
        if _group(change.key) != group:
            group = _group(change.key)
            lines.append(f"@@ {group} @@")
        for field, old, new in change.fields():
            label = _label(change, field)
            if old is not None:
                lines.append(f"-{label}: {old}")
            if new is not None:
                lines.append(f"+{label}: {new}")
    return "\n".join(lines) + "\n"
