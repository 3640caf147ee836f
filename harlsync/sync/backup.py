"""The nightly plant backup: pull every robot, one commit per run, a report.

Three layers, each importing only the one before it: one robot's backup
(:mod:`.robotbackup`), the fleet that runs them on the plant's lines
(:mod:`.fleet`), and this module, the plant run (outputs checked first, the
commit on the backup branch); what the run tells (the report, metrics and hooks)
is :mod:`.backupreport`'s.

Robots on separate lines are pulled in parallel (every line at once, or at
most ``jobs`` lines at once), spread over a worker process per core
(:mod:`harlsync.sync.fleet`);
robots that share a line (stations of one controller on one port) are pulled one after
the other by the same worker, so their frames never interleave.  A robot that
fails leaves its previous backup as it was (a pull is atomic) and the others go
on.  Each project records its last successful backup in
``DIR/.harlsync/backup.json``, so the report can flag robots that are stale or
never had a good backup.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Iterable
from contextlib import ExitStack
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

from ..errors import HarlsyncError, ProjectError, SyncError
from ..link.lock import LockTimeout
from ..project.lock import holder, lock_path, project_lock
from . import backupcommit, backupref, git, history, states
from .backupreport import BackupReport
from .robotbackup import (
    BackupWatch,
    RobotOutcome,
    Unwatched,
    in_process,
    line_of,
    lines_of,
    record_not_backed_up,
)

if TYPE_CHECKING:  # for the checker only: not imported at run time
    from typing_extensions import Unpack

__all__ = [
    "BackupReport",
    "BackupWatch",
    "RobotOutcome",
    "backup",
    "find_projects",
    "in_process",
    "line_of",
    "lines_of",
    "record_not_backed_up",
]

log = logging.getLogger(__name__)


def find_projects(paths: Iterable[str | Path]) -> list[Path]:
    """Project directories: each PATH that holds a robot.yaml, or those below it.

    Raises ProjectError for a PATH that is neither.
    """
    found: list[Path] = []
    for raw in paths:
        path = Path(raw)
        if (path / "robot.yaml").is_file():
            found.append(path)
            continue
        if not path.is_dir():
            raise ProjectError(f"{path}: no such directory")
        below = sorted(p.parent for p in path.glob("**/robot.yaml") if ".harlsync" not in p.parts)
        if not below:
            raise ProjectError(f"{path}: no robot project here (no robot.yaml below it)")
        found += below
    unique: dict[Path, None] = {p.resolve(): None for p in found}
    return list(unique)


def project_labels(paths: Iterable[Path]) -> dict[Path, str]:
    """Each project's directory relative to the deepest one that holds them all
    (``lineA/cell``), or its own name when it is alone: what tells two robots of
    one name apart."""
    found = [Path(p) for p in paths]
    if not found:
        return {}
    top = Path(os.path.commonpath([str(p.resolve().parent) for p in found]))
    return {p: p.resolve().relative_to(top).as_posix() for p in found}


def shown_names(robots: Iterable[tuple[str, str]]) -> list[str]:
    """Each (name, project label) as a person reads it: the name, or ``cell
    (lineA/cell)`` when another robot has the same name."""
    listed = list(robots)
    count: dict[str, int] = {}
    for name, _ in listed:
        count[name] = count.get(name, 0) + 1
    return [name if count[name] == 1 else f"{name} ({label})" for name, label in listed]


def _record_commit(paths: list[Path], commit: str) -> None:
    """Record in each robot's history the commit that holds its backup.  A history
    that cannot be written costs only the commit shown by ``harlsync status``."""
    for path in paths:
        try:
            history.committed(path, commit)
        except HarlsyncError as exc:
            log.warning("%s: %s", path.name, exc)


class BackupOptions(TypedDict, total=False):
    """A backup's options, as :func:`_run` takes them."""

    jobs: int | None
    workers: int | None
    commit: bool
    push: bool
    stale_after: timedelta
    attempts: int
    lock_timeout: float
    now: datetime | None
    watch: BackupWatch | None


def backup(paths: Iterable[str | Path], **options: Unpack[BackupOptions]) -> BackupReport:
    """Pull every robot under ``paths``; commit and push once when asked (see
    :func:`_run` for the ``options``).

    One backup of a PATH runs at a time: a second one while the first runs (an
    overlapping cron schedule, a run that hangs) raises SyncError at once, naming
    the one that runs, and backs up nothing.
    """
    given = list(dict.fromkeys(Path(p).resolve() for p in paths))
    with ExitStack() as running:
        for path in given:
            key = path / ".harlsync-backup-run"
            try:
                running.enter_context(project_lock(key, timeout=0, command="backup"))
            except ProjectError as exc:
                if not isinstance(exc.__cause__, LockTimeout):
                    raise
                raise SyncError(
                    f"a backup of {path} is running already ({holder(lock_path(key))}); "
                    "this one backs up nothing and stops. If cron starts the next before "
                    "the last ends, space the runs out or give fewer robots to each"
                ) from exc
        return _run(given, **options)


def _run(
    paths: Iterable[str | Path],
    *,
    jobs: int | None = None,
    workers: int | None = None,
    commit: bool = False,
    push: bool = False,
    stale_after: timedelta = timedelta(hours=36),
    attempts: int = 2,
    lock_timeout: float = 60.0,
    now: datetime | None = None,
    watch: BackupWatch | None = None,
) -> BackupReport:
    """Pull every robot under ``paths``; commit and push once when asked.

    ``now`` is the time the run starts (default: the clock's); staleness is judged
    at it, and each robot's good backup is recorded as ``now`` plus the time the
    run took until that robot was done.

    ``workers`` is how many processes read the lines (default: one per core, see
    :mod:`harlsync.sync.fleet`), ``jobs`` how many lines are read at once in all
    (default: all of them).  Each line spends nearly all its time waiting for the
    wire, so a line costs a thread, not a core: a fixed pool of 4 made 32 robots
    take 8 times as long as one; but at a hundred lines one process needs its
    whole core.  ``watch`` hears of each robot as it starts, reads and ends.
    Interrupted (KeyboardInterrupt), every robot's read stops at its next exchange,
    in every worker, leaving its previous backup as it was, before the
    interruption goes on.
    """
    from . import fleet

    started = time.monotonic()
    now = now or datetime.now(timezone.utc)

    def clock() -> datetime:
        """The run's clock: ``now`` at its start, then as time passes (a robot's
        good backup is recorded when it ended, not when the run began)."""
        return now + timedelta(seconds=time.monotonic() - started)

    projects = find_projects(paths)
    # Pushes made from other clones moved their deployed refs there: fetched first,
    # so that tonight's comparison credits them.
    fetched = backupcommit.fetch_deployed(projects[0]) if push and projects else None
    outcomes = fleet.read_lines(
        projects,
        fleet.Task(attempts, lock_timeout, clock),
        workers=fleet.default_workers() if workers is None else max(1, workers),
        jobs=jobs,
        watch=watch or Unwatched(),
        watched=watch is not None,
    )
    _name_outcomes(outcomes, projects, now, stale_after)
    report = _report(outcomes, projects, now, fetched, commit=commit, push=push)
    report.duration = time.monotonic() - started
    return report


def _report(
    outcomes: list[RobotOutcome],
    projects: list[Path],
    now: datetime,
    fetched: str | None,
    *,
    commit: bool,
    push: bool,
) -> BackupReport:
    """The run's report once every robot was read: what it committed (and pushed)
    when asked, each robot's three states recorded."""
    report = BackupReport(outcomes, started=now.isoformat(timespec="seconds"))
    if fetched:
        report.said.append(fetched)
    legacy = [Path(o.path) for o in outcomes if o.ok and o.changed and o.kept is None]
    kept = [o for o in outcomes if o.ok and o.kept is not None]
    if commit:
        _commit_run(report, projects, legacy, kept, push=push)
    _record_states(kept)
    return report


def _name_outcomes(
    outcomes: list[RobotOutcome], projects: list[Path], now: datetime, stale_after: timedelta
) -> None:
    """Give each outcome its project label and the name a person reads, sort them by
    it, and flag the robots never backed up or whose last good backup is stale at
    ``now``."""
    labels = project_labels(projects)
    for outcome in outcomes:
        outcome.project = labels.get(Path(outcome.path), outcome.name)
    outcomes.sort(key=lambda o: (o.name, o.project))
    for outcome, shown in zip(outcomes, shown_names((o.name, o.project) for o in outcomes)):
        outcome.label = shown

    for outcome in outcomes:
        outcome.never_backed_up = outcome.last_success is None
        outcome.stale = history.stale(outcome.last_success, now, stale_after)


def _commit_run(
    report: BackupReport,
    projects: list[Path],
    legacy: list[Path],
    kept: list[RobotOutcome],
    *,
    push: bool,
) -> None:
    """Commit the night's backups (``legacy``: pulled into their directories, on
    their branch; ``kept``: on the backup branch) and, with ``push``, push; what
    failed is told in ``report``, never raised."""
    if legacy:  # pulled into their directories: committed on their branch, as before
        try:
            report.commit = git.commit(legacy, report.commit_message())
        except HarlsyncError as exc:  # the night's report, metrics and hooks still come
            report.commit_error = str(exc)
        if report.commit:
            _record_commit(legacy, report.commit)
    if kept:
        _commit_kept(report, kept)
    if push:
        # Push even when nothing changed tonight: it catches up a failed push.
        try:
            # The robots' own states; the branch only for what was committed on it
            # (robots pulled into their directories), or in a plant without them.
            if not backupcommit.push_refs(projects[0]) or legacy:
                git.push(projects[0])
            report.pushed = True
        except HarlsyncError as exc:
            report.pushed, report.push_error = False, str(exc)


def _commit_kept(report: BackupReport, kept: list[RobotOutcome]) -> None:
    """Commit what the robots in git were read to hold on the backup branch (the
    approved branch and working tree untouched), and record where it is."""
    try:
        new, said = backupcommit.commit_observed(
            [(Path(o.path), o.kept, o.compared) for o in kept if o.kept is not None],
            report.commit_message(),
        )
    except HarlsyncError as exc:
        report.commit_error = str(exc)
        return
    report.said += said
    if new is not None:
        report.commit = report.commit or new
        _record_commit([Path(o.path) for o in kept if o.changed], new)
    for o in kept:
        standing, where = o.compared, o.kept
        if standing is None or where is None:
            continue
        root = Path(where["root"])
        standing.observed = backupref.commit_of(root, backupref.BACKUP_REF)
        if standing.deployed is None:
            standing.deployed = backupref.commit_of(root, backupref.deployed_ref(where["where"]))
        o.standing = standing.to_json()


def _record_states(kept: list[RobotOutcome]) -> None:
    """Record each robot's three states for ``harlsync status``; a record that cannot
    be written is logged (the backup itself is done)."""
    for o in kept:
        standing = o.compared
        if standing is None:
            continue
        try:
            states.write(Path(o.path), standing)
        except HarlsyncError as exc:
            log.warning("%s", exc)
