"""The plant's commands: ``backup``, ``status``, ``log``, ``snapshots``, ``validate``."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ..terminal import BackupDisplay
from .common import (
    EXIT_NO,
    EXIT_OK,
    Sub,
    _add,
    _command,
    _dir_arg,
    _format_arg,
    _json,
    _lines,
    _lock_arg,
    _print,
    _usage,
    _warn,
)

#: The longest --stale-after, in hours: ten years.  Beyond it no clock or backup
#: record means anything, and Python's dates end (inf, 1e12 raised OverflowError).
MAX_STALE_HOURS = 87600


def _plant_args(p: argparse.ArgumentParser) -> None:
    """The robots of a plant, as backup and status find and judge them."""
    p.add_argument(
        "paths", nargs="+", metavar="PATH", help="project directory or directory of projects"
    )
    p.add_argument(
        "--stale-after",
        type=float,
        default=36.0,
        metavar="HOURS",
        help=f"flag robots with no good backup for this long (0 to {MAX_STALE_HOURS}, default 36)",
    )


def _bad_stale_after(command: str, hours: float) -> int | None:
    """A usage error for ``--stale-after HOURS`` (nan, inf, negative, too long), or None."""
    if 0 <= hours <= MAX_STALE_HOURS:  # nan is neither
        return None
    return _usage(
        f"{command}: --stale-after {hours:g}: give 0 to {MAX_STALE_HOURS} hours (ten years)"
    )


def _add_backup(sub: Sub) -> None:
    p = _command(
        sub,
        "backup",
        _cmd_backup,
        help="back up every robot of a plant (for cron and systemd)",
        description="Pull every robot project found in PATH (a project directory, or a directory "
        "of projects): in parallel across separate lines, spread over a worker process per core, "
        "one at a time for stations that share a line. A robot whose project git holds is kept "
        "on the branch harlsync/backup, never over the approved branch or the working tree, and "
        "reported as same as approved, pending (approved, not yet on the robot) or drift "
        "(changed on the robot, not by a push); see docs/states.md. A robot that fails keeps its "
        "previous backup and the others go on. On a terminal it shows a live line per robot "
        "(exchanges with the controller, rate, time left) and a result line as each ends. Exit "
        "0 when every robot was backed up, 1 when any failed or the git commit or push failed, "
        "2 on an error before any robot ran, 130 interrupted.",
    )
    _plant_args(p)
    p.add_argument("--jobs", type=int, metavar="N", help=_BACKUP["--jobs N"])
    p.add_argument("--workers", type=int, metavar="N", help=_BACKUP["--workers N"])
    _add(p, _BACKUP, "--commit", "--push")
    _format_arg(p)
    _add(p, _BACKUP, "--quiet")
    p.add_argument("--attempts", type=int, default=2, metavar="N", help=_BACKUP["--attempts N"])
    _lock_arg(p, 60.0, "wait this long for a line or a project another harlsync is using")
    _add(p, _BACKUP, *_BACKUP_OUTPUTS)


#: backup's own options: "--flag [METAVAR]" -> help (see :func:`_add`).
_BACKUP = {
    "--jobs N": "lines read at once (default: every line at once)",
    "--workers N": "processes the lines are spread over, a thread a line in each (default: one "
    "per core; 1: all in this process)",
    "--commit": "one git commit for the run on the branch harlsync/backup, listing which robots "
    "changed and how much, and what is pending or drifted",
    "--push": "git push the backup branch and the robots' deployed refs after committing (needs "
    "--commit)",
    "--quiet": "print the summary only when a robot failed (for cron mail)",
    "--attempts N": "tries per robot when the line fails (default 2)",
    "--on-change CMD": "run CMD (through the shell, summary on stdin) when a robot changed",
    "--on-failure CMD": "run CMD (through the shell, summary on stdin) when a robot failed",
    "--metrics FILE": "write a Prometheus textfile with per-robot results",
    "--html FILE": "write the fleet report page (as 'harlsync status --html') at the end of the "
    "run, atomically",
}
#: What the run leaves besides its report (:class:`~harlsync.sync.backupoutputs.BackupOutputs`).
_BACKUP_OUTPUTS = ("--on-change CMD", "--on-failure CMD", "--metrics FILE", "--html FILE")


def _cmd_backup(args: argparse.Namespace) -> int:
    from datetime import timedelta

    from ..sync import backup
    from ..sync.backupoutputs import BackupOutputs

    if args.push and not args.commit:
        return _usage("backup: --push needs --commit")
    if args.workers is not None and args.workers < 1:
        return _usage(f"backup: --workers {args.workers}: give 1 or more processes")
    if args.attempts < 1:
        return _usage(f"backup: --attempts {args.attempts}: give 1 or more tries")
    if (wrong := _bad_stale_after("backup", args.stale_after)) is not None:
        return wrong
    outputs = BackupOutputs(args.metrics, args.html, args.on_change, args.on_failure)
    outputs.check()
    display = BackupDisplay()
    stale_after = timedelta(hours=args.stale_after)
    try:
        report = backup.backup(
            args.paths,
            jobs=args.jobs,
            workers=args.workers,
            commit=args.commit,
            push=args.push,
            stale_after=stale_after,
            attempts=args.attempts,
            lock_timeout=args.lock_timeout,
            watch=display if display.live and not args.quiet else None,
        )
    finally:  # Ctrl-C too: no bar left on the screen
        display.close()
    if args.format == "json":
        _json(report.to_json())
    elif not args.quiet or not report.ok:
        sys.stdout.write(report.render())
    outputs.deliver(report, args.paths, stale_after)
    return EXIT_OK if report.ok else EXIT_NO


def _add_status(sub: Sub) -> None:
    p = _command(
        sub,
        "status",
        _cmd_status,
        help="the state of every robot, from what backups and pushes recorded",
        description="Show every robot project found in PATH: its family, port and station, its "
        "last good backup (time and commit), its last attempt and result, what the last backup "
        "changed, its last push (who, when, reason, result) and any push that never finished. "
        "Reads robot.yaml, DIR/.harlsync, the audit log and git only: no robot is contacted. A "
        "robot's state is the most urgent of: unfinished push, partial push (stopped part way), "
        "never backed up, failed, stale, changed, ok. The pending and drift columns are what the "
        "last backup found against the approved version, each item listed below. Exit 0 when "
        "every robot is ok or changed, 1 when any is failed, stale, never backed up or has an "
        "unfinished or partial push, 2 on an error (no project found).",
    )
    _plant_args(p)
    _format_arg(p)
    _add(p, {"--html FILE": "also write the fleet report page: one self-contained HTML file"})


def _cmd_status(args: argparse.Namespace) -> int:
    from datetime import timedelta

    from ..sync import status

    if (wrong := _bad_stale_after("status", args.stale_after)) is not None:
        return wrong
    plant = status.collect(args.paths, stale_after=timedelta(hours=args.stale_after))
    if args.html:
        from ..sync import report

        report.write_html(args.html, plant)
    if args.format == "json":
        _json(plant.to_json())
    else:  # colour on a terminal, unless NO_COLOR is set (https://no-color.org)
        sys.stdout.write(plant.render(color=sys.stdout.isatty() and not os.environ.get("NO_COLOR")))
    return EXIT_OK if plant.ok else EXIT_NO


def _add_log(sub: Sub) -> None:
    p = _command(
        sub,
        "log",
        _cmd_log,
        help="the pushes and rollbacks the audit log recorded, the latest first",
        description="Print the audit log's pushes and rollbacks (refused and unfinished ones "
        "too) of the robot of DIR, whatever project pushed to it, or of every robot without "
        "DIR, the latest first: time, robot, action, result, user and host, git commit, reason "
        "and each item written (old -> new). The log is $HARLSYNC_AUDIT_LOG, or "
        "$XDG_STATE_HOME/harlsync/audit.jsonl.",
    )
    p.add_argument("dir", nargs="?", metavar="DIR", help="robot project directory (default: all)")
    p.add_argument(
        "-n", "--max-count", type=int, default=None, metavar="N", help="only the latest N"
    )
    _format_arg(p)


def _cmd_log(args: argparse.Namespace) -> int:
    from ..sync import audit

    if args.max_count is not None and args.max_count < 1:
        return _usage("log: -n/--max-count must be 1 or more")
    problems: list[str] = []
    try:
        records = audit.pushes(Path(args.dir) if args.dir else None, args.max_count, problems)
    finally:
        _warn(problems)
    if args.format == "json":
        _json([r.to_json() for r in records], default=str)
        return EXIT_OK
    if not records:
        _print(f"no push or rollback recorded in {audit.audit_path()}")
    for r in records:
        _lines(r.log_lines(args.verbose))
    return EXIT_OK


def _add_snapshots(sub: Sub) -> None:
    p = _command(
        sub,
        "snapshots",
        _cmd_snapshots,
        help="the snapshots a rollback can restore, the latest first",
        description="List the snapshots of DIR/.harlsync/snapshots, the latest first: number, "
        "time, the action it was taken before, and its path. 'rollback DIR' restores the one "
        "marked; 'rollback DIR --snapshot PATH' any other.",
    )
    _dir_arg(p)
    _format_arg(p)


def _cmd_snapshots(args: argparse.Namespace) -> int:
    from ..sync import snapshots

    found = snapshots.listing(args.dir)
    if args.format == "json":
        _json(found.to_json())
    else:
        _lines(found.lines())
    return EXIT_OK


def _add_validate(sub: Sub) -> None:
    p = _command(
        sub,
        "validate",
        _cmd_validate,
        help="check a robot project against its schemas and its own configuration",
        description="Report every problem in a robot project, one per line as file:line: "
        "field: what is wrong (allowed: ...); a valid one in one line saying what was checked. "
        "Exit 0 when valid, 1 when not.",
    )
    _dir_arg(p)


def _cmd_validate(args: argparse.Namespace) -> int:
    from ..project.store import check_project

    checked = check_project(args.dir)
    _lines([*checked.issues, *(f"note: {note}" for note in checked.notes)])
    if checked.issues:
        print(f"harlsync: {args.dir}: {len(checked.issues)} problem(s)", file=sys.stderr)
        return EXIT_NO
    _print(  # asked for: said even under cron
        f"{args.dir}: valid {checked.family} project: {len(checked.files)} files checked "
        "against their schemas and its own configuration"
    )
    return EXIT_OK
