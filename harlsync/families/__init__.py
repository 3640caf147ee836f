"""The controller families harlsync knows, by the name ``robot.yaml`` gives them.

This registry is the one place that names the family packages (python-can's
``BACKENDS``): adding a family adds a package under ``harlsync/families/`` and
one line in :data:`FAMILIES`, and changes no engine file.  A family kept
elsewhere (a test's, a plant's own) joins with :func:`register`, or, installed
as a distribution of its own, through the entry-point group
``harlsync.families`` (python-can finds its interfaces so)::

    [project.entry-points."harlsync.families"]
    kuka-krc = "myplant.kuka"     # the package holding its family and sim modules

Entry points are looked at only when a name is not registered already, or
when every name is asked for (importing :mod:`importlib.metadata` costs more
than a pull's whole start-up).  A project
whose ``robot.yaml`` has no ``family`` key is of the :data:`DEFAULT` family.

Every family package has a ``family`` module whose ``FAMILY`` is its
:class:`~harlsync.families.base.Family`, and a ``sim`` package with its simulated
controller.  Neither is imported before it is asked for.

A family is resolved once, where a command starts (:func:`get` for a name the
command line gives, :func:`of_project` for a project's robot.yaml), and the
object is passed down.  The layers below (the project store, the line lock)
reach the registry through :mod:`harlsync.lookup`, which it fills in when it is
imported: they never import it.

What the command line offers and says of every family is looked up here too:
the connection options (:func:`options`), the kinds of port (:func:`port_kinds`)
and the ``--help`` phrases each family declares (:func:`help_phrases`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from importlib import import_module
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from .. import lookup
from ..errors import ProjectError

if TYPE_CHECKING:
    from .base import AnyFamily
    from .declare import Option

__all__ = [
    "DEFAULT",
    "ENTRY_POINTS",
    "FAMILIES",
    "KNOWN",
    "every",
    "get",
    "help_phrases",
    "names",
    "of_port",
    "of_project",
    "options",
    "port_hint",
    "port_kinds",
    "refuse_options",
    "register",
    "simulator_module",
    "url_schemes",
]

#: family name (as robot.yaml and --family say it) -> its package
FAMILIES: dict[str, str] = {
    "harl-u2": f"{__name__}.harl_u2",
    "iai": f"{__name__}.iai",
    "epson": f"{__name__}.epson",
}
DEFAULT = "harl-u2"
#: The entry-point group through which an installed distribution adds a family.
ENTRY_POINTS = "harlsync.families"
_discovered = False


def _discover() -> None:
    """Add the families installed distributions declare (:data:`ENTRY_POINTS`),
    once; a name registered already keeps its package."""
    global _discovered
    if _discovered:
        return
    from importlib.metadata import entry_points

    for point in entry_points(group=ENTRY_POINTS):
        FAMILIES.setdefault(point.name, point.value)
    _discovered = True


class _Known:
    """Every family name, for a command line's ``choices``: a name registered
    already is found without looking at the installed entry points."""

    def __contains__(self, name: object) -> bool:
        if name not in FAMILIES:
            _discover()
        return name in FAMILIES

    def __iter__(self) -> Iterator[str]:
        return iter(names())

    def __len__(self) -> int:
        return len(names())


#: The family names as a command line's ``choices=`` takes them.
KNOWN = _Known()


def register(name: str, package: str) -> None:
    """Add the family ``name``, whose package (``family`` and ``sim`` modules) is
    ``package`` (a dotted module path, importable)."""
    FAMILIES[name] = package


def names() -> tuple[str, ...]:
    """Every family: the registered ones and those installed distributions add."""
    _discover()
    return tuple(FAMILIES)


def _package(name: str) -> str:
    if name not in FAMILIES:
        _discover()
    try:
        return FAMILIES[name]
    except KeyError:
        raise ProjectError(
            f"unknown controller family {name!r} (known: {', '.join(FAMILIES)})"
        ) from None


def get(name: str | None) -> AnyFamily:
    """The family called ``name`` (``None`` or empty: the default).  Raises ProjectError."""
    family: AnyFamily = import_module(_package(name or DEFAULT) + ".family").FAMILY
    return family


def every() -> tuple[AnyFamily, ...]:
    """Every family registered, in :data:`FAMILIES` order (each one imported)."""
    return tuple(get(name) for name in names())


def of_project(root: Path, *, strict: bool = False) -> AnyFamily:
    """The family a project's robot.yaml names (none, or no readable robot.yaml:
    the default, whose reading of the file says what is wrong with it).

    Raises ProjectFormatError, naming the file and line, for a family harlsync
    does not know, and (``strict``) for a robot.yaml that cannot be read.
    """
    from ..project import store  # not at import: --help reads no project

    return store.family_of(root, strict=strict)


def refuse_options(family: AnyFamily, given: Mapping[str, bool]) -> None:
    """Raise ProjectError for an option set in ``given`` that ``family`` does not
    take, naming the families that do (what the command line says of it)."""
    for name in sorted(
        n for n, value in given.items() if value and n not in family.connect_options
    ):
        takers = [f.name for f in every() if name in f.connect_options]
        raise ProjectError(
            f"--{name.replace('_', '-')}: the {family.name} family has no such option "
            f"(only {', '.join(takers) or 'no family'}); leave it out"
        )


def url_schemes() -> dict[str, int]:
    """Every family's own URL schemes -> the port a URL of it means when it names none.

    The families registered so far: one an entry point adds is registered as soon as
    a robot.yaml or ``--family`` names it, before its line is opened."""
    return {s.name: s.default_port for name in tuple(FAMILIES) for s in get(name).schemes}


def of_port(port: str | None) -> str | None:
    """The name of the family whose own URL scheme ``port`` has (``scheme://``), or None."""
    scheme = port.partition("://")[0].lower() if port and "://" in port else None
    for family in every():
        if scheme and scheme in {s.name for s in family.schemes}:
            return family.name
    return None


def port_hint(port: str) -> str | None:
    """What to give instead of a ``HOST:PORT`` without a scheme, which pyserial would
    take for a device file (None when ``port`` is not one)."""
    import re

    if "://" in port or not re.fullmatch(
        r"[A-Za-z0-9.-]+:\d{1,5}|\[[0-9A-Fa-f:.]+\]:\d{1,5}", port
    ):
        return None
    own = [
        f"{scheme.name}://{port} ({scheme.help.partition(':')[0]})"
        for family in every()
        for scheme in family.schemes
    ]
    return (
        f"--port {port}: a network port is given as a URL: socket://{port} (a serial "
        f"device server){''.join(', or ' + text for text in own)}"
    )


def help_phrases(place: str) -> str:
    """``name: phrase; ...`` of what each family's ``--help`` says at ``place`` (a
    field of :class:`~harlsync.families.declare.Help`: ``stations``, ``busy``...),
    in :data:`FAMILIES` order; a family with nothing to say there is left out."""
    phrases = []
    for family in every():
        phrase: str = getattr(family.help, place)
        if phrase:
            phrases.append(f"{family.name}: {phrase}")
    return "; ".join(phrases)


def options() -> list[Option]:
    """Every family's connection options (``Family.options``), each name once, in
    :data:`FAMILIES` order: what every command that opens a line offers."""
    found: dict[str, Option] = {}
    for family in every():
        for option in family.options:
            found.setdefault(option.name, option)
    return list(found.values())


def port_kinds() -> str:
    """The kinds of port a ``--port`` takes, for its help: a serial device, the URLs
    the link opens itself, then each family's own URL schemes."""
    return "/dev/ttyUSB0, COM3, socket://HOST:PORT, rfc2217://HOST:PORT, sim://PROJECT_DIR" + (
        "".join(f"; {scheme.help}" for family in every() for scheme in family.schemes)
    )


def simulator_module(name: str | None) -> ModuleType:
    """The family's ``sim`` package (its simulated controller).  Raises ProjectError."""
    return import_module(_package(name or DEFAULT) + ".sim")


lookup.provide(get, url_schemes)
