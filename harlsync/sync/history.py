"""When each robot was last backed up, kept beside its project.

``DIR/.harlsync/backup.json`` (ignored by git) records the time of the last
good pull or backup, and the last error.  Every successful pull updates it, so
a robot set up with ``harlsync pull`` is not reported as never backed up.
"""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from ..project import store
from ..project.store import disk_error, replace_file

__all__ = ["LOCAL_DIR", "ensure_local_dir", "read", "record"]

#: harlsync's local, unversioned state inside a project.
LOCAL_DIR = Path(store.LOCAL_DIR)
_FILE = LOCAL_DIR / "backup.json"


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


def read(project: Path) -> dict[str, Any]:
    try:
        return dict(json.loads((project / _FILE).read_text(encoding="utf-8")))
    except (OSError, ValueError):
        return {}


def record(project: Path, *, ok: bool, error: str | None = None,
           now: datetime | None = None) -> dict[str, Any]:
    """Record one attempt; return the updated state.  Raises ProjectError when the
    disk refuses (read-only, full): the previous record is then kept."""
    stamp = (now or datetime.now(timezone.utc)).isoformat(timespec="seconds")
    state = read(project)
    if ok:
        state["last_success"] = stamp
        state.pop("last_error", None)
    else:
        state["last_error"] = error
    state["last_attempt"] = stamp
    target = ensure_local_dir(project) / _FILE.name
    try:
        replace_file(target, (json.dumps(state, indent=2, sort_keys=True) + "\n").encode())
    except OSError as exc:
        raise disk_error(exc, target, "record the backup") from exc
    return state
