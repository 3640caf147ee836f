"""The workflow's names as they were before it was split by job, for callers that
import them from here: reaching the robot (:mod:`.live`), pull (:mod:`.pulling`), diff
and plan (:mod:`.comparison`), push and rollback (:mod:`.deploy`), snapshots
(:mod:`.snapshots`) and the git policy (:mod:`.policy`)."""

from __future__ import annotations

from ..project import load_project, load_robot
from . import git
from .comparison import Comparison, compare, plan
from .deploy import PushFailed, PushOptions, PushResult, push, rollback
from .deploy import run as _deploy
from .live import LiveRead, Station, catalogue, connect, read_live, station_number
from .pulling import PullResult, change_summary, pull
from .snapshots import SNAPSHOT_DIR, Snapshot, all_snapshots, snapshots

__all__ = [
    "SNAPSHOT_DIR",
    "Comparison",
    "LiveRead",
    "PullResult",
    "PushFailed",
    "PushOptions",
    "PushResult",
    "Snapshot",
    "Station",
    "_deploy",
    "all_snapshots",
    "catalogue",
    "change_summary",
    "compare",
    "connect",
    "git",
    "load_project",
    "load_robot",
    "plan",
    "pull",
    "push",
    "read_live",
    "rollback",
    "snapshots",
    "station_number",
]
