"""The write loop of a push or rollback, and the interlock and window checks around
each write (the "for each write" steps of :mod:`.deploy`'s outline)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from datetime import datetime

from ..errors import (
    HarlsyncError,
    InterlockError,
    LinkTimeout,
    NotWritten,
    PartlyWritten,
    PolicyError,
    PortBusyError,
    PortError,
    ReplyError,
    StalePlanError,
    VerifyError,
)
from ..families.base import D, Driver, Family, K, Words
from ..project import Robot
from . import audit
from .plan import Plan, PlannedWrite
from .pushtypes import PushOptions, PushResult

__all__ = ["check_window", "interlock", "write_all"]

# The push's own logger, as before the write loop moved here: -v shows "wrote ..." under it.
log = logging.getLogger("harlsync.sync.deploy")


def check_window(robot: Robot, opts: PushOptions, before: str | None = None) -> None:
    """Refuse outside the maintenance windows: before the port is opened, and again
    ``before`` each write, so a long push stops when its window closes."""
    now = opts.now or datetime.now()
    if not opts.outside_window and not robot.in_window(now):
        windows = "; ".join(str(w) for w in robot.windows)
        stopped = f"; stopped before {before}" if before else ""
        raise PolicyError(
            f"robot {robot.name}: {now:%a %H:%M} is outside its maintenance windows ({windows})"
            f"{stopped}; wait for a window or give --outside-window REASON"
        )


def _no_answer(exc: HarlsyncError) -> bool:
    """The line failed without any robot answering: the port, or silence (wrong
    station, cable, baud) rather than a status reply that makes no sense."""
    if isinstance(exc, LinkTimeout):
        return not isinstance(exc.__cause__, ReplyError)
    return isinstance(exc, PortError | PortBusyError)


def interlock(driver: Driver[K, D], robot: Robot, words: Words, before: str) -> None:
    """Raise InterlockError unless the robot's status (``words.state``, in the
    family's words) shows it idle.

    When no robot answers at all the link's own error goes through (exit 2, like
    diff and pull): nothing can be written either way, and "refused for safety"
    would send the reader looking for a running robot instead of at the port.
    """
    try:
        status = driver.status()
    except HarlsyncError as exc:
        if _no_answer(exc):
            raise
        raise InterlockError(
            f"robot {robot.name} ({driver.label}): cannot read {words.state} before "
            f"{before} ({exc}); not writing"
        ) from exc
    if not status.idle:
        advice = driver.advice(status)
        raise InterlockError(
            f"robot {robot.name} ({driver.label}) is not idle: {status.describe()}; "
            f"stopped before {before}" + (f". {advice}" if advice else "")
        )


def write_all(
    family: Family[K, D],
    driver: Driver[K, D],
    robot: Robot,
    the_plan: Plan[K],
    opts: PushOptions,
    result: PushResult,
    announce: Callable[[PlannedWrite[K]], None],
) -> None:
    """Make each write of ``the_plan`` in turn, each checked against the window, the
    robot's state and what the robot holds, and read back; ``result`` says what was
    written (and which write failed).  ``announce`` is told each write before it
    is made."""
    tunable = family.catalogue.live_tuning

    def live(write: PlannedWrite[K]) -> bool:
        return opts.allow_live_tuning and write.key.kind in tunable and not write.unsafe

    if opts.allow_live_tuning and not all(live(w) for w in the_plan.writes):
        # Live tuning covers timers and tables only: a plan that also holds any
        # other write needs an idle robot before its first write of any kind.
        interlock(driver, robot, family.words, f"the first write ({the_plan.writes[0].name})")
    for write in the_plan.writes:
        _write_one(family, driver, robot, write, opts, result, live, announce)
    if _last_guarded(result, live) is not None:
        _idle_at_end(family, driver, robot, result, live)


def _write_one(
    family: Family[K, D],
    driver: Driver[K, D],
    robot: Robot,
    write: PlannedWrite[K],
    opts: PushOptions,
    result: PushResult,
    live: Callable[[PlannedWrite[K]], bool],
    announce: Callable[[PlannedWrite[K]], None],
) -> None:
    """One write: refused when the robot no longer holds what the plan was made
    from, outside the window, or (unless ``live``) when the robot is not idle;
    verified by reading it back."""
    now = driver.read(write.key)
    if now != write.old:
        raise StalePlanError(
            f"{write.name} changed on the robot since it was read "
            f"({audit.difference(family.catalogue, write.key, write.old, now)}); not "
            "overwriting it. Pull or diff to see the change, then run again"
        )
    check_window(robot, opts, f"writing {write.name}")
    announce(write)  # before the interlock: nothing between the status read and the write
    if not live(write):
        try:
            interlock(driver, robot, family.words, f"writing {write.name}")
        except InterlockError as exc:
            raise InterlockError(f"{exc}{_maybe_hit(result, live)}") from exc
    result.failed = write
    # A re-send after a lost reply is a write too: the same interlock applies.
    try:
        driver.write(write.key, write.new, write.old, needs_idle=not live(write))
    except NotWritten:
        result.failed = None  # refused, not lost: the item is not written
        raise
    except PartlyWritten as exc:
        result.partly_written = exc
        raise
    got = driver.read(write.key)
    if got != write.new:
        raise VerifyError(
            f"{write.name} does not read back as written "
            f"({audit.difference(family.catalogue, write.key, write.new, got)}, written → "
            "read back)"
        )
    result.failed = None
    result.written.append(write)
    log.info("wrote %s: %s", write.name, write.command)


def _idle_at_end(
    family: Family[K, D],
    driver: Driver[K, D],
    robot: Robot,
    result: PushResult,
    live: Callable[[PlannedWrite[K]], bool],
) -> None:
    """The last write that needed an idle robot had no status read after it: one more
    tells whether the robot was started between the read before it and its arrival (no
    client can prevent that); a warning in ``result`` when it was."""
    try:
        status = driver.status()
    except HarlsyncError as exc:
        result.warnings.append(f"cannot read {family.words.state} after the last write ({exc})")
        return
    if not status.idle:
        result.warnings.append(
            f"robot {robot.name} ({driver.label}) is not idle at the end of the push: "
            f"{status.describe()}{_maybe_hit(result, live)}"
        )


def _last_guarded(
    result: PushResult, live: Callable[[PlannedWrite[K]], bool]
) -> PlannedWrite[K] | None:
    """The last write made that needed an idle robot (the last one a status read cleared)."""
    return next((w for w in reversed(result.written) if not live(w)), None)


def _maybe_hit(result: PushResult, live: Callable[[PlannedWrite[K]], bool]) -> str:
    """What an operator must check when the robot turned out started mid-push."""
    last = _last_guarded(result, live)
    if last is None:
        return ""
    return (
        f". It was started after the status read before {last.name}: that write may "
        "have reached it while it ran; check the robot"
    )
