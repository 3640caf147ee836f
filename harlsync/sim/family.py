"""How the simulator framework reaches a family: the :class:`SimFamily` each
family's ``sim`` package exports as ``SIM_FAMILY``, found through the registry
(:func:`harlsync.families.simulator_module`), never by importing a family.

A family's controllers are reached one of two ways.  A :class:`LineFamily`
(HARL-U2, IAI) has a sans-I/O decoder for the bytes on a serial line, and the
framework serves its :class:`~harlsync.sim.device.Simulator` on a pty, TCP and
``sim://``.  A :class:`ServedFamily` (Epson: registers over Modbus TCP) serves
its :class:`~harlsync.sim.device.Device` itself, with the protocol's own
library, and ``harlsync sim`` asks it to.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from .. import families
from ..errors import ProjectError
from .device import Decoder, Device, RequestFrame
from .variants import Variant

__all__ = [
    "LineFamily",
    "ServedFamily",
    "SimFamily",
    "SimServer",
    "Verb",
    "line_family",
    "project_family",
    "sim_family",
]


@dataclass(frozen=True)
class Verb:
    """One control command of a family's simulator, as ``harlsync sim`` help lists it."""

    name: str
    #: the words after the verb, ``[STATION [TASK]]``
    usage: str
    #: what it does, in a few words
    does: str

    def __str__(self) -> str:
        return f"{self.name} {self.usage}".strip()


class SimFamily(Protocol):
    """What the framework needs of a family's simulated controller."""

    @property
    def name(self) -> str:
        """The family's name, as ``robot.yaml`` and ``--family`` say it."""
        ...

    @property
    def verbs(self) -> tuple[Verb, ...]:
        """The control verbs its stations take (``status`` and ``BUSY-after-writes
        N`` are the framework's, for every family)."""
        ...

    @property
    def busy_verb(self) -> str:
        """The verb that makes a station busy with no more arguments (``auto``,
        ``run``); it also names the schedule, ``auto-after-writes N``."""
        ...

    @property
    def variants(self) -> tuple[Variant, ...]:
        """Each choice its profile makes where the manual is silent, with the other
        ways a controller may answer (:mod:`harlsync.sim.variants`)."""
        ...

    @property
    def default_station(self) -> int:
        """Where a generated robot sits.  (How stations are written is the family's
        :class:`~harlsync.families.base.Family`'s, not repeated here.)"""
        ...

    def generate(self, seed: int, stations: Sequence[int]) -> Device[Any]:
        """Realistic robots drawn from seeds ``seed``, ``seed + 1`` ..., one a station."""
        ...

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Device[Any]:
        """The robot of a project directory, on its own station or on each of
        ``stations``.  Raises :class:`~harlsync.errors.ProjectError`."""
        ...


@runtime_checkable
class LineFamily(SimFamily, Protocol):
    """A family whose controllers sit on a serial line: the framework serves its
    :class:`~harlsync.sim.device.Simulator` (pty, TCP, ``sim://``)."""

    def decoder(self) -> Decoder[RequestFrame]:
        """A new decoder for the requests a client sends this family's controllers."""
        ...


class SimServer(Protocol):
    """A running server of a :class:`ServedFamily`."""

    @property
    def url(self) -> str:
        """Where clients connect (``modbus://127.0.0.1:5020``)."""
        ...

    def stop(self) -> None: ...


@runtime_checkable
class ServedFamily(SimFamily, Protocol):
    """A family that serves its simulated controllers itself, over its own
    protocol (Epson: a Modbus TCP server)."""

    def serve(self, sim: Device[Any], host: str, port: int) -> SimServer:
        """Serve ``sim`` on ``host:port`` (port 0: a free one) in the background;
        the server is listening when this returns.  Raises OSError when it cannot
        listen."""
        ...


def sim_family(name: str | None) -> SimFamily:
    """The simulated side of the family called ``name`` (None: the default).

    Raises :class:`~harlsync.errors.ProjectError` for an unknown family.
    """
    family: SimFamily = families.simulator_module(name).SIM_FAMILY
    return family


def line_family(name: str | None) -> LineFamily:
    """The simulated side of a family on a serial line (None: the default).

    Raises :class:`~harlsync.errors.ProjectError` for an unknown family, or one
    whose controllers are not on a serial line.
    """
    family = sim_family(name)
    if not isinstance(family, LineFamily):
        raise ProjectError(
            f"the {family.name} simulator is not a serial line: serve it with "
            f"harlsync sim --family {family.name} --listen HOST:PORT"
        )
    return family


def project_family(project: str | os.PathLike[str]) -> str:
    """The family a project directory's ``robot.yaml`` names (``family:``; absent:
    the default), read as the project store reads it.

    Raises :class:`~harlsync.errors.ProjectError` when robot.yaml cannot be read
    or names a family harlsync does not know.
    """
    return families.of_project(Path(project), strict=True).name
