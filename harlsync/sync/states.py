"""A robot's three states, and what follows from them (docs/states.md).

::

    approved   the project's branch (HEAD): what engineers commit, what a push deploys
    deployed   what the last push or rollback wrote: refs/harlsync/deployed/<project>
    observed   what the last backup read: refs/heads/harlsync/backup

Each item where the robot (observed) differs from the project (approved), as
the one item diff (:func:`.items.diff_items`) finds it, is::

                     deployed == observed     deployed == approved     all three differ
    approved  A' --------------------------------------------------------------------
    deployed  A      A   (push not yet made)  A'                       A
    observed  A      A   -> pending           B   -> drift             B -> pending and drift

*pending*: approved, not yet on the robot (a push deploys it); *drift*: on the
robot, not from a push (a pendant edit, a program loaded by other means: a
push reverts it).  Each is kept with the night a backup first saw it and, for
a pending item, the commit and author that made it, in
``DIR/.harlsync/states.json`` (local, ignored by git, as backup.json is)::

    {"checked": "2026-11-25T02:00:41+00:00",  when the backup read the robot
     "approved": "<commit>", "deployed": "<commit>" | null, "observed": "<commit>" | null,
     "pending": [{"item": "MAIN program 0 step 2", "first_seen": "...",
                  "by": "alice, 1a2b3c4d5e 2026-11-24"}],
     "drift":   [{"item": "timer 3", "first_seen": "..."}],
     "notes":   ["what the first backup under this model set up"]}

Where there is no deployed ref yet (a project backed up by an older harlsync),
the last backup commit that older harlsync recorded stands for it
(:func:`deployed_commit`): the robot held it then, and every difference since is
either an engineer's commit or the robot's own.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, NamedTuple

from ..errors import HarlsyncError, ProjectError
from ..families.base import Catalogue, D, K
from ..project import statefile
from ..project.store import disk_error, replace_file
from . import backupref, git, history
from .items import Change, diff_items
from .plan import Plan

__all__ = [
    "LOOK_BACK",
    "Origin",
    "Seen",
    "Standing",
    "classify",
    "date_of",
    "deployed_commit",
    "introduced",
    "project_at",
    "read",
    "reverts",
    "write",
]

log = logging.getLogger(__name__)

_FILE = history.LOCAL_DIR / "states.json"
#: How many commits of a project's history are read to find when an item took its
#: value (who committed a pending item, the night a drift was first seen).
LOOK_BACK = 20


@dataclass(frozen=True)
class Seen:
    """One pending or drifted item: its name (the family's words), when a backup first
    saw it so, and for a pending item who committed it."""

    item: str
    first_seen: str
    by: str | None = None

    def describe(self) -> str:
        """``MAIN program 0 step 2 (first seen 2026-11-25, by alice, 1a2b3c4d5e 2026-11-24)``."""
        by = f", by {self.by}" if self.by else ""
        return f"{self.item} (first seen {date_of(self.first_seen)}{by})"


@dataclass
class Standing:
    """What a backup found of one robot's three states."""

    checked: str
    approved: str | None = None
    deployed: str | None = None
    observed: str | None = None
    pending: list[Seen] = field(default_factory=list)
    drift: list[Seen] = field(default_factory=list)
    #: What the backup set up or could not know, said once (a first backup under
    #: this model, an approved version that does not load).
    notes: list[str] = field(default_factory=list)

    @property
    def verdict(self) -> str:
        """``same as approved``, ``pending 2 items``, ``drift 1 item``, or both."""
        said = [
            f"{what} {len(found)} item{'s' * (len(found) != 1)}"
            for what, found in (("pending", self.pending), ("drift", self.drift))
            if found
        ]
        return ", ".join(said) or "same as approved"

    def lines(self) -> list[str]:
        """The items, a line each: ``drift: timer 3 (first seen 2026-11-25)``."""
        return [f"pending: {s.describe()}" for s in self.pending] + [
            f"drift: {s.describe()}" for s in self.drift
        ]

    def to_json(self) -> dict[str, object]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: object) -> Standing | None:
        """The record as :meth:`to_json` wrote it; None for anything else."""
        if not isinstance(data, dict):
            return None
        fields = statefile.Fields(data)

        def seen(name: str) -> list[Seen]:
            return [
                Seen(str(s["item"]), str(s.get("first_seen") or ""), s.get("by") or None)
                for s in fields.objects(name) or []
                if isinstance(s.get("item"), str)
            ]

        checked = fields.time("checked")
        if checked is None:
            return None
        return cls(
            checked,
            fields.text("approved"),
            fields.text("deployed"),
            fields.text("observed"),
            seen("pending"),
            seen("drift"),
            fields.texts("notes") or [],
        )


def read(project: Path) -> Standing | None:
    """What the last backup recorded of the robot's states (None: nothing, or a file
    that is not such a record, which the next backup writes anew)."""
    try:
        return Standing.from_json(statefile.load(project / _FILE))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        log.warning("%s: cannot be read (%s); the next backup writes it anew", project / _FILE, exc)
        return None


def write(project: Path, standing: Standing) -> None:
    """Record ``standing``.  Raises ProjectError when the disk refuses."""
    target = history.ensure_local_dir(project) / _FILE.name
    try:
        text = json.dumps(standing.to_json(), indent=2, sort_keys=True) + "\n"
        replace_file(target, text.encode("utf-8"))
    except OSError as exc:
        raise disk_error(exc, target, "record the robot's states") from exc


def date_of(stamp: str) -> str:
    """A recorded time as this machine's date: ``2026-11-25``."""
    try:
        return datetime.fromisoformat(stamp).astimezone().strftime("%Y-%m-%d")
    except ValueError:
        return stamp or "?"


def classify(
    catalogue: Catalogue[K, D], approved: D, deployed: D, observed: D
) -> tuple[list[Change[K]], list[Change[K]]]:
    """The pending and the drifted items, as changes from the robot (``old``, observed)
    to the project (``new``, approved): what a push would write.  An item changed on
    both sides since it was deployed is in both lists.  Runtime data never counts."""
    a, d, o = (catalogue.items(x, registers=False) for x in (approved, deployed, observed))
    differ = diff_items(catalogue, o, a)
    if not differ:
        return [], []
    moved = {c.key for c in diff_items(catalogue, d, o)}  # the robot, since deployed
    kept = {c.key for c in diff_items(catalogue, d, a)}  # the project, since deployed
    return [c for c in differ if c.key in kept], [c for c in differ if c.key in moved]


def project_at(path: Path, commit: str) -> Any:
    """The project ``path`` as ``commit`` holds it: its data.  Raises ProjectError."""
    from .revisions import version_of

    return version_of(path, commit).project.data


class Origin(NamedTuple):
    """The commit an item's value came from."""

    sha: str
    time: str  # the committer's, ISO 8601
    author: str

    def by(self) -> str:
        """``alice, 1a2b3c4d5e 2026-11-24``."""
        return f"{self.author}, {self.sha[:10]} {date_of(self.time)}"


def introduced(
    path: Path,
    catalogue: Catalogue[K, D],
    start: str,
    values: Mapping[K, object],
    *,
    limit: int = LOOK_BACK,
) -> dict[K, Origin]:
    """For each item of ``values`` (key -> value): the oldest commit of the unbroken
    run, back from ``start`` along first parents, whose project holds that value:
    the commit that made it (on the approved branch) or the night that first saw it
    (on the backup branch).  At most ``limit`` commits that changed the project
    are read; an item that held its value that far back gets the oldest of them.
    Items whose value even ``start`` does not hold, or that cannot be read, get none."""
    root = git.repo_root(path)
    if root is None or not values:
        return {}
    where = backupref.where_of(root, path)
    listing = git.run(
        root,
        "log",
        "--first-parent",
        f"-n{limit}",
        "--format=%H%x1f%cI%x1f%an",
        start,
        "--",
        where or ".",
        ok=(0, 128),
    )
    left = dict(values)
    found: dict[K, Origin] = {}
    newer: Origin | None = None
    for line in listing.splitlines():
        origin = Origin(*line.split("\x1f", 2))
        try:
            items = catalogue.items(project_at(path, origin.sha), registers=False)
        except HarlsyncError:
            break  # an older project that does not load: the run stops there
        gone = {c.key for c in diff_items(catalogue, {k: items.get(k) for k in left}, left)}
        for key in gone:
            if newer is not None:
                found[key] = newer
            del left[key]
        newer = origin
        if not left:
            break
    if newer is not None:
        found.update({key: newer for key in left})
    return found


def deployed_commit(root: Path, path: Path, where: str) -> tuple[str | None, str]:
    """The commit that holds what was last deployed to the robot of ``path``, and
    where it came from: its deployed ref, else (a project backed up by an older
    harlsync) the last backup commit its backup.json names, else none."""
    ref = backupref.deployed_ref(where)
    found = backupref.commit_of(root, ref)
    if found is not None:
        return found, ref
    last = history.read(path, []).get("last_commit")
    if isinstance(last, str):
        commit = git.resolve(root, last)
        if commit is not None and backupref.has_project(root, commit, where):
            return commit, "last backup"
    return None, ""


def reverts(
    path: Path, catalogue: Catalogue[K, D], live: D, items: list[Change[K]]
) -> dict[K, str]:
    """Which of ``items`` (a plan's, from the robot ``live``) revert a change made on
    the robot since the last push or rollback: key -> ``reverts a change made on the
    robot on 2026-11-25`` (the night a backup first read it; when none has, since
    the last push).  None when no deployed state is known, or git cannot tell."""
    try:
        root = git.repo_root(path)
        if root is None or not items:
            return {}
        where = backupref.where_of(root, path)
        commit, _ = deployed_commit(root, path, where)
        if commit is None:
            return {}
        deployed = catalogue.items(project_at(path, commit), registers=False)
        now = catalogue.items(live, registers=False)
        moved = {c.key for c in diff_items(catalogue, deployed, now)}
        drifted = {c.key: now.get(c.key) for c in items if c.key in moved}
        if not drifted:
            return {}
        backup = backupref.commit_of(root, backupref.BACKUP_REF)
        seen = introduced(path, catalogue, backup, drifted) if backup else {}
        since = date_of(backupref.commit_time(root, commit))
    except (HarlsyncError, OSError) as exc:
        log.warning("%s: cannot tell which items revert a change made on the robot: %s", path, exc)
        return {}
    return {
        key: (
            f"reverts a change made on the robot on {date_of(seen[key].time)}"
            if key in seen
            else f"reverts a change made on the robot since {since} (no backup has read it yet)"
        )
        for key in drifted
    }


def check_pending(path: Path, catalogue: Catalogue[K, D], live: D) -> list[str]:
    """The pending items a pull of ``live`` into ``path`` would overwrite: approved on
    the project's branch, not yet deployed, and not what the robot holds.  None
    outside git, or when nothing tells what was deployed."""
    root = git.repo_root(path)
    if root is None:
        return []
    where = backupref.where_of(root, path)
    head = backupref.commit_of(root, "HEAD")
    if head is None or not backupref.has_project(root, head, where):
        return []
    deployed, _ = deployed_commit(root, path, where)
    if deployed is None:
        return []
    if backupref.project_tree(root, head, where) == backupref.project_tree(root, deployed, where):
        return []  # approved is what was deployed: nothing is pending
    try:
        approved = project_at(path, head)
        was = project_at(path, deployed)
    except ProjectError as exc:
        log.warning("%s: cannot tell which items are pending: %s", path, exc)
        return []
    pending, _ = classify(catalogue, approved, was, live)
    return [c.name for c in pending]


def record_deployed(
    path: Path,
    files: Mapping[str, bytes],
    action: str,
    robot: str,
    written: list[str],
    reason: str | None,
) -> str | None:
    """Move the deployed ref of the robot of ``path`` to a commit of ``files`` (the
    project as a push or rollback that finished wrote it): its previous commit and,
    when it is what the approved HEAD holds, that commit too, are its parents.  The
    new commit (the old one when nothing changed); None outside git.  Raises
    SyncError (the ref moved meanwhile, git failed): the robot was written all the
    same, and the caller says so."""
    root = git.repo_root(path)
    if root is None:
        return None
    where = backupref.where_of(root, path)
    prefix = f"{where}/" if where else ""
    ref = backupref.deployed_ref(where)
    old = backupref.commit_of(root, ref)
    head = backupref.commit_of(root, "HEAD")
    # What the approved commit holds beside the project's YAML files (the schema
    # copies, a person's notes) is kept: a clean push's tree is the approved one.
    held = {
        n: e for n, e in backupref.entries(root, head, where).items() if not n.endswith(".yaml")
    }
    held.update(backupref.store_files(root, files))
    tree = backupref.write_tree(root, {prefix + n: e for n, e in held.items()})
    subtree = backupref.project_tree(root, tree, where)
    if old is not None and backupref.project_tree(root, old, where) == subtree:
        return old
    parents = [old] if old else []
    if head is not None and backupref.project_tree(root, head, where) == subtree:
        parents.append(head)
    who = f"{audit_user()}"
    lines = [f"{action}: {robot}: {len(written)} item(s) written by {who}", ""]
    if reason:
        lines += [f"reason: {reason}", ""]
    lines += [f"  {item}" for item in statefile.fold(written, history.NAMED)]
    commit = backupref.make_commit(root, tree, parents, "\n".join(lines) + "\n")
    backupref.update_refs(root, [backupref.RefUpdate(ref, commit, old)], f"harlsync {action}")
    return commit


def audit_user() -> str:
    """``alice@plant-pc``: who a push's record says made it."""
    from . import audit

    record = audit.base_record("push")
    return f"{record.user}@{record.host}"


def mark_reverts(path: Path, live: object, plan: Plan[K]) -> Plan[K]:
    """``plan`` (made from the robot ``live``) with :attr:`Plan.reverts` filled in
    from :func:`reverts`; the same plan."""
    found = reverts(path, plan_catalogue(plan), live, plan.items) if plan.items else {}
    plan.reverts = {change.name: found[change.key] for change in plan.items if change.key in found}
    return plan


def plan_catalogue(plan: Plan[K]) -> Catalogue[K, Any]:
    return plan.items[0].catalogue
