"""Push and rollback: the writes of the candidate workflow, under the interlock.

How a push goes (each step stops the push when it fails; nothing is written
before the last check)::

    load + validate the project      (before the port is touched)
    policy: git clean, maintenance window
    open the port (exclusive lock on the line)
    an earlier push left unfinished? (audit log: warn, naming what it wrote)
    status: robot idle?              (interlock, before the long read)
    read the live robot, make the plan
    stale plan? unwritable? reconfiguration allowed? confirmed?
    snapshot the live robot          (DIR/.harlsync/snapshots/<n>-<time>-push/)
    audit "start" record, the plan   (write-ahead, fsynced)
    for each write, in the safe order:
        read the item: as planned?   (drift: edited on the pendant since the read)
        still in the window?         (policy: a long push stops when its window closes)
        status: idle?                (interlock: before every write)
        audit "write" record         (fsynced: a SIGKILL still leaves a trace)
        write, read back, compare    (verify)
    audit "end" record               (always, whatever happened)

The interlock reads the robot's status (``Driver.status``, what the family
calls it in ``Family.words``) immediately before every write, a re-send after
a lost reply included (the family's controller reads it again before
re-sending).  With ``allow_live_tuning`` it skips that only before writes of
the kinds the family's catalogue allows while the robot runs
(``Catalogue.live_tuning``) and that are not ``unsafe``; it still reads the
status before every other write, and a plan that holds any such write needs an
idle robot before its first write.

The "for each write" loop, with the interlock and window checks, is
:mod:`.writes`; this module holds the steps around it and the audit record.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import (
    HarlsyncError,
    InterlockError,
    PartlyWritten,
    PolicyError,
    StalePlanError,
    SyncError,
)
from ..families.base import D, Driver, K
from ..project import Project, load_project, load_robot
from ..project.lock import holding_project
from ..project.store import read_project
from . import audit, git
from .live import Station, connect, station_number, unfinished_pushes
from .plan import Plan, PlannedWrite, make_plan
from .policy import check_committed
from .pushtypes import PushFailed, PushOptions, PushResult
from .snapshots import load_snapshot, save_snapshot, snapshots
from .states import mark_reverts
from .writes import check_window, interlock, write_all

__all__ = ["PushFailed", "PushOptions", "PushResult", "push", "rollback", "run"]

log = logging.getLogger(__name__)


def run(
    action: str,
    project: Project,
    target: Any,
    opts: PushOptions,
    port: str | None,
    station: Station,
) -> PushResult:
    """Deploy ``target`` (the project's data for a push, a snapshot's for a
    rollback: ``action`` says which) to the robot, with every interlock: confirmed,
    inside its window, idle, the same controller; then read, plan, snapshot and
    write, each write journalled in the audit log.

    Returns the result (its plan, what was written, the snapshot taken).  Raises
    :class:`PushFailed` carrying the result when refused or stopped part way.
    """
    robot = project.robot
    family = project.family
    station = station_number(family, station)
    _check_audit_log()
    result = PushResult()
    record = _start_record(action, project, opts, port, station)
    driver: Driver[Any, Any] | None = None
    try:
        _someone_confirms(action, project, opts)  # before minutes of reading the robot
        check_window(robot, opts)
        driver = connect(
            family,
            robot,
            port,
            station,
            lock_timeout=opts.lock_timeout,
            options=opts.connect_options,
            command=action,
        )
        result.warnings = unfinished_pushes(robot, port, station)
        live, the_plan = _read_and_plan(project, target, opts, driver, record, result)
        if the_plan.empty:
            record.result = "nothing to write"
            return result
        if not opts.yes and not (opts.confirm and opts.confirm(the_plan)):
            raise PolicyError("push not confirmed: nothing was written")
        _tell_reverts(robot.name, the_plan, opts)  # said before the first write
        result.snapshot = save_snapshot(project.path, robot, live, action)
        record.snapshot = str(result.snapshot)
        _journal(replace(record, event="start"))
        _write_journaled(project, the_plan, opts, driver, record, result)
        record.result = "ok"
        return result
    except (HarlsyncError, KeyboardInterrupt) as exc:
        raise PushFailed(_stopped(exc, action, record, result), result) from exc
    except BaseException as exc:  # a bug: still record what was written
        result.error = f"{type(exc).__name__}: {exc}"
        record.result = "failed"
        record.error = result.error
        raise
    finally:
        _finish(action, project, driver, record, result)


def _someone_confirms(action: str, project: Project, opts: PushOptions) -> None:
    """Refuse a push or rollback nobody can confirm: no terminal to ask on and no ``yes``."""
    if not opts.yes and opts.confirm is None:
        review = f"review it with 'harlsync plan {project.path}', then " * (action == "push")
        raise PolicyError(
            f"nobody to confirm the {action} (no terminal to ask on) and no "
            f"--yes: nothing was read or written; {review}give --yes"
        )


def _tell_reverts(name: str, the_plan: Plan[K], opts: PushOptions) -> None:
    """Say each write of ``the_plan`` that takes back a change made on the robot: in
    the log, and to ``opts.told`` when nobody was asked."""
    for item, said in the_plan.reverts.items():
        log.warning("%s: %s: %s", name, item, said)
        if opts.yes and opts.told is not None:
            opts.told(f"{item}: {said}")


def _start_record(
    action: str, project: Project, opts: PushOptions, port: str | None, station: int | None
) -> audit.AuditRecord:
    """The audit record of this push or rollback, as its start and end records share it."""
    robot = project.robot
    record = audit.base_record(action)
    record.robot = audit.RecordedRobot(
        robot.name, port or robot.port, station if station is not None else robot.station
    )
    record.project = str(project.path.resolve())
    record.commit = git.head(project.path)
    record.reason = opts.reason
    record.outside_window = opts.outside_window
    return record


def _read_and_plan(
    project: Project,
    target: D,
    opts: PushOptions,
    driver: Driver[K, D],
    record: audit.AuditRecord,
    result: PushResult,
) -> tuple[D, Plan[K]]:
    """Check the robot (interlock, identity), read it all and plan the writes that
    turn it into ``target``; the live data and the plan, which it records in
    ``result`` and ``record``.  Raises InterlockError or PolicyError to refuse."""
    robot, family = project.robot, project.family
    if not opts.allow_live_tuning:
        interlock(driver, robot, family.words, "reading the robot")
    # A swapped controller is refused at its first reads, not after the long read
    # (the interlock's status comes first: a robot that is not idle is told so).
    now = driver.identity()
    other = None if now is None else family.catalogue.other_identity(now, target)
    if other is not None:
        raise PolicyError(f"cannot deploy: {other}")
    live = driver.read_all(registers=opts.registers, progress=opts.progress)
    other = family.catalogue.other_robot(live, target)  # what the read found out (issue 29)
    if other is not None:
        raise PolicyError(f"cannot deploy: {other}")
    result.plan = the_plan = make_plan(
        family.catalogue, live, target, driver, robot=robot.name, registers=opts.registers
    )
    mark_reverts(project.path, live, the_plan)
    record.plan = list(the_plan.commands)
    if the_plan.reverts:
        record.reverts = [f"{name}: {said}" for name, said in the_plan.reverts.items()]
    _check_plan(the_plan, opts)
    return live, the_plan


def _write_journaled(
    project: Project,
    the_plan: Plan[K],
    opts: PushOptions,
    driver: Driver[K, D],
    record: audit.AuditRecord,
    result: PushResult,
) -> None:
    """Write the plan, journalling each write in the audit log as it is made."""
    write_all(
        project.family,
        driver,
        project.robot,
        the_plan,
        opts,
        result,
        lambda w: _journal(
            audit.AuditRecord(
                event="write",
                id=record.id,
                time=audit.now(),
                item=w.name,
                command=w.command,
                changes=audit.change_entries(w.items),
            )
        ),
    )


def _stopped(
    exc: HarlsyncError | KeyboardInterrupt,
    action: str,
    record: audit.AuditRecord,
    result: PushResult,
) -> HarlsyncError:
    """Record why the push or rollback stopped (refused, interrupted or failed) and
    what was not written; the error to raise, as its cause says."""
    stopped: HarlsyncError = (
        exc if isinstance(exc, HarlsyncError) else SyncError(f"{action} interrupted (Ctrl-C)")
    )
    result.error = str(stopped)
    if isinstance(stopped, PartlyWritten):  # refused or failed as its cause says
        stopped = stopped.cause
    refused = isinstance(stopped, InterlockError | PolicyError | StalePlanError)
    record.result = (
        "refused" if refused else "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed"
    )
    record.error = result.error
    if result.plan is not None:
        done = {id(w) for w in result.written}
        result.not_written = [w for w in result.plan.writes if id(w) not in done]
    return stopped


def _finish(
    action: str,
    project: Project,
    driver: Driver[K, D] | None,
    record: audit.AuditRecord,
    result: PushResult,
) -> None:
    """Complete the end record with what was written, close the line and append the
    record to the audit log (a log that fails is told in ``result``, never raised)."""
    family = project.family
    record.written = [audit.written_entry(w) for w in result.written]
    if result.failed is not None:
        record.failed_item = result.failed.name
        if result.partly_written is not None:
            record.partly_written = _partly(result.failed, result.partly_written)
    if result.warnings:
        record.warnings = result.warnings
    if result.written or result.failed is not None:
        planned = result.plan.notes if result.plan is not None else []
        result.notes = [*planned, *family.deploy_notes]
        if result.notes:
            record.notes = result.notes
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


def _partly(write: PlannedWrite[K], partly: PartlyWritten) -> audit.PartlyRecorded:
    """The audit record's account of an item written part way."""
    return audit.PartlyRecorded(
        write.name, write.command, tuple(partly.sent), partly.unknown, tuple(partly.left)
    )


def _journal(record: audit.AuditRecord) -> None:
    """Append a start or write record before the write it announces; stop if it fails."""
    try:
        audit.append(record)
    except OSError as exc:
        raise SyncError(
            f"cannot write the audit log {audit.audit_path()} ({exc}); stopped before "
            + ("the first write" if record.event == "start" else f"writing {record.item}")
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


def _check_plan_file(path: str | Path, plan_file: str | Path) -> None:
    """Refuse, before the robot is read, a plan file that cannot be read
    (ProjectFormatError) or that was made for another robot (StalePlanError)."""
    saved = Plan.load_saved(plan_file)
    robot = load_robot(path)
    if saved.get("robot") != robot.name:
        raise StalePlanError(
            f"the plan {plan_file} was made for robot {saved.get('robot')} "
            f"({saved.get('target')}), not {robot.name}; make one for this robot with "
            f"'harlsync plan {path} --out FILE' and review it"
        )


def _check_plan(the_plan: Plan[K], opts: PushOptions) -> None:
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
    the refusal is audited like any other.  A plan file (``opts.plan_file``) that
    cannot be read or was made for another robot is refused first: nothing was
    asked of the robot, so there is no push to record.
    """
    if opts.plan_file is not None:
        _check_plan_file(path, opts.plan_file)
    try:
        project, files = read_project(path)
        station = station_number(project.family, station)
        if not opts.allow_dirty:
            check_committed(Path(path), files)
    except HarlsyncError as exc:
        _audit_refusal("push", path, opts, exc)
        raise
    result = run("push", project, project.data, opts, port, station)
    _deployed(Path(path), files, "push", project, opts, result)
    return result


def _deployed(
    path: Path,
    files: Mapping[str, bytes],
    action: str,
    project: Project,
    opts: PushOptions,
    result: PushResult,
) -> None:
    """Move the robot's deployed ref to what the finished push or rollback made it
    hold (``files``); when it cannot move, a warning says so: the robot was written."""
    from .states import record_deployed

    try:
        result.deployed = record_deployed(
            path,
            files,
            action,
            project.robot.name,
            [w.name for w in result.written],
            opts.reason,
        )
    except HarlsyncError as exc:
        result.warnings.append(
            f"the robot's deployed state was not recorded in git ({exc}): the next backup "
            f"may report what this {action} wrote as pending"
        )


def _audit_refusal(action: str, path: str | Path, opts: PushOptions, exc: HarlsyncError) -> None:
    record = audit.base_record(action)
    record.project = str(Path(path).resolve())
    record.reason = opts.reason
    record.result = "refused"
    record.error = str(exc)
    record.written = []
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
    station = station_number(project.family, station)
    taken = snapshots(path)
    chosen = Path(snapshot) if snapshot else (taken[-1] if taken else None)
    if chosen is None:
        raise SyncError(f"{path}: no snapshot to roll back to (none has been taken by a push)")
    saved = load_snapshot(path, chosen, project.family)
    _, files = read_project(chosen, project.family)  # what the deployed ref will hold
    result = run("rollback", project, saved.data, opts, port, station)
    _deployed(Path(path), files, "rollback", project, opts, result)
    return result
