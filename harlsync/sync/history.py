"""When each robot was last backed up, kept beside its project.

``DIR/.harlsync/backup.json`` (ignored by git) records every pull's and backup's
outcome, so that ``harlsync status`` can tell the state of a plant without
touching a robot::

    {"last_attempt":  "2026-11-25T02:00:41+00:00",  the last pull or backup of this robot
     "last_result":   "ok" | "failed",               how it ended
     "last_error":    "port ... no reply",           why it failed (only while it has)
     "last_success":  "2026-11-25T02:00:41+00:00",  the last good one
     "last_changed":  true,                          whether that one changed the backup
     "last_changes":  "2 programs (5 steps)",        what it changed, in the family's words
     "last_commit":   "3f9a1c2e4b..." | null,        the git commit that holds it (null:
                                                     not committed by harlsync)
     "last_exchanges": 1080}                         how many exchanges the last good
                                                     backup's read took: a backup's
                                                     fleet weighs its shares by it

Every successful pull updates it, so a robot set up with ``harlsync pull`` is
not reported as never backed up.  A failed attempt keeps what the last good
one recorded.
"""

from __future__ import annotations

import json
import logging
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import TypedDict

from ..project import statefile, store
from ..project.store import disk_error, replace_file
from . import git

__all__ = ["LOCAL_DIR", "BackupState", "committed", "ensure_local_dir", "read", "record", "stale"]

#: harlsync's local, unversioned state inside a project.
LOCAL_DIR = Path(store.LOCAL_DIR)
_FILE = LOCAL_DIR / "backup.json"

log = logging.getLogger(__name__)


class BackupState(TypedDict, total=False):
    """What ``DIR/.harlsync/backup.json`` records of a robot's backups; a field
    nobody recorded (or of the wrong type) is absent."""

    last_attempt: str
    last_success: str
    last_result: str  # ok or failed
    last_error: str | None
    last_changed: bool
    last_changes: str | None
    #: None: the last good backup was not committed by harlsync
    last_commit: str | None
    last_exchanges: int


def ensure_local_dir(project: Path) -> Path:
    """``DIR/.harlsync``, created with a .gitignore that keeps it out of git.

    Raises ProjectError when the disk refuses (read-only, full).
    """
    local = project / LOCAL_DIR
    try:
        local.mkdir(parents=True, exist_ok=True)
        ignore = local / ".gitignore"
        if not ignore.exists():
            replace_file(ignore, store.LOCAL_IGNORE_TEXT)
    except OSError as exc:
        raise disk_error(exc, local, "write harlsync's local state") from exc
    return local


def read(project: Path, problems: list[str] | None = None) -> BackupState:
    """What ``DIR/.harlsync/backup.json`` records, each field of its type.

    A file that is not such a record reads as empty (the next pull or backup
    rewrites it), a field of the wrong type as missing; either is said in one line
    naming the file: appended to ``problems`` when given, else logged.
    """
    path = project / _FILE
    try:
        data = statefile.load(path)
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        _say(problems, f"{path}: cannot be read ({why}); {_REWRITTEN}")
        return {}
    if not isinstance(data, dict):
        _say(
            problems,
            f"{path}: holds {statefile.kind_of(data)}, not harlsync's record; {_REWRITTEN}",
        )
        return {}
    fields = statefile.Fields(data)
    attempt, success = fields.time("last_attempt"), fields.time("last_success")
    result, error = fields.text("last_result"), fields.text("last_error")
    changed, changes = fields.flag("last_changed"), fields.text("last_changes")
    commit, exchanges = fields.text("last_commit"), fields.integer("last_exchanges")
    if result not in (None, "ok", "failed"):
        fields.problems.append(f"last_result holds {result!r}, not ok or failed")
        result = None
    if fields.problems:
        _say(
            problems,
            f"{path}: {'; '.join(statefile.fold(fields.problems, 3))}: read as missing; {_REWRITTEN}",
        )
    state = BackupState()
    if attempt is not None:
        state["last_attempt"] = attempt
    if success is not None:
        state["last_success"] = success
    if result is not None:
        state["last_result"] = result
    if error is not None:
        state["last_error"] = error
    if changed is not None:
        state["last_changed"] = changed
    if changes is not None:
        state["last_changes"] = changes
    if commit is not None or "last_commit" in data:
        # last_commit: null means "not committed by harlsync", and is kept as such.
        state["last_commit"] = commit
    if exchanges is not None:
        state["last_exchanges"] = exchanges
    return state


_REWRITTEN = "the next pull or backup of this robot writes it anew"


def _say(problems: list[str] | None, text: str) -> None:
    if problems is None:
        log.warning("%s", text)
    else:
        problems.append(text)


def stale(last_success: str | None, now: datetime, after: timedelta) -> bool:
    """Whether a good backup at ``last_success`` (as recorded) is older than ``after``
    at ``now``; a robot never backed up is not stale but worse, and said so apart."""
    return last_success is not None and now - datetime.fromisoformat(last_success) > after


def record(
    project: Path,
    *,
    ok: bool,
    error: str | None = None,
    now: datetime | None = None,
    changed: bool | None = None,
    changes: str | None = None,
    exchanges: int | None = None,
) -> BackupState:
    """Record one attempt; return the updated state.

    A good one that says what it ``changed`` (``changes``, in the family's words)
    replaces what the previous good one said; one that changed anything is not
    committed until :func:`committed` says so.  A good one that says how many
    ``exchanges`` its read took replaces the count of the previous one.  Raises ProjectError when the
    disk refuses (read-only, full): the previous record is then kept.
    """
    stamp = (now or datetime.now(timezone.utc)).isoformat(timespec="seconds")
    state = read(project)
    if ok:
        state["last_success"] = stamp
        state.pop("last_error", None)
        if exchanges is not None:
            state["last_exchanges"] = exchanges
        if changed is not None:
            state["last_changed"] = changed
            state["last_changes"] = changes
            # A backup that changed nothing is what git already holds: the last commit
            # of the project; one that changed anything is not committed yet.
            found = [] if changed else git.log(project, 1)
            state["last_commit"] = found[0].sha if found else None
    else:
        state["last_error"] = error
    state["last_attempt"] = stamp
    state["last_result"] = "ok" if ok else "failed"
    return _write(project, state, "record the backup")


def committed(project: Path, commit: str) -> BackupState:
    """Record that ``commit`` holds the last good backup; the updated state.
    Raises ProjectError when the disk refuses."""
    state = read(project)
    state["last_commit"] = commit
    return _write(project, state, "record the backup's commit")


def _write(project: Path, state: BackupState, what: str) -> BackupState:
    target = ensure_local_dir(project) / _FILE.name
    try:
        replace_file(target, (json.dumps(state, indent=2, sort_keys=True) + "\n").encode())
    except OSError as exc:
        raise disk_error(exc, target, what) from exc
    return state


#: How many items a commit message names per robot before "and 40 more".
NAMED = 12


def commit_message(head: str, summary: str, items: list[str], pushes: list[str]) -> str:
    """A commit message that names what changed: ``pull press: MAIN program 0 step 4;
    position 12 speed`` (shortened to fit a subject line), then the summary, every
    item (folded) and who pushed to the robot since its last backup."""
    named = "; ".join(items) or summary
    subject = f"{head}: {named}"
    if len(subject) > 72:
        subject = f"{head}: {summary}"
    lines = [subject, ""] + body(summary, items, pushes)
    return "\n".join(lines) + "\n"


def body(summary: str, items: list[str], pushes: list[str], indent: str = "") -> list[str]:
    """The lines that say what changed and who pushed, for a commit message."""
    lines = [f"{indent}{summary}:"] if items else [f"{indent}{summary}"]
    lines += [f"{indent}  {item}" for item in statefile.fold(items, NAMED, "more")]
    if pushes:
        lines += [f"{indent}pushed since the last backup:"]
        lines += [f"{indent}  {push}" for push in statefile.fold(pushes, NAMED, "more")]
    return lines
