"""The robot's own states, kept in git beside the approved branch, written with
git's plumbing: no HEAD, index or work tree of the repository ever moves.

::

    refs/heads/<branch>                  approved: what engineers commit (HEAD)
    refs/heads/harlsync/backup           observed: one commit a night, the whole plant
    refs/harlsync/deployed/<project>     deployed: one ref a robot, moved by each push
                                         and rollback that finished

A commit on one of them is made as ``git commit`` would make it, without its
index::

    files --hash-object -w--> blobs --update-index (a temporary GIT_INDEX_FILE)-->
          --write-tree--> tree --commit-tree -p <the ref's commit>--> commit
          --update-ref <ref> <commit> <the commit it held>--> the ref moves

``update-ref`` is given the commit the ref held when the run read it, so a ref
another harlsync moved meanwhile is never overwritten: git refuses, and the
run says so.  The backup branch's first commit has the approved HEAD as its
parent: the nights before it, committed on the approved branch by an older
harlsync, stay its history.
"""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

from ..errors import HarlsyncError, SyncError
from . import git

__all__ = [
    "BACKUP_BRANCH",
    "BACKUP_REF",
    "DEPLOYED",
    "Entry",
    "RefUpdate",
    "commit_of",
    "commit_time",
    "deployed_ref",
    "entries",
    "has_project",
    "make_commit",
    "project_tree",
    "store_files",
    "update_refs",
    "where_of",
    "write_tree",
]

#: The branch each nightly backup commits what it read on (observed).
BACKUP_BRANCH = "harlsync/backup"
BACKUP_REF = f"refs/heads/{BACKUP_BRANCH}"
#: Where each robot's deployed ref lives: ``refs/harlsync/deployed/lineA/cell``.
DEPLOYED = "refs/harlsync/deployed/"
#: The object id git gives "no such ref" in an update (SHA-1 length; git takes it
#: for SHA-256 repositories too).
_ABSENT = "0" * 40


class Entry(NamedTuple):
    """A file in a tree: its mode (``100644``) and blob id."""

    mode: str
    oid: str


class RefUpdate(NamedTuple):
    """Move ``ref`` to ``new``, only if it still holds ``old`` (None: it must not exist)."""

    ref: str
    new: str
    old: str | None


def where_of(root: Path, path: Path) -> str:
    """The project ``path`` as a path in the repository at ``root`` (``lineA/cell``;
    ``""`` for a project at its top)."""
    where = path.resolve().relative_to(root.resolve()).as_posix()
    return "" if where == "." else where


#: What is kept as it is in a ref name; anything else (a dot, a space) is %XX encoded,
#: which keeps every rule of git-check-ref-format (no leading dot, no ``..``, no
#: ``.lock`` ending, no space or ``~^:?*[\\``).
_UNSAFE = re.compile(r"[^A-Za-z0-9_+=,-]")


def deployed_ref(where: str) -> str:
    """The deployed ref of the project at ``where`` in the repository: its path, each
    character git could refuse %XX encoded (``cell.v2`` -> ``cell%2Ev2``); ``%2E``
    for a project at the top."""
    parts = [p for p in where.split("/") if p] or ["."]
    encoded = [
        _UNSAFE.sub(lambda m: "".join(f"%{b:02X}" for b in m.group().encode()), part)
        for part in parts
    ]
    return DEPLOYED + "/".join(encoded)


def commit_of(root: Path, ref: str) -> str | None:
    """The commit ``ref`` holds, or None when there is no such ref."""
    out = git.run(root, "rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}", ok=(0, 1))
    return out.strip() or None


def commit_time(root: Path, commit: str) -> str:
    """When ``commit`` was made (the committer's date, ISO 8601)."""
    return git.run(root, "show", "-s", "--format=%cI", commit).strip()


def has_project(root: Path, commit: str | None, where: str) -> bool:
    """Whether ``commit`` holds a robot project (a robot.yaml) at ``where``."""
    if commit is None:
        return False
    name = f"{where}/robot.yaml" if where else "robot.yaml"
    return bool(git.run(root, "ls-tree", "--name-only", commit, "--", name, ok=(0, 128)).strip())


def project_tree(root: Path, commit: str | None, where: str) -> str | None:
    """The id of the tree ``commit`` holds at ``where`` (None: none there): two equal
    ids are the same files, with no need to read them."""
    if commit is None:
        return None
    spec = f"{commit}:{where}" if where else f"{commit}^{{tree}}"
    return git.run(root, "rev-parse", "--verify", "--quiet", spec, ok=(0, 1)).strip() or None


def entries(root: Path, commit: str | None, where: str = "") -> dict[str, Entry]:
    """Every file ``commit`` holds under ``where``, by its path relative to it."""
    if commit is None:
        return {}
    listing = git.run(root, "ls-tree", "-r", "-z", "--full-tree", commit, "--", where or ".")
    prefix = f"{where}/" if where else ""
    found: dict[str, Entry] = {}
    for line in filter(None, listing.split("\0")):
        meta, _, name = line.partition("\t")
        mode, kind, oid = meta.split(" ")
        if kind == "blob" and name.startswith(prefix):
            found[name[len(prefix) :]] = Entry(mode, oid)
    return found


def store_files(root: Path, files: Mapping[str, bytes]) -> dict[str, Entry]:
    """Write ``files`` (path -> bytes) into the repository's objects, as they are
    (no filters: what the file holds is what a checkout gives); their entries."""
    if not files:
        return {}
    names = sorted(files)
    with tempfile.TemporaryDirectory(prefix="harlsync-blobs-") as temp:
        paths = []
        for n, name in enumerate(names):
            target = Path(temp) / str(n)
            target.write_bytes(files[name])
            paths.append(str(target))
        out = git.run(
            root, "hash-object", "-w", "--no-filters", "--stdin-paths", stdin="\n".join(paths)
        )
    oids = out.split()
    if len(oids) != len(names):
        raise SyncError(f"git hash-object failed in {root}: {len(oids)} of {len(names)} files")
    return {name: Entry("100644", oid) for name, oid in zip(names, oids)}


def write_tree(root: Path, files: Mapping[str, Entry]) -> str:
    """The tree of ``files`` (path in the repository -> entry), written through a
    temporary index: the repository's own index is never read or written."""
    with tempfile.TemporaryDirectory(prefix="harlsync-index-") as temp:
        env = dict(os.environ, GIT_INDEX_FILE=str(Path(temp) / "index"))
        lines = "".join(f"{e.mode} {e.oid}\t{name}\0" for name, e in sorted(files.items()))
        if lines:
            git.run(root, "update-index", "--add", "-z", "--index-info", stdin=lines, env=env)
        return git.run(root, "write-tree", env=env).strip()


def make_commit(root: Path, tree: str, parents: Sequence[str], message: str) -> str:
    """A commit of ``tree`` on ``parents`` with ``message``, by git's identity (or
    harlsync's, :func:`.git.identity`); no ref moves."""
    args = [arg for parent in dict.fromkeys(parents) for arg in ("-p", parent)]
    return git.run(root, "commit-tree", tree, *args, stdin=message, env=git.identity(root)).strip()


def update_refs(root: Path, updates: Iterable[RefUpdate], reason: str) -> None:
    """Move every ref of ``updates`` at once, or none (one ``update-ref --stdin``
    transaction).  Raises SyncError naming git's reason: one moved meanwhile by
    another harlsync is never overwritten."""
    lines = [f"update {u.ref} {u.new} {u.old or _ABSENT}\n" for u in updates]
    if not lines:
        return
    try:
        git.run(root, "update-ref", "-m", reason, "--stdin", stdin="".join(lines))
    except HarlsyncError as exc:
        raise SyncError(f"{exc}; another harlsync may have moved it meanwhile: run again") from exc
