"""What every command's parser and printing share: output, usage errors, the help
formatter and the options several commands take (what each family offers and says
of them is looked up in :mod:`harlsync.families`)."""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from collections.abc import Callable, Iterable, Mapping
from typing import Any, TypeAlias, TypedDict

from .. import families

EXIT_OK, EXIT_NO, EXIT_ERROR, EXIT_REFUSED = 0, 1, 2, 3

#: What adds the commands' parsers.
Sub: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"

log = logging.getLogger("harlsync")


def _print(*args: object) -> None:
    print(*args, flush=True)


def _json(data: object, default: Callable[[object], object] | None = None) -> None:
    """``data`` as ``--format json`` prints it."""
    _print(json.dumps(data, indent=2, default=default))


def _lines(lines: Iterable[object]) -> None:
    for line in lines:
        _print(line)


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


def _command(
    sub: Sub, name: str, run: Callable[[argparse.Namespace], int], **kwargs: Any
) -> argparse.ArgumentParser:
    """The parser of the command ``name`` (``help``, ``description``), which ``run`` runs."""
    p = sub.add_parser(name, **kwargs)
    p.set_defaults(func=run)
    return p


def _add(p: argparse._ActionsContainer, table: Mapping[str, str], *only: str) -> None:
    """The options of ``table`` (or only those named), in its order: ``"--flag
    METAVAR"`` (an option that takes a value) or ``"--flag"`` (a switch) -> its help."""
    for spec, text in table.items():
        flag, _, metavar = spec.partition(" ")
        if only and spec not in only:
            continue
        if metavar:
            p.add_argument(flag, metavar=metavar, help=text)
        else:
            p.add_argument(flag, action="store_true", help=text)


def _phrases(place: str, template: str) -> str:
    """``template`` with what the families' ``--help`` says at ``place``
    (:func:`~harlsync.families.help_phrases`) in its ``{}``, or "" when no family
    says anything there: a family that declares nothing adds nothing."""
    said = families.help_phrases(place)
    return template.format(said) if said else ""


def _dir_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("dir", metavar="DIR", help="robot project directory")


def _format_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="text for people (default), json for scripts",
    )


def _family_arg(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--family", choices=families.KNOWN, default=None, help=help)


def _lock_arg(p: argparse.ArgumentParser, default: float, what: str) -> None:
    p.add_argument(
        "--lock-timeout",
        type=float,
        default=default,
        metavar="SECONDS",
        help=f"{what} (default {default:g})",
    )


def _connection_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--port",
        metavar="URL",
        help=f"port to use instead of the robot file's: {families.port_kinds()}",
    )
    stations = families.help_phrases("stations")
    p.add_argument(
        "--station", metavar="N", help=f"station number instead of the robot file's ({stations})"
    )
    _lock_arg(p, 10.0, "how long to wait for another harlsync using the same line or project")
    for option in families.options():
        p.add_argument(option.flag, dest=option.name, action="store_true", help=option.help)


def _connect_options(args: argparse.Namespace) -> dict[str, bool]:
    """The family options of the connection, as the engine takes them."""
    return {option.name: bool(getattr(args, option.name)) for option in families.options()}


class _Line(TypedDict):
    """The connection's options (:func:`_connection_args`), as the engine takes them."""

    port: str | None
    station: str | None
    lock_timeout: float
    connect_options: dict[str, bool]


def _line(args: argparse.Namespace) -> _Line:
    return _Line(
        port=args.port,
        station=args.station,
        lock_timeout=args.lock_timeout,
        connect_options=_connect_options(args),
    )
