"""The controller families harlsync knows, by the name ``robot.yaml`` gives them.

This registry is the one place that names the family packages (python-can's
``BACKENDS``): adding a family adds a package under ``harlsync/families/`` and
one line in :data:`FAMILIES`, and changes no engine file.  A project whose
``robot.yaml`` has no ``family`` key is a HARL-U2 project (:data:`DEFAULT`).

Every family package has a ``family`` module whose ``FAMILY`` is its
:class:`~harlsync.families.base.Family`, and a ``sim`` package with its simulated
controller.  Neither is imported before it is asked for.
"""

from __future__ import annotations

from importlib import import_module
from types import ModuleType
from typing import TYPE_CHECKING

from ..errors import ProjectError

if TYPE_CHECKING:
    from .base import Family

__all__ = ["DEFAULT", "FAMILIES", "get", "names", "simulator_module"]

#: family name (as robot.yaml and --family say it) -> package under harlsync.families
FAMILIES: dict[str, str] = {
    "harl-u2": "harl_u2",
    "iai": "iai",
    "epson": "epson",
}
DEFAULT = "harl-u2"


def names() -> tuple[str, ...]:
    return tuple(FAMILIES)


def _package(name: str) -> str:
    try:
        return f"{__name__}.{FAMILIES[name]}"
    except KeyError:
        raise ProjectError(
            f"unknown controller family {name!r} (known: {', '.join(FAMILIES)})"
        ) from None


def get(name: str | None) -> Family:
    """The family called ``name`` (``None``: the default).  Raises ProjectError."""
    family: Family = import_module(_package(name or DEFAULT) + ".family").FAMILY
    return family


def simulator_module(name: str | None) -> ModuleType:
    """The family's ``sim`` package (its simulated controller).  Raises ProjectError."""
    return import_module(_package(name or DEFAULT) + ".sim")
