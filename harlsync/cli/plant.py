"""The plant's commands: ``backup``, ``status``, ``log``, ``snapshots``, ``validate``."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from ..errors import (
    HarlsyncError,
    SyncError,
)
from ..terminal import BackupDisplay
from .common import EXIT_NO, EXIT_OK, _format_arg, _print, _project_dir, _usage, _warn


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


#: The longest --stale-after, in hours: ten years.  Beyond it no clock or backup
#: record means anything, and Python's dates end (inf, 1e12 raised OverflowError).
MAX_STALE_HOURS = 87600


def _stale_after_problem(hours: float) -> str | None:
    """Why ``--stale-after HOURS`` cannot be taken (nan, inf, negative, too long), or None."""
    if 0 <= hours <= MAX_STALE_HOURS:  # nan is neither
        return None
    return f"--stale-after {hours:g}: give 0 to {MAX_STALE_HOURS} hours (ten years)"


def _add_backup(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "backup",
        help="back up every robot of a plant (for cron and systemd)",
        description="Pull every robot project found in PATH (a project directory, or a directory "
        "of projects): in parallel across separate lines, spread over a worker process "
        "per core, one at a time for stations that share a line. A robot whose project git "
        "holds is kept on the branch harlsync/backup, never over the approved branch or the "
        "working tree, and reported as same as approved, pending (approved, not yet on the "
        "robot) or drift (changed on the robot, not by a push); see docs/states.md. A robot "
        "that fails keeps its previous backup and the others go on. On a terminal it shows a live line per robot (exchanges with the "
        "controller, rate, time left) and a result line as each ends. Exit 0 when "
        "every robot was backed up, 1 when any failed or the git commit or push "
        "failed, 2 on an error before any robot ran, 130 interrupted.",
    )
    _plant_args(p)
    p.add_argument(
        "--jobs",
        type=int,
        default=None,
        metavar="N",
        help="lines read at once (default: every line at once)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes the lines are spread over, a thread a line in each "
        "(default: one per core; 1: all in this process)",
    )
    p.add_argument(
        "--commit",
        action="store_true",
        help="one git commit for the run on the branch harlsync/backup, listing which "
        "robots changed and how much, and what is pending or drifted",
    )
    p.add_argument(
        "--push",
        action="store_true",
        help="git push the backup branch and the robots' deployed refs after committing "
        "(needs --commit)",
    )
    _format_arg(p)
    p.add_argument(
        "--quiet",
        action="store_true",
        help="print the summary only when a robot failed (for cron mail)",
    )
    p.add_argument(
        "--attempts",
        type=int,
        default=2,
        metavar="N",
        help="tries per robot when the line fails (default 2)",
    )
    p.add_argument(
        "--lock-timeout",
        type=float,
        default=60.0,
        metavar="SECONDS",
        help="wait this long for a line or a project another harlsync is using (default 60)",
    )
    p.add_argument(
        "--on-change",
        metavar="CMD",
        help="run CMD (through the shell, summary on stdin) when a robot changed",
    )
    p.add_argument(
        "--on-failure",
        metavar="CMD",
        help="run CMD (through the shell, summary on stdin) when a robot failed",
    )
    p.add_argument(
        "--metrics", metavar="FILE", help="write a Prometheus textfile with per-robot results"
    )
    p.add_argument(
        "--html",
        metavar="FILE",
        help="write the fleet report page (as 'harlsync status --html') at the end "
        "of the run, atomically",
    )
    p.set_defaults(func=_cmd_backup)


def _cmd_backup(args: argparse.Namespace) -> int:
    from datetime import timedelta

    from ..sync import backup

    if args.push and not args.commit:
        return _usage("backup: --push needs --commit")
    if args.workers is not None and args.workers < 1:
        return _usage(f"backup: --workers {args.workers}: give 1 or more processes")
    if args.attempts < 1:
        return _usage(f"backup: --attempts {args.attempts}: give 1 or more tries")
    if (stale := _stale_after_problem(args.stale_after)) is not None:
        return _usage(f"backup: {stale}")
    outputs = {"--metrics": args.metrics, "--html": args.html}
    hooks = {"--on-change": args.on_change, "--on-failure": args.on_failure}
    problems = backup.output_problems(outputs, hooks)
    if problems:  # every one of them, before a robot is read
        raise SyncError("; ".join(problems) + "; no robot was read")
    display = BackupDisplay()
    try:
        report = backup.backup(
            args.paths,
            jobs=args.jobs,
            workers=args.workers,
            commit=args.commit,
            push=args.push,
            stale_after=timedelta(hours=args.stale_after),
            attempts=args.attempts,
            lock_timeout=args.lock_timeout,
            watch=display if display.live and not args.quiet else None,
        )
    finally:  # Ctrl-C too: no bar left on the screen
        display.close()
    if args.format == "json":
        _print(json.dumps(report.to_json(), indent=2))
    elif not args.quiet or not report.ok:
        sys.stdout.write(report.render())
    unwritten: list[str] = []  # checked before, yet the disk may fill meanwhile
    if args.metrics:
        try:
            backup.write_metrics(args.metrics, report)
        except HarlsyncError as exc:  # the hooks still run: they may be the only alarm
            unwritten.append(str(exc))
    if args.html:
        from ..sync import report as page
        from ..sync import status

        try:
            page.write_html(
                args.html, status.collect(args.paths, stale_after=timedelta(hours=args.stale_after))
            )
        except HarlsyncError as exc:
            unwritten.append(str(exc))
    if args.on_change and report.changed:
        backup.run_hook(args.on_change, report, "change")
    if args.on_failure and not report.ok:
        backup.run_hook(args.on_failure, report, "failure")
    if unwritten:
        raise SyncError("; ".join(unwritten))
    return EXIT_OK if report.ok else EXIT_NO


def _add_status(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "status",
        help="the state of every robot, from what backups and pushes recorded",
        description="Show every robot project found in PATH: its family, port and station, "
        "its last good backup (time and commit), its last attempt and result, what "
        "the last backup changed, its last push (who, when, reason, result) and any "
        "push that never finished. Reads robot.yaml, DIR/.harlsync, the audit log "
        "and git only: no robot is contacted. A robot's state is the most urgent "
        "of: unfinished push, partial push (stopped part way), never backed up, failed, "
        "stale, changed, ok. The pending and drift columns are what the last backup found "
        "against the approved version, each item listed below. Exit 0 "
        "when every robot is ok or changed, 1 when any is failed, stale, never "
        "backed up or has an unfinished or partial push, 2 on an error (no project found).",
    )
    _plant_args(p)
    _format_arg(p)
    p.add_argument(
        "--html",
        metavar="FILE",
        help="also write the fleet report page: one self-contained HTML file",
    )
    p.set_defaults(func=_cmd_status)


def _color() -> bool:
    """Colour on a terminal, unless NO_COLOR is set (https://no-color.org)."""
    return sys.stdout.isatty() and not os.environ.get("NO_COLOR")


def _cmd_status(args: argparse.Namespace) -> int:
    from datetime import timedelta

    from ..sync import status

    if (stale := _stale_after_problem(args.stale_after)) is not None:
        return _usage(f"status: {stale}")
    plant = status.collect(args.paths, stale_after=timedelta(hours=args.stale_after))
    if args.html:
        from ..sync import report

        report.write_html(args.html, plant)
    if args.format == "json":
        _print(json.dumps(plant.to_json(), indent=2))
    else:
        sys.stdout.write(plant.render(color=_color()))
    return EXIT_OK if plant.ok else EXIT_NO


def _add_log(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "log",
        help="the pushes and rollbacks the audit log recorded, the latest first",
        description="Print the audit log's pushes and rollbacks (refused and unfinished ones "
        "too) of the robot of DIR, whatever project pushed to it, or of every "
        "robot without DIR, the latest first: time, robot, action, result, user and "
        "host, git commit, reason and each item written (old -> new). The log is "
        "$HARLSYNC_AUDIT_LOG, or $XDG_STATE_HOME/harlsync/audit.jsonl.",
    )
    p.add_argument("dir", nargs="?", metavar="DIR", help="robot project directory (default: all)")
    p.add_argument(
        "-n", "--max-count", type=int, default=None, metavar="N", help="only the latest N"
    )
    _format_arg(p)
    p.set_defaults(func=_cmd_log)


def _cmd_log(args: argparse.Namespace) -> int:
    from ..project import load_robot
    from ..sync import audit
    from ..sync.status import local_time

    if args.max_count is not None and args.max_count < 1:
        return _usage("log: -n/--max-count must be 1 or more")
    problems: list[str] = []
    records = audit.results(problems=problems)
    _warn(problems)
    if args.dir:
        robot = load_robot(_project_dir(args.dir))
        records = audit.of_robot(records, robot.port, robot.station, Path(args.dir))
    records = records[::-1][: args.max_count]
    if args.format == "json":
        _print(json.dumps([r.to_json() for r in records], indent=2, default=str))
        return EXIT_OK
    if not records:
        _print(f"no push or rollback recorded in {audit.audit_path()}")
    for r in records:
        head = (
            f"{local_time(r.time)}  {r.robot_name or '?'}  {r.shown_action} {r.shown_result}  "
            f"by {r.user}@{r.host}"
        )
        _print(head + (f"  commit {r.commit[:10]}" if r.commit else ""))
        if r.reason:
            _print(f"    reason: {r.reason}")
        lines = r.written_lines(None)
        shown = lines if args.verbose or len(lines) <= audit.SHOWN else lines[: audit.SHOWN - 1]
        for line in shown:
            _print(f"    wrote {line}")
        if len(shown) < len(lines):
            _print(f"    and {len(lines) - len(shown)} more (-v shows them)")
        if args.verbose:
            for w in r.done:
                _print(f"    command {w.item}: {w.command}")
        if r.partly_written:
            _print(f"    partly written: {r.partly_text()}")
        elif r.failed_item:
            _print(f"    unknown: {r.failed_item} (may or may not have been written)")
        if r.error and r.result != "ok":
            _print(f"    error: {audit.shorten(r.error, args.verbose)}")
    return EXIT_OK


def _add_snapshots(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "snapshots",
        help="the snapshots a rollback can restore, the latest first",
        description="List the snapshots of DIR/.harlsync/snapshots, the latest first: number, "
        "time, the action it was taken before, and its path. 'rollback DIR' "
        "restores the one marked; 'rollback DIR --snapshot PATH' any other.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _format_arg(p)
    p.set_defaults(func=_cmd_snapshots)


def _cmd_snapshots(args: argparse.Namespace) -> int:
    from ..sync import snapshots
    from ..sync.status import local_time

    taken = snapshots.all_snapshots(_project_dir(args.dir))
    pushes = snapshots.snapshots(args.dir)
    chosen = pushes[-1] if pushes else None
    latest_first = [(s, s.time.isoformat() if s.time else None) for s in reversed(taken)]
    if args.format == "json":
        _print(
            json.dumps(
                [
                    {
                        "number": s.number,
                        "time": when,
                        "action": s.action,
                        "path": str(s.path),
                        "rollback_restores": s.path == chosen,
                    }
                    for s, when in latest_first
                ],
                indent=2,
            )
        )
        return EXIT_OK
    if not taken:
        _print(f"no snapshot in {args.dir}: a push takes one before its first write")
        return EXIT_OK
    rows = [("number", "time", "action", "path")] + [
        (
            str(s.number),
            local_time(when),
            s.action,
            str(s.path) + ("  <- rollback restores this" if s.path == chosen else ""),
        )
        for s, when in latest_first
    ]
    from ..columns import ljust, rjust, width

    widths = [max(width(row[i]) for row in rows) for i in range(3)]
    for row in rows:
        _print(
            "  ".join(
                [
                    rjust(row[0], widths[0]),
                    *(ljust(c, w) for c, w in zip(row[1:3], widths[1:])),
                    row[3],
                ]
            )
        )
    return EXIT_OK


def _add_validate(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "validate",
        help="check a robot project against its schemas and its own configuration",
        description="Report every problem in a robot project, one per line as "
        "file:line: field: what is wrong (allowed: ...); a valid one in one line saying "
        "what was checked. Exit 0 when valid, 1 when not.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    p.set_defaults(func=_cmd_validate)


def _cmd_validate(args: argparse.Namespace) -> int:
    from ..project.store import check_project

    checked = check_project(args.dir)
    for issue in checked.issues:
        _print(issue)
    for note in checked.notes:
        _print(f"note: {note}")
    if checked.issues:
        print(f"harlsync: {args.dir}: {len(checked.issues)} problem(s)", file=sys.stderr)
        return EXIT_NO
    _print(  # asked for: said even under cron
        f"{args.dir}: valid {checked.family} project: {len(checked.files)} files checked "
        "against their schemas and its own configuration"
    )
    return EXIT_OK
