"""The audit log: one JSON line per push and rollback, appended, never rewritten.

Where it lives: ``$HARLSYNC_AUDIT_LOG`` if set, else
``$XDG_STATE_HOME/harlsync/audit.jsonl`` (``~/.local/state/harlsync/audit.jsonl``).
Each record holds the time, user and host, the git commit and the reason, the
robot, the plan, the result, and every item written with its old and new value.
The file is opened in append mode and each record is written whole and fsynced;
on a server, ``chattr +a`` makes it append-only for root too.
"""

from __future__ import annotations

import getpass
import json
import os
import socket
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

__all__ = ["append", "audit_path", "base_record", "read"]


def audit_path() -> Path:
    explicit = os.environ.get("HARLSYNC_AUDIT_LOG")
    if explicit:
        return Path(explicit)
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "harlsync" / "audit.jsonl"


def base_record(action: str) -> dict[str, Any]:
    """The fields every record starts with: action, time, user, host."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = str(os.getuid()) if hasattr(os, "getuid") else "unknown"
    return {
        "action": action,
        "time": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "user": user,
        "host": socket.gethostname(),
    }


def append(record: dict[str, Any], path: Path | None = None) -> Path:
    """Append one record as a JSON line; return the log's path."""
    path = path or audit_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    line = json.dumps(record, sort_keys=True, default=str) + "\n"
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line.encode("utf-8"))
        os.fsync(fd)
    finally:
        os.close(fd)
    return path


def read(path: Path | None = None) -> list[dict[str, Any]]:
    path = path or audit_path()
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line]
