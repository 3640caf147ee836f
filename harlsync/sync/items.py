"""The differences between two robots, item by item, for any family.

An item is the smallest thing one write changes; the family's
:class:`~harlsync.families.base.Catalogue` says what the items of its data are,
their keys (identity, never a position in a list), their names and their safe
push order.  Two robots are compared item by item, matched by key::

    live  {key: value}  ---+
                           +--> [Change(key, old, new), ...]  in push order
    project {key: value} --+

``old`` is what the robot holds, ``new`` what the project says; ``None`` stands
for an item one side does not have (an empty step, an undefined position).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Generic

from ..alignment import Shift, align
from ..families.base import Catalogue, Change3, D, K

__all__ = ["Change", "Differences", "diff", "diff_items", "render_text", "summarize", "to_json"]


@dataclass(frozen=True)
class Change(Generic[K]):
    """One item that differs: ``old`` is what the robot holds, ``new`` what the project says."""

    key: K
    old: object
    new: object
    catalogue: Catalogue[K, Any] = field(compare=False, repr=False)

    @property
    def name(self) -> str:
        return self.catalogue.describe(self.key)

    def fields(self) -> list[tuple[str, str | None, str | None]]:
        """The change field by field, ``(field, old text, new text)``, only what differs."""
        return self.catalogue.fields(self.key, self.old, self.new)


def diff(
    catalogue: Catalogue[K, D], live: D, project: D, *, registers: bool = False
) -> list[Change[K]]:
    """Every item that differs between the robot and the project, in push order.

    Runtime data (registers, variables) is compared only when asked.
    """
    return diff_items(
        catalogue,
        catalogue.items(live, registers=registers),
        catalogue.items(project, registers=registers),
    )


def diff_items(
    catalogue: Catalogue[K, D], a: Mapping[K, object], b: Mapping[K, object]
) -> list[Change[K]]:
    """:func:`diff` of two robots' items (:meth:`Catalogue.items`), already taken.

    Only the items that differ are put in push order: a full-size robot has some
    12,700 items and a pull again usually changes none."""
    other = b.get
    differ = [k for k, value in a.items() if value != other(k)]  # as a.get(k) != b.get(k)
    differ += [k for k, value in b.items() if k not in a and value is not None]
    differ.sort(key=catalogue.order)
    return [Change(k, a.get(k), b.get(k), catalogue) for k in differ]


def _triples(changes: Iterable[Change[K]]) -> list[Change3[K]]:
    return [(c.key, c.old, c.new) for c in changes]


def summarize(catalogue: Catalogue[K, D], changes: Iterable[Change[K]]) -> dict[str, int]:
    """How much changed, in the family's units."""
    return catalogue.counts(_triples(changes))


def change_summary(changes: list[Change[K]]) -> str:
    """``"2 programs (5 steps), 1 table, 3 timers"``, or ``"no change"``."""
    if not changes:
        return "no change"
    return changes[0].catalogue.summary(_triples(changes))


def differ_words(changes: list[Change[K]]) -> str:
    """``; 3 items differ (1 program (2 steps), 1 timer)``, or ``; no differences``."""
    if not changes:
        return "; no differences"
    n = len(changes)
    return f"; {n} item{'s' * (n != 1)} differ{'s' * (n == 1)} ({change_summary(changes)})"


@dataclass
class Differences:
    """Two sides compared item by item, as ``diff`` prints them: :meth:`render` the
    text (``-`` lines the ``old`` side), :meth:`to_json` its ``--format json``."""

    changes: list[Change[Any]]
    old: str
    new: str
    #: what the JSON says first: the robot, and what was compared
    about: dict[str, object] = field(default_factory=dict)

    def to_json(self) -> dict[str, object]:
        """``about``, whether the two sides are identical, the summary, each change."""
        return {
            **self.about,
            "identical": not self.changes,
            "summary": change_summary(self.changes),
            "changes": [to_json(c) for c in self.changes],
        }

    def render(self) -> str:
        """The changes as :func:`render_text` shows them; nothing when there are none."""
        return render_text(self.changes, self.old, self.new) if self.changes else ""


def to_json(change: Change[K]) -> dict[str, object]:
    """A change as plain JSON data: identity fields, then old and new per field."""
    identity = change.catalogue.identity(change.key)
    ident: dict[str, object] = {"kind": identity.pop("kind"), "item": change.name, **identity}
    ident["fields"] = [
        {"field": f or None, "old": old, "new": new} for f, old, new in change.fields()
    ]
    return ident


def render_text(changes: list[Change[K]], old_label: str, new_label: str) -> str:
    """The changes as a unified-diff-like text: ``-`` the robot, ``+`` the project.

    A sequence (a program's steps, :meth:`Catalogue.position`) is aligned: an item
    inserted, deleted or moved shows as that, under a header that says which numbers
    it shifts (``@@ MAIN program 0: insert at 4 (steps 4-16 move to 5-17) @@``); the
    items that only moved along are not shown as changed.
    """
    lines = [f"--- {old_label}", f"+++ {new_label}"]
    shifts: dict[str, list[Shift]] = {}
    if changes:
        for shift in align(changes[0].catalogue, _triples(changes)):
            shifts.setdefault(shift.group, []).append(shift)
    group = None
    for change in changes:
        catalogue = change.catalogue
        here = catalogue.group(change.key)
        where = catalogue.position(change.key)
        if here in shifts and where is not None:
            if here != group:
                group = here
                _shifted(lines, here, shifts[here], changes)
            continue
        if here != group:
            group = here
            lines.append(f"@@ {group} @@")
        for name, old, new in change.fields():
            label = catalogue.label(change.key, name)
            if old is not None:
                lines.append(f"-{label}: {old}")
            if new is not None:
                lines.append(f"+{label}: {new}")
    return "\n".join(lines) + "\n"


def _shifted(lines: list[str], group: str, shifts: list[Shift], changes: list[Change[K]]) -> None:
    """An aligned sequence: each shift under its own header, then the changes in
    place that no shift covers (a step edited where it is)."""
    covered: set[int] = set()
    for shift in shifts:
        moved = f" ({'; '.join(shift.moved)})" if shift.moved else ""
        lines.append(f"@@ {group}: {shift.what}{moved} @@")
        lines += [f"{sign}{n}: {text}" for sign, n, text in shift.lines]
        covered.update(shift.rewrites)
    rest = [
        c
        for c in changes
        if c.catalogue.group(c.key) == group
        and (where := c.catalogue.position(c.key)) is not None
        and where[1] not in covered
    ]
    if rest:
        lines.append(f"@@ {group} @@")
    for change in rest:
        for name, old, new in change.fields():
            label = change.catalogue.label(change.key, name)
            if old is not None:
                lines.append(f"-{label}: {old}")
            if new is not None:
                lines.append(f"+{label}: {new}")
