"""How the simulator framework reaches a family: the :class:`SimFamily` each
family's ``sim`` package exports as ``SIM_FAMILY``, found through the registry
(:func:`harlsync.families.simulator_module`), never by importing a family.

A family's controllers are reached one of two ways.  A :class:`LineFamily`
(frames on a serial line) has a sans-I/O decoder for the bytes on a serial line, and the
framework serves its :class:`~harlsync.sim.device.Simulator` on a pty, TCP and
``sim://``.  A :class:`ServedFamily` (a network protocol of its own) serves
its :class:`~harlsync.sim.device.Device` itself, with the protocol's own
library, and ``harlsync sim`` asks it to.

:class:`SimFamily`, :class:`LineFamily` and :class:`Verb` are defined beside
:class:`~harlsync.sim.device.Device` (each names the other) and re-exported here.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from .. import families
from ..errors import ProjectError
from .device import Device, LineFamily, SimFamily, Verb

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


class SimServer(Protocol):
    """A running server of a :class:`ServedFamily`."""

    @property
    def url(self) -> str:
        """Where clients connect (the family's own URL scheme, ``scheme://127.0.0.1:5020``)."""
        ...

    def stop(self) -> None: ...


@runtime_checkable
class ServedFamily(SimFamily, Protocol):
    """A family that serves its simulated controllers itself, over its own
    protocol (a server of the protocol's own library)."""

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
