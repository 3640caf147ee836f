"""The workflow's names as they were before it was split by job, for callers that
import them from here: reaching the robot (:mod:`.live`), pull (:mod:`.pulling`), diff
and plan (:mod:`.comparison`), push and rollback (:mod:`.deploy`), snapshots
(:mod:`.snapshots`) and the git policy (:mod:`.policy`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

from .. import families
from ..families.base import AnyFamily, Catalogue, Driver, Progress
from ..project import Robot, load_project, load_robot
from . import git, pulling
from .comparison import Comparison, compare, plan
from .deploy import PushFailed, PushOptions, PushResult, push, rollback
from .deploy import run as _deploy
from .items import change_summary
from .live import LiveRead, Station, read_live
from .live import connect as connect_family
from .live import station_number as family_station_number
from .pulling import PullResult
from .snapshots import SNAPSHOT_DIR, Snapshot, all_snapshots, snapshots

if TYPE_CHECKING:  # for the checker only: not imported at run time
    from typing_extensions import Unpack

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


def catalogue(robot: Robot) -> Catalogue[Any, Any]:
    """The items of the robot's family."""
    return families.get(robot.family).catalogue


def connect(
    robot: Robot,
    port: str | None = None,
    station: int | None = None,
    *,
    lock_timeout: float = 10.0,
    options: Mapping[str, bool] | None = None,
) -> Driver[Any, Any]:
    """Open the line of a robot of the family it names (see :func:`.live.connect`);
    an option its family does not take is refused naming the families that do."""
    family = families.get(robot.family)
    families.refuse_options(family, options or {})
    return connect_family(family, robot, port, station, lock_timeout=lock_timeout, options=options)


def station_number(family: str | AnyFamily | None, station: Station) -> int | None:
    """``station`` read by the family (by name or object): see :func:`.live.station_number`."""
    found = family if not isinstance(family, str | None) else families.get(family)
    return family_station_number(found, station)


class PullOptions(TypedDict, total=False):
    """A pull's options besides its family, as :func:`.pulling.pull` takes them."""

    port: str | None
    station: Station
    commit: bool
    progress: Progress | None
    lock_timeout: float
    allow_dirty: bool
    new_robot: bool
    connect_options: Mapping[str, bool] | None
    noted: Callable[[str], None] | None
    discard_pending: bool


def pull(
    path: str | Path, *, family: str | AnyFamily | None = None, **options: Unpack[PullOptions]
) -> PullResult:
    """:func:`.pulling.pull`, with ``family`` given by name too (as robot.yaml says it)."""
    found = families.get(family) if isinstance(family, str) else family
    return pulling.pull(path, family=found, **options)
