"""The nightly plant backup: pull every robot, one commit per run, a report.

Three layers, each importing only the one before it: one robot's backup
(:mod:`.robotbackup`), the fleet that runs them on the plant's lines
(:mod:`.fleet`), and this module, the plant run (outputs checked first, the
commit on the backup branch, the report, metrics and hooks).

Robots on separate lines are pulled in parallel (every line at once, or at
most ``jobs`` lines at once), spread over a worker process per core
(:mod:`harlsync.sync.fleet`);
robots that share a line (stations of one HNC on one port) are pulled one after
the other by the same worker, so their frames never interleave.  A robot that
fails leaves its previous backup as it was (a pull is atomic) and the others go
on.  Each project records its last successful backup in
``DIR/.harlsync/backup.json``, so the report can flag robots that are stale or
never had a good backup.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shlex
import subprocess
import time
from collections.abc import Callable, Iterable, Mapping
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

from .. import columns
from ..errors import HarlsyncError, ProjectError, SyncError
from ..link.lock import LockTimeout
from ..project import statefile
from ..project.lock import holder, lock_path, project_lock
from ..project.store import check_replaceable, replace_file
from . import audit, backupref, git, history, nightly, states
from .robotbackup import (
    BackupWatch,
    RobotOutcome,
    Unwatched,
    in_process,
    line_of,
    lines_of,
    record_not_backed_up,
)

__all__ = [
    "BackupReport",
    "BackupWatch",
    "RobotOutcome",
    "backup",
    "find_projects",
    "in_process",
    "line_of",
    "lines_of",
    "output_problems",
    "record_not_backed_up",
    "run_hook",
    "write_metrics",
]

log = logging.getLogger(__name__)


@dataclass
class BackupReport:
    robots: list[RobotOutcome]
    commit: str | None = None
    #: Why the commit failed (a stale .git/index.lock...); the backups are then
    #: saved but uncommitted, and the next run's pulls commit them.
    commit_error: str | None = None
    pushed: bool | None = None
    push_error: str | None = None
    started: str = ""
    duration: float = 0.0
    #: What the run set up or could not do beside the robots (the backup branch,
    #: deployed refs, a fetch that failed), a line each.
    said: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Every robot backed up and committed, and pushed when a push was asked for."""
        return (
            all(r.ok for r in self.robots)
            and self.commit_error is None
            and self.pushed is not False
        )

    @property
    def changed(self) -> list[RobotOutcome]:
        return [r for r in self.robots if r.changed]

    def to_json(self) -> dict[str, Any]:
        return {
            "ok": self.ok,
            "started": self.started,
            "duration": round(self.duration, 3),
            "commit": self.commit,
            "commit_error": self.commit_error,
            "pushed": self.pushed,
            "push_error": self.push_error,
            "said": self.said,
            "robots": [
                {k: v for k, v in asdict(r).items() if k != "kept"}
                | {"duration": round(r.duration, 3)}
                for r in self.robots
            ],
        }

    def commit_message(self) -> str:
        """Names what changed: ``backup: press: MAIN program 0 step 4; timer 3`` when one
        robot changed, else which robots; then each robot's items and who pushed to it
        since its last backup."""
        changed = self.changed
        head = f"backup: {len(changed)} of {len(self.robots)} robot(s) changed"
        if len(changed) == 1:
            one = changed[0]
            subject = history.commit_message(
                f"backup: {one.label or one.name}", one.summary, one.items, []
            ).split("\n", 1)[0]
        else:
            subject = f"{head}: {', '.join(r.label or r.name for r in changed)}"
        if not changed:  # a first backup that keeps the robots' own state apart
            subject = (
                f"backup: no change of {len(self.robots)} robot(s); their own state kept apart"
            )
        if len(subject) > 72:
            subject = head
        lines = [subject, ""]
        for r in changed:
            said = history.body(r.summary, r.items, r.pushed, "  ")
            lines += [f"- {r.label or r.name}: {said[0].strip()}", *said[1:]]
        standings = [(r, r.compared) for r in self.robots if r.ok]
        differ = [(r, s) for r, s in standings if s is not None and (s.pending or s.drift)]
        if differ:
            lines += ["", "Against the approved version:"]
            for r, s in differ:
                lines += [f"- {r.label or r.name}: {s.verdict}"]
                lines += [f"    {line}" for line in statefile.fold(s.lines(), history.NAMED)]
        failed = [r for r in self.robots if not r.ok]
        if failed:
            lines += ["", "Not backed up:"] + [
                f"- {r.label or r.name}: {audit.shorten(r.error)}" for r in failed
            ]
        return "\n".join(lines) + "\n"

    def render(self) -> str:
        """The summary a person reads in the morning."""
        rows = [("robot", "result", "duration", "changes")]
        for r in self.robots:
            if r.ok:
                result = "ok"
            else:
                result = "FAILED"
            flags = []
            if r.never_backed_up:
                flags.append("never backed up")
            elif r.stale:
                flags.append(f"stale: last good backup {r.last_success}")
            changes = r.summary if r.ok else (audit.shorten(r.error) or "")
            standing = r.compared if r.ok else None
            if standing is not None:
                changes = f"{changes}; {standing.verdict}"
            if flags:
                changes = f"{changes} ({'; '.join(flags)})" if changes else f"({'; '.join(flags)})"
            rows.append((r.label or r.name, result, f"{r.duration:.1f}s", changes))
        # What changed, or why not, is last: a long error text moves no other column.
        widths = [max(columns.width(row[i]) for row in rows) for i in range(3)]
        left, right = columns.ljust, columns.rjust  # terminal columns, not characters
        lines = [
            "  ".join([left(row[0], widths[0]), left(row[1], widths[1]), right(row[2], widths[2])])
            + "  "
            + row[3]
            for row in rows
        ]
        ok = sum(r.ok for r in self.robots)
        tail = f"{ok} of {len(self.robots)} robot(s) backed up, {len(self.changed)} changed"
        if self.commit:
            tail += f", commit {self.commit[:10]}"
        if self.commit_error:
            tail += (
                f"; git commit FAILED: {self.commit_error} (the backups are saved; the "
                "next run commits them)"
            )
        if self.push_error:
            tail += f"; git push FAILED: {self.push_error} (the commit is kept locally)"
        elif self.pushed:
            tail += ", pushed"
        notes = [f"note: {r.name}: {note}" for r in self.robots for note in r.notes]
        for r in self.robots:
            standing = r.compared if r.ok else None
            if standing is not None:
                notes += [f"{r.label or r.name}: {line}" for line in standing.lines()]
                notes += [f"note: {r.label or r.name}: {note}" for note in standing.notes]
        notes += [f"note: {line}" for line in self.said]
        return "\n".join(lines + ["", *notes, *([""] if notes else []), tail]) + "\n"


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


def backup(paths: Iterable[str | Path], **options: Any) -> BackupReport:
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
    fetched = nightly.fetch_deployed(projects[0]) if push and projects else None
    outcomes = fleet.read_lines(
        projects,
        fleet.Task(attempts, lock_timeout, clock),
        workers=fleet.default_workers() if workers is None else max(1, workers),
        jobs=jobs,
        watch=watch or Unwatched(),
        watched=watch is not None,
    )
    labels = project_labels(projects)
    for outcome in outcomes:
        outcome.project = labels.get(Path(outcome.path), outcome.name)
    outcomes.sort(key=lambda o: (o.name, o.project))
    for outcome, shown in zip(outcomes, shown_names((o.name, o.project) for o in outcomes)):
        outcome.label = shown

    for outcome in outcomes:
        outcome.never_backed_up = outcome.last_success is None
        outcome.stale = history.stale(outcome.last_success, now, stale_after)

    report = BackupReport(outcomes, started=now.isoformat(timespec="seconds"))
    if fetched:
        report.said.append(fetched)
    legacy = [Path(o.path) for o in outcomes if o.ok and o.changed and o.kept is None]
    kept = [o for o in outcomes if o.ok and o.kept is not None]
    if commit:
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
                if not nightly.push_refs(projects[0]) or legacy:
                    git.push(projects[0])
                report.pushed = True
            except HarlsyncError as exc:
                report.pushed, report.push_error = False, str(exc)
    _record_states(kept)
    report.duration = time.monotonic() - started
    return report


def _commit_kept(report: BackupReport, kept: list[RobotOutcome]) -> None:
    """Commit what the robots in git were read to hold on the backup branch (the
    approved branch and working tree untouched), and record where it is."""
    try:
        new, said = nightly.commit_observed(
            [(Path(o.path), o.kept or {}, o.compared) for o in kept], report.commit_message()
        )
    except HarlsyncError as exc:
        report.commit_error = str(exc)
        return
    report.said += said
    if new is not None:
        report.commit = report.commit or new
        _record_commit([Path(o.path) for o in kept if o.changed], new)
    for o in kept:
        standing, where = o.compared, (o.kept or {})
        if standing is None:
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


def output_problems(files: Mapping[str, str | None], hooks: Mapping[str, str | None]) -> list[str]:
    """Why each output of a backup could not be made, found before any robot is read,
    one line each: ``files`` (the metrics file, the report page) by the option that
    names them (``--metrics``), each written as :func:`replace_file` writes it, and
    ``hooks`` (``--on-failure``) the commands the shell is to run.  A mistyped
    output would otherwise show only after the night's reads, and one a night."""
    problems = []
    for option, given in files.items():
        if given:
            why = _unwritable(Path(given))
            if why is not None:
                problems.append(
                    f"cannot write the {_OUTPUTS.get(option, 'file')} {given} ({why}): "
                    f"fix that, or give another {option} FILE"
                )
    for option, command in hooks.items():
        if command:
            why = _hook_problem(command)
            if why is not None:
                problems.append(f"{option} '{command}': {why}")
    return problems


#: What each output option of a backup writes, as its messages name it.
_OUTPUTS = {"--metrics": "metrics file", "--html": "report page"}


def _unwritable(target: Path) -> str | None:
    """Why ``target`` cannot be replaced now, or None."""
    folder = target.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        return f"not a directory: {folder}"
    if folder != target.parent:
        return f"no directory {target.parent}"
    try:
        check_replaceable(target)
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


def _hook_problem(command: str) -> str | None:
    """Why the shell could not run ``command``: it cannot parse it, or finds no
    command by its first word (a word it would look up; None for anything else).
    Nothing is run: the shell only reads it (``sh -n``) and looks the word up."""
    if os.name != "posix":  # cmd.exe runs the hooks there: it has no such check
        return None
    read = subprocess.run(
        ["/bin/sh", "-n", "-c", command], capture_output=True, text=True, check=False
    )
    if read.returncode:
        said = (read.stderr.strip().splitlines() or ["syntax error"])[-1]
        said = re.sub(r"^\S*sh: (line )?\d+: ", "", said)
        return f"the shell cannot read it ({said}): correct it"
    try:
        words = shlex.split(command, comments=True)
    except ValueError:
        return None
    word = words[0] if words else ""
    if not re.fullmatch(r"[\w./+][\w./+-]*", word):
        return None  # an assignment, a redirection, a group: the shell's to judge
    found = subprocess.run(["/bin/sh", "-c", 'command -v "$1" >/dev/null', "sh", word], check=False)
    if found.returncode:
        return f"the shell finds no command {word}: correct it, or give its full path"
    return None


def run_hook(command: str, report: BackupReport, event: str) -> int:
    """Run a hook through the shell with the summary on stdin; its exit status.

    The environment carries ``HARLSYNC_EVENT`` (``change`` or ``failure``),
    ``HARLSYNC_CHANGED`` and ``HARLSYNC_FAILED`` (robot names, space separated)
    and ``HARLSYNC_REPORT`` (the JSON report).
    """
    env = dict(os.environ)
    env.update(
        HARLSYNC_EVENT=event,
        HARLSYNC_CHANGED=" ".join(r.name for r in report.changed),
        HARLSYNC_FAILED=" ".join(r.name for r in report.robots if not r.ok),
        HARLSYNC_REPORT=json.dumps(report.to_json()),
    )
    done = subprocess.run(
        command, shell=True, input=report.render(), text=True, env=env, check=False
    )
    if done.returncode:
        log.error("hook %r exited with %d", command, done.returncode)
    return done.returncode


def _standing(r: RobotOutcome) -> states.Standing:
    """What the robot's backup found of its states: tonight's, else (a failed robot)
    what the last one recorded, else nothing pending or drifted."""
    return r.compared or states.read(Path(r.path)) or states.Standing("")


def write_metrics(path: str | Path, report: BackupReport) -> None:
    """Write a Prometheus textfile (node_exporter's textfile collector), atomically.

    Raises SyncError when it cannot be written (the previous file is then kept).
    """

    def escaped(text: str) -> str:
        return text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")

    def last(r: RobotOutcome) -> str:
        return f"{datetime.fromisoformat(r.last_success).timestamp() if r.last_success else 0:.0f}"

    families: list[tuple[str, str, Callable[[RobotOutcome], str]]] = [
        ("success", "Whether the robot's last backup run succeeded.", lambda r: str(int(r.ok))),
        ("last_success_timestamp_seconds", "Time of the robot's last good backup.", last),
        ("duration_seconds", "How long the robot's backup took.", lambda r: f"{r.duration:.3f}"),
        (
            "changed_items",
            "Items changed since the previous backup.",
            lambda r: str(sum(v for k, v in r.counts.items() if k != "programs")),
        ),
        ("failed_attempts", "Failed attempts in this run.", lambda r: str(len(r.attempts))),
        (
            "pending_items",
            "Items approved and not yet on the robot (a push deploys them).",
            lambda r: str(len(_standing(r).pending)),
        ),
        (
            "drift_items",
            "Items changed on the robot since the last push or rollback, not by one.",
            lambda r: str(len(_standing(r).drift)),
        ),
    ]
    lines: list[str] = []
    # Each metric's samples in one group, each robot once: by its project (two robots
    # may share a name), and by name for the dashboards that used it alone.
    for suffix, text, value in families:
        name = f"harlsync_backup_{suffix}"
        lines += [f"# HELP {name} {text}", f"# TYPE {name} gauge"]
        for r in report.robots:
            label = f'{{project="{escaped(r.project or r.name)}",robot="{escaped(r.name)}"}}'
            lines.append(f"{name}{label} {value(r)}")
    if report.commit is not None or report.commit_error is not None:
        lines += [
            "# HELP harlsync_backup_git_commit_success Whether the run's git commit succeeded.",
            "# TYPE harlsync_backup_git_commit_success gauge",
            f"harlsync_backup_git_commit_success {int(report.commit_error is None)}",
        ]
    if report.pushed is not None:
        lines += [
            "# HELP harlsync_backup_git_push_success Whether the run's git push succeeded.",
            "# TYPE harlsync_backup_git_push_success gauge",
            f"harlsync_backup_git_push_success {int(report.pushed)}",
        ]
    try:
        replace_file(Path(path), ("\n".join(lines) + "\n").encode("utf-8"))
    except OSError as exc:
        raise SyncError(f"cannot write the metrics file {path}: {exc.strerror or exc}") from exc
