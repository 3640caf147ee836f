"""``harlsync probe``: what answers on a port, with reads only (a first contact)."""

from __future__ import annotations

import argparse

from .. import families
from .common import (
    EXIT_OK,
    Sub,
    _add,
    _command,
    _family_arg,
    _json,
    _lines,
    _lock_arg,
    _phrases,
)

__all__ = ["_add_probe"]


def _add_probe(sub: Sub) -> None:
    p = _command(
        sub,
        "probe",
        _cmd_probe,
        help="tell what controller answers on a port, with reads only (a first contact)",
        description="Find which controller answers on --port and what it is, sending read "
        "requests only (a write is refused before its bytes are made): on a serial line each "
        "family's identity read at the stations it allows (or those given), on a family's own "
        "URL scheme that family. It reports the family, station and serial settings, the "
        'identity, each table\'s real extent and its "not there" reply, the reply turnaround '
        "measured, the interlock now, the profile's guesses this controller confirmed or "
        "contradicted (with the robot.yaml setting of each) and how long a full pull takes. "
        "--write DIR then creates the project's robot.yaml, ready for harlsync pull DIR. The "
        "line is held only while a read is under way.",
    )
    p.add_argument(
        "--port", metavar="URL", required=True, help=f"the port: {families.port_kinds()}"
    )
    _family_arg(
        p,
        "try only this family (default: the family whose own URL scheme --port has, else every "
        "serial family)",
    )
    stations = families.help_phrases("stations")
    _add(
        p.add_mutually_exclusive_group(),
        {
            "--station N": f"try only this station ({stations})",
            "--stations LIST": "the stations to try, in order, as each family writes them ("
            + _phrases("station_list", "{}; ")
            + "default: the stations each family's manual gives as defaults)",
        },
    )
    _add(p, _PROBE)
    _lock_arg(p, 10.0, "how long to wait for another harlsync using the same line")


#: probe's options after --port, --family and the stations.
_PROBE = {
    "--baud auto|N": "the baud rate to try (default: the family's profile's); auto: every rate "
    "the family's manual lists, on a local serial port only (a device server sets its own)",
    "--json": "print the findings as JSON",
    "--write DIR": "create the project DIR with the robot.yaml of what was found (commented); "
    "refuses a directory that exists and is not empty",
    "--capture FILE": "record the survey's traffic in FILE as a spy:// hex dump; harlsync probe "
    "--port 'replay://FILE?family=F' --family F --station N plays it back",
}


def _cmd_probe(args: argparse.Namespace) -> int:
    from ..sync.firstcontact import first_contact

    found = first_contact(
        args.port,
        family=args.family,
        stations=args.station or args.stations,
        baud=args.baud,
        write=args.write,
        lock_timeout=args.lock_timeout,
        capture=args.capture,
    )
    if args.json:
        _json(found.to_json())
    else:
        _lines(found.lines())
    return EXIT_OK
