"""The ``harlsync`` command: parse arguments, call the library, print.

Exit codes: 0 success, 1 a negative answer (``diff``: different; ``validate``:
invalid; ``backup``: a robot failed; ``status``: a robot needs looking at), 2 an
error, 3 refused for safety (interlock or policy), 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import gc
import json
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Collection, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from . import __version__, families
from .errors import (
    HarlsyncError,
    InterlockError,
    PartlyWritten,
    PolicyError,
    StalePlanError,
    SyncError,
    partly_words,
)
from .families import DEFAULT
from .families.base import AnyFamily, Option
from .robotlog import RobotFilter
from .terminal import BackupDisplay, Feedback

if TYPE_CHECKING:
    from .sim.run import Running
    from .sync.deploy import PushOptions, PushResult
    from .sync.plan import Plan, PlannedWrite

__all__ = ["main"]

EXIT_OK, EXIT_NO, EXIT_ERROR, EXIT_REFUSED = 0, 1, 2, 3

log = logging.getLogger("harlsync")


def _print(*args: object) -> None:
    print(*args, flush=True)


def _warn(warnings: list[str]) -> None:
    """What the library found worth saying whatever the verbosity (an unfinished push)."""
    for warning in warnings:
        print(f"harlsync: warning: {warning}", file=sys.stderr, flush=True)


def _usage(message: str) -> int:
    """A wrong combination of options: say so on stderr, exit 2 like argparse does."""
    print(f"harlsync {message}", file=sys.stderr)
    return EXIT_ERROR


# --- sim ------------------------------------------------------------------------------


def _sim_verbs() -> str:
    """The control commands of ``harlsync sim``, per family, for its help."""
    from .families import names
    from .sim import sim_family
    from .sim.control import after_writes_verb

    lines = []
    for name in names():
        family = sim_family(name)
        verbs = [str(v) for v in family.verbs]
        verbs.append(f"{after_writes_verb(family.busy_verb)} N")
        lines.append(f"{name}: {', '.join(verbs)}, status")
    return "; ".join(lines)


def _sim_busy() -> str:
    """What each family's simulator does when it is made busy, for its help."""
    from .families import names
    from .sim import sim_family

    parts = []
    for name in names():
        family = sim_family(name)
        does = [v.does for v in family.verbs if v.name == family.busy_verb]
        parts.append(f"{name}: {does[0] if does else family.busy_verb}")
    return "; ".join(parts)


def _sim_variants() -> str:
    """Each family's simulator variants (the guesses it can make otherwise), for its help."""
    from .families import names
    from .sim import sim_family

    parts = []
    for name in names():
        declared = sim_family(name).variants
        parts.append(f"{name}: {', '.join(str(v) for v in declared) or 'none'}")
    return "; ".join(parts)


def _columns() -> int:
    """The terminal's width as :func:`shutil.get_terminal_size` measures it: $COLUMNS,
    else standard output's terminal, else 80."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns or 80


class _Help(argparse.HelpFormatter):
    """argparse's help, as wide as argparse makes it, measured without importing
    :mod:`shutil` (and bz2 and lzma with it): argparse makes a formatter for every
    option it adds, so a pull paid for it before its first request (issue 24)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        if len(args) < 4 and kwargs.get("width") is None:
            kwargs["width"] = _columns() - 2
        super().__init__(*args, **kwargs)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose help is :class:`_Help` unless told otherwise (its
    command parsers too: argparse makes them of the class of their parent)."""

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _Help)
        super().__init__(**kwargs)


class _SimHelp(_Help):
    """Fills in :func:`_sim_verbs` when the help is shown: only then are the
    families' simulators imported."""

    VERBS = "<verbs>"
    BUSY = "<busy>"
    VARIANTS = "<variants>"

    def add_text(self, text: str | None) -> None:
        if text and self.VERBS in text:
            text = text.replace(self.VERBS, _sim_verbs())
        super().add_text(text)

    def _expand_help(self, action: argparse.Action) -> str:
        text = super()._expand_help(action)
        if self.BUSY in text:
            text = text.replace(self.BUSY, _sim_busy())
        if self.VARIANTS in text:
            text = text.replace(self.VARIANTS, _sim_variants())
        return text


def _add_sim(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:

    p = sub.add_parser(
        "sim",
        help="run a simulated controller of any family (on a pty and/or a TCP port, or "
        "over the family's own protocol)",
        description=(
            "Serve a simulated controller of one family. It prints the pty device path and the "
            "socket:// URL to connect to (a family with a server of its own: its URL, "
            "--listen only), then reads control commands on standard input "
            f"(STATION as the family writes it, default the lowest): {_SimHelp.VERBS}. "
            "Stop it with Ctrl-C, SIGTERM or end of input. In the background (&, a service) "
            "give --no-input: it then serves until SIGTERM; started with & from a terminal it "
            "reads no commands either."
        ),
        formatter_class=_SimHelp,
    )
    p.add_argument(
        "--family",
        default=None,
        choices=_family_names(),
        help=f"the controller family (default: {DEFAULT}, or with --project the one "
        "its robot.yaml names)",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--project", metavar="DIR", help="serve the robot of this project directory")
    src.add_argument(
        "--seed",
        type=int,
        default=0,
        help="generate a realistic robot (programs, positions) from SEED",
    )
    p.add_argument(
        "--stations",
        default=None,
        metavar="N[,N...]",
        help="stations on the line, in the family's notation ("
        + _per_family("stations")
        + "; default: the project's station, or the family's default)",
    )
    p.add_argument("--listen", metavar="HOST:PORT", help="also serve over TCP (socket://HOST:PORT)")
    p.add_argument("--no-pty", action="store_true", help="do not open a pty (needs --listen)")
    p.add_argument(
        "--no-input",
        action="store_true",
        help="read no commands: serve until SIGTERM or Ctrl-C, to run in the "
        "background or under a service manager (the mode then changes only "
        "through --auto and --auto-after-writes)",
    )
    p.add_argument(
        "--baud",
        type=int,
        default=9600,
        help="delay each reply by its time on the wire at this speed; 0 turns it off (default 9600)",
    )
    p.add_argument(
        "--turnaround",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="extra delay before each reply",
    )
    p.add_argument(
        "--faults",
        default="",
        metavar="NAME=RATE,...",
        help="fault injection: noise, drop, bad_checksum, fragment, slow (rates 0-1), "
        "slow_delay (seconds), seed",
    )
    p.add_argument(
        "--variant",
        default="",
        metavar="NAME=VALUE,...",
        help="answer as a controller that fills a silence of its manual another way than "
        "the profile's choice, the first value of each (docs/profile.md): "
        f"{_SimHelp.VARIANTS}",
    )
    p.add_argument(
        "--auto",
        "--run",
        dest="busy",
        action="store_true",
        help=f"start busy ({_SimHelp.BUSY})",
    )
    p.add_argument(
        "--auto-after-writes",
        "--run-after-writes",
        dest="busy_after_writes",
        type=int,
        default=0,
        metavar="N",
        help="become busy after N writes, once (see --auto); 'stop' disarms it",
    )
    p.add_argument(
        "--record",
        metavar="FILE",
        help="append every request received to FILE as JSON lines (station, "
        "payload, busy: whether the station was not idle, client: 'pty' or "
        "the TCP peer)",
    )
    p.add_argument(
        "--state",
        metavar="DIR",
        help="battery-backed memory: keep each station in DIR/station-N, "
        "saved after every write and loaded again when the simulator restarts",
    )
    p.set_defaults(func=_cmd_sim)


def _cmd_sim(args: argparse.Namespace) -> int:
    from .sim.control import apply_command
    from .sim.run import SimOptions, start

    opts = SimOptions(
        family=args.family,
        project=args.project,
        seed=args.seed,
        stations=args.stations,
        listen=args.listen,
        pty=not args.no_pty,
        baud=args.baud,
        turnaround=args.turnaround,
        faults=args.faults,
        variant=args.variant,
        busy=args.busy,
        busy_after_writes=args.busy_after_writes,
        record=args.record,
        state=args.state,
    )
    stopped = threading.Event()  # from here on SIGTERM stops it cleanly, exit 0
    signal.signal(signal.SIGTERM, lambda *_: stopped.set())
    try:
        running = start(opts)
    except ValueError as exc:
        return _usage(f"sim: {exc}")
    for line in running.said:
        _print(line)
    control = (lambda line: apply_command(running.sim, line)) if _reads_input(args) else None
    _serve(running, stopped, control)
    return EXIT_OK


def _reads_input(args: argparse.Namespace) -> bool:
    """Whether ``harlsync sim`` reads control commands on its standard input: not
    with --no-input, nor when started in the background of a terminal (``&``), where
    a read would stop it (SIGTTIN)."""
    if args.no_input:
        return False
    try:
        background = os.isatty(0) and os.tcgetpgrp(0) != os.getpgrp()
    except OSError:  # no controlling terminal: stdin is what it is
        background = False
    if background:
        print(
            "harlsync sim: started in the background: not reading commands; stop it with "
            "kill (SIGTERM)",
            file=sys.stderr,
            flush=True,
        )
    return not background


def _serve(running: Running, done: threading.Event, control: Callable[[str], str] | None) -> None:
    """Serve until ``done`` is set (SIGTERM), Ctrl-C, or the end of the input
    ``control`` takes its commands from (every line, its answer printed); without
    ``control``, until one of the first two."""

    def read_commands(run: Callable[[str], str]) -> None:
        for line in sys.stdin:
            try:
                answer = run(line)
            except (ValueError, IndexError) as exc:
                answer = f"error: {exc}"
            if answer:
                _print(answer)
        print(
            "harlsync sim: end of input: stopping (--no-input serves until SIGTERM)",
            file=sys.stderr,
            flush=True,
        )
        done.set()

    if control is not None:
        threading.Thread(target=read_commands, args=(control,), daemon=True).start()
    try:
        done.wait()
    except KeyboardInterrupt:
        pass
    running.stop()


# --- backup -----------------------------------------------------------------------------


def _format_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="text for people (default), json for scripts",
    )


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

    from .sync import backup

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
        from .sync import report as page
        from .sync import status

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


# --- status, log, snapshots -------------------------------------------------------------


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

    from .sync import status

    if (stale := _stale_after_problem(args.stale_after)) is not None:
        return _usage(f"status: {stale}")
    plant = status.collect(args.paths, stale_after=timedelta(hours=args.stale_after))
    if args.html:
        from .sync import report

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


def _project_dir(path: str) -> Path:
    """``path``, which must hold a robot project.  Raises ProjectError naming it."""
    from .project.store import require_project

    require_project(Path(path))
    return Path(path)


def _cmd_log(args: argparse.Namespace) -> int:
    from .project import load_robot
    from .sync import audit
    from .sync.status import local_time

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
    from .sync import snapshots
    from .sync.status import local_time

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
    from .columns import ljust, rjust, width

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


# --- validate ---------------------------------------------------------------------------


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
    from .project.store import check_project

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


# --- pull / diff / plan / push / rollback ---------------------------------------------


def _connection_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--port",
        metavar="URL",
        help="port to use instead of the robot file's: /dev/ttyUSB0, COM3, "
        "socket://HOST:PORT, rfc2217://HOST:PORT, sim://PROJECT_DIR"
        + "".join(f"; {scheme.help}" for f in _families() for scheme in f.schemes),
    )
    p.add_argument(
        "--station",
        metavar="N",
        help="station number instead of the robot file's (" + _per_family("stations") + ")",
    )
    p.add_argument(
        "--lock-timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="how long to wait for another harlsync using the same line or project (default 10)",
    )
    for option in _options():
        p.add_argument(option.flag, dest=option.name, action="store_true", help=option.help)


def _families() -> tuple[AnyFamily, ...]:
    from .families import every

    return every()


def _per_family(place: str) -> str:
    """``name: phrase; ...`` of what each family's help says at ``place`` (see
    :class:`~harlsync.families.base.Help`)."""
    return "; ".join(
        f"{f.name}: {getattr(f.help, place)}" for f in _families() if getattr(f.help, place)
    )


def _options() -> list[Option]:
    """Every family's connection options, each name once."""
    found: dict[str, Option] = {}
    for family in _families():
        for option in family.options:
            found.setdefault(option.name, option)
    return list(found.values())


def _connect_options(args: argparse.Namespace) -> dict[str, bool]:
    """The family options of the connection, as the engine takes them."""
    return {option.name: bool(getattr(args, option.name)) for option in _options()}


def _family_names() -> Collection[str]:
    from .families import KNOWN

    return KNOWN


def _add_probe(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "probe",
        help="tell what controller answers on a port, with reads only (a first contact)",
        description="Find which controller answers on --port and what it is, sending read "
        "requests only (a write is refused before its bytes are made): on a serial line "
        "each family's identity read at the stations it allows (or those given), on a "
        "family's own URL scheme that family. It reports the family, station and serial "
        'settings, the identity, each table\'s real extent and its "not there" reply, the '
        "reply turnaround measured, the interlock now, the profile's guesses this "
        "controller confirmed or contradicted (with the robot.yaml setting of each) and how "
        "long a full pull takes. --write DIR then creates the project's robot.yaml, ready "
        "for harlsync pull DIR. The line is held only while a read is under way.",
    )
    p.add_argument(
        "--port",
        metavar="URL",
        required=True,
        help="the port: /dev/ttyUSB0, COM3, socket://HOST:PORT, rfc2217://HOST:PORT, "
        "sim://PROJECT_DIR"
        + "".join(f"; {scheme.help}" for f in _families() for scheme in f.schemes),
    )
    p.add_argument(
        "--family",
        choices=_family_names(),
        default=None,
        help="try only this family (default: the family whose own URL scheme --port has, "
        "else every serial family)",
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--station",
        metavar="N",
        help="try only this station (" + _per_family("stations") + ")",
    )
    where.add_argument(
        "--stations",
        metavar="LIST",
        help="the stations to try, in order, as each family writes them: 1-4, or 99,1-F "
        "(default: the stations each family's manual gives as defaults)",
    )
    p.add_argument(
        "--baud",
        metavar="auto|N",
        default=None,
        help="the baud rate to try (default: the family's profile's); auto: every rate "
        "the family's manual lists, on a local serial port only (a device server sets "
        "its own)",
    )
    p.add_argument("--json", action="store_true", help="print the findings as JSON")
    p.add_argument(
        "--write",
        metavar="DIR",
        help="create the project DIR with the robot.yaml of what was found (commented); "
        "refuses a directory that exists and is not empty",
    )
    p.add_argument(
        "--capture",
        metavar="FILE",
        help="record the survey's traffic in FILE as a spy:// hex dump; harlsync probe "
        "--port 'replay://FILE?family=F' --family F --station N plays it back",
    )
    p.add_argument(
        "--lock-timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="how long to wait for another harlsync using the same line (default 10)",
    )
    p.set_defaults(func=_cmd_probe)


def _station_list(family: AnyFamily, text: str) -> list[int]:
    """``1-4`` or ``99,1-F``: each station as the family writes it.  Raises
    HarlsyncError (a ProjectError) naming the one that is not a station."""
    from .errors import ProjectError

    stations: list[int] = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        first, dash, last = part.partition("-")
        try:
            low = family.parse_station(first)
            high = family.parse_station(last) if dash else low
        except ValueError as exc:
            raise ProjectError(f"--stations {text}: {exc}") from None
        stations += range(low, high + 1)
    return stations


def _cmd_probe(args: argparse.Namespace) -> int:
    from .errors import ProjectError
    from .sync import probe

    if args.family:
        candidates = [families.get(args.family)]
    elif families.of_port(args.port):
        candidates = [families.get(families.of_port(args.port))]
    else:
        candidates = [f for f in _families() if not f.schemes]
    baud: int | str | None = args.baud
    if isinstance(baud, str) and baud != "auto":
        if not (baud.isascii() and baud.isdigit() and int(baud) > 0):
            raise ProjectError(f"--baud {baud}: give auto or a rate such as 9600")
        baud = int(baud)
    stations: dict[str, list[int]] | None = None
    text = args.station or args.stations
    if text is not None:  # as each family writes its stations; one that cannot is not tried
        stations, refused = {}, None
        for family in candidates:
            try:
                stations[family.name] = _station_list(family, text)
            except ProjectError as exc:
                refused = exc
        if not stations and refused is not None:
            raise refused
        candidates = [f for f in candidates if f.name in stations]
    write = Path(args.write) if args.write else None
    if write is not None and write.exists() and (not write.is_dir() or any(write.iterdir())):
        raise ProjectError(  # before the line is opened
            f"{write}: exists and is not empty; --write creates a new project: give a new "
            "directory (harlsync pull updates an existing one)"
        )
    found = probe.probe(
        args.port,
        candidates,
        stations=stations,
        baud=baud,
        lock_timeout=args.lock_timeout,
        capture=Path(args.capture) if args.capture else None,
    )
    written = probe.write_project(found, write) if write is not None else None
    if args.json:
        out = probe.to_json(found)
        out["written"] = str(written) if written else None
        _print(json.dumps(out, indent=2))
    else:
        for line in probe.report(found):
            _print(line)
        if written is not None:
            _print(f"wrote {written}: harlsync pull {write} backs the robot up")
    return EXIT_OK


def _add_pull(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "pull",
        help="read everything from the robot into a project directory",
        description="Read everything the robot holds that the project keeps ("
        + _per_family("pull")
        + "; runtime data if the project keeps it) and write the project atomically: a pull that fails leaves the "
        "previous files as they were. DIR is created if missing; a first pull needs "
        "--port (or the robot.yaml harlsync probe --write DIR makes), and one that gets no "
        "answer points to harlsync probe. A controller that does not look like the robot backed up in DIR "
        "(another version or program configuration, or most of the backup would "
        "change) is refused (exit 3) until --new-robot; so is a pull that would overwrite "
        "changes the project's branch approved and no push deployed yet (pending) until "
        "--discard-pending.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _connection_args(p)
    p.add_argument(
        "--family",
        choices=_family_names(),
        default=None,
        help=f"the controller family of a first pull (default {DEFAULT}, or the family "
        "whose own URL scheme --port has); later commands read it from robot.yaml",
    )
    p.add_argument(
        "--commit",
        action="store_true",
        help="commit the change to git, with a message that says what changed",
    )
    p.add_argument(
        "--allow-dirty",
        action="store_true",
        help="pull even over uncommitted edits in DIR (they are overwritten)",
    )
    p.add_argument(
        "--discard-pending",
        action="store_true",
        help="pull even over changes the project's branch approved and no push has "
        "deployed yet (pending: they are overwritten in the working tree)",
    )
    p.add_argument(
        "--new-robot",
        action="store_true",
        help="accept a controller that does not look like the robot backed up in "
        "DIR (another version or program configuration, or most of the "
        "backup changed): a replaced, reconfigured or updated robot",
    )
    p.set_defaults(func=_cmd_pull)


def _cmd_pull(args: argparse.Namespace) -> int:
    from .sync import pulling

    if args.family is None and not (Path(args.dir) / "robot.yaml").exists():
        args.family = families.of_port(args.port)
    progress = Feedback("pull")
    try:
        result = pulling.pull(
            args.dir,
            port=args.port,
            station=args.station,
            commit=args.commit,
            progress=progress,
            lock_timeout=args.lock_timeout,
            allow_dirty=args.allow_dirty,
            family=families.get(args.family) if args.family else None,
            new_robot=args.new_robot,
            connect_options=_connect_options(args),
            discard_pending=args.discard_pending,
        )
    finally:
        progress.close()
    progress.summary(result.robot.name, result.contents)
    if result.commit or sys.stdout.isatty():  # a commit is always said: cron logs it
        committed = f", committed {result.commit[:10]}" if result.commit else ""
        _print(f"{result.robot.name}: {result.summary}{committed}")
    return EXIT_OK


def _add_diff(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "diff",
        help="compare the project with the live robot, or two versions of it (--rev)",
        description="Read the whole robot, as a pull does, and compare it with the project, "
        "item by item (" + _per_family("items") + "). '-' "
        "lines are the robot, '+' lines the project. On a terminal it ends with "
        "what was read, how long it took and how many items differ. "
        "Warns when the audit log shows an earlier push to this robot that never "
        "finished (killed part way). Exit 0 identical, 1 different, 2 error.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _connection_args(p)
    _format_arg(p)
    p.add_argument(
        "--registers",
        action="store_true",
        help="compare runtime data too (" + _per_family("runtime") + ")",
    )
    p.add_argument(
        "--rev",
        action="append",
        metavar="REV",
        help="compare versions of the project, not the robot: a git revision (HEAD~1, a "
        "commit, a tag) or a snapshot number as 'harlsync snapshots' lists it; once: "
        "that version against the project on disk, twice: the first against the second. "
        "No robot is contacted",
    )
    p.set_defaults(func=_cmd_diff)


def _cmd_diff(args: argparse.Namespace) -> int:
    from .sync import comparison
    from .sync.items import changes_json, differ_words, render_text

    if args.rev:
        return _diff_versions(args)
    progress = Feedback("diff")
    try:
        result = comparison.compare(
            args.dir,
            port=args.port,
            station=args.station,
            progress=progress,
            registers=args.registers,
            lock_timeout=args.lock_timeout,
            connect_options=_connect_options(args),
        )
    finally:
        progress.close()
    _warn(result.warnings)
    progress.summary(result.project.robot.name, result.contents, differ_words(result.changes))
    if args.format == "json":
        _print(
            json.dumps(
                changes_json(
                    result.changes,
                    robot=result.project.robot.name,
                    target=result.target,
                    project=str(result.project.path),
                ),
                indent=2,
            )
        )
    elif result.changes:
        sys.stdout.write(
            render_text(result.changes, f"robot {result.target}", f"project {result.project.path}")
        )
    return EXIT_NO if result.changes else EXIT_OK


def _diff_versions(args: argparse.Namespace) -> int:
    """``diff DIR --rev A [--rev B]``: two versions of the project, no robot."""
    from .sync.items import changes_json, render_text
    from .sync.revisions import compare_versions

    if len(args.rev) > 2:
        return _usage("diff: --rev at most twice (the old version, then the new one)")
    if args.port or args.station is not None:
        return _usage("diff: --rev compares versions of the project: no --port or --station")
    old, new = args.rev[0], args.rev[1] if len(args.rev) == 2 else None
    a, b, changes = compare_versions(_project_dir(args.dir), old, new, registers=args.registers)
    if args.format == "json":
        _print(
            json.dumps(
                changes_json(changes, robot=b.project.robot.name, old=a.label, new=b.label),
                indent=2,
            )
        )
    elif changes:
        sys.stdout.write(render_text(changes, a.label, b.label))
    return EXIT_NO if changes else EXIT_OK


def _add_plan(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "plan",
        help="print what a push would write, and write nothing",
        description="Read the whole robot, compare it with the project and print, in push "
        "order, what a push would write, item by item as diff shows it, and how many "
        "items in how many writes; with -v also the exact command of each write ("
        + _per_family("commands")
        + "). Nothing is written. Warns when the robot is not idle: a push would be "
        "refused now. --out saves the plan "
        "with a fingerprint of the robot and the project; push --plan refuses it "
        "if either changed since. The plan file is not part of the project: "
        "delete it after the push, or keep it outside the repository.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _connection_args(p)
    p.add_argument("--out", metavar="PLANFILE", help="save the plan to this file")
    p.add_argument(
        "--registers",
        action="store_true",
        help="include runtime data (" + _per_family("runtime") + ")",
    )
    p.set_defaults(func=_cmd_plan)


def _show_plan(the_plan: Plan[Any], verbose: int = 0) -> None:
    """What a push of ``the_plan`` writes, as ``diff`` shows it, item by item; with -v
    each write's wire command too."""
    from .sync.items import render_text

    for line in the_plan.unwritable:
        _print(f"# cannot write: {line}")
    if the_plan.reconfiguration_note:
        _print(f"# {the_plan.reconfiguration_note}")
    for note in the_plan.notes:
        _print(f"# note: {note}")
    if the_plan.items:
        for line in render_text(the_plan.items, "", "").splitlines()[2:]:
            _print(line)
    for name, said in the_plan.reverts.items():
        _print(f"# {name}: {said}")
    if verbose:
        for write in the_plan.writes:
            flag = "  # unsafe in automatic operation" if write.unsafe else ""
            _print(f"# {write.name}: {write.command}{flag}")
    _print(f"# {_counted(the_plan)} to {the_plan.robot} ({the_plan.target})")


def _counted(the_plan: Plan[Any]) -> str:
    """``5 item(s) in 2 write(s)``: the items as diff counts them, and the commands."""
    items, writes = len(the_plan.items), len(the_plan.writes)
    return f"{items} item(s) in {writes} write(s)" if items != writes else f"{items} item(s)"


def _cmd_plan(args: argparse.Namespace) -> int:
    from .sync import comparison
    from .sync.items import differ_words

    progress = Feedback("plan")
    try:
        found = comparison.compare(
            args.dir,
            port=args.port,
            station=args.station,
            progress=progress,
            registers=args.registers,
            lock_timeout=args.lock_timeout,
            idle_check=True,
            connect_options=_connect_options(args),
            command="plan",
        )
    finally:
        progress.close()
    _warn(found.warnings)
    the_plan = found.plan()
    _show_plan(the_plan, args.verbose)
    if args.out:
        the_plan.save(args.out)
        _print(f"# plan saved to {args.out}")
    progress.summary(found.project.robot.name, found.contents, differ_words(found.changes))
    from .sync.plan import policy_refusals

    # Every reason a push would be refused now, not only the first it would meet.
    reasons = policy_refusals(Path(args.dir), found.project.robot)
    if found.busy is not None:  # a push reads the state before anything else
        reasons.append(
            f"robot {found.project.robot.name} ({found.target}) is not idle: {found.busy}"
        )
    _warn([f"a push would be refused now: {reason}" for reason in reasons])
    return EXIT_OK


def _push_args(p: argparse.ArgumentParser) -> None:
    _connection_args(p)
    p.add_argument("--yes", action="store_true", help="do not ask before writing")
    p.add_argument("--reason", metavar="TEXT", help="why, for the audit log")
    p.add_argument(
        "--outside-window",
        metavar="REASON",
        help="allow a write outside the robot's maintenance windows, saying why",
    )
    p.add_argument(
        "--allow-reconfigure",
        action="store_true",
        help="allow a program configuration change (SNX), which destroys every "
        "program; all of them are rewritten after it",
    )
    p.add_argument(
        "--allow-live-tuning",
        action="store_true",
        help="write what the family allows while the robot runs ("
        + _per_family("live_tuning")
        + "); nothing else",
    )
    p.add_argument(
        "--registers",
        action="store_true",
        help="write runtime data too (" + _per_family("runtime") + "; the project must keep it)",
    )


def _confirm(the_plan: Plan[Any], verbose: int = 0) -> bool:
    """Show the plan and ask on the terminal (only given when stdin is one)."""
    _show_plan(the_plan, verbose)
    answer = input(f"Write these {_counted(the_plan)} to {the_plan.robot}? [y/N] ")
    return answer.strip().lower() in ("y", "yes")


def _add_push(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "push",
        help="write what differs to the robot, safely",
        description="Read the whole robot and write only what differs, in the family's safe "
        "order (" + _per_family("order") + "). "
        "Refuses a project that is invalid, has "
        "uncommitted changes, or is outside its maintenance window; stops before "
        "any write while the robot runs (" + _per_family("busy") + "; read before "
        "every write and after the last: a robot started while a write was on the "
        "wire is named in a warning); verifies each write by reading it back; "
        "snapshots the robot "
        "first (see rollback) and records everything in the audit log, each write "
        "before it is sent, so the next push or diff can name what a push killed "
        "part way had written. Without a terminal to ask on, --yes is needed (it is "
        "refused before the robot is read). Exit 0 done, 2 failed, 3 refused for "
        "safety, 130 interrupted (what was written is listed and audited).",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _push_args(p)
    p.add_argument(
        "--allow-dirty", action="store_true", help="push a project with uncommitted changes"
    )
    p.add_argument(
        "--plan",
        metavar="PLANFILE",
        help="push only if the robot and project are as when this plan was made",
    )
    p.set_defaults(func=_cmd_push)


def _push_options(args: argparse.Namespace, progress: Feedback) -> PushOptions:
    from .sync.deploy import PushOptions

    return PushOptions(
        yes=args.yes,
        confirm=(lambda plan: _confirm(plan, args.verbose)) if sys.stdin.isatty() else None,
        reason=args.reason,
        allow_dirty=getattr(args, "allow_dirty", False),
        outside_window=args.outside_window,
        allow_reconfigure=args.allow_reconfigure,
        allow_live_tuning=args.allow_live_tuning,
        registers=args.registers,
        plan_file=getattr(args, "plan", None),
        lock_timeout=args.lock_timeout,
        progress=progress,
        connect_options=_connect_options(args),
        told=lambda line: print(f"harlsync: {line}", file=sys.stderr),
    )


def _partly_text(partly: PartlyWritten) -> str:
    """``x, y went out; z, hand not sent``."""
    return partly_words(partly.sent, partly.unknown, partly.left)


def _report(action: str, run: Callable[[], PushResult], progress: Feedback) -> int:
    from .sync.deploy import PushFailed

    try:
        result = run()
    except PushFailed as failed:
        progress.close()
        r = failed.result
        _warn(r.warnings)
        if r.plan is not None and (r.written or r.failed):
            print(
                f"harlsync: {action} stopped: wrote {len(r.written)} of "
                f"{len(r.plan.writes)} item(s)",
                file=sys.stderr,
            )
            verbose = logging.getLogger().isEnabledFor(logging.INFO)  # -v: the wire too

            def said(w: PlannedWrite[Any]) -> str:
                return f"{w.name} ({w.command})" if verbose else w.name

            for w in r.written:
                print(f"  written:     {said(w)}", file=sys.stderr)
            if r.failed is not None and r.partly_written is not None:
                print(
                    f"  partly written: {r.failed.name}: {_partly_text(r.partly_written)}",
                    file=sys.stderr,
                )
            elif r.failed is not None:
                print(
                    f"  unknown:     {said(r.failed)} (may or may not have been written)",
                    file=sys.stderr,
                )
            for w in r.not_written:
                if w is not r.failed:
                    print(f"  not written: {said(w)}", file=sys.stderr)
            print(f"harlsync: run the same {action} again to finish", file=sys.stderr)
        for note in r.notes:
            print(f"harlsync: note: {note}", file=sys.stderr)
        if isinstance(failed.__cause__, KeyboardInterrupt):
            raise KeyboardInterrupt from failed  # exit 130, as any command interrupted
        raise failed.cause from failed
    finally:  # Ctrl-C too: no bar left on the screen
        progress.close()
    _warn(result.warnings)
    if result.plan is None or result.plan.empty:
        _print(f"{action}: robot already matches; nothing written")
    else:
        _print(
            f"{action}: wrote and verified {len(result.written)} item(s); "
            f"snapshot {result.snapshot}; audit {result.audit_log}"
        )
    for note in result.notes:
        _print(f"note: {note}")
    return EXIT_OK


def _cmd_push(args: argparse.Namespace) -> int:
    from .sync import deploy

    progress = Feedback("read")
    opts = _push_options(args, progress)
    return _report(
        "push", lambda: deploy.push(args.dir, opts, port=args.port, station=args.station), progress
    )


def _add_adopt(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "adopt",
        help="write changes made on the robot, as the last backup kept them, into the project",
        description="Write into the project the items the last backup read (kept on the "
        "branch harlsync/backup) where the robot differs from the project: the ITEMs "
        "named (as status and backup name them, e.g. 'MAIN program 0 step 2'), or every "
        "item the robot changed since the last push or rollback (drift). Nothing is "
        "committed and no robot is contacted: review the change (git diff) and commit "
        "it; then the robot's change is approved. Refuses uncommitted edits (exit 3) "
        "unless --allow-dirty.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    p.add_argument("items", nargs="*", metavar="ITEM", help="an item to adopt (default: the drift)")
    p.add_argument(
        "--allow-dirty",
        action="store_true",
        help="adopt even over uncommitted edits in DIR (they are overwritten)",
    )
    p.set_defaults(func=_cmd_adopt)


def _cmd_adopt(args: argparse.Namespace) -> int:
    from .sync.adopt import adopt
    from .sync.states import date_of

    found = adopt(_project_dir(args.dir), args.items, allow_dirty=args.allow_dirty)
    source = f"the backup of {date_of(found.time)} (commit {found.commit[:10]})"
    if not found.items:
        _print(f"nothing to adopt: the project already holds what {source} read")
        return EXIT_OK
    _print(f"adopted {len(found.items)} item(s) from {source}:")
    for item in found.items:
        _print(f"  {item}")
    _print(f"review with 'git diff {args.dir}' and commit: {', '.join(found.files)}")
    return EXIT_OK


def _add_rollback(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "rollback",
        help="restore the snapshot taken before the last push",
        description="Write back the robot's state as it was before the last push (or the "
        "snapshot named by --snapshot), under the same interlocks, verification "
        "and audit as push. The project in git then still holds what was pushed: "
        "revert that commit, or push again once fixed.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    _push_args(p)
    p.add_argument(
        "--snapshot",
        metavar="N",
        help="the snapshot to restore: its number as 'harlsync snapshots DIR' shows it, "
        "or its directory (default: the one taken before the last push)",
    )
    p.set_defaults(func=_cmd_rollback)


def _cmd_rollback(args: argparse.Namespace) -> int:
    from .sync import deploy
    from .sync.revisions import snapshot_path

    chosen = snapshot_path(_project_dir(args.dir), args.snapshot) if args.snapshot else None
    progress = Feedback("read")
    opts = _push_options(args, progress)
    return _report(
        "rollback",
        lambda: deploy.rollback(
            args.dir, opts, snapshot=chosen, port=args.port, station=args.station
        ),
        progress,
    )


# --- main -------------------------------------------------------------------------------

#: Each command (in ``--help`` order) -> what adds its parser.
_COMMANDS: dict[str, Callable[[argparse._SubParsersAction[argparse.ArgumentParser]], None]] = {
    "probe": _add_probe,
    "pull": _add_pull,
    "diff": _add_diff,
    "plan": _add_plan,
    "push": _add_push,
    "rollback": _add_rollback,
    "adopt": _add_adopt,
    "backup": _add_backup,
    "status": _add_status,
    "log": _add_log,
    "snapshots": _add_snapshots,
    "validate": _add_validate,
    "sim": _add_sim,
}


#: Commands that open no line to a robot: -v has no traffic to show for them.
_NO_LINE = frozenset({"validate", "status", "log", "snapshots", "adopt"})


def _one_line(exc: BaseException, verbose: int = 0) -> str:
    """An error as one line for stderr and cron mail, whatever text it carries
    (an OS message, a file name with a newline in it); a wire frame in it (a long
    run of hex) is named by its size unless -vv."""
    from .sync.audit import shorten

    text = "; ".join(part.strip() for part in str(exc).splitlines() if part.strip())
    return shorten(text, verbose) or text


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser; ``only``: of that command alone, for a command line
    that runs it (:func:`_command_of`): the others' parsers, some 60 options with
    their help, are a tenth of a pull's start-up, and such a command line never
    reaches them (only ``--help`` lists them, and a wrong command)."""
    parser = _Parser(
        prog="harlsync",
        description="Keep robot programs and settings under version control ("
        + ", ".join(f.title for f in _families())
        + ").",
        epilog="Exit codes: 0 success, 1 a negative answer (diff: different, validate: "
        "invalid, backup: a robot failed, status: a robot needs looking at), 2 an "
        "error, 3 refused for safety, 130 interrupted (Ctrl-C). On a terminal, "
        "progress is counted in exchanges with the controller.",
    )
    parser.add_argument("--version", action="version", version=f"harlsync {__version__}")
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="more output: -v what it does, -vv raw traffic on a robot's line as hex",
    )
    sub = cast(
        "argparse._SubParsersAction[argparse.ArgumentParser]",
        parser.add_subparsers(dest="command", required=True, metavar="COMMAND"),
    )
    for name, add in _COMMANDS.items():
        if only in (None, name):
            add(sub)
    for name, command in sub.choices.items():  # -v works after the command too
        traffic = ", -vv raw traffic as hex" if name not in _NO_LINE else ""
        command.add_argument(
            "-v",
            "--verbose",
            action="count",
            default=argparse.SUPPRESS,
            help=f"more output: -v what it does{traffic}",
        )
    return parser


def _setup_logging(verbose: int) -> None:
    from .terminal import LogHandler

    if verbose >= 2:
        level = logging.DEBUG
    elif verbose == 1:
        level = logging.INFO
    else:
        # Quiet under cron: only errors when nobody is watching.
        level = logging.WARNING if sys.stderr.isatty() else logging.ERROR
    logging.basicConfig(  # each line above a progress bar drawn meanwhile
        level=level,
        format="harlsync: %(levelname)s: %(robot)s%(message)s",
        handlers=[LogHandler()],
    )
    for handler in logging.getLogger().handlers:  # %(robot)s: which robot, under backup
        if not any(isinstance(f, RobotFilter) for f in handler.filters):
            handler.addFilter(RobotFilter())
    # The libraries a family uses may log their own ERROR lines above the one line
    # harlsync says of the same failure: -vv shows their warnings.
    for family in _families():
        for name in family.loggers:
            logging.getLogger(name).setLevel(logging.WARNING if verbose >= 2 else logging.CRITICAL)


def _command_of(argv: Sequence[str]) -> str | None:
    """The command ``argv`` runs, when it says so plainly: its first word that is not
    ``-v`` (``-vv``, ``--verbose``).  None for anything else first (``--help``,
    ``--version``, an abbreviation, a typo), which the whole parser takes."""
    for word in argv:
        if word == "--verbose" or (word.startswith("-") and word.strip("v") == "-"):
            continue
        return word if word in _COMMANDS else None
    return None


def main(argv: Sequence[str] | None = None) -> int:
    if argv is None:  # the process's own command line: the process ends when this returns
        return _whole_process()
    parser = build_parser(_command_of(argv))
    args = parser.parse_args(argv)
    _setup_logging(args.verbose)
    hint = families.port_hint(args.port) if isinstance(getattr(args, "port", None), str) else None
    if hint is not None:
        print(f"harlsync: error: {hint}", file=sys.stderr)
        return EXIT_ERROR
    try:
        return int(args.func(args))
    except (InterlockError, PolicyError, StalePlanError) as exc:
        print(f"harlsync: refused: {_one_line(exc, args.verbose)}", file=sys.stderr)
        return EXIT_REFUSED
    except HarlsyncError as exc:
        print(f"harlsync: error: {_one_line(exc, args.verbose)}", file=sys.stderr)
        return EXIT_ERROR
    except OSError as exc:
        # The library names the file-system failures it expects (a full disk, a
        # read-only project) with what to do; any other is still one line, not a
        # traceback, and -vv shows where it came from.
        log.debug("file-system error", exc_info=True)
        print(f"harlsync: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("harlsync: interrupted", file=sys.stderr)
        return 130


def _whole_process() -> int:
    """The command of the process's own command line, ``harlsync ...``, with the
    cyclic garbage collector spared what needs no collecting (issue 24).

    Before the command: what the start-up made (modules, classes, functions) lives
    until the process ends, so it is frozen out of every later collection instead
    of being traversed by each full one.  After it: the process ends, and what is
    left is freed by the operating system, so the collections of the interpreter's
    shutdown (about 15-20 ms after a pull, all CPU) are skipped too.  Nothing is
    lost by it: ``gc.freeze`` only keeps the collector from looking at objects.
    The atexit handlers (the logging's flush among them) still run, stdout and
    stderr are still flushed, and every file a command writes is closed (and
    synced, for a save) before the command returns.  :func:`main` called with an
    argument list (a test, a program using harlsync) never freezes: that process
    goes on.
    """
    gc.freeze()
    try:
        return main(sys.argv[1:])
    finally:
        gc.freeze()


if __name__ == "__main__":
    sys.exit(main())
