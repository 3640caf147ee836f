"""Reaching the live robot, for every workflow: open its line, read it whole, and
say what the audit log knows of earlier pushes to it."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic

from ..errors import HarlsyncError, ProjectError
from ..families.base import AnyFamily, D, Driver, Family, K, Progress

if TYPE_CHECKING:
    from ..project.robot import Robot

__all__ = [
    "LiveRead",
    "Station",
    "connect",
    "read_live",
    "station_number",
    "unfinished_pushes",
]


def connect(
    family: Family[K, D],
    robot: Robot,
    port: str | None = None,
    station: int | None = None,
    *,
    lock_timeout: float = 10.0,
    options: Mapping[str, bool] | None = None,
    command: str = "",
) -> Driver[K, D]:
    """Open the robot's line (``port``/``station`` override the robot file).

    ``options`` are the family's options of the connection (:attr:`Family.options`),
    each given when set.  ``command`` is the harlsync command it serves
    (:attr:`Driver.serves`).  Raises ProjectError, before anything is opened, for
    one the family does not take.
    """
    given = {name: value for name, value in (options or {}).items() if value}
    for name in sorted(set(given) - family.connect_options):
        raise ProjectError(
            f"--{name.replace('_', '-')}: the {family.name} family has no such option; leave it out"
        )
    driver = family.connect(robot, port, station, lock_timeout=lock_timeout, **given)
    if command:
        driver.serves = command
    return driver


#: A station as the command line gives it (text, read by the robot's family, in
#: its notation), as a library caller gives it (a number), or none (robot.yaml's).
Station = int | str | None


def station_number(family: AnyFamily, station: Station) -> int | None:
    """``station`` as a number; text is read by the family (its notation), and a
    number must be in the family's range too.  Raises ProjectError naming the
    range, as robot.yaml's check does."""
    if station is None:
        return None
    text = station if isinstance(station, str) else family.format_station(station)
    try:
        return family.parse_station(text)
    except ValueError as exc:
        raise ProjectError(
            f"--station: {exc}" if isinstance(station, str) else f"station: {exc}"
        ) from None


@dataclass(frozen=True)
class LiveRead(Generic[K, D]):
    """What :func:`read_live` found."""

    #: closed: it still names the robot and builds commands
    driver: Driver[K, D]
    #: everything the robot holds, as the family's data
    live: D
    #: a warning for each earlier push to it that did not finish
    warnings: list[str]
    #: when asked and the robot is not idle: why a push would be refused now
    busy: str | None = None


def read_live(
    family: Family[K, D],
    robot: Robot,
    port: str | None,
    station: int | None,
    *,
    registers: bool,
    progress: Progress | None,
    lock_timeout: float,
    idle_check: bool = False,
    options: Mapping[str, bool] | None = None,
    whole: bool = False,
    noted: Callable[[Sequence[str]], None] | None = None,
    identified: Callable[[Mapping[str, str], str], None] | None = None,
    command: str = "",
) -> LiveRead[K, D]:
    """Everything the robot holds, read over a line opened and closed for it; with
    ``idle_check`` its state after the read too (what the interlock reads).
    ``options`` are the connection's (see :func:`connect`); ``whole`` (a pull): find
    out how far each table goes and fail rather than read part of one.  ``noted`` is
    given the driver's notes (what it did on its own) once the read is over, whether
    it succeeded or not: what was done to the robot is told even when the read fails.
    ``identified`` is given what the robot says it is (:meth:`Driver.identity`) and
    where it is, before anything else is read, when the family can tell it first:
    it raises to refuse a swapped controller before the long read.  What else the
    read found out of the controller is the caller's to compare with what the
    project recorded (:meth:`Catalogue.other_robot`).  ``command`` is the harlsync
    command it serves (:attr:`Driver.serves`)."""
    driver = _connect_noting(family, robot, port, station, lock_timeout, options, command, noted)
    try:
        if identified is not None:
            now = driver.identity()
            if now is not None:
                identified(now, driver.label)
        live = driver.read_all(registers=registers, progress=progress, whole=whole)
        # After the read, the line still held: the first request does not wait for
        # the audit log (issue 24), and what it says is the same.
        warnings = unfinished_pushes(robot, port, station)
        busy = _busy(driver) if idle_check else None
        return LiveRead(driver, live, warnings, busy)
    finally:
        try:
            if noted is not None and driver.notes:
                noted(tuple(driver.notes))
        finally:
            driver.close()


def _connect_noting(
    family: Family[K, D],
    robot: Robot,
    port: str | None,
    station: int | None,
    lock_timeout: float,
    options: Mapping[str, bool] | None,
    command: str,
    noted: Callable[[Sequence[str]], None] | None,
) -> Driver[K, D]:
    """The robot's line opened (:func:`connect`); failing, what was done to the robot
    before the line failed given to ``noted``."""
    try:
        return connect(
            family,
            robot,
            port,
            station,
            lock_timeout=lock_timeout,
            options=options,
            command=command,
        )
    except HarlsyncError as exc:
        if noted is not None and exc.notes:
            noted(exc.notes)
        raise


def _busy(driver: Driver[K, D]) -> str | None:
    """Why the interlock would refuse a write now (None: the robot is idle)."""
    try:
        status = driver.status()
    except HarlsyncError as exc:
        return f"cannot read its state ({exc})"
    if status.idle:
        return None
    advice = driver.advice(status)
    return status.describe() + (f". {advice}" if advice else "")


def unfinished_pushes(robot: Robot, port: str | None, station: int | None) -> list[str]:
    """What the audit log says about earlier pushes to this robot that never ended.

    Called with the line held, so no push in progress can be mistaken for one.
    """
    from . import audit, auditindex  # not at import: the first request does not wait for it

    problems: list[str] = []
    try:
        found = auditindex.unfinished(
            port or robot.port, station if station is not None else robot.station, problems=problems
        )
    except OSError as exc:
        return [
            (
                f"cannot read the audit log {audit.audit_path()} ({exc}) to check for an "
                "unfinished push"
            )
        ]
    return problems + [audit.describe_unfinished(record) for record in found]
