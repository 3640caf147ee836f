"""A first contact, as ``harlsync probe`` asks for it, for the command line and any
Python caller: the families to try (the one named, else the one whose own URL scheme
the port has, else every serial family), the stations and baud rate as a person
writes them, the project to write refused before the line is opened, then the probe
(:mod:`.probe`) and the robot.yaml it found."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .. import families
from ..errors import ProjectError
from ..families.base import AnyFamily
from . import probe
from .probe import Probed

__all__ = ["FirstContact", "candidates", "first_contact", "station_list"]


@dataclass
class FirstContact:
    """What a probe found, and the robot.yaml it wrote (``--write``)."""

    found: Probed
    #: the project directory asked for, and the robot.yaml written in it
    directory: Path | None = None
    written: Path | None = None

    def to_json(self) -> dict[str, object]:
        out = probe.to_json(self.found)
        out["written"] = str(self.written) if self.written else None
        return out

    def lines(self) -> list[str]:
        """The findings in words (:func:`~.probe.report`), then the file written."""
        said = probe.report(self.found)
        if self.written is not None:
            said.append(f"wrote {self.written}: harlsync pull {self.directory} backs the robot up")
        return said


def candidates(port: str, family: str | None = None) -> list[AnyFamily]:
    """The families to try on ``port``: ``family``, else the one whose own URL scheme
    the port has, else every family without a scheme of its own (the serial ones)."""
    own = family or families.of_port(port)
    return [families.get(own)] if own else [f for f in families.every() if not f.schemes]


def station_list(family: AnyFamily, text: str) -> list[int]:
    """``1-4`` or ``99,1-F``: each station as the family writes it.  Raises
    ProjectError naming the one that is not a station."""
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


def _baud(text: str | None) -> int | str | None:
    if text is None or text == "auto":
        return text
    if not (text.isascii() and text.isdigit() and int(text) > 0):
        raise ProjectError(f"--baud {text}: give auto or a rate such as 9600")
    return int(text)


def _stations(tried: list[AnyFamily], text: str) -> tuple[list[AnyFamily], dict[str, list[int]]]:
    """The stations ``text`` names, as each family writes its stations; a family that
    cannot write them is not tried (the last refusal raised when none can)."""
    stations: dict[str, list[int]] = {}
    refused = None
    for family in tried:
        try:
            stations[family.name] = station_list(family, text)
        except ProjectError as exc:
            refused = exc
    if not stations and refused is not None:
        raise refused
    return [f for f in tried if f.name in stations], stations


def first_contact(
    port: str,
    *,
    family: str | None = None,
    stations: str | None = None,
    baud: str | None = None,
    write: str | Path | None = None,
    lock_timeout: float = 10.0,
    capture: str | Path | None = None,
) -> FirstContact:
    """Probe ``port`` with reads only (:func:`~.probe.probe`) and, given ``write``,
    create that project with the robot.yaml of what was found.

    ``stations``: ``1-4`` or ``99,1-F``; ``baud``: ``auto`` or a rate.  Raises
    ProjectError for either that cannot be taken, and for a ``write`` directory that
    exists and is not empty, before the line is opened."""
    tried = candidates(port, family)
    rate = _baud(baud)
    per_family = None
    if stations is not None:
        tried, per_family = _stations(tried, stations)
    directory = Path(write) if write else None
    if directory is not None:
        probe.refuse_existing(directory)
    found = probe.probe(
        port,
        tried,
        stations=per_family,
        baud=rate,
        lock_timeout=lock_timeout,
        capture=Path(capture) if capture else None,
    )
    written = probe.write_project(found, directory) if directory is not None else None
    return FirstContact(found, directory, written)
