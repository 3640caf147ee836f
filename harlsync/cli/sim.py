"""``harlsync sim``: parse its options, start the simulator (:mod:`harlsync.sim.run`),
print where it serves and serve it, reading its control commands."""

from __future__ import annotations

import argparse
import signal
import sys
import threading

from .. import families
from ..families import DEFAULT
from ..terminal import in_background
from .common import (
    EXIT_OK,
    Sub,
    _add,
    _command,
    _family_arg,
    _Help,
    _lines,
    _phrases,
    _print,
    _usage,
)


class _SimHelp(_Help):
    """Fills in each family's simulator's words (:mod:`harlsync.sim.helptext`) when
    the help is shown: only then are the families' simulators imported."""

    VERBS = "<verbs>"
    BUSY = "<busy>"
    VARIANTS = "<variants>"

    def add_text(self, text: str | None) -> None:
        if text and self.VERBS in text:
            from ..sim.helptext import verbs_words

            text = text.replace(self.VERBS, verbs_words())
        super().add_text(text)

    def _expand_help(self, action: argparse.Action) -> str:
        from ..sim.helptext import busy_words, variants_words

        text = super()._expand_help(action)
        for mark, words in ((self.BUSY, busy_words), (self.VARIANTS, variants_words)):
            if mark in text:
                text = text.replace(mark, words())
        return text


def _add_sim(sub: Sub) -> None:
    p = _command(
        sub,
        "sim",
        _cmd_sim,
        help="run a simulated controller of any family (on a pty and/or a TCP port, or over the "
        "family's own protocol)",
        description="Serve a simulated controller of one family. It prints the pty device path "
        "and the socket:// URL to connect to (a family with a server of its own: its URL, "
        "--listen only), then reads control commands on standard input (STATION as the family "
        f"writes it, default the lowest): {_SimHelp.VERBS}. Stop it with Ctrl-C, SIGTERM or end "
        "of input. In the background (&, a service) give --no-input: it then serves until "
        "SIGTERM; started with & from a terminal it reads no commands either.",
        formatter_class=_SimHelp,
    )
    _family_arg(
        p,
        f"the controller family (default: {DEFAULT}, or with --project the one its robot.yaml "
        "names)",
    )
    src = p.add_mutually_exclusive_group()
    _add(src, _SIM, "--project DIR")
    seed = _SIM["--seed"].format(_phrases("items", " ({})"))
    src.add_argument("--seed", type=int, default=0, help=seed)
    stations = families.help_phrases("stations")
    _add(p, {"--stations N[,N...]": _SIM["--stations N[,N...]"].format(stations)})
    _add(p, _SIM, "--listen HOST:PORT", "--no-pty", "--no-input")
    p.add_argument("--baud", type=int, default=9600, help=_SIM["--baud"])
    seconds = "--turnaround SECONDS"
    p.add_argument("--turnaround", type=float, default=0.0, metavar="SECONDS", help=_SIM[seconds])
    for spec in ("--faults NAME=RATE,...", "--variant NAME=VALUE,..."):
        flag, metavar = spec.split(" ")
        p.add_argument(flag, default="", metavar=metavar, help=_SIM[spec])
    p.add_argument("--auto", "--run", dest="busy", action="store_true", help=_SIM["--auto"])
    p.add_argument(
        "--auto-after-writes",
        "--run-after-writes",
        dest="busy_after_writes",
        type=int,
        default=0,
        metavar="N",
        help=_SIM["--auto-after-writes N"],
    )
    _add(p, _SIM, "--record FILE", "--state DIR")


#: sim's options after --family: "--flag [METAVAR]" -> help (see :func:`_add`).
_SIM = {
    "--project DIR": "serve the robot of this project directory",
    "--seed": "generate a realistic robot{} from SEED",
    "--stations N[,N...]": "stations on the line, in the family's notation ({}; default: the "
    "project's station, or the family's default)",
    "--listen HOST:PORT": "also serve over TCP (socket://HOST:PORT)",
    "--no-pty": "do not open a pty (needs --listen)",
    "--no-input": "read no commands: serve until SIGTERM or Ctrl-C, to run in the background or "
    "under a service manager (the mode then changes only through --auto and --auto-after-writes)",
    "--baud": "delay each reply by its time on the wire at this speed; 0 turns it off (default "
    "9600)",
    "--turnaround SECONDS": "extra delay before each reply",
    "--faults NAME=RATE,...": "fault injection: noise, drop, bad_checksum, fragment, slow (rates "
    "0-1), slow_delay (seconds), seed",
    "--variant NAME=VALUE,...": "answer as a controller that fills a silence of its manual "
    "another way than the profile's choice, the first value of each (docs/profile.md): "
    + _SimHelp.VARIANTS,
    "--auto": f"start busy ({_SimHelp.BUSY})",
    "--auto-after-writes N": "become busy after N writes, once (see --auto); 'stop' disarms it",
    "--record FILE": "append every request received to FILE as JSON lines (station, payload, "
    "busy: whether the station was not idle, client: 'pty' or the TCP peer)",
    "--state DIR": "battery-backed memory: keep each station in DIR/station-N, saved after "
    "every write and loaded again when the simulator restarts",
}


def _cmd_sim(args: argparse.Namespace) -> int:
    from ..sim.run import SimOptions, start

    opts = SimOptions(
        family=args.family,
        project=args.project,
        seed=args.seed,
        stations=args.stations,
        listen=args.listen,
        pty=not args.no_pty,
        baud=args.baud,
        turnaround=args.turnaround,
        faults=args.faults,
        variant=args.variant,
        busy=args.busy,
        busy_after_writes=args.busy_after_writes,
        record=args.record,
        state=args.state,
    )
    stopped = threading.Event()  # from here on SIGTERM stops it cleanly, exit 0
    signal.signal(signal.SIGTERM, lambda *_: stopped.set())
    try:
        running = start(opts)
    except ValueError as exc:
        return _usage(f"sim: {exc}")
    _lines(running.said)
    running.serve(stopped, sys.stdin if _reads_input(args) else None, _print, _end_of_input)
    return EXIT_OK


def _end_of_input() -> None:
    _say("end of input: stopping (--no-input serves until SIGTERM)")


def _say(text: str) -> None:
    print(f"harlsync sim: {text}", file=sys.stderr, flush=True)


def _reads_input(args: argparse.Namespace) -> bool:
    """Whether ``harlsync sim`` reads control commands on its standard input: not with
    --no-input, nor when started in the background of a terminal."""
    if args.no_input:
        return False
    if in_background():
        _say("started in the background: not reading commands; stop it with kill (SIGTERM)")
        return False
    return True
