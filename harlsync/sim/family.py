"""How the simulator framework reaches a family: the :class:`SimFamily` each
family's ``sim`` package exports as ``SIM_FAMILY``, found through the registry
(:func:`harlsync.families.simulator_module`), never by importing a family."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from .. import families
from ..errors import ProjectError, ProjectFormatError
from .device import Decoder, RequestFrame, Simulator

__all__ = ["SimFamily", "Verb", "project_family", "sim_family"]


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
    def default_station(self) -> int:
        """Where a generated robot sits.  (How stations are written is the family's
        :class:`~harlsync.families.base.Family`'s, not repeated here.)"""
        ...

    def decoder(self) -> Decoder[RequestFrame]:
        """A new decoder for the requests a client sends this family's controllers."""
        ...

    def generate(self, seed: int, stations: Sequence[int]) -> Simulator[Any, Any]:
        """A line of realistic robots drawn from seeds ``seed``, ``seed + 1`` ..., one a station."""
        ...

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Simulator[Any, Any]:
        """A line holding the robot of a project directory, on its own station or on
        each of ``stations``.  Raises :class:`~harlsync.errors.ProjectError`."""
        ...


def sim_family(name: str | None) -> SimFamily:
    """The simulated side of the family called ``name`` (None: the default).

    Raises :class:`~harlsync.errors.ProjectError` for an unknown family.
    """
    family: SimFamily = families.simulator_module(name).SIM_FAMILY
    return family


def project_family(project: str | os.PathLike[str]) -> str:
    """The family a project directory's ``robot.yaml`` names (``family:``; absent:
    the default).

    Raises :class:`~harlsync.errors.ProjectError` when robot.yaml cannot be read.
    """
    from ..project import yamlio

    path = Path(project) / "robot.yaml"
    try:
        data = yamlio.parse(path.read_text(encoding="utf-8")).data
    except OSError as exc:
        raise ProjectFormatError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    except yamlio.YamlSyntaxError as exc:
        raise ProjectFormatError(f"{path}:{exc.line}: {exc.message}") from exc
    name = data.get("family") if isinstance(data, dict) else None
    if name is None:
        return families.DEFAULT
    if not isinstance(name, str) or name not in families.names():
        raise ProjectError(
            f"{path}: family: unknown controller family {name!r} "
            f"(allowed: {', '.join(families.names())})"
        )
    return name
