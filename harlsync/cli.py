"""The ``harlsync`` command: parse arguments, call the library, print.

Exit codes: 0 success, 1 a negative answer (``diff``: different; ``validate``:
invalid), 2 an error, 3 refused for safety (interlock or policy).
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import threading
from collections.abc import Callable, Sequence

from . import __version__
from .errors import HarlsyncError, InterlockError, PolicyError

__all__ = ["main"]

EXIT_OK, EXIT_NO, EXIT_ERROR, EXIT_REFUSED = 0, 1, 2, 3

log = logging.getLogger("harlsync")


def _print(*args: object) -> None:
    print(*args, flush=True)


# --- sim ------------------------------------------------------------------------------


def _add_sim(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sim",
        help="run a simulated HARL-U2 on a pty and/or a TCP port",
        description=(
            "Serve a simulated HARL-U2 controller. It prints the pty device path and the "
            "socket:// URL to connect to, then reads control commands on standard input: "
            "auto [STATION [TASK]], suspend [STATION [TASK]], stop [STATION], "
            "auto-after-writes N, status. Stop it with Ctrl-C or end of input."
        ),
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--project", metavar="DIR", help="serve the robot of this project directory")
    src.add_argument("--seed", type=int, default=0, help="generate realistic programs from SEED")
    p.add_argument(
        "--stations", default=None, metavar="N[,N...]",
        help="stations on the line (default: the project's station, or 1)",
    )
    p.add_argument("--listen", metavar="HOST:PORT", help="also serve over TCP (socket://HOST:PORT)")
    p.add_argument("--no-pty", action="store_true", help="do not open a pty (needs --listen)")
    p.add_argument(
        "--baud", type=int, default=9600,
        help="delay each reply by its time on the wire at this speed; 0 turns it off (default 9600)",
    )
    p.add_argument("--turnaround", type=float, default=0.0, metavar="SECONDS",
                   help="extra delay before each reply")
    p.add_argument(
        "--faults", default="", metavar="NAME=RATE,...",
        help="fault injection: noise, drop, bad_lrc, fragment, slow (rates 0-1), "
             "slow_delay (seconds), seed",
    )
    p.add_argument("--auto", action="store_true", help="start with task 0 in automatic operation")
    p.add_argument("--auto-after-writes", type=int, default=0, metavar="N",
                   help="switch to automatic operation after N SN writes")
    p.add_argument("--record", metavar="FILE",
                   help="append every request received to FILE as JSON lines")
    p.set_defaults(func=_cmd_sim)


def _cmd_sim(args: argparse.Namespace) -> int:
    from .sim import Faults
    from .sim.control import apply_command
    from .sim.protocol_sim import build_simulator
    from .sim.serve import PtyServer, TcpServer

    if args.no_pty and not args.listen:
        raise SystemExit("harlsync sim: --no-pty needs --listen HOST:PORT")
    try:
        faults = Faults.parse(args.faults)
    except ValueError as exc:
        raise SystemExit(f"harlsync sim: --faults: {exc}") from exc
    sim = build_simulator(
        project=args.project,
        seed=args.seed,
        stations=[int(s) for s in args.stations.split(",")] if args.stations else None,
        baudrate=args.baud or None,
        turnaround=args.turnaround,
        faults=faults,
        auto_after_writes=args.auto_after_writes,
    )
    if args.auto:
        for state in sim.stations.values():
            state.start_task(0)
    if args.record:
        record = open(args.record, "a", encoding="utf-8")  # noqa: SIM115 - open for the run
        sim.listeners.append(
            lambda r: (record.write(json.dumps(
                {"station": r.station, "payload": r.payload, "automatic": r.automatic}
            ) + "\n"), record.flush())
        )
    servers: list[PtyServer | TcpServer] = []
    if not args.no_pty:
        pty = PtyServer(sim)
        _print(f"pty: {pty.start()}")
        servers.append(pty)
    if args.listen:
        host, _, port = args.listen.rpartition(":")
        tcp = TcpServer(sim, host or "127.0.0.1", int(port))
        _print(f"tcp: {tcp.start()}")
        servers.append(tcp)
    _print(f"stations: {', '.join(str(n) for n in sorted(sim.stations))}")

    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())

    def control() -> None:
        for line in sys.stdin:
            try:
                answer = apply_command(sim, line)
            except (ValueError, IndexError) as exc:
                answer = f"error: {exc}"
            if answer:
                _print(answer)
        done.set()

    threading.Thread(target=control, daemon=True).start()
    try:
        done.wait()
    except KeyboardInterrupt:
        pass
    for server in servers:
        server.stop()
    return EXIT_OK


# --- validate ---------------------------------------------------------------------------


def _add_validate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "validate",
        help="check a robot project against its schemas and its own configuration",
        description="Report every problem in a robot project, one per line as "
                    "file:line: field: what is wrong (allowed: ...). Exit 0 when valid, 1 when not.",
    )
    p.add_argument("dir", metavar="DIR", help="robot project directory")
    p.set_defaults(func=_cmd_validate)


def _cmd_validate(args: argparse.Namespace) -> int:
    from .project import validate_project

    issues = validate_project(args.dir)
    for issue in issues:
        _print(issue)
    if issues:
        print(f"harlsync: {args.dir}: {len(issues)} problem(s)", file=sys.stderr)
        return EXIT_NO
    return EXIT_OK


# --- main -------------------------------------------------------------------------------

_COMMANDS: list[Callable[[argparse._SubParsersAction], None]] = [_add_validate, _add_sim]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="harlsync",
        description="Keep Hirata HARL-U2 robot programs under version control.",
    )
    parser.add_argument("--version", action="version", version=f"harlsync {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more output: -v progress details, -vv raw traffic as hex")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in _COMMANDS:
        add(sub)
    return parser


def _setup_logging(verbose: int) -> None:
    if verbose >= 2:
        level = logging.DEBUG
    elif verbose == 1:
        level = logging.INFO
    else:
        # Quiet under cron: only errors when nobody is watching.
        level = logging.WARNING if sys.stderr.isatty() else logging.ERROR
    logging.basicConfig(level=level, format="harlsync: %(levelname)s: %(message)s")


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    _setup_logging(args.verbose)
    try:
        return int(args.func(args))
    except (InterlockError, PolicyError) as exc:
        print(f"harlsync: refused: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    except HarlsyncError as exc:
        print(f"harlsync: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("harlsync: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
