"""``harlsync probe``: what answers on a port, found with reads only.

A first contact with a controller nobody has configured harlsync for yet::

    port  -->  candidates: the family whose own URL scheme the port has, else every
               family the line can carry (or the one given)
          -->  per family, station and baud rate: one identity read (no retry)
               until one answers: that is the family, station and rate
          -->  the survey (Family.survey: identity, each table's extent and "not
               there" reply, the interlock, the guesses), recorded when asked
          -->  a report in words or JSON, and robot.yaml (``--write``)

Everything runs under :func:`~harlsync.link.readonly.reads_only`: a write anywhere
below (a family's code, a handshake) is refused before its bytes are made.  The line
is opened for each attempt and closed after it (the line lock is taken and freed with
it), so another harlsync waits no longer than one attempt.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path

from ..errors import ControllerError, LinkTimeout, ProjectError, ProtocolError
from ..families.base import AnyFamily, Survey
from ..link.capture import recording
from ..link.readonly import WriteForbidden, reads_only
from ..project.robot import Robot
from ..settings import SerialSettings

__all__ = ["Probed", "probe", "report", "to_json", "write_project"]

log = logging.getLogger(__name__)

WHY = "harlsync probe"


@dataclass
class Probed:
    """What a probe found: the family, station and serial settings that answered,
    and the survey."""

    family: AnyFamily
    port: str
    station: int
    serial: SerialSettings
    survey: Survey
    #: seconds the line was held for the survey
    held: float
    #: the attempts that got no answer, one phrase each
    tried: list[str] = field(default_factory=list)

    @property
    def pull_seconds(self) -> float | None:
        """A full pull's duration at the turnaround measured (None: not known)."""
        s = self.survey
        if s.pull_exchanges is None or s.turnaround is None:
            return None
        return s.pull_exchanges * s.turnaround

    @property
    def where(self) -> str:
        return f"port {self.port} station {self.family.format_station(self.station)}"


def _serial(family: AnyFamily, port: str, station: int, baud: int | None) -> SerialSettings:
    settings = family.new_robot("probe", port, station).serial
    return settings if baud is None else replace(settings, baudrate=baud)


def _bauds(family: AnyFamily, port: str, baud: int | str | None) -> list[int | None]:
    """The rates to try: the one given; with ``auto``, the family's manual's on a
    local port (a device server sets its own rate); else the profile's."""
    if isinstance(baud, int):
        return [baud]
    if baud == "auto" and "://" not in port and family.probe_bauds:
        return list(family.probe_bauds)
    return [None]


def _answers(family: AnyFamily, robot: Robot, lock_timeout: float) -> bool:
    """Whether the controller at ``robot``'s port and station answers ``family``'s
    identity read (its status read when it has none), without a retry."""
    quick = replace(robot, serial=replace(robot.serial, retries=0))
    try:
        driver = family.connect(quick, None, None, lock_timeout=lock_timeout)
    except (LinkTimeout, ControllerError, ProtocolError, WriteForbidden) as exc:
        log.info("%s at %s station %s: %s", family.name, robot.port, robot.station, exc)
        return False
    try:
        if driver.identity() is None:
            driver.status()
        return True
    except (LinkTimeout, ControllerError, ProtocolError, WriteForbidden) as exc:
        log.info("%s at %s station %s: %s", family.name, robot.port, robot.station, exc)
        return False
    finally:
        driver.close()


def probe(
    port: str,
    candidates: Sequence[AnyFamily],
    *,
    stations: Mapping[str, Sequence[int]] | None = None,
    baud: int | str | None = None,
    lock_timeout: float = 10.0,
    capture: Path | None = None,
) -> Probed:
    """Find which of ``candidates`` answers on ``port`` and survey it, with reads
    only.  The command line resolves them: the family given, or the one whose own URL
    scheme the port has, or every family without a scheme of its own (the serial ones).

    ``stations`` (by family name) are tried in order (default: each family's
    :attr:`~harlsync.families.base.Family.probe_stations`); ``baud`` is a rate,
    ``"auto"`` (the rates the family's manual lists, on a local port) or None (the
    profile's).  ``capture``: the survey's traffic recorded there as a ``spy://``
    hex dump, which ``replay://`` plays back.

    Raises ProjectError when nothing answers (saying what was tried), and the link's
    errors for a port that cannot be opened or is busy.
    """
    tried: list[str] = []
    for fam in candidates:
        _capturable(fam, port, capture)
        given = None if stations is None else stations.get(fam.name)
        numbers = list(given or fam.probe_stations or (fam.default_station,))
        for station in numbers:
            for rate in _bauds(fam, port, baud):
                settings = _serial(fam, port, station, rate)
                robot = fam.new_robot("probe", port, station, serial=settings)
                # told the family and one station, or a port only one family speaks:
                # straight to the survey, whose first read is the identity
                sure = (
                    len(candidates) == 1
                    and len(numbers) == 1
                    and rate == _bauds(fam, port, baud)[0]
                )
                with reads_only(WHY):
                    if not sure and not _answers(fam, robot, lock_timeout):
                        tried.append(
                            f"{fam.title} station {fam.format_station(station)} at "
                            f"{settings.baudrate} baud: no answer"
                        )
                        continue
                    survey, took = _surveyed(fam, robot, lock_timeout, capture)
                return Probed(fam, port, station, settings, survey, took, tried)
    raise ProjectError(
        f"port {port}: nothing answered a read of any family tried ({'; '.join(tried)}); "
        "check the cable and that the controller is on, give --family and --station if "
        "you know them, or --baud auto on a local serial port"
    )


def _capturable(fam: AnyFamily, port: str, capture: Path | None) -> None:
    """Refuse a capture of a family's own network protocol: it records a serial line's bytes."""
    if capture is not None and fam.schemes:
        raise ProjectError(
            f"--capture records a serial line's bytes, and {port} is the {fam.title}'s "
            "own network protocol: leave --capture out"
        )


def _surveyed(
    fam: AnyFamily, robot: Robot, lock_timeout: float, capture: Path | None
) -> tuple[Survey, float]:
    """The family's survey of ``robot`` (its traffic recorded to ``capture``, when
    given) and the seconds it took."""
    started = time.monotonic()
    if capture is not None:
        with recording(capture):
            survey = fam.survey(robot, lock_timeout=lock_timeout)
    else:
        survey = fam.survey(robot, lock_timeout=lock_timeout)
    return survey, time.monotonic() - started


# --- what it reports ---------------------------------------------------------------------


def _duration(value: float) -> str:
    if value < 1:
        return f"{value * 1000:.0f} ms"
    if value < 60:
        return f"{value:.1f} s"
    return f"{int(value // 60)} min {round(value % 60)} s"


def report(found: Probed) -> list[str]:
    """The probe's findings in words, one screen."""
    s, fam = found.survey, found.family
    lines = [
        f"{fam.title} ({fam.name}) at {found.where}",
        f"  serial settings: {found.serial}",
    ]
    for name, value in s.identity.items():
        lines.append(f"  {name}: {value}")
    for extent in s.extents:
        lines.append(
            f"  {extent.table}: {extent.count} ({extent.counted}); past the end the "
            f"controller answers {extent.reply} (robot.yaml: {', '.join(extent.settings)})"
        )
    if s.turnaround is not None:
        lines.append(f"  reply turnaround measured: {s.turnaround * 1000:.1f} ms an exchange")
    lines.append(f"  interlock now: {s.status}")
    for guess in s.guesses:
        verdict = "confirmed" if guess.confirmed else "contradicted"
        found_text = "" if guess.confirmed else f", this controller: {guess.found}"
        lines.append(
            f"  guess {verdict}: {guess.what} (profile: {guess.guessed}{found_text}; "
            f"robot.yaml {guess.setting})"
        )
    pull = found.pull_seconds
    if pull is not None:
        lines.append(
            f"  a full pull: {s.pull_exchanges} exchanges, about {_duration(pull)} at "
            "the speed of this line"
        )
    lines.append(f"  the probe held the line {_duration(found.held)}, reads only")
    return lines


def to_json(found: Probed) -> dict[str, object]:
    """The findings as ``--json`` prints them."""
    s = found.survey
    return {
        "family": found.family.name,
        "port": found.port,
        "station": found.family.format_station(found.station),
        "serial": str(found.serial),
        "baudrate": found.serial.baudrate,
        "identity": dict(s.identity),
        "extents": [
            {
                "table": e.table,
                "count": e.count,
                "counted": e.counted,
                "not_there": e.reply,
                "settings": list(e.settings),
            }
            for e in s.extents
        ],
        "turnaround_seconds": s.turnaround,
        "interlock": {"idle": s.idle, "status": s.status},
        "guesses": [
            {
                "what": g.what,
                "profile": g.guessed,
                "found": g.found,
                "confirmed": g.confirmed,
                "setting": g.setting,
            }
            for g in s.guesses
        ],
        "robot_options": dict(s.options),
        "pull_exchanges": s.pull_exchanges,
        "pull_seconds": found.pull_seconds,
        "held_seconds": found.held,
        "tried": found.tried,
    }


def write_project(found: Probed, directory: Path) -> Path:
    """Create ``directory`` with the robot.yaml of what was found, commented with the
    report, ready for ``harlsync pull``; returns its path.

    Raises ProjectError for a directory that exists and is not empty (a project is
    never overwritten), or a family that cannot write a robot.yaml on its own.
    """
    refuse_existing(directory)
    fam = found.family
    robot = fam.new_robot(directory.resolve().name, found.port, found.station, serial=found.serial)
    robot = replace(robot, options={**robot.options, **found.survey.options})
    text = fam.robot_text(robot)
    if text is None:
        raise ProjectError(
            f"the {fam.name} family cannot write a robot.yaml before a pull: run "
            f"harlsync pull {directory} --family {fam.name} --port {found.port} --station "
            f"{fam.format_station(found.station)}"
        )
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    header = [f"# Written by harlsync probe, {stamp}. What the controller showed:"]
    header += [f"#{line[1:] if line.startswith(' ') else ' ' + line}" for line in report(found)]
    header.append("# Each setting the probe learnt is filled in below; harlsync pull DIR reads it.")
    directory.mkdir(parents=True, exist_ok=True)
    target = directory / "robot.yaml"
    partial = directory / ".robot.yaml.partial"
    partial.write_text("\n".join(header) + "\n" + text, encoding="utf-8")
    os.replace(partial, target)
    return target


def refuse_existing(directory: Path) -> None:
    """Raises ProjectError for a ``directory`` that exists and is not empty: a probe
    writes a new project, never over one."""
    if directory.exists() and (not directory.is_dir() or any(directory.iterdir())):
        raise ProjectError(
            f"{directory}: exists and is not empty; --write creates a new project: give "
            "a new directory (harlsync pull updates an existing one)"
        )
