"""How the layers below the families reach them without importing the registry.

The project store needs a family by the name robot.yaml gives, and the line lock
needs the families' own TCP URL schemes; both sit below :mod:`harlsync.families`
and must not import it.  The registry hands over its two look-ups here when it
is imported (as the encodings package hands its search function to
:mod:`codecs`), and ``harlsync/__init__`` imports it, so they are always there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from .errors import ProjectError

if TYPE_CHECKING:
    from .families.base import AnyFamily

__all__ = ["family", "provide", "tcp_schemes"]

_family: Callable[[str | None], AnyFamily] | None = None
_schemes: Callable[[], Mapping[str, int]] | None = None


def provide(
    family: Callable[[str | None], AnyFamily], schemes: Callable[[], Mapping[str, int]]
) -> None:
    """The registry's call: the family by name (None: the default), and every
    family's TCP schemes -> the port a URL of it means when it names none."""
    global _family, _schemes
    _family, _schemes = family, schemes


def family(name: str | None) -> AnyFamily:
    """The family called ``name`` (None or empty: the default).  Raises ProjectError."""
    if _family is None:  # pragma: no cover - harlsync/__init__ imports the registry
        raise ProjectError("no controller families are registered (import harlsync.families)")
    return _family(name)


def tcp_schemes() -> Mapping[str, int]:
    """Every family's own TCP URL schemes, with their default port."""
    return _schemes() if _schemes is not None else {}
