"""Git policy: what is pushed must be exactly what a commit holds, and a pull
must never overwrite a person's uncommitted edit."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..errors import PolicyError
from ..families.base import AnyFamily
from ..project.store import edited_since_save
from . import git

__all__ = ["check_committed", "earlier_pull_and_edits", "listed"]


def _uncommitted(path: Path, *, ignore: tuple[str, ...] = ()) -> str:
    """The files under ``path`` with uncommitted changes, for a message ('' when none)."""
    return listed([f for f in git.changed_files(path) if Path(f).name not in ignore])


def listed(files: list[str]) -> str:
    return ", ".join(files[:3]) + (", ..." if len(files) > 3 else "")


def earlier_pull_and_edits(
    path: Path, family: AnyFamily, asked: git.Asked | None = None
) -> tuple[list[str], str]:
    """What a pull finds uncommitted under ``path`` (robot.yaml aside, which it never
    rewrites): the files an earlier pull saved and nobody touched since, and the
    others, for a message ('' when none).  ``asked`` is git's answer for ``path``
    asked earlier (:class:`~harlsync.sync.git.Asked`); None: asked now.

    The first are harlsync's own backup whose commit failed (a stale index.lock,
    a pull killed between its save and its commit): the save's record of what it
    wrote (:func:`~harlsync.project.store.edited_since_save`) tells them from a
    person's edit, which a pull must never overwrite.
    """
    asked = asked or git.Asked(path)
    dirty = [f for f in asked.changed_files() if Path(f).name != "robot.yaml"]
    top = asked.root()
    if not dirty or top is None:
        return [], ""
    inside = {f: (top / f).relative_to(path.resolve()).as_posix() for f in dirty}
    edited = set(edited_since_save(path, inside.values(), family))
    return (
        [name for name in inside.values() if name not in edited],
        listed([f for f, name in inside.items() if name in edited]),
    )


def check_committed(path: Path, files: Mapping[str, bytes]) -> None:
    """Refuse (PolicyError) unless git sees nothing uncommitted under ``path`` and
    the commit checked out holds every byte of ``files`` (what the project was
    loaded from, by path relative to ``path``), where the file really is.

    git status alone is not enough: a file reached through a symbolic link out of
    the repository or elsewhere in it, a file .gitignore names, or one git was told
    to skip (``update-index --skip-worktree``) all look clean to it.
    """
    top = git.repo_root(path)
    if top is None:
        raise PolicyError(
            f"{path} is not in a git repository, so what is pushed could not be traced: "
            "git init; git add; git commit it (or give --allow-dirty)"
        )
    dirty = _uncommitted(path)
    if dirty:
        raise PolicyError(
            f"{path} has uncommitted changes ({dirty}): commit them, or give --allow-dirty"
        )
    top = top.resolve()
    inside: dict[str, str] = {}  # path in the repository -> the project's name for it
    for name in files:
        real = (path / name).resolve()
        if not real.is_relative_to(top):
            link = next((p for p in _prefixes(path, name) if p.is_symlink()), path / name)
            raise PolicyError(
                f"{link} is a symbolic link to {link.resolve()}, outside the git repository "
                f"{top}, so no commit holds what a push reads there: move it into the "
                "repository and commit it, or give --allow-dirty"
            )
        inside[real.relative_to(top).as_posix()] = name
    commit = git.head(path)
    wrong = git.not_in_commit(top, commit, {at: files[name] for at, name in inside.items()})
    if wrong:
        at = next(at for at in inside if at in wrong)
        raise PolicyError(_not_committed(path, inside[at], at, wrong[at], commit, len(wrong)))


def _prefixes(path: Path, name: str) -> list[Path]:
    """``path/programs``, ``path/programs/main-00.yaml`` for ``programs/main-00.yaml``."""
    parts = Path(name).parts
    return [path.joinpath(*parts[: n + 1]) for n in range(len(parts))]


def _not_committed(path: Path, name: str, at: str, why: str, commit: str | None, count: int) -> str:
    """One line: the project's file ``name`` (at ``at`` in the repository) is not as
    the commit holds it, ``why`` (see :func:`git.not_in_commit`), and what to do."""
    file = path / name
    linked = file.resolve() != path.resolve() / name
    shown = f"{file} ({at} in the repository)" if linked else str(file)
    if why == "ignored":
        text = f"{shown} is ignored by git (.gitignore), so no commit holds it: git add -f it and commit it"
    elif commit is None:
        text = f"{shown} is in no commit (the repository has none yet): git add and commit it"
    elif why == "missing":
        text = f"{shown} is not in commit {commit[:10]}: git add and commit it"
    else:
        text = (
            f"{shown} differs from commit {commit[:10]}: commit it, or restore it with git checkout"
        )
    more = f"; {count - 1} more file(s) likewise" if count > 1 else ""
    return f"{text}, or give --allow-dirty{more}"
