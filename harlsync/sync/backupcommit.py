"""What a nightly backup does in git once for the run, in the process that started
it: commit what each robot's read (:mod:`.nightly`) stored on the backup branch, set
up the deployed ref of a robot that has none, and push or fetch those refs."""

from __future__ import annotations

from pathlib import Path
from typing import TypedDict

from ..errors import HarlsyncError, SyncError
from ..project import load_robot
from . import backupref, git, states
from .backupref import Entry, RefUpdate

__all__ = ["Kept", "commit_observed", "fetch_deployed", "push_refs"]


class Kept(TypedDict):
    """What the run commits of one robot's read, as JSON (it crosses from a worker
    process): its repository, its project's place there, its files as
    ``{path: [mode, blob]}`` and what to set up as deployed (None: nothing)."""

    root: str
    where: str
    files: dict[str, list[str]]
    setup: str | None


def commit_observed(
    observed: list[tuple[Path, Kept, states.Standing | None]],
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


def _set_up_deployed(root: Path, path: Path, kept: Kept, observed: str | None) -> None:
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
