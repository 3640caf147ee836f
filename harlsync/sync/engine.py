"""Pull, diff, plan, push and rollback: the candidate workflow for a robot.

How a push goes (each step stops the push when it fails; nothing is written
before the last check)::

    load + validate the project      (before the port is touched)
    policy: git clean, maintenance window
    open the port (exclusive lock on the line)
    an earlier push left unfinished? (audit log: warn, naming what it wrote)
    LNR: robot idle?                 (interlock, before the long read)
    read the live robot, make the plan
    stale plan? unwritable? reconfiguration allowed? confirmed?
    snapshot the live robot          (DIR/.harlsync/snapshots/<n>-<time>-push/)
    audit "start" record, the plan   (write-ahead, fsynced)
    for each write, in the safe order:
        read the item: as planned?   (drift: edited on the pendant since the read)
        still in the window?         (policy: a long push stops when its window closes)
        LNR: idle?                   (interlock: before every write)
        audit "write" record         (fsynced: a SIGKILL still leaves a trace)
        write, read back, compare    (verify)
    audit "end" record               (always, whatever happened)

The interlock reads LNR immediately before every write, a re-send after a
lost reply included (the controller reads it again before re-sending).  With
``allow_live_tuning`` it skips that only before timer and offset writes, which
the manual allows during automatic operation; it still reads LNR before every
other write (SNA, SNM, SNS, SNH, SNE, SNX, and SND registers), and a plan that
holds any such write needs an idle robot before its first write.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, NamedTuple

from .. import families
from ..errors import (
    HarlsyncError,
    InterlockError,
    LinkTimeout,
    PolicyError,
    PortBusyError,
    PortError,
    ProjectError,
    ReplyError,
    StalePlanError,
    SyncError,
    VerifyError,
)
from ..families.base import Catalogue, Driver, Progress
from ..project import Project, Robot, load_project, load_robot, save_project
from ..project.lock import holding_project
from ..project.store import disk_error, edited_since_save, read_project
from . import audit, git, history
from .items import Change, diff
from .plan import Plan, PlannedWrite, make_plan

__all__ = [
    "Comparison",
    "LiveRead",
    "PullResult",
    "PushFailed",
    "PushOptions",
    "PushResult",
    "Snapshot",
    "all_snapshots",
    "change_summary",
    "compare",
    "connect",
    "plan",
    "pull",
    "push",
    "rollback",
    "snapshots",
]

log = logging.getLogger(__name__)

SNAPSHOT_DIR = history.LOCAL_DIR / "snapshots"


def connect(
    robot: Robot,
    port: str | None = None,
    station: int | None = None,
    *,
    lock_timeout: float = 10.0,
    options: Mapping[str, Any] | None = None,
) -> Driver:
    """Open the robot's line (``port``/``station`` override the robot file).

    ``options`` are family options of the connection (``reset_function``), each
    given when true.  Raises ProjectError, before anything is opened, for one the
    robot's family does not take.
    """
    family = families.get(robot.family)
    given = {name: value for name, value in (options or {}).items() if value}
    for name in sorted(set(given) - family.connect_options):
        takers = [n for n in families.names() if name in families.get(n).connect_options]
        raise ProjectError(
            f"--{name.replace('_', '-')}: the {family.name} family has no such option "
            f"(only {', '.join(takers) or 'no family'}); leave it out"
        )
    return family.connect(robot, port, station, lock_timeout=lock_timeout, **given)


def catalogue(robot: Robot) -> Catalogue:
    """The robot's family's items."""
    return families.get(robot.family).catalogue


#: A station as the command line gives it (text, read by the robot's family: hex for
#: IAI), as a library caller gives it (a number), or none (robot.yaml's).
Station = int | str | None


def station_number(family: str | None, station: Station) -> int | None:
    """``station`` as a number; text is read by the family (``"99"`` is 0x99 for IAI),
    and a number must be in the family's range too.  Raises ProjectError naming the
    range, as robot.yaml's check does."""
    if station is None:
        return None
    the_family = families.get(family)
    text = station if isinstance(station, str) else the_family.format_station(station)
    try:
        return the_family.parse_station(text)
    except ValueError as exc:
        raise ProjectError(
            f"--station: {exc}" if isinstance(station, str) else f"station: {exc}"
        ) from None


class LiveRead(NamedTuple):
    """What :func:`read_live` found."""

    #: closed: it still names the robot and builds commands
    driver: Driver
    #: everything the robot holds, as the family's data
    live: Any
    #: a warning for each earlier push to it that did not finish
    warnings: list[str]
    #: when asked and the robot is not idle: why a push would be refused now
    busy: str | None = None


def read_live(
    robot: Robot,
    port: str | None,
    station: int | None,
    *,
    registers: bool,
    progress: Progress | None,
    lock_timeout: float,
    idle_check: bool = False,
    options: Mapping[str, Any] | None = None,
) -> LiveRead:
    """Everything the robot holds, read over a line opened and closed for it; with
    ``idle_check`` its state after the read too (what the interlock reads).
    ``options`` are the connection's (see :func:`connect`)."""
    driver = connect(robot, port, station, lock_timeout=lock_timeout, options=options)
    try:
        warnings = _unfinished(robot, port, station)
        live = driver.read_all(registers=registers, progress=progress)
        return LiveRead(driver, live, warnings, _busy(driver) if idle_check else None)
    finally:
        driver.close()


def _busy(driver: Driver) -> str | None:
    """Why the interlock would refuse a write now (None: the robot is idle)."""
    try:
        status = driver.status()
    except HarlsyncError as exc:
        return f"cannot read its state ({exc})"
    return None if status.idle else status.describe()


def _unfinished(robot: Robot, port: str | None, station: int | None) -> list[str]:
    """What the audit log says about earlier pushes to this robot that never ended.

    Called with the line held, so no push in progress can be mistaken for one.
    """
    problems: list[str] = []
    try:
        found = audit.unfinished(
            port or robot.port, station if station is not None else robot.station, problems=problems
        )
    except OSError as exc:
        return [
            (
                f"cannot read the audit log {audit.audit_path()} ({exc}) to check for an "
                "unfinished push"
            )
        ]
    return problems + [audit.describe_unfinished(record) for record in found]


def change_summary(changes: list[Change]) -> str:
    """``"2 programs (5 steps), 1 table, 3 timers"``, or ``"no change"``."""
    if not changes:
        return "no change"
    return changes[0].catalogue.summary([(c.key, c.old, c.new) for c in changes])


# --- pull ---------------------------------------------------------------------------


@dataclass
class PullResult:
    path: Path
    robot: Robot
    changes: list[Change] | None  # None: there was no valid previous backup
    commit: str | None = None
    #: Files an earlier pull saved and nobody touched since, still uncommitted (its
    #: commit failed or was killed): this pull's save and commit take them over.
    earlier: list[str] = field(default_factory=list)
    #: What was read, in the family's words (Catalogue.contents).
    contents: str = ""

    @property
    def changed(self) -> bool:
        """Whether the backup in git changes: a first backup, a change, or an earlier
        pull's files still to commit."""
        return self.changes is None or bool(self.changes) or bool(self.earlier)

    @property
    def summary(self) -> str:
        said = "first backup" if self.changes is None else change_summary(self.changes)
        if self.earlier:
            said += f"; with an earlier pull's backup, never committed ({_listed(self.earlier)})"
        return said


def _robot_for(path: Path, port: str | None, station: Station, family: str | None) -> Robot:
    if (path / "robot.yaml").exists():
        robot = load_robot(path)
        if family is not None and family != robot.family:
            raise ProjectError(
                f"{path / 'robot.yaml'}: the robot is of family {robot.family}, not {family}; "
                "drop --family (it is only for a first pull) or pull into another directory"
            )
        return robot
    if not port:
        raise ProjectError(
            f"{path}: no robot.yaml here; give --port (and --station) for a first pull"
        )
    return families.get(family).new_robot(
        path.resolve().name, _absolute_sim_path(port), station_number(family, station)
    )


def _absolute_sim_path(port: str) -> str:
    """``sim://projects/x`` as ``sim:///abs/projects/x``: robot.yaml works from any directory."""
    if not port.startswith("sim://"):
        return port
    rest = port[len("sim://") :]
    path, sep, query = rest.partition("?")
    if not path or path.startswith(("@", "/")):
        return port
    return f"sim://{Path(path).resolve()}{sep}{query}"


def _uncommitted(path: Path, *, ignore: tuple[str, ...] = ()) -> str:
    """The files under ``path`` with uncommitted changes, for a message ('' when none)."""
    return _listed([f for f in git.changed_files(path) if Path(f).name not in ignore])


def _listed(files: list[str]) -> str:
    return ", ".join(files[:3]) + (", ..." if len(files) > 3 else "")


def _earlier_pull_and_edits(path: Path) -> tuple[list[str], str]:
    """What a pull finds uncommitted under ``path`` (robot.yaml aside, which it never
    rewrites): the files an earlier pull saved and nobody touched since, and the
    others, for a message ('' when none).

    The first are harlsync's own backup whose commit failed (a stale index.lock,
    a pull killed between its save and its commit): the save's record of what it
    wrote (:func:`~harlsync.project.store.edited_since_save`) tells them from a
    person's edit, which a pull must never overwrite.
    """
    dirty = [f for f in git.changed_files(path) if Path(f).name != "robot.yaml"]
    top = git.repo_root(path)
    if not dirty or top is None:
        return [], ""
    inside = {f: (top / f).relative_to(path.resolve()).as_posix() for f in dirty}
    edited = set(edited_since_save(path, inside.values()))
    return (
        [name for name in inside.values() if name not in edited],
        _listed([f for f, name in inside.items() if name in edited]),
    )


@holding_project("pull")
def pull(
    path: str | Path,
    *,
    port: str | None = None,
    station: Station = None,
    commit: bool = False,
    progress: Progress | None = None,
    lock_timeout: float = 10.0,
    allow_dirty: bool = False,
    family: str | None = None,
    new_robot: bool = False,
    connect_options: Mapping[str, Any] | None = None,
) -> PullResult:
    """Read everything from the robot and write the project, atomically.

    A controller that does not look like the robot of the backup in ``path``
    (another version or program configuration, or most of the backup would
    change) is refused with PolicyError and the backup left as it was, unless
    ``new_robot`` (see :func:`_same_robot`).

    A pull that fails leaves the previous files untouched.  A project with
    uncommitted edits (other than robot.yaml, which a pull never rewrites) is
    refused unless ``allow_dirty``: the pull would overwrite them.  Files an
    earlier pull saved, untouched since, are not edits: this pull takes them over
    (:attr:`PullResult.earlier`) and commits them with its own.  ``family``
    names the controller family of a first pull (default: HARL-U2);
    ``connect_options`` are the connection's (see :func:`connect`).
    """
    path = Path(path)
    robot = _robot_for(path, port, station, family)
    station = station_number(robot.family, station)
    earlier, dirty = ([], "") if allow_dirty else _earlier_pull_and_edits(path)
    if dirty:
        raise PolicyError(
            f"{path}: uncommitted changes a pull would overwrite ({dirty}); "
            f"commit or stash them, or overwrite them with 'harlsync pull {path} --allow-dirty'"
        )
    read = read_live(
        robot,
        port,
        station,
        registers=robot.keep_registers,
        progress=progress,
        lock_timeout=lock_timeout,
        options=connect_options,
    )
    live = read.live
    try:  # after the read: the first request need not wait for it (issue 15)
        previous: Any = load_project(path).data
    except ProjectError:
        previous = None
    if previous is not None and not new_robot:
        _same_robot(path, catalogue(robot), previous, live, read.driver.label)
    save_project(path, Project(path, robot, live))
    changes = (
        None
        if previous is None
        else diff(catalogue(robot), previous, live, registers=robot.keep_registers)
    )
    result = PullResult(
        path,
        robot,
        changes,
        earlier=earlier,
        contents=catalogue(robot).contents(live, registers=robot.keep_registers),
    )
    since = history.read(path).get("last_success")
    history.record(path, ok=True, changed=result.changed, changes=result.summary)
    if commit and result.changed:
        message = history.commit_message(
            f"pull {robot.name}",
            result.summary,
            audit.changed_names(result.changes or []),
            audit.pushes_since(robot.port, robot.station, path, since),
        )
        result.commit = git.commit([path], message)
        if result.commit:
            history.committed(path, result.commit)
    return result


#: A pull that would change more than this share of the items of one kind (steps,
#: positions...) looks like another robot ...
MOST = 0.5
#: ... when there are at least this many: a small table re-taught is the same robot.
FEW_ITEMS = 10


def _same_robot(path: Path, things: Catalogue, backup: Any, live: Any, where: str) -> None:
    """Raise PolicyError unless the controller read (``live``) looks like the robot
    backed up in ``path``: the same identity (the family's: version, configuration,
    model), and not most items of a kind changed at once (runtime data aside), which
    a wrong port or station, a swapped controller or a lost memory would do.

    Each kind is judged alone: the HARL-U2's 100 offset tables, most of them unused
    and alike on every robot, must not hide that every program step changed."""
    was, now = things.robot_identity(backup), things.robot_identity(live)
    differ = [
        f"{name} {now.get(name)!r} (the backup has {value!r})"
        for name, value in was.items()
        if now.get(name) != value
    ]
    if not differ:
        held = things.items(backup, registers=False).keys() | things.items(live, registers=False)
        changes = diff(things, backup, live)
        for kind in sorted({key.kind for key in held}):
            of_kind = [c for c in changes if c.key.kind == kind]
            count = sum(key.kind == kind for key in held)
            if count >= FEW_ITEMS and len(of_kind) > MOST * count:
                differ = [
                    (
                        f"{change_summary(of_kind)} would change, {len(of_kind)} of the "
                        f"{count} items of that kind: it looks like another robot, or one "
                        "whose memory was lost"
                    )
                ]
                break
    if differ:
        raise PolicyError(
            f"{path}: the controller at {where} does not look like the robot backed up "
            f"here: {'; '.join(differ)}. The backup was left as it was. If this is the "
            f"robot (replaced, reconfigured, updated), accept it with "
            f"'harlsync pull {path} --new-robot'"
        )


# --- diff and plan ------------------------------------------------------------------


@dataclass
class Comparison:
    """The live robot against the project.  ``driver`` is closed; it still names
    the robot and builds its commands."""

    project: Project
    driver: Driver
    live: Any
    changes: list[Change]
    #: Earlier pushes to this robot that never finished (see :mod:`.audit`).
    warnings: list[str] = field(default_factory=list)
    #: With ``idle_check``, when the robot is not idle: why a push would be refused now.
    busy: str | None = None
    #: What was read, in the family's words (Catalogue.contents).
    contents: str = ""
    #: Whether runtime data was compared.
    registers: bool = False

    @property
    def target(self) -> str:
        return self.driver.label

    def plan(self) -> Plan:
        """The plan a push would carry out, from this comparison."""
        return make_plan(
            catalogue(self.project.robot),
            self.live,
            self.project.data,
            self.driver,
            robot=self.project.robot.name,
            registers=self.registers,
        )


def compare(
    path: str | Path,
    *,
    port: str | None = None,
    station: Station = None,
    progress: Progress | None = None,
    registers: bool = False,
    lock_timeout: float = 10.0,
    idle_check: bool = False,
    connect_options: Mapping[str, Any] | None = None,
) -> Comparison:
    """Read the live robot and compare it with the project, item by item; with
    ``idle_check`` also say whether a push would be refused now (robot not idle)."""
    project = load_project(path)
    station = station_number(project.robot.family, station)
    read = read_live(
        project.robot,
        port,
        station,
        registers=registers,
        progress=progress,
        lock_timeout=lock_timeout,
        idle_check=idle_check,
        options=connect_options,
    )
    things = catalogue(project.robot)
    changes = diff(things, read.live, project.data, registers=registers)
    return Comparison(
        project,
        read.driver,
        read.live,
        changes,
        read.warnings,
        read.busy,
        things.contents(read.live, registers=registers),
        registers,
    )


def plan(
    path: str | Path,
    *,
    port: str | None = None,
    station: Station = None,
    progress: Progress | None = None,
    registers: bool = False,
    lock_timeout: float = 10.0,
    connect_options: Mapping[str, Any] | None = None,
) -> Plan:
    """The plan a push would carry out now; sends no write."""
    return compare(
        path,
        port=port,
        station=station,
        progress=progress,
        registers=registers,
        lock_timeout=lock_timeout,
        connect_options=connect_options,
    ).plan()


# --- push and rollback --------------------------------------------------------------


@dataclass
class PushOptions:
    """Everything a person decides for one push or rollback."""

    yes: bool = False
    #: Asks a person to confirm the plan; without it and without ``yes`` the push is
    #: refused before the robot is read.
    confirm: Callable[[Plan], bool] | None = None
    reason: str | None = None
    allow_dirty: bool = False
    outside_window: str | None = None
    allow_reconfigure: bool = False
    allow_live_tuning: bool = False
    registers: bool = False
    plan_file: str | Path | None = None
    lock_timeout: float = 10.0
    now: datetime | None = None
    progress: Progress | None = None
    #: the connection's family options (see :func:`connect`): ``reset_function``
    connect_options: Mapping[str, Any] = field(default_factory=dict)


@dataclass
class PushResult:
    """What a push did: the plan, what was written, and what was not."""

    plan: Plan | None = None
    written: list[PlannedWrite] = field(default_factory=list)
    not_written: list[PlannedWrite] = field(default_factory=list)
    failed: PlannedWrite | None = None
    error: str | None = None
    snapshot: Path | None = None
    audit_log: Path | None = None
    #: Earlier pushes to this robot that never finished (see :mod:`.audit`).
    warnings: list[str] = field(default_factory=list)
    #: What the family says after anything was written (IAI: not yet in flash ROM).
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.error is None


class PushFailed(SyncError):
    """A push stopped; ``result`` says exactly what was and was not written."""

    def __init__(self, cause: HarlsyncError, result: PushResult) -> None:
        self.cause = cause
        self.result = result
        super().__init__(str(cause))


def _check_window(robot: Robot, opts: PushOptions, before: str | None = None) -> None:
    """Refuse outside the maintenance windows: before the port is opened, and again
    ``before`` each write, so a long push stops when its window closes."""
    now = opts.now or datetime.now()
    if not opts.outside_window and not robot.in_window(now):
        windows = "; ".join(str(w) for w in robot.windows)
        stopped = f"; stopped before {before}" if before else ""
        raise PolicyError(
            f"robot {robot.name}: {now:%a %H:%M} is outside its maintenance windows ({windows})"
            f"{stopped}; wait for a window or give --outside-window REASON"
        )


def _no_answer(exc: HarlsyncError) -> bool:
    """The line failed without any robot answering: the port, or silence (wrong
    station, cable, baud) rather than an LNR reply that makes no sense."""
    if isinstance(exc, LinkTimeout):
        return not isinstance(exc.__cause__, ReplyError)
    return isinstance(exc, PortError | PortBusyError)


def _interlock(driver: Driver, robot: Robot, before: str) -> None:
    """Raise InterlockError unless LNR shows every task known and idle.

    When no robot answers at all the link's own error goes through (exit 2, like
    diff and pull): nothing can be written either way, and "refused for safety"
    would send the reader looking for a running task instead of at the port.
    """
    try:
        status = driver.status()
    except HarlsyncError as exc:
        if _no_answer(exc):
            raise
        raise InterlockError(
            f"robot {robot.name} ({driver.label}): cannot read the task states before "
            f"{before} ({exc}); not writing"
        ) from exc
    if not status.idle:
        raise InterlockError(
            f"robot {robot.name} ({driver.label}) is not idle: {status.describe()}; "
            f"stopped before {before}. Stop the robot (or wait for the cycle to end) and run again"
        )


#: A snapshot's name: a sequence number, which orders the snapshots whatever the clock
#: did between two pushes, then the time (for people) and the action:
#: ``000012-20261124T202350.294650Z-push``.  Names an older harlsync gave have no
#: number (``20261124T202350.294650Z-push``): they come before every numbered one.
_SNAPSHOT_NAME = re.compile(
    r"(?:(?P<number>[0-9]+)-)?(?P<time>[0-9]{8}T[0-9.]+Z)-(?P<action>[a-z]+)"
)


def _snapshot_number(snapshot: Path) -> int:
    """Its sequence number; 0 for a name without one."""
    match = _SNAPSHOT_NAME.fullmatch(snapshot.name)
    return int(match["number"]) if match and match["number"] else 0


class Snapshot(NamedTuple):
    """A snapshot, as its name tells it."""

    number: int  # 0 for a name an older harlsync gave
    time: datetime | None  # UTC; None in a name harlsync did not give
    action: str  # what it was taken before: push or rollback
    path: Path


def all_snapshots(path: str | Path) -> list[Snapshot]:
    """Every snapshot of the project (before pushes and rollbacks), oldest first."""
    root = Path(path) / SNAPSHOT_DIR
    if not root.is_dir():
        return []
    found = []
    for taken in root.iterdir():
        match = _SNAPSHOT_NAME.fullmatch(taken.name)
        if match and taken.is_dir():
            try:
                when = datetime.strptime(match["time"], "%Y%m%dT%H%M%S.%fZ")
            except ValueError:  # not a time harlsync wrote: the number still orders it
                when = None
            found.append(
                Snapshot(
                    int(match["number"] or 0),
                    when and when.replace(tzinfo=timezone.utc),
                    match["action"],
                    taken,
                )
            )
    return sorted(found, key=lambda s: (s.number, s.path.name))


def snapshots(path: str | Path, action: str = "push") -> list[Path]:
    """The snapshots taken before each ``action`` (push or rollback), oldest first:
    rollback restores the last of the pushes'."""
    return [s.path for s in all_snapshots(path) if s.action == action]


def _save_snapshot(path: Path, robot: Robot, live: Any, action: str) -> Path:
    """Save the robot as a snapshot, whole or not at all: it is saved under a
    hidden name and renamed, so a process killed meanwhile leaves no half
    snapshot for rollback to pick (the next snapshot removes the leftover)."""
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S.%fZ")
    history.ensure_local_dir(path)
    root = (path / SNAPSHOT_DIR).resolve()
    try:
        root.mkdir(exist_ok=True)
        for leftover in root.glob(".*.partial"):
            shutil.rmtree(leftover, ignore_errors=True)
        number = 1 + max((_snapshot_number(p) for p in root.iterdir()), default=0)
        name = f"{number:06d}-{stamp}-{action}"
        partial = root / f".{name}.partial"
        save_project(partial, Project(partial, robot, live))
        target = root / name
        os.rename(partial, target)
        if os.name == "posix":  # the rename must be on disk before the first write
            fd = os.open(root, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
    except OSError as exc:
        raise disk_error(exc, root, f"save the snapshot before the {action}") from exc
    return target


def _deploy(
    action: str,
    project: Project,
    target: Any,
    opts: PushOptions,
    port: str | None,
    station: Station,
) -> PushResult:
    robot = project.robot
    station = station_number(robot.family, station)
    _check_audit_log()
    result = PushResult()
    record = audit.base_record(action)
    record.update(
        robot={
            "name": robot.name,
            "port": port or robot.port,
            "station": station if station is not None else robot.station,
        },
        project=str(project.path.resolve()),
        commit=git.head(project.path),
        reason=opts.reason,
        outside_window=opts.outside_window,
    )
    driver: Driver | None = None
    try:
        if not opts.yes and opts.confirm is None:  # before minutes of reading the robot
            review = f"review it with 'harlsync plan {project.path}', then " * (action == "push")
            raise PolicyError(
                f"nobody to confirm the {action} (no terminal to ask on) and no "
                f"--yes: nothing was read or written; {review}give --yes"
            )
        _check_window(robot, opts)
        driver = connect(
            robot, port, station, lock_timeout=opts.lock_timeout, options=opts.connect_options
        )
        result.warnings = _unfinished(robot, port, station)
        if not opts.allow_live_tuning:
            _interlock(driver, robot, "reading the robot")
        live = driver.read_all(registers=opts.registers, progress=opts.progress)
        result.plan = the_plan = make_plan(
            catalogue(robot), live, target, driver, robot=robot.name, registers=opts.registers
        )
        record["plan"] = the_plan.commands
        _check_plan(the_plan, opts)
        if the_plan.empty:
            record["result"] = "nothing to write"
            return result
        if not opts.yes and not (opts.confirm and opts.confirm(the_plan)):
            raise PolicyError("push not confirmed: nothing was written")
        result.snapshot = _save_snapshot(project.path, robot, live, action)
        record["snapshot"] = str(result.snapshot)
        _journal(dict(record, event="start"))
        _write_all(
            driver,
            robot,
            the_plan,
            opts,
            result,
            lambda w: _journal(
                {
                    "event": "write",
                    "id": record["id"],
                    "time": audit.now(),
                    "item": w.name,
                    "command": w.command,
                    "changes": audit.change_entries(w.items),
                }
            ),
        )
        record["result"] = "ok"
        return result
    except (HarlsyncError, KeyboardInterrupt) as exc:
        stopped: HarlsyncError = (
            exc if isinstance(exc, HarlsyncError) else SyncError(f"{action} interrupted (Ctrl-C)")
        )
        result.error = str(stopped)
        refused = isinstance(exc, InterlockError | PolicyError | StalePlanError)
        record["result"] = (
            "refused"
            if refused
            else "interrupted"
            if isinstance(exc, KeyboardInterrupt)
            else "failed"
        )
        record["error"] = result.error
        if result.plan is not None:
            done = {id(w) for w in result.written}
            result.not_written = [w for w in result.plan.writes if id(w) not in done]
        raise PushFailed(stopped, result) from exc
    except BaseException as exc:  # a bug: still record what was written
        result.error = f"{type(exc).__name__}: {exc}"
        record["result"] = "failed"
        record["error"] = result.error
        raise
    finally:
        record["written"] = [audit.written_entry(w) for w in result.written]
        if result.failed is not None:
            record["failed_item"] = result.failed.name
        if result.warnings:
            record["warnings"] = result.warnings
        if result.written or result.failed is not None:
            planned = result.plan.notes if result.plan is not None else []
            result.notes = [*planned, *families.get(robot.family).deploy_notes]
            if result.notes:
                record["notes"] = result.notes
        if driver is not None:
            driver.close()
        try:
            result.audit_log = audit.append(record)
        except OSError as exc:
            # Never hide what happened on the robot behind the log's own failure.
            log.error("cannot write the audit log's end record for this %s: %s", action, exc)
            result.warnings.append(
                f"the audit log {audit.audit_path()} could not record the end of this {action} "
                f"({exc}); what it wrote is listed here"
            )


def _journal(record: dict[str, Any]) -> None:
    """Append a start or write record before the write it announces; stop if it fails."""
    try:
        audit.append(record)
    except OSError as exc:
        raise SyncError(
            f"cannot write the audit log {audit.audit_path()} ({exc}); stopped before "
            + ("the first write" if record["event"] == "start" else f"writing {record['item']}")
        ) from exc


def _check_audit_log() -> None:
    """Refuse, before the port is opened, a push whose audit record could not be kept."""
    path = audit.audit_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        os.close(os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644))
    except OSError as exc:
        raise PolicyError(
            f"cannot write the audit log {path} ({exc}); nothing was written. "
            "Fix it or set HARLSYNC_AUDIT_LOG to a writable file"
        ) from exc


def _check_plan(the_plan: Plan, opts: PushOptions) -> None:
    if opts.plan_file is not None:
        saved = Plan.load_saved(opts.plan_file)
        if (saved.get("robot"), saved.get("target")) != (the_plan.robot, the_plan.target):
            raise StalePlanError(
                f"the plan {opts.plan_file} was made for {saved.get('robot')} "
                f"({saved.get('target')}), not {the_plan.robot} ({the_plan.target}); make "
                "a plan of this robot and review it"
            )
        if saved["live_fingerprint"] != the_plan.live_fingerprint:
            raise StalePlanError(
                f"the robot changed since the plan {opts.plan_file} was made; "
                "make a new plan and review it"
            )
        if saved["project_fingerprint"] != the_plan.project_fingerprint:
            raise StalePlanError(
                f"the project changed since the plan {opts.plan_file} was made; "
                "make a new plan and review it"
            )
    if the_plan.unwritable:
        raise PolicyError("cannot deploy: " + "; ".join(the_plan.unwritable))
    if the_plan.reconfiguration is not None and not opts.allow_reconfigure:
        raise PolicyError(the_plan.reconfiguration)


def _write_all(
    driver: Driver,
    robot: Robot,
    the_plan: Plan,
    opts: PushOptions,
    result: PushResult,
    announce: Callable[[PlannedWrite], None],
) -> None:
    tunable = catalogue(robot).live_tuning

    def live(write: PlannedWrite) -> bool:
        return opts.allow_live_tuning and write.key.kind in tunable and not write.unsafe

    if opts.allow_live_tuning and not all(live(w) for w in the_plan.writes):
        # Live tuning covers timers and tables only: a plan that also holds any
        # other write needs an idle robot before its first write of any kind.
        _interlock(driver, robot, f"the first write ({the_plan.writes[0].name})")
    for write in the_plan.writes:
        now = driver.read(write.key)
        if now != write.old:
            raise StalePlanError(
                f"{write.name} changed on the robot since it was read "
                f"({audit.difference(catalogue(robot), write.key, write.old, now)}); not "
                "overwriting it. Pull or diff to see the change, then run again"
            )
        _check_window(robot, opts, f"writing {write.name}")
        announce(write)  # before the interlock: nothing between LNR and the write
        if not live(write):
            try:
                _interlock(driver, robot, f"writing {write.name}")
            except InterlockError as exc:
                raise InterlockError(f"{exc}{_maybe_hit(result, live)}") from exc
        result.failed = write
        # A re-send after a lost reply is a write too: the same interlock applies.
        driver.write(write.key, write.new, write.old, needs_idle=not live(write))
        got = driver.read(write.key)
        if got != write.new:
            raise VerifyError(
                f"{write.name} does not read back as written "
                f"({audit.difference(catalogue(robot), write.key, write.new, got)}, written → "
                "read back)"
            )
        result.failed = None
        result.written.append(write)
        log.info("wrote %s: %s", write.name, write.command)
    if _last_guarded(result, live) is not None:
        # The last write that needed an idle robot had no LNR after it: one more tells
        # whether the robot was started between the LNR before it and its arrival (no
        # client can prevent that).
        try:
            status = driver.status()
        except HarlsyncError as exc:
            result.warnings.append(f"cannot read the task states after the last write ({exc})")
            return
        if not status.idle:
            result.warnings.append(
                f"robot {robot.name} ({driver.label}) is not idle at the end of the push: "
                f"{status.describe()}{_maybe_hit(result, live)}"
            )


def _last_guarded(result: PushResult, live: Callable[[PlannedWrite], bool]) -> PlannedWrite | None:
    """The last write made that needed an idle robot (the last one LNR cleared)."""
    return next((w for w in reversed(result.written) if not live(w)), None)


def _maybe_hit(result: PushResult, live: Callable[[PlannedWrite], bool]) -> str:
    """What an operator must check when the robot turned out started mid-push."""
    last = _last_guarded(result, live)
    if last is None:
        return ""
    return (
        f". It was started after the status read before {last.name}: that write may "
        "have reached it while a task ran; check the robot"
    )


@holding_project("push")
def push(
    path: str | Path,
    opts: PushOptions,
    *,
    port: str | None = None,
    station: Station = None,
) -> PushResult:
    """Make the robot equal the project, safely.  Raises PushFailed with the result.

    An invalid or uncommitted project is refused before the port is opened, and
    the refusal is audited like any other.
    """
    try:
        project, files = read_project(path)
        station = station_number(project.robot.family, station)
        if not opts.allow_dirty:
            _check_committed(Path(path), files)
    except HarlsyncError as exc:
        _audit_refusal("push", path, opts, exc)
        raise
    return _deploy("push", project, project.data, opts, port, station)


def _check_committed(path: Path, files: Mapping[str, bytes]) -> None:
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


def _audit_refusal(action: str, path: str | Path, opts: PushOptions, exc: HarlsyncError) -> None:
    record = audit.base_record(action)
    record.update(
        project=str(Path(path).resolve()),
        reason=opts.reason,
        result="refused",
        error=str(exc),
        written=[],
    )
    try:
        audit.append(record)
    except OSError as err:
        log.error("cannot write the audit log: %s", err)


@holding_project("rollback")
def rollback(
    path: str | Path,
    opts: PushOptions,
    *,
    snapshot: str | Path | None = None,
    port: str | None = None,
    station: Station = None,
) -> PushResult:
    """Restore the snapshot taken before the last push, under the same interlocks.

    A rollback takes a snapshot of its own (``...-rollback``), but rolling back
    again still restores the state before the last push, never the rollback's.
    """
    project = load_project(path)
    station = station_number(project.robot.family, station)
    taken = snapshots(path)
    chosen = Path(snapshot) if snapshot else (taken[-1] if taken else None)
    if chosen is None:
        raise SyncError(f"{path}: no snapshot to roll back to (none has been taken by a push)")
    saved = load_project(chosen)
    return _deploy("rollback", project, saved.data, opts, port, station)
