"""What a plant backup tells: its report (the morning's summary, the JSON, the
commit message) and the outputs made of it, each checked before any robot is
read: the Prometheus metrics file and the hooks run through the shell.

:mod:`harlsync.sync.backup` runs the night and re-exports these names.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shlex
import subprocess
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path

from .. import columns
from ..errors import SyncError
from ..project import statefile
from ..project.store import check_replaceable, replace_file
from . import audit, history, states
from .robotbackup import RobotOutcome

__all__ = ["BackupReport", "output_problems", "run_hook", "write_metrics"]

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

    def to_json(self) -> dict[str, object]:
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
                {k: v for k, v in asdict(r).items() if k not in ("kept", "changed_items")}
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
            lambda r: str(r.changed_items),
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
