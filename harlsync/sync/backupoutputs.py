"""What a plant backup leaves besides its report: the metrics file, the fleet report
page and the hooks, checked before any robot is read and made after the run, for
``harlsync backup`` and for any Python caller of :func:`~harlsync.sync.backup.backup`."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path

from ..errors import HarlsyncError, SyncError
from .backupreport import BackupReport, output_problems, run_hook, write_metrics

__all__ = ["BackupOutputs"]


@dataclass
class BackupOutputs:
    """The outputs of one plant run: files to write, commands to run."""

    #: a Prometheus textfile with per-robot results
    metrics: str | None = None
    #: the fleet report page, as ``harlsync status --html`` writes it
    html: str | None = None
    #: run through the shell, the summary on stdin, when a robot changed
    on_change: str | None = None
    #: likewise when a robot failed
    on_failure: str | None = None

    def check(self) -> None:
        """Raises SyncError naming every output that could not be made (a mistyped
        one would otherwise show only after the night's reads); call it before the run."""
        problems = output_problems(
            {"--metrics": self.metrics, "--html": self.html},
            {"--on-change": self.on_change, "--on-failure": self.on_failure},
        )
        if problems:  # every one of them, before a robot is read
            raise SyncError("; ".join(problems) + "; no robot was read")

    def deliver(
        self, report: BackupReport, paths: Iterable[str | Path], stale_after: timedelta
    ) -> None:
        """Write the metrics file and the report page (of the robots in ``paths``),
        then run the hooks ``report`` calls for.  Raises SyncError naming a file that
        could not be written (checked before, yet the disk may fill meanwhile) once
        the hooks ran: they may be the only alarm."""
        unwritten: list[str] = []
        if self.metrics:
            try:
                write_metrics(self.metrics, report)
            except HarlsyncError as exc:
                unwritten.append(str(exc))
        if self.html:
            from . import report as page  # jinja2: only for a run that writes the page
            from . import status

            try:
                page.write_html(self.html, status.collect(paths, stale_after=stale_after))
            except HarlsyncError as exc:
                unwritten.append(str(exc))
        if self.on_change and report.changed:
            run_hook(self.on_change, report, "change")
        if self.on_failure and not report.ok:
            run_hook(self.on_failure, report, "failure")
        if unwritten:
            raise SyncError("; ".join(unwritten))
