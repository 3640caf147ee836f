"""``harlsync probe``: what answers on a port, with reads only (a first contact)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .. import families
from ..families.base import AnyFamily
from .common import EXIT_OK, _families, _family_names, _per_family, _print

__all__ = ["_add_probe"]


def _add_probe(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "probe",
        help="tell what controller answers on a port, with reads only (a first contact)",
        description="Find which controller answers on --port and what it is, sending read "
        "requests only (a write is refused before its bytes are made): on a serial line "
        "each family's identity read at the stations it allows (or those given), on a "
        "family's own URL scheme that family. It reports the family, station and serial "
        'settings, the identity, each table\'s real extent and its "not there" reply, the '
        "reply turnaround measured, the interlock now, the profile's guesses this "
        "controller confirmed or contradicted (with the robot.yaml setting of each) and how "
        "long a full pull takes. --write DIR then creates the project's robot.yaml, ready "
        "for harlsync pull DIR. The line is held only while a read is under way.",
    )
    p.add_argument(
        "--port",
        metavar="URL",
        required=True,
        help="the port: /dev/ttyUSB0, COM3, socket://HOST:PORT, rfc2217://HOST:PORT, "
        "sim://PROJECT_DIR"
        + "".join(f"; {scheme.help}" for f in _families() for scheme in f.schemes),
    )
    p.add_argument(
        "--family",
        choices=_family_names(),
        default=None,
        help="try only this family (default: the family whose own URL scheme --port has, "
        "else every serial family)",
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--station",
        metavar="N",
        help="try only this station (" + _per_family("stations") + ")",
    )
    where.add_argument(
        "--stations",
        metavar="LIST",
        help="the stations to try, in order, as each family writes them: 1-4, or 99,1-F "
        "(default: the stations each family's manual gives as defaults)",
    )
    p.add_argument(
        "--baud",
        metavar="auto|N",
        default=None,
        help="the baud rate to try (default: the family's profile's); auto: every rate "
        "the family's manual lists, on a local serial port only (a device server sets "
        "its own)",
    )
    p.add_argument("--json", action="store_true", help="print the findings as JSON")
    p.add_argument(
        "--write",
        metavar="DIR",
        help="create the project DIR with the robot.yaml of what was found (commented); "
        "refuses a directory that exists and is not empty",
    )
    p.add_argument(
        "--capture",
        metavar="FILE",
        help="record the survey's traffic in FILE as a spy:// hex dump; harlsync probe "
        "--port 'replay://FILE?family=F' --family F --station N plays it back",
    )
    p.add_argument(
        "--lock-timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="how long to wait for another harlsync using the same line (default 10)",
    )
    p.set_defaults(func=_cmd_probe)


def _station_list(family: AnyFamily, text: str) -> list[int]:
    """``1-4`` or ``99,1-F``: each station as the family writes it.  Raises
    HarlsyncError (a ProjectError) naming the one that is not a station."""
    from ..errors import ProjectError

    stations: list[int] = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        first, dash, last = part.partition("-")
        try:
            low = family.parse_station(first)
            high = family.parse_station(last) if dash else low
        except ValueError as exc:
            raise ProjectError(f"--stations {text}: {exc}") from None
        stations += range(low, high + 1)
    return stations


def _cmd_probe(args: argparse.Namespace) -> int:
    from ..errors import ProjectError
    from ..sync import probe

    if args.family:
        candidates = [families.get(args.family)]
    elif families.of_port(args.port):
        candidates = [families.get(families.of_port(args.port))]
    else:
        candidates = [f for f in _families() if not f.schemes]
    baud: int | str | None = args.baud
    if isinstance(baud, str) and baud != "auto":
        if not (baud.isascii() and baud.isdigit() and int(baud) > 0):
            raise ProjectError(f"--baud {baud}: give auto or a rate such as 9600")
        baud = int(baud)
    stations: dict[str, list[int]] | None = None
    text = args.station or args.stations
    if text is not None:  # as each family writes its stations; one that cannot is not tried
        stations, refused = {}, None
        for family in candidates:
            try:
                stations[family.name] = _station_list(family, text)
            except ProjectError as exc:
                refused = exc
        if not stations and refused is not None:
            raise refused
        candidates = [f for f in candidates if f.name in stations]
    write = Path(args.write) if args.write else None
    if write is not None and write.exists() and (not write.is_dir() or any(write.iterdir())):
        raise ProjectError(  # before the line is opened
            f"{write}: exists and is not empty; --write creates a new project: give a new "
            "directory (harlsync pull updates an existing one)"
        )
    found = probe.probe(
        args.port,
        candidates,
        stations=stations,
        baud=baud,
        lock_timeout=args.lock_timeout,
        capture=Path(args.capture) if args.capture else None,
    )
    written = probe.write_project(found, write) if write is not None else None
    if args.json:
        out = probe.to_json(found)
        out["written"] = str(written) if written else None
        _print(json.dumps(out, indent=2))
    else:
        for line in probe.report(found):
            _print(line)
        if written is not None:
            _print(f"wrote {written}: harlsync pull {write} backs the robot up")
    return EXIT_OK
