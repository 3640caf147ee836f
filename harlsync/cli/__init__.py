"""The ``harlsync`` command: parse arguments, call the library, print.

Exit codes: 0 success, 1 a negative answer (``diff``: different; ``validate``:
invalid; ``backup``: a robot failed; ``status``: a robot needs looking at), 2 an
error, 3 refused for safety (interlock or policy), 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import gc
import sys
from collections.abc import Callable, Sequence
from typing import cast

from .. import __version__, families
from ..errors import (
    HarlsyncError,
    InterlockError,
    PolicyError,
    StalePlanError,
)
from ..terminal import log_to_terminal
from .common import EXIT_ERROR, EXIT_REFUSED, Sub, _Parser, log
from .plant import _add_backup, _add_log, _add_snapshots, _add_status, _add_validate
from .probe import _add_probe
from .robot import _add_adopt, _add_diff, _add_plan, _add_pull, _add_push, _add_rollback
from .sim import _add_sim

__all__ = ["main"]


#: Each command (in ``--help`` order) -> what adds its parser.
_COMMANDS: dict[str, Callable[[Sub], None]] = {
    "probe": _add_probe,
    "pull": _add_pull,
    "diff": _add_diff,
    "plan": _add_plan,
    "push": _add_push,
    "rollback": _add_rollback,
    "adopt": _add_adopt,
    "backup": _add_backup,
    "status": _add_status,
    "log": _add_log,
    "snapshots": _add_snapshots,
    "validate": _add_validate,
    "sim": _add_sim,
}


#: Commands that open no line to a robot: -v has no traffic to show for them.
_NO_LINE = frozenset({"validate", "status", "log", "snapshots", "adopt"})


def _one_line(exc: BaseException, verbose: int = 0) -> str:
    """An error as one line for stderr and cron mail, whatever text it carries
    (an OS message, a file name with a newline in it); a wire frame in it (a long
    run of hex) is named by its size unless -vv."""
    from ..sync.audit import shorten

    text = "; ".join(part.strip() for part in str(exc).splitlines() if part.strip())
    return shorten(text, verbose) or text


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser; ``only``: of that command alone, for a command line
    that runs it (:func:`_command_of`): the others' parsers, some 60 options with
    their help, are a tenth of a pull's start-up, and such a command line never
    reaches them (only ``--help`` lists them, and a wrong command)."""
    parser = _Parser(
        prog="harlsync",
        description="Keep robot programs and settings under version control ("
        + ", ".join(f.title for f in families.every())
        + ").",
        epilog="Exit codes: 0 success, 1 a negative answer (diff: different, validate: "
        "invalid, backup: a robot failed, status: a robot needs looking at), 2 an "
        "error, 3 refused for safety, 130 interrupted (Ctrl-C). On a terminal, "
        "progress is counted in exchanges with the controller.",
    )
    parser.add_argument("--version", action="version", version=f"harlsync {__version__}")
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="more output: -v what it does, -vv raw traffic on a robot's line as hex",
    )
    sub = cast(Sub, parser.add_subparsers(dest="command", required=True, metavar="COMMAND"))
    for name, add in _COMMANDS.items():
        if only in (None, name):
            add(sub)
    for name, command in sub.choices.items():  # -v works after the command too
        traffic = ", -vv raw traffic as hex" if name not in _NO_LINE else ""
        command.add_argument(
            "-v",
            "--verbose",
            action="count",
            default=argparse.SUPPRESS,
            help=f"more output: -v what it does{traffic}",
        )
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """The command ``argv`` runs, when it says so plainly: its first word that is not
    ``-v`` (``-vv``, ``--verbose``).  None for anything else first (``--help``,
    ``--version``, an abbreviation, a typo), which the whole parser takes."""
    for word in argv:
        if word == "--verbose" or (word.startswith("-") and word.strip("v") == "-"):
            continue
        return word if word in _COMMANDS else None
    return None


def main(argv: Sequence[str] | None = None) -> int:
    if argv is None:  # the process's own command line: the process ends when this returns
        return _whole_process()
    parser = build_parser(_command_of(argv))
    args = parser.parse_args(argv)
    log_to_terminal(args.verbose, (name for f in families.every() for name in f.loggers))
    hint = families.port_hint(args.port) if isinstance(getattr(args, "port", None), str) else None
    if hint is not None:
        print(f"harlsync: error: {hint}", file=sys.stderr)
        return EXIT_ERROR
    try:
        return int(args.func(args))
    except (InterlockError, PolicyError, StalePlanError) as exc:
        print(f"harlsync: refused: {_one_line(exc, args.verbose)}", file=sys.stderr)
        return EXIT_REFUSED
    except HarlsyncError as exc:
        print(f"harlsync: error: {_one_line(exc, args.verbose)}", file=sys.stderr)
        return EXIT_ERROR
    except OSError as exc:
        # The library names the file-system failures it expects (a full disk, a
        # read-only project) with what to do; any other is still one line, not a
        # traceback, and -vv shows where it came from.
        log.debug("file-system error", exc_info=True)
        print(f"harlsync: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("harlsync: interrupted", file=sys.stderr)
        return 130


def _whole_process() -> int:
    """The command of the process's own command line, ``harlsync ...``, with the
    cyclic garbage collector spared what needs no collecting (issue 24).

    Before the command: what the start-up made (modules, classes, functions) lives
    until the process ends, so it is frozen out of every later collection instead
    of being traversed by each full one.  After it: the process ends, and what is
    left is freed by the operating system, so the collections of the interpreter's
    shutdown (about 15-20 ms after a pull, all CPU) are skipped too.  Nothing is
    lost by it: ``gc.freeze`` only keeps the collector from looking at objects.
    The atexit handlers (the logging's flush among them) still run, stdout and
    stderr are still flushed, and every file a command writes is closed (and
    synced, for a save) before the command returns.  :func:`main` called with an
    argument list (a test, a program using harlsync) never freezes: that process
    goes on.
    """
    gc.freeze()
    try:
        return main(sys.argv[1:])
    finally:
        gc.freeze()


if __name__ == "__main__":
    sys.exit(main())
