"""What every command's parser and printing share: output, usage errors, the help
formatter, the connection options and the families' help phrases."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Collection
from pathlib import Path
from typing import Any

from ..families.base import AnyFamily, Option

EXIT_OK, EXIT_NO, EXIT_ERROR, EXIT_REFUSED = 0, 1, 2, 3

log = logging.getLogger("harlsync")


def _print(*args: object) -> None:
    print(*args, flush=True)


def _warn(warnings: list[str]) -> None:
    """What the library found worth saying whatever the verbosity (an unfinished push)."""
    for warning in warnings:
        print(f"harlsync: warning: {warning}", file=sys.stderr, flush=True)


def _usage(message: str) -> int:
    """A wrong combination of options: say so on stderr, exit 2 like argparse does."""
    print(f"harlsync {message}", file=sys.stderr)
    return EXIT_ERROR


def _columns() -> int:
    """The terminal's width as :func:`shutil.get_terminal_size` measures it: $COLUMNS,
    else standard output's terminal, else 80."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns or 80


class _Help(argparse.HelpFormatter):
    """argparse's help, as wide as argparse makes it, measured without importing
    :mod:`shutil` (and bz2 and lzma with it): argparse makes a formatter for every
    option it adds, so a pull paid for it before its first request (issue 24)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        if len(args) < 4 and kwargs.get("width") is None:
            kwargs["width"] = _columns() - 2
        super().__init__(*args, **kwargs)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose help is :class:`_Help` unless told otherwise (its
    command parsers too: argparse makes them of the class of their parent)."""

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _Help)
        super().__init__(**kwargs)


def _format_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="text for people (default), json for scripts",
    )


def _project_dir(path: str) -> Path:
    """``path``, which must hold a robot project.  Raises ProjectError naming it."""
    from ..project.store import require_project

    require_project(Path(path))
    return Path(path)


def _connection_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--port",
        metavar="URL",
        help="port to use instead of the robot file's: /dev/ttyUSB0, COM3, "
        "socket://HOST:PORT, rfc2217://HOST:PORT, sim://PROJECT_DIR"
        + "".join(f"; {scheme.help}" for f in _families() for scheme in f.schemes),
    )
    p.add_argument(
        "--station",
        metavar="N",
        help="station number instead of the robot file's (" + _per_family("stations") + ")",
    )
    p.add_argument(
        "--lock-timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="how long to wait for another harlsync using the same line or project (default 10)",
    )
    for option in _options():
        p.add_argument(option.flag, dest=option.name, action="store_true", help=option.help)


def _families() -> tuple[AnyFamily, ...]:
    from ..families import every

    return every()


def _per_family(place: str) -> str:
    """``name: phrase; ...`` of what each family's help says at ``place`` (see
    :class:`~harlsync.families.base.Help`)."""
    return "; ".join(
        f"{f.name}: {getattr(f.help, place)}" for f in _families() if getattr(f.help, place)
    )


def _options() -> list[Option]:
    """Every family's connection options, each name once."""
    found: dict[str, Option] = {}
    for family in _families():
        for option in family.options:
            found.setdefault(option.name, option)
    return list(found.values())


def _connect_options(args: argparse.Namespace) -> dict[str, bool]:
    """The family options of the connection, as the engine takes them."""
    return {option.name: bool(getattr(args, option.name)) for option in _options()}


def _family_names() -> Collection[str]:
    from ..families import KNOWN

    return KNOWN
