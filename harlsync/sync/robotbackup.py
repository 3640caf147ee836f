"""One robot's nightly backup: read it (a pull, or the backup branch's observation),
record the outcome in its ``.harlsync/backup.json``, and say what became of it.
The fleet (:mod:`.fleet`) runs these on the plant's lines; the plant run
(:mod:`.backup`) commits, reports and calls the hooks."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable
from contextlib import ExitStack
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Protocol

from ..errors import HarlsyncError, LinkError, ProjectError
from ..families.base import AnyFamily, Progress
from ..link import lock_key
from ..project import family_of, load_robot
from ..project.lock import project_lock
from ..robotlog import about
from . import audit, auditindex, backupcommit, history, nightly, states
from .items import summarize

__all__ = [
    "BackupWatch",
    "RobotOutcome",
    "Stopped",
    "Unwatched",
    "backup_one",
    "in_process",
    "line_of",
    "lines_of",
    "not_backed_up",
    "record_not_backed_up",
]

log = logging.getLogger(__name__)

#: The connect option a family declares when it can recover on its own what it would
#: otherwise ask a person to (see :attr:`~harlsync.families.base.Family.connect_options`).
UNATTENDED = "unattended"


@dataclass
class RobotOutcome:
    """One robot's result in a backup run."""

    name: str
    path: str
    port: str
    station: int
    ok: bool = False
    changed: bool = False
    summary: str = ""
    counts: dict[str, int] = field(default_factory=dict)
    #: How many items changed: :attr:`counts` but the family's
    #: :attr:`~harlsync.families.base.Catalogue.group_counts` (the metrics' number).
    changed_items: int = 0
    duration: float = 0.0
    error: str | None = None
    attempts: list[str] = field(default_factory=list)  # reason of each failed attempt
    last_success: str | None = None
    stale: bool = False
    never_backed_up: bool = False
    #: what the connection recovered on its own (also in the audit log)
    notes: list[str] = field(default_factory=list)
    #: Its project's directory under the plant's (``lineA/cell``): apart from
    #: another robot of the same name (see :func:`project_labels`).
    project: str = ""
    #: Its name as the report shows it: ``cell``, or ``cell (lineA/cell)`` when
    #: another robot of the run has that name.
    label: str = ""
    #: What changed, item by item (``MAIN program 0 step 4``, ``position 12 speed``).
    items: list[str] = field(default_factory=list)
    #: The pushes and rollbacks the audit log holds since its previous good backup.
    pushed: list[str] = field(default_factory=list)
    #: Its three states compared (:class:`.states.Standing` as JSON): same as
    #: approved, pending or drift; None when not read into git's keeping.
    standing: dict[str, object] | None = None
    #: What the run commits of its read on the backup branch (:meth:`.nightly.Observed.kept`);
    #: None when it was pulled into its directory (not in git, no approved version).
    kept: backupcommit.Kept | None = None

    @property
    def compared(self) -> states.Standing | None:
        """:attr:`standing` read back."""
        return states.Standing.from_json(self.standing)

    def line(self) -> str:
        """One line as it finishes: ``press: ok, changed: 1 program (1 step) (4.0 s)``."""
        took = f" ({self.duration:.1f} s)"
        if not self.ok:
            tries = f" after {len(self.attempts)} attempts" if len(self.attempts) > 1 else ""
            return f"{self.label or self.name}: FAILED{tries}: {audit.shorten(self.error)}{took}"
        said = f"changed: {self.summary}" if self.changed else self.summary or "no change"
        standing = self.compared  # said when there is something to say
        verdict = (
            f"; {standing.verdict}" if standing and (standing.pending or standing.drift) else ""
        )
        return f"{self.label or self.name}: ok, {said}{verdict}{took}"


def line_of(port: str) -> str:
    """The physical line a port URL names, so robots sharing it are pulled in turn:
    the same identity the line lock uses."""
    return lock_key(port) or port


def in_process(port: str) -> bool:
    """Whether only this process can open ``port``: a peer registered in it
    (``sim://@name``, :class:`harlsync.sim.protocol_sim.Registry`) or ``loop://``."""
    return "://@" in port or lock_key(port) is None


def lines_of(projects: Iterable[Path], here: set[str] | None = None) -> dict[str, list[Path]]:
    """The projects by line (:func:`line_of` their port), in order: each line's are
    read one after the other.  A project whose robot.yaml cannot be read is a line
    of its own (it fails, naming why).  ``here``, when given, gets the lines only
    this process can read: a port :func:`in_process`, or a robot.yaml that cannot
    be read (this process says why as well as any)."""
    lines: dict[str, list[Path]] = {}
    for path in projects:
        try:
            port = load_robot(path).port
            local = in_process(port)
        except HarlsyncError:
            port, local = f"unreadable:{path}", True
        key = line_of(port)
        lines.setdefault(key, []).append(path)
        if local and here is not None:
            here.add(key)
    return lines


class BackupWatch(Protocol):
    """What a backup tells while it runs, for a live display (the CLI's, on a
    terminal).  Called from this process's threads, one per line it reads and one per
    worker process (:mod:`harlsync.sync.fleet`).  Progress is in
    exchanges with the controller, as a pull's."""

    def started(self, path: Path, name: str) -> None:
        """Robot ``name`` (project ``path``) is being backed up."""

    def progress(self, path: Path, done: int, total: int) -> None:
        """``done`` of ``total`` exchanges of its read (a new attempt starts at 0)."""

    def finished(self, outcome: RobotOutcome) -> None:
        """It is done: :meth:`RobotOutcome.line` says how."""


class Unwatched:
    def started(self, path: Path, name: str) -> None:
        pass

    def progress(self, path: Path, done: int, total: int) -> None:
        pass

    def finished(self, outcome: RobotOutcome) -> None:
        pass


class Stopped(Exception):
    """The run was interrupted (Ctrl-C): a robot's read stops at its next exchange."""


def _pull_one(
    path: Path, attempts: int, lock_timeout: float, progress: Progress | None = None
) -> RobotOutcome:
    start = time.monotonic()
    try:
        family = family_of(path)
        robot = load_robot(path, family)
    except HarlsyncError as exc:
        return RobotOutcome(path.name, str(path), "?", 0, error=str(exc))
    outcome = RobotOutcome(robot.name, str(path), robot.port, robot.station)
    for attempt in range(1, attempts + 1):
        try:
            result = nightly.read_robot(
                path,
                lock_timeout=lock_timeout,
                progress=progress,
                family=family,
                connect_options=_unattended(family),
                noted=outcome.notes.append,  # a reset is told even when the read then fails
            )
        except Stopped:
            raise
        except LinkError as exc:  # the line may recover: try again, bounded
            outcome.attempts.append(f"attempt {attempt}: {exc}")
            outcome.error = str(exc)
            log.warning("%s", exc)
            continue
        except HarlsyncError as exc:  # garbage, bad project: trying again will not help
            outcome.attempts.append(f"attempt {attempt}: {exc}")
            outcome.error = str(exc)
            break
        except Exception as exc:  # a bug must cost one robot, never the night's backup
            log.exception("unexpected error")
            outcome.attempts.append(f"attempt {attempt}: unexpected {type(exc).__name__}: {exc}")
            outcome.error = f"unexpected {type(exc).__name__}: {exc} (please report it)"
            break
        outcome.ok, outcome.error = True, None
        outcome.changed = result.changed
        outcome.summary = result.summary
        outcome.counts = summarize(family.catalogue, result.changes or [])
        groups = family.catalogue.group_counts
        outcome.changed_items = sum(n for k, n in outcome.counts.items() if k not in groups)
        outcome.items = audit.changed_names(result.changes or [])
        if isinstance(result, nightly.Observed):
            outcome.kept = result.kept()
            outcome.standing = result.standing.to_json() if result.standing else None
        break
    outcome.duration = time.monotonic() - start
    return outcome


def _unattended(family: AnyFamily) -> dict[str, bool]:
    """The connection option of a run no person watches, for a family that takes it
    (recover a remote function left in use by a harlsync that is gone, say)."""
    return {UNATTENDED: True} if UNATTENDED in family.connect_options else {}


def backup_one(
    path: Path,
    attempts: int,
    lock_timeout: float,
    clock: Callable[[], datetime],
    watch: BackupWatch,
    stop: threading.Event,
) -> RobotOutcome:
    """Back up one robot, holding its project from the pull to the record of it,
    which says when it ended (``clock()``).  Every log line meanwhile names the
    robot (:mod:`harlsync.robotlog`).  Raises Stopped once ``stop`` is set."""

    read = [0]  # the exchanges of the last attempt's read, as the pull counts them

    def progress(done: int, total: int) -> None:
        if stop.is_set():
            raise Stopped
        read[0] = total
        watch.progress(path, done, total)

    name = _name_of(path)
    with ExitStack() as held:
        held.enter_context(about(name))
        watch.started(path, name)
        try:
            held.enter_context(project_lock(path, timeout=lock_timeout, command="backup"))
        except ProjectError as exc:  # another harlsync is saving it: one line, that robot
            outcome = not_backed_up(path, exc)
        else:
            since = history.read(path).get("last_success")
            outcome = _pull_one(path, attempts, lock_timeout, progress)
            if outcome.ok and outcome.changed:
                outcome.pushed = auditindex.pushes_since(outcome.port, outcome.station, path, since)
            outcome = _record(outcome, clock(), read[0])
    watch.finished(outcome)
    return outcome


def _name_of(path: Path) -> str:
    """The robot's name as robot.yaml gives it, else its directory's."""
    try:
        return load_robot(path).name
    except HarlsyncError:
        return path.name


def not_backed_up(path: Path, exc: HarlsyncError) -> RobotOutcome:
    """The outcome of a robot not even tried, reading only what it needs to name it."""
    try:
        robot = load_robot(path)
        outcome = RobotOutcome(robot.name, str(path), robot.port, robot.station)
    except HarlsyncError:
        outcome = RobotOutcome(path.name, str(path), "?", 0)
    outcome.error = str(exc)
    outcome.attempts.append(f"attempt 1: {exc}")
    outcome.last_success = history.read(path).get("last_success")
    return outcome


def record_not_backed_up(path: Path, exc: HarlsyncError, now: datetime) -> RobotOutcome:
    """The outcome of a robot whose backup was started and never told its end (its
    worker process was killed), recorded failed in its history as of ``now``: the
    report fails it, so ``harlsync status`` must not show last night's "ok".

    Its project lock died with the worker; a harlsync that took the project since
    records its own result after this one (a record is replaced whole, never mixed).
    """
    return _record(not_backed_up(path, exc), now)


def _record(outcome: RobotOutcome, now: datetime, exchanges: int = 0) -> RobotOutcome:
    """Record the attempt in the robot's history (``DIR/.harlsync/backup.json``),
    a good one with the ``exchanges`` its read took (what the next run weighs the
    robot's line by, :func:`harlsync.sync.fleet.plan`).

    A history that cannot be written (a read-only or full disk) fails that robot
    only: a robot backed up fine becomes a failure naming it.
    """
    path = Path(outcome.path)
    try:
        state = history.record(
            path, ok=outcome.ok, error=outcome.error, now=now, exchanges=exchanges or None
        )
    except HarlsyncError as exc:
        log.warning("%s", exc)
        if outcome.ok:
            outcome.ok, outcome.error = False, str(exc)
        state = history.read(path)
    outcome.last_success = state.get("last_success")
    return outcome
