"""A nightly backup under the three-state model (docs/states.md): the robot is
read, compared with the approved version and the deployed one, and kept on the
backup branch; the project's branch and its working tree are never touched.

Per robot (in a worker process, :func:`read_robot`)::

    robot.yaml (work tree) --> read the robot (identity checked against what was
                               observed before, or what is approved)
    live --> render its files --> git objects (hash-object -w): its tree entries
         --> against the last observed (harlsync/backup): what changed tonight
         --> against approved (HEAD) and deployed (its ref): pending and drift

Once for the run (in the process that started it, :func:`.backupcommit.commit_observed`)::

    harlsync/backup's tree, each robot read replaced --> write-tree --> commit-tree
    --> update-ref refs/heads/harlsync/backup; a robot with no deployed ref yet gets
    one (what its first backup under this model took as deployed, and says so)

A project that is not in git, or whose approved branch does not hold it yet (a
robot being set up), is pulled into its directory as before: there is no
approved version to keep apart from the robot's own.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Generic, TypedDict

from ..errors import PolicyError, ProjectError, ProjectInvalid, SyncError
from ..families.base import AnyFamily, Catalogue, D, Family, K, Progress
from ..project import load_robot
from ..project.robot import Robot
from ..project.store import SCHEMAS_DIR
from . import backupref, git, history, states
from .backupcommit import Kept
from .backupref import Entry
from .items import Change, diff, diff_items
from .live import LiveRead, read_live
from .pulling import PullResult, pull

if TYPE_CHECKING:  # for the checker only: not imported at run time
    from typing_extensions import NotRequired, Unpack

__all__ = ["Observed", "read_robot"]

log = logging.getLogger(__name__)


@dataclass
class Observed(PullResult):
    """A backup's read of a robot in git: what :class:`PullResult` says (changes are
    since the last observed), and what the run commits of it."""

    root: str = ""
    where: str = ""
    #: the project's files as read, path (relative to the project) -> [mode, blob]
    files: dict[str, list[str]] = field(default_factory=dict)
    standing: states.Standing | None = None
    #: no deployed ref yet: the commit taken as deployed ("" : what was read tonight)
    setup: str | None = None

    def kept(self) -> Kept:
        """What the run's commit needs, as JSON (it crosses from a worker process)."""
        return {"root": self.root, "where": self.where, "files": self.files, "setup": self.setup}


class ReadOptions(TypedDict):
    """What :func:`read_robot` passes on to a pull or an observation."""

    lock_timeout: float
    family: AnyFamily
    progress: NotRequired[Progress | None]
    connect_options: NotRequired[Mapping[str, bool] | None]
    noted: NotRequired[Callable[[str], None] | None]


def read_robot(path: Path, **options: Unpack[ReadOptions]) -> PullResult:
    """Back up the robot of ``path``: :func:`_observe` it when git holds an approved
    version of it, else :func:`.pulling.pull` it into its directory.  ``options``
    are a pull's (``lock_timeout``, ``progress``, ``family``, ``connect_options``,
    ``noted``)."""
    root = git.repo_root(path)
    head = backupref.commit_of(root, "HEAD") if root is not None else None
    if root is None or head is None:
        return pull(path, **options)
    where = backupref.where_of(root, path)
    if not backupref.has_project(root, head, where):
        return pull(path, **options)
    branch = git.run(root, "symbolic-ref", "--quiet", "HEAD", ok=(0, 1)).strip()
    if branch == backupref.BACKUP_REF:
        raise SyncError(
            f"{root}: the branch {backupref.BACKUP_BRANCH} is checked out, so nothing tells "
            "what is approved; check the project's branch out again (git checkout main, or "
            "the one engineers commit on) and run the backup again"
        )
    return _observe(path, root, where, head, **options)


def _observe(
    path: Path,
    root: Path,
    where: str,
    head: str,
    *,
    lock_timeout: float,
    progress: Progress | None = None,
    family: Family[K, D],
    connect_options: Mapping[str, bool] | None = None,
    noted: Callable[[str], None] | None = None,
) -> Observed:
    """Read the robot of ``path`` held to what was observed before (or approved), and
    store its files as git objects: what changed since, and its three states."""
    from .pulling import _same_robot

    robot = load_robot(path, family)
    things = family.catalogue
    tip = backupref.commit_of(root, backupref.BACKUP_REF)
    seen: _Observing[D] = _Observing(
        path, root, where, head, _last_observed(root, path, where, tip, head)
    )
    read = seen.read(family, robot, progress, lock_timeout, connect_options, noted)
    live = read.live
    seen.accepted(lambda data: _same_robot(path, things, data, live, read.driver.label))
    previous = seen.data_at(seen.last)
    changes = (
        None if previous is None else diff(things, previous, live, registers=robot.keep_registers)
    )
    stored = backupref.store_files(root, _files(path, family, robot, live))
    result = Observed(
        path,
        robot,
        changes,
        contents=things.contents(live, registers=robot.keep_registers),
        root=str(root),
        where=where,
        files={name: [e.mode, e.oid] for name, e in stored.items()},
    )
    if previous is not None:  # files rewritten with no item changed: a migration, said
        _note_rewritten(result, root, seen.last, where, stored, family.format)
    now = datetime.now(timezone.utc).isoformat(timespec="seconds")
    result.standing, result.setup = _standing(
        path, root, where, head, tip, things, live, seen.data_at, now
    )
    history.record(path, ok=True, changed=result.changed, changes=result.summary)
    if not result.changed:
        history.committed(path, seen.last)  # it holds what was read
    return result


@dataclass
class _Observing(Generic[D]):
    """One robot's read in a nightly backup: the projects it is held to, at the commit
    last observed (``last``) and the approved one (``head``), each loaded once a tree."""

    path: Path
    root: Path
    where: str
    head: str
    last: str
    loaded: dict[str, D | None] = field(default_factory=dict)

    def data_at(self, commit: str) -> D | None:
        """The project at ``commit`` (None: it does not load), read once a tree."""
        tree = backupref.project_tree(self.root, commit, self.where) or commit
        if tree not in self.loaded:
            try:
                self.loaded[tree] = states.project_at(self.path, commit)
            except ProjectError as exc:
                log.warning("%s", exc)
                self.loaded[tree] = None
        return self.loaded[tree]

    def accepted(self, check: Callable[[D], object]) -> None:
        """``check`` against the robot last observed; failing, against the approved
        one: a robot an engineer accepted (``pull --new-robot``, committed) is it."""
        try:
            previous = self.data_at(self.last)
            if previous is not None:
                check(previous)
        except PolicyError:
            approved = self.data_at(self.head)
            if self.last == self.head or approved is None:
                raise
            check(approved)

    def read(
        self,
        family: Family[K, D],
        robot: Robot,
        progress: Progress | None,
        lock_timeout: float,
        connect_options: Mapping[str, bool] | None,
        noted: Callable[[str], None] | None,
    ) -> LiveRead[K, D]:
        """Everything the robot holds, its identity checked first where the family
        tells it, held to what the last backup found (issue 29)."""
        from .pulling import _identity_differs, _not_this_robot, _record_notes

        def same_identity(now: Mapping[str, str], where_read: str) -> None:
            def check(data: D) -> None:
                differ = _identity_differs(family.catalogue.robot_identity(data), now)
                if differ:
                    raise _not_this_robot(self.path, where_read, differ)

            self.accepted(check)

        return read_live(
            family,
            robot,
            None,
            None,
            registers=robot.keep_registers,
            progress=progress,
            lock_timeout=lock_timeout,
            options=connect_options,
            whole=True,
            noted=partial(_record_notes, self.path, robot, None, None, noted),
            identified=same_identity,
        )


def _note_rewritten(
    result: Observed, root: Path, last: str, where: str, stored: Mapping[str, Entry], current: int
) -> None:
    """Note in ``result`` the files stored otherwise than the last observed commit
    held them (robot.yaml aside: a person's file), and which of them a migration from
    an older format rewrote."""
    from .pulling import _migrated

    before = backupref.entries(root, last, where)
    result.written = sorted(
        name for name, entry in stored.items() if name != "robot.yaml" and before.get(name) != entry
    )
    was = git.read_blobs(root, [before[n].oid for n in result.written if n in before])
    _migrated(result, {n: was[before[n].oid] for n in result.written if n in before}, current)


def _last_observed(root: Path, path: Path, where: str, tip: str | None, head: str) -> str:
    """The commit that holds what the robot held at its last backup: the backup
    branch's; before there is one, the last backup commit an older harlsync
    recorded (on the approved branch); else the approved one."""
    if tip is not None and backupref.has_project(root, tip, where):
        return tip
    last = history.read(path, []).get("last_commit")
    if isinstance(last, str):
        commit = git.resolve(root, last)
        if commit is not None and backupref.has_project(root, commit, where):
            return commit
    return head


def _files(path: Path, family: Family[K, D], robot: Robot, live: D) -> dict[str, bytes]:
    """The project's files as a save would write them of ``live``, robot.yaml as the
    work tree has it (a person's file).  Raises ProjectInvalid as a save does."""
    texts = family.render_files(robot, live)
    files = {name: text.encode("utf-8") for name, text in texts.items()}
    issues = family.data_problems(live) + [str(i) for i in family.analyse(files).issues]
    if issues:
        raise ProjectInvalid(issues)
    files["robot.yaml"] = (path / "robot.yaml").read_bytes()
    for name, text in family.schemas().items():
        files[f"{SCHEMAS_DIR}/{name}"] = text.encode("utf-8")
    return files


def _standing(
    path: Path,
    root: Path,
    where: str,
    head: str,
    tip: str | None,
    things: Catalogue[K, D],
    live: D,
    data_at: Callable[[str], D | None],
    now: str,
) -> tuple[states.Standing, str | None]:
    """The robot's three states compared, and the deployed ref to set up (None: it
    has one; ``""``: tonight's read; else the commit taken as deployed)."""
    standing = states.Standing(now, approved=head)
    approved = data_at(head)
    if approved is None:
        standing.notes.append(
            f"the approved version (commit {head[:10]}) does not load: pending and drift "
            f"unknown; 'harlsync validate {path}' says why"
        )
        return standing, None
    deployed_commit, how = states.deployed_commit(root, path, where)
    was = data_at(deployed_commit) if deployed_commit is not None else None
    setup: str | None = None
    if deployed_commit is None or was is None:
        setup, deployed = _take_as_deployed(standing, where, head, things, live, approved)
    else:
        deployed = was
        if how != backupref.deployed_ref(where):
            setup = deployed_commit
            standing.notes.append(
                f"set up {backupref.deployed_ref(where)}: the last backup commit "
                f"{deployed_commit[:10]} "
                f"({states.date_of(backupref.commit_time(root, deployed_commit))}, made before "
                "backups were kept apart from the approved branch) is taken as deployed"
            )
    standing.deployed = deployed_commit if setup is None else (setup or None)
    pending, drift = states.classify(things, approved, deployed, live)
    _first_seen(standing, path, head, tip, things, pending, drift)
    return standing, setup


def _take_as_deployed(
    standing: states.Standing,
    where: str,
    head: str,
    things: Catalogue[K, D],
    live: D,
    approved: D,
) -> tuple[str, D]:
    """What a robot with no deployed state known is taken to hold from its last push:
    the approved commit when it matches it, else what it holds now (``""``); said in
    ``standing``'s notes."""
    if not diff_items(
        things, things.items(live, registers=False), things.items(approved, registers=False)
    ):
        standing.notes.append(
            f"set up {backupref.deployed_ref(where)}: no deployed state was known; the "
            f"robot matches the approved commit {head[:10]}, taken as deployed"
        )
        return head, approved
    standing.notes.append(
        f"set up {backupref.deployed_ref(where)}: no deployed state was known; what "
        "the robot holds now is taken as deployed, so each difference from approved "
        "is reported as pending"
    )
    return "", live


def _first_seen(
    standing: states.Standing,
    path: Path,
    head: str,
    tip: str | None,
    things: Catalogue[K, D],
    pending: list[Change[K]],
    drift: list[Change[K]],
) -> None:
    """Each pending and drifted item in ``standing``, with when it was first seen (the
    last standing's, else the backup commit that brought it, else now) and, pending,
    who approved it."""
    now = standing.checked  # when this backup read the robot
    earlier = states.read(path)
    before = (
        {
            (what, s.item): s
            for what, seen in (("pending", earlier.pending), ("drift", earlier.drift))
            for s in seen
        }
        if earlier is not None
        else {}
    )
    new_drift = {c.key: c.old for c in drift if ("drift", c.name) not in before}
    first = states.introduced(path, things, tip, new_drift) if tip and new_drift else {}
    for change in drift:
        kept = before.get(("drift", change.name))
        seen = kept.first_seen if kept else first[change.key].time if change.key in first else now
        standing.drift.append(states.Seen(change.name, seen))
    same_approved = earlier is not None and earlier.approved == head
    unknown = {
        c.key: c.new
        for c in pending
        if not (same_approved and (kept := before.get(("pending", c.name))) and kept.by)
    }
    origins = states.introduced(path, things, head, unknown) if unknown else {}
    for change in pending:
        kept = before.get(("pending", change.name))
        by = (
            origins[change.key].by()
            if change.key in origins
            else kept.by
            if kept and change.key not in unknown
            else None
        )
        standing.pending.append(states.Seen(change.name, kept.first_seen if kept else now, by))
