"""A push plan: the exact writes that would make the robot equal the project.

A plan is computed from the live robot and the project, in the family's safe
order (the catalogue's ``order``).  It carries a fingerprint of the live state and of the project it was
computed from, so a saved plan can be refused when either changed since (a
stale plan).

The family decides what cannot be written and whether the plan reconfigures
the robot destructively (a write that wipes what follows it, which such a
plan then rewrites); the engine asks for
``--allow-reconfigure`` before such a plan.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Generic

from ..errors import ProjectFormatError
from ..families.base import Catalogue, Change3, D, Driver, K
from ..project import statefile
from ..project.robot import Robot
from . import git
from .items import Change, diff, render_text

__all__ = [
    "PLAN_FORMAT",
    "Plan",
    "PlannedWrite",
    "covered",
    "fingerprint",
    "make_plan",
    "policy_refusals",
]

PLAN_FORMAT = 1


@dataclass(frozen=True)
class PlannedWrite(Generic[K]):
    """One write: the item, what the robot holds, what it will hold, the wire command."""

    key: K
    old: object
    new: object
    command: str
    unsafe: bool
    #: the item's name for people: ``MAIN program 2 step 3``
    name: str
    #: the items of the diff this write changes (one, or a run of positions), as
    #: ``diff`` shows them; a write of an item that did not differ (a step rewritten
    #: after a reconfiguration) is its own change
    items: tuple[Change[K], ...] = ()


@dataclass
class Plan(Generic[K]):
    """What a push would do to one robot."""

    robot: str
    target: str
    live_fingerprint: str
    project_fingerprint: str
    changes: list[Change[K]]
    writes: list[PlannedWrite[K]]
    #: The refusal a push of this plan gives without --allow-reconfigure, when the
    #: plan holds a destructive reconfiguration (and the line a printed plan starts with).
    reconfiguration: str | None = None
    reconfiguration_note: str | None = None
    #: Differences no write can fix (timer, memory bit, register counts).
    unwritable: list[str] = field(default_factory=list)
    #: What the family says of these writes (items that go to a memory card,
    #: say); a push's result and audit record carry it too.
    notes: list[str] = field(default_factory=list)
    #: The items whose write reverts a change made on the robot since the last push
    #: or rollback (drift, :mod:`.states`): name -> ``reverts a change made on the
    #: robot on 2026-11-25``.
    reverts: dict[str, str] = field(default_factory=dict)

    @property
    def reconfigure(self) -> bool:
        return self.reconfiguration is not None

    @property
    def empty(self) -> bool:
        return not self.writes

    @property
    def items(self) -> list[Change[K]]:
        """The changes of the diff that the writes make, in push order: what a person
        confirms (one write of a run of items makes several, each one item)."""
        return [c for w in self.writes for c in w.items]

    @property
    def commands(self) -> list[str]:
        return [w.command for w in self.writes]

    @property
    def counted(self) -> str:
        """``5 item(s) in 2 write(s)``: the items as diff counts them, and the writes."""
        items, writes = len(self.items), len(self.writes)
        return f"{items} item(s) in {writes} write(s)" if items != writes else f"{items} item(s)"

    def lines(self, verbose: int = 0) -> list[str]:
        """What a push of this plan writes, as ``diff`` shows it, item by item, as
        ``plan`` prints it; with ``verbose`` each write's wire command too."""
        lines = [f"# cannot write: {line}" for line in self.unwritable]
        if self.reconfiguration_note:
            lines.append(f"# {self.reconfiguration_note}")
        lines += [f"# note: {note}" for note in self.notes]
        if self.items:
            lines += render_text(self.items, "", "").splitlines()[2:]
        lines += [f"# {name}: {said}" for name, said in self.reverts.items()]
        for write in self.writes if verbose else ():
            flag = "  # unsafe in automatic operation" if write.unsafe else ""
            lines.append(f"# {write.name}: {write.command}{flag}")
        return [*lines, f"# {self.counted} to {self.robot} ({self.target})"]

    def to_json(self) -> dict[str, object]:
        return {
            "format": PLAN_FORMAT,
            "robot": self.robot,
            "target": self.target,
            "live_fingerprint": self.live_fingerprint,
            "project_fingerprint": self.project_fingerprint,
            "reconfigure": self.reconfigure,
            "unwritable": self.unwritable,
            "notes": self.notes,
            "commands": self.commands,
        }

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n", encoding="utf-8")

    @staticmethod
    def load_saved(path: str | Path) -> dict[str, object]:
        """A saved plan's data.  Raises ProjectFormatError when unreadable."""
        try:
            data = statefile.load(Path(path))
        except OSError as exc:
            raise ProjectFormatError(
                f"{path}: cannot read the plan ({exc.strerror or exc}); give the file "
                "'harlsync plan DIR --out FILE' saved"
            ) from exc
        except ValueError as exc:
            raise ProjectFormatError(
                f"{path}: not a harlsync plan ({exc}); make a new one with "
                "'harlsync plan DIR --out FILE'"
            ) from exc
        if not isinstance(data, dict) or data.get("format") != PLAN_FORMAT:
            raise ProjectFormatError(
                f"{path}: not a harlsync plan of format {PLAN_FORMAT}; make a new one with "
                "'harlsync plan DIR --out FILE'"
            )
        fields = statefile.Fields(data)
        for name in ("live_fingerprint", "project_fingerprint"):
            if fields.text(name) is None:
                fields.problems.append(f"{name} is missing")
        if fields.problems:
            raise ProjectFormatError(
                f"{path}: not a whole harlsync plan ({'; '.join(fields.problems)}); make a "
                "new one with 'harlsync plan DIR --out FILE'"
            )
        return data


def _canonical(value: object) -> object:
    if hasattr(value, "__dataclass_fields__"):
        return {k: _canonical(getattr(value, k)) for k in value.__dataclass_fields__}
    if isinstance(value, tuple | list):
        return [_canonical(v) for v in value]
    return value


def fingerprint(catalogue: Catalogue[K, D], data: D, *, registers: bool = False) -> str:
    """A hash of every item (and the version), stable across runs and machines."""
    flat = sorted(
        (json.dumps(_canonical(k)), _canonical(v))
        for k, v in catalogue.items(data, registers=registers).items()
    )
    text = json.dumps([catalogue.version(data), flat], sort_keys=True, separators=(",", ":"))
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def covered(
    catalogue: Catalogue[K, D], changes: list[Change[K]], wanted: list[Change3[K]]
) -> list[tuple[Change[K], ...]]:
    """For each write (key, old, new) of ``wanted``, in order, the changes of the diff it
    makes.

    A write of one item is keyed as its change is.  A write of a run of items (items
    3-7 of a table, written by one request) carries a tuple of their new values, in order:
    each is matched to the first change not yet matched, of the same group, whose new
    value it is.  A write that matches no change is its own.
    """
    by_key = {c.key: c for c in changes}
    taken: set[int] = set()
    found: list[tuple[Change[K], ...]] = []
    for key, old, new in wanted:
        if key in by_key:
            found.append((by_key[key],))
            taken.add(id(by_key[key]))
            continue
        mine: list[Change[K]] = []
        if isinstance(new, tuple):
            group = catalogue.group(key)
            for value in new:
                candidates = [
                    c for c in changes if id(c) not in taken and catalogue.group(c.key) == group
                ]
                match = next((c for c in candidates if c.new is value), None) or next(
                    (c for c in candidates if c.new == value), None
                )
                if match is not None:
                    taken.add(id(match))
                    mine.append(match)
        if not mine and not isinstance(new, tuple):
            mine = [Change(key, old, new, catalogue)]
        found.append(tuple(mine))
    return found


def make_plan(
    catalogue: Catalogue[K, D],
    live: D,
    project: D,
    driver: Driver[K, D],
    *,
    robot: str,
    registers: bool = False,
) -> Plan[K]:
    """The writes that turn ``live`` into ``project``, in the safe order."""
    changes = diff(catalogue, live, project, registers=registers)
    shape = catalogue.plan(
        live, project, [(c.key, c.old, c.new) for c in changes], registers=registers
    )
    wanted = sorted(shape.wanted, key=lambda w: catalogue.order(w[0]))
    items = covered(catalogue, changes, wanted)
    writes = [
        PlannedWrite(
            key,
            old,
            new,
            driver.command(key, new),
            driver.unsafe(key),
            catalogue.describe(key),
            items[n],
        )
        for n, (key, old, new) in enumerate(wanted)
    ]
    return Plan(
        robot=robot,
        target=driver.label,
        live_fingerprint=fingerprint(catalogue, live, registers=registers),
        project_fingerprint=fingerprint(catalogue, project, registers=registers),
        changes=changes,
        writes=writes,
        reconfiguration=shape.reconfigure,
        reconfiguration_note=shape.reconfigure_note,
        unwritable=shape.unwritable,
        notes=shape.notes,
    )


def policy_refusals(path: Path, robot: Robot, now: datetime | None = None) -> list[str]:
    """Why a push of the project at ``path`` would be refused now besides the robot's
    state, each as a sentence: uncommitted changes, outside the maintenance windows.
    For ``plan`` to list every reason at once (the push stops at the first)."""
    found = []
    dirty = git.changed_files(path)
    if git.repo_root(path) is None:
        found.append(f"{path} is not in a git repository (give --allow-dirty, or commit it)")
    elif dirty:
        shown = ", ".join(dirty[:3]) + (", ..." if len(dirty) > 3 else "")
        found.append(
            f"{path} has uncommitted changes ({shown}): commit them, or give --allow-dirty"
        )
    moment = now or datetime.now()
    if not robot.in_window(moment):
        windows = "; ".join(str(w) for w in robot.windows)
        found.append(
            f"{moment:%a %H:%M} is outside its maintenance windows ({windows}): wait for a "
            "window or give --outside-window REASON"
        )
    return found
