"""A nightly backup under the three-state model (docs/states.md): the robot is
read, compared with the approved version and the deployed one, and kept on the
backup branch; the project's branch and its working tree are never touched.

Per robot (in a worker process, :func:`read_robot`)::

    robot.yaml (work tree) --> read the robot (identity checked against what was
                               observed before, or what is approved)
    live --> render its files --> git objects (hash-object -w): its tree entries
         --> against the last observed (harlsync/backup): what changed tonight
         --> against approved (HEAD) and deployed (its ref): pending and drift

Once for the run (in the process that started it, :func:`commit_observed`)::

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
from typing import Any

from ..errors import HarlsyncError, PolicyError, ProjectError, ProjectInvalid, SyncError
from ..families.base import AnyFamily, Progress
from ..project import load_robot
from ..project.store import SCHEMAS_DIR
from . import backupref, git, history, states
from .backupref import Entry, RefUpdate
from .items import diff, diff_items
from .live import read_live
from .pulling import PullResult, pull

__all__ = ["Observed", "commit_observed", "fetch_deployed", "push_refs", "read_robot"]

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

    def kept(self) -> dict[str, Any]:
        """What the run's commit needs, as JSON (it crosses from a worker process)."""
        return {"root": self.root, "where": self.where, "files": self.files, "setup": self.setup}


def read_robot(path: Path, **options: Any) -> PullResult:
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
    family: AnyFamily,
    connect_options: Mapping[str, bool] | None = None,
    noted: Callable[[str], None] | None = None,
) -> Observed:
    from .pulling import _migrated, _not_this_robot, _record_notes, _same_robot

    robot = load_robot(path, family)
    things = family.catalogue
    tip = backupref.commit_of(root, backupref.BACKUP_REF)
    previous_commit = _last_observed(root, path, where, tip, head)
    loaded: dict[str, Any] = {}

    def data_at(commit: str) -> Any:
        """The project at ``commit`` (None: it does not load), read once a tree."""
        tree = backupref.project_tree(root, commit, where) or commit
        if tree not in loaded:
            try:
                loaded[tree] = states.project_at(path, commit)
            except ProjectError as exc:
                log.warning("%s", exc)
                loaded[tree] = None
        return loaded[tree]

    def accepted(check: Callable[[Any], object]) -> None:
        """``check`` against the robot last observed; failing, against the approved
        one: a robot an engineer accepted (``pull --new-robot``, committed) is it."""
        try:
            previous = data_at(previous_commit)
            if previous is not None:
                check(previous)
        except PolicyError:
            approved = data_at(head)
            if previous_commit == head or approved is None:
                raise
            check(approved)

    def same_identity(now: Mapping[str, str], where_read: str) -> None:
        from .pulling import _identity_differs

        def check(data: Any) -> None:
            differ = _identity_differs(things.robot_identity(data), now)
            if differ:
                raise _not_this_robot(path, where_read, differ)

        accepted(check)

    read = read_live(
        family,
        robot,
        None,
        None,
        registers=robot.keep_registers,
        progress=progress,
        lock_timeout=lock_timeout,
        options=connect_options,
        whole=True,
        noted=partial(_record_notes, path, robot, None, None, noted),
        identified=same_identity,
    )
    live = read.live
    accepted(lambda data: _same_robot(path, things, data, live, read.driver.label))
    previous = data_at(previous_commit)
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
        before = backupref.entries(root, previous_commit, where)
        result.written = sorted(
            name
            for name, entry in stored.items()
            if name != "robot.yaml" and before.get(name) != entry  # robot.yaml: a person's
        )
        was = git.read_blobs(root, [before[n].oid for n in result.written if n in before])
        _migrated(
            result,
            {n: was[before[n].oid] for n in result.written if n in before},
            family.format,
        )
    now = datetime.now(timezone.utc).isoformat(timespec="seconds")
    result.standing, result.setup = _standing(
        path, root, where, head, tip, things, live, data_at, now
    )
    history.record(path, ok=True, changed=result.changed, changes=result.summary)
    if not result.changed:
        history.committed(path, previous_commit)  # it holds what was read
    return result


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


def _files(path: Path, family: AnyFamily, robot: Any, live: Any) -> dict[str, bytes]:
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
    things: Any,
    live: Any,
    data_at: Callable[[str], Any],
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
    setup: str | None = None
    deployed: Any = None
    if deployed_commit is not None:
        deployed = data_at(deployed_commit)
    if deployed_commit is None or deployed is None:
        if not diff_items(
            things, things.items(live, registers=False), things.items(approved, registers=False)
        ):
            setup, deployed = head, approved
            standing.notes.append(
                f"set up {backupref.deployed_ref(where)}: no deployed state was known; the "
                f"robot matches the approved commit {head[:10]}, taken as deployed"
            )
        else:
            setup, deployed = "", live
            standing.notes.append(
                f"set up {backupref.deployed_ref(where)}: no deployed state was known; what "
                "the robot holds now is taken as deployed, so each difference from approved "
                "is reported as pending"
            )
    elif how != backupref.deployed_ref(where):
        setup = deployed_commit
        standing.notes.append(
            f"set up {backupref.deployed_ref(where)}: the last backup commit {deployed_commit[:10]} "
            f"({states.date_of(backupref.commit_time(root, deployed_commit))}, made before "
            "backups were kept apart from the approved branch) is taken as deployed"
        )
    standing.deployed = deployed_commit if setup is None else (setup or None)
    pending, drift = states.classify(things, approved, deployed, live)
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
    return standing, setup


def commit_observed(
    observed: list[tuple[Path, dict[str, Any], states.Standing | None]],
    message: str,
) -> tuple[str | None, list[str]]:
    """Commit what each robot's backup read (``(project, kept, standing)``, as
    :meth:`Observed.kept` gives it) on the backup branch, and set up the deployed
    ref of each robot that has none: the new commit (None: the branch already holds
    all of it) and what was set up, a line each.  Raises SyncError: the projects
    are not in one repository, or git fails (then no ref moved)."""
    roots = {kept["root"] for _, kept, _ in observed}
    if len(roots) != 1:
        raise SyncError(
            f"{', '.join(str(p) for p, _, _ in observed)}: not inside one git repository; "
            "back each repository up on its own"
        )
    root = Path(roots.pop())
    tip = backupref.commit_of(root, backupref.BACKUP_REF)
    head = backupref.commit_of(root, "HEAD")
    base = tip or head
    files = backupref.entries(root, base)
    for _, kept, _ in observed:
        where = kept["where"]
        prefix = f"{where}/" if where else ""
        files = {n: e for n, e in files.items() if not n.startswith(prefix)}
        files.update({prefix + n: Entry(*e) for n, e in kept["files"].items()})
    tree = backupref.write_tree(root, files)
    said: list[str] = []
    new: str | None = None
    if base is None or tree != backupref.project_tree(root, base, ""):
        new = backupref.make_commit(root, tree, [base] if base else [], message)
    moved = new or (head if tip is None else None)  # every robot as approved: from HEAD
    if moved is not None:
        backupref.update_refs(
            root, [RefUpdate(backupref.BACKUP_REF, moved, tip)], "harlsync backup"
        )
        if tip is None:
            said.append(
                f"set up: the branch {backupref.BACKUP_BRANCH} keeps what each backup reads, "
                f"from {moved[:10]} on; the approved branch and the working tree are left alone"
            )
    held = moved or tip
    for path, kept, _ in observed:
        if kept.get("setup") is None:
            continue
        try:
            _set_up_deployed(root, path, kept, held)
        except HarlsyncError as exc:
            said.append(f"{path.name}: its deployed ref was not set up: {exc}")
    return new, said


def _set_up_deployed(root: Path, path: Path, kept: dict[str, Any], observed: str | None) -> None:
    """Make the deployed ref of a robot that has none, holding what its backup took
    as deployed (its standing's note says what)."""
    where = kept["where"]
    source = kept["setup"] or observed
    if source is None:
        raise SyncError("nothing holds what was read")
    prefix = f"{where}/" if where else ""
    tree = backupref.write_tree(
        root, {prefix + n: e for n, e in backupref.entries(root, source, where).items()}
    )
    ref = backupref.deployed_ref(where)
    name = load_robot_name(path)
    commit = backupref.make_commit(
        root,
        tree,
        [source],
        f"deployed: {name}: set up by its first backup under the three-state model\n\n"
        f"What the robot was taken to hold from its last push: commit {source[:10]}.\n",
    )
    backupref.update_refs(root, [RefUpdate(ref, commit, None)], "harlsync backup: set up")


def load_robot_name(path: Path) -> str:
    try:
        return load_robot(path).name
    except HarlsyncError:
        return path.name


def remote_of(root: Path) -> str | None:
    """The remote of the branch checked out (its upstream's), else ``origin`` when
    there is one, else None."""
    branch = git.run(root, "symbolic-ref", "--quiet", "--short", "HEAD", ok=(0, 1)).strip()
    if branch:
        remote = git.run(root, "config", f"branch.{branch}.remote", ok=(0, 1)).strip()
        if remote:
            return remote
    remotes = git.run(root, "remote").split()
    return "origin" if "origin" in remotes else (remotes[0] if len(remotes) == 1 else None)


def push_refs(path: Path) -> bool:
    """Push the backup branch and every deployed ref to the remote; whether there was
    any.  Raises SyncError with git's reason (the local commit is kept: the next run
    pushes it)."""
    root = git.repo_root(path)
    if root is None:
        raise SyncError(f"{path}: not inside a git repository")
    specs = []
    if backupref.commit_of(root, backupref.BACKUP_REF) is not None:
        specs.append(f"{backupref.BACKUP_REF}:{backupref.BACKUP_REF}")
    if git.run(root, "for-each-ref", "--count=1", backupref.DEPLOYED).strip():
        specs.append(f"{backupref.DEPLOYED}*:{backupref.DEPLOYED}*")
    if not specs:
        return False
    remote = remote_of(root)
    if remote is None:
        raise SyncError(f"{root}: no git remote to push to; add one (git remote add origin URL)")
    git.run(root, "push", "--quiet", remote, *specs)
    return True


def fetch_deployed(path: Path) -> str | None:
    """Fetch the deployed refs the remote has (pushes made from other clones), each
    only where it moves forward; what went wrong, or None."""
    root = git.repo_root(path)
    remote = remote_of(root) if root is not None else None
    if root is None or remote is None:
        return None
    try:
        git.run(root, "fetch", "--quiet", remote, f"{backupref.DEPLOYED}*:{backupref.DEPLOYED}*")
    except HarlsyncError as exc:
        return f"the deployed refs were not fetched from {remote}: {exc}"
    return None
