"""What a person decides for one push or rollback, and what it did: the types
:mod:`.deploy` runs on and :mod:`.writes`' loop fills in, kept apart so that
neither imports the other."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Protocol

from ..errors import HarlsyncError, PartlyWritten, SyncError, partly_words
from ..families.base import K, Progress
from .plan import Plan, PlannedWrite

__all__ = ["Confirm", "PushFailed", "PushOptions", "PushResult"]


class Confirm(Protocol):
    """Asks a person to confirm a plan, of whichever family's robot it is."""

    def __call__(self, plan: Plan[K], /) -> bool: ...


@dataclass
class PushOptions:
    """Everything a person decides for one push or rollback."""

    yes: bool = False
    #: Asks a person to confirm the plan; without it and without ``yes`` the push is
    #: refused before the robot is read.
    confirm: Confirm | None = None
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
    connect_options: Mapping[str, bool] = field(default_factory=dict)
    #: Told, before the first write of a push not shown to ``confirm`` (``yes``),
    #: each item it reverts of a change made on the robot (:attr:`Plan.reverts`).
    told: Callable[[str], None] | None = None


@dataclass
class PushResult:
    """What a push did: the plan, what was written, and what was not."""

    plan: Plan[Any] | None = None
    written: list[PlannedWrite[Any]] = field(default_factory=list)
    not_written: list[PlannedWrite[Any]] = field(default_factory=list)
    failed: PlannedWrite[Any] | None = None
    #: set when ``failed`` stopped part way (:class:`~harlsync.errors.PartlyWritten`):
    #: its parts that went out, may have, and did not
    partly_written: PartlyWritten | None = None
    error: str | None = None
    snapshot: Path | None = None
    audit_log: Path | None = None
    #: Earlier pushes to this robot that never finished (see :mod:`.audit`).
    warnings: list[str] = field(default_factory=list)
    #: What the family says after anything was written (``Family.deploy_notes``).
    notes: list[str] = field(default_factory=list)
    #: The commit the robot's deployed ref holds after it (:mod:`.states`); None
    #: outside git, or when it could not be moved (a warning says why).
    deployed: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    def summary(self, action: str) -> str:
        """The line that says what a push (``action``) that finished did."""
        if self.plan is None or self.plan.empty:
            return f"{action}: robot already matches; nothing written"
        return (
            f"{action}: wrote and verified {len(self.written)} item(s); "
            f"snapshot {self.snapshot}; audit {self.audit_log}"
        )

    def stopped(self, action: str, verbose: bool = False) -> list[str]:
        """What a person is told of a push (``action``) that stopped, line by line:
        each item written, partly written, perhaps written and not written (with
        ``verbose`` each write's wire command), then the family's notes."""
        lines = []
        if self.plan is not None and (self.written or self.failed):
            lines.append(
                f"harlsync: {action} stopped: wrote {len(self.written)} of "
                f"{len(self.plan.writes)} item(s)"
            )

            def said(w: PlannedWrite[Any]) -> str:
                return f"{w.name} ({w.command})" if verbose else w.name

            lines += [f"  written:     {said(w)}" for w in self.written]
            if self.failed is not None and self.partly_written is not None:
                p = self.partly_written
                words = partly_words(p.sent, p.unknown, p.left)
                lines.append(f"  partly written: {self.failed.name}: {words}")
            elif self.failed is not None:
                lines.append(
                    f"  unknown:     {said(self.failed)} (may or may not have been written)"
                )
            lines += [f"  not written: {said(w)}" for w in self.not_written if w is not self.failed]
            lines.append(f"harlsync: run the same {action} again to finish")
        return lines + [f"harlsync: note: {note}" for note in self.notes]


class PushFailed(SyncError):
    """A push stopped; ``result`` says exactly what was and was not written."""

    def __init__(self, cause: HarlsyncError, result: PushResult) -> None:
        self.cause = cause
        self.result = result
        super().__init__(str(cause))
