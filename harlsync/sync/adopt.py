"""Adopt: the robot's own change, as the last backup kept it, written into the
project for an engineer to review and commit (docs/states.md).

::

    harlsync/backup:DIR (observed) --+
                                     +--> the items chosen (default: the drift) -->
    DIR on disk (approved) ----------+    the project with their observed values --> saved

Nothing is committed and no robot is contacted: adopting a change made on the
robot is an engineer's decision, made by the commit that follows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import PolicyError, ProjectError, SyncError
from ..families.base import Catalogue, D, K
from ..project import Project, load_project, save_project
from . import backupref, git, states
from .items import Change, diff_items
from .policy import listed

__all__ = ["Adopted", "adopt"]


@dataclass
class Adopted:
    """What :func:`adopt` wrote."""

    #: the items, in the family's words, and the files of the project written
    items: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    #: the backup commit they came from, and when it was made
    commit: str = ""
    time: str = ""


def adopt(path: str | Path, names: Sequence[str] = (), *, allow_dirty: bool = False) -> Adopted:
    """Write into the project at ``path`` the items ``names`` (their names as status
    and backup list them; none: every drifted item) as the last backup read them.

    Raises ProjectError for a project outside git, never backed up under the
    three-state model, or an item that does not differ; PolicyError for
    uncommitted edits (unless ``allow_dirty``) or no item named while nothing tells
    drift from pending."""
    path = Path(path)
    project = load_project(path)
    root = git.repo_root(path)
    if root is None:
        raise ProjectError(
            f"{path}: not in a git repository, so no backup kept what the robot holds; "
            f"'harlsync pull {path}' reads it into the project"
        )
    where = backupref.where_of(root, path)
    tip = backupref.commit_of(root, backupref.BACKUP_REF)
    if not backupref.has_project(root, tip, where):
        raise ProjectError(
            f"{path}: no backup kept what this robot holds yet (no {path.name} on the "
            f"branch {backupref.BACKUP_BRANCH}); run 'harlsync backup {path} --commit' first"
        )
    assert tip is not None
    dirty = [f for f in git.changed_files(path) if Path(f).name != "robot.yaml"]
    if dirty and not allow_dirty:
        raise PolicyError(
            f"{path}: uncommitted changes adopt would overwrite ({listed(dirty)}); commit "
            f"or stash them, or overwrite them with 'harlsync adopt {path} --allow-dirty'"
        )
    things = project.family.catalogue
    observed = states.project_at(path, tip)
    now = things.items(project.data, registers=False)
    differ = diff_items(things, now, things.items(observed, registers=False))
    chosen = _chosen(path, root, where, things, project, observed, differ, names)
    found = Adopted(commit=tip, time=backupref.commit_time(root, tip))
    if not chosen:
        return found
    try:
        data = things.with_items(project.data, {c.key: c.new for c in chosen})
    except NotImplementedError:
        raise ProjectError(
            f"{path}: the {project.family.name} family cannot adopt single items; "
            f"'git checkout {backupref.BACKUP_BRANCH} -- {where or '.'}' takes every file "
            "the backup kept, to review and commit"
        ) from None
    found.files = save_project(path, Project(path, project.robot, data, project.family))
    found.items = [c.name for c in chosen]
    return found


def _chosen(
    path: Path,
    root: Path,
    where: str,
    things: Catalogue[K, D],
    project: Project,
    observed: D,
    differ: list[Change[K]],
    names: Sequence[str],
) -> list[Change[K]]:
    """The differences to adopt: those ``names`` names, or every drifted one."""
    if names:
        by_name = {c.name.casefold(): c for c in differ}
        unknown = [n for n in names if n.casefold() not in by_name]
        if unknown:
            what = listed([c.name for c in differ]) if differ else "none"
            raise ProjectError(
                f"{path}: {listed(unknown)}: not an item where the last backup differs from "
                f"the project (those that do: {what})"
            )
        return list(dict.fromkeys(by_name[n.casefold()] for n in names))
    deployed_commit, _ = states.deployed_commit(root, path, where)
    if deployed_commit is None:
        if not differ:
            return []
        raise PolicyError(
            f"{path}: nothing tells which differences are the robot's own (no deployed "
            f"state known); name the items to adopt: {listed([c.name for c in differ])}"
        )
    try:
        deployed = states.project_at(path, deployed_commit)
    except ProjectError as exc:
        raise SyncError(f"{path}: the deployed state does not load: {exc}") from exc
    _, drift = states.classify(things, project.data, deployed, observed)
    drifted = {c.key for c in drift}
    return [c for c in differ if c.key in drifted]
