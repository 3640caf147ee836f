"""``harlsync sim``: parse its options, start the simulator (:mod:`harlsync.sim.run`),
print where it serves and read its control commands."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..families import DEFAULT

if TYPE_CHECKING:
    from ..sim.run import Running


from .common import EXIT_OK, _family_names, _Help, _per_family, _print, _usage


def _sim_verbs() -> str:
    """The control commands of ``harlsync sim``, per family, for its help."""
    from ..families import names
    from ..sim import sim_family
    from ..sim.control import after_writes_verb

    lines = []
    for name in names():
        family = sim_family(name)
        verbs = [str(v) for v in family.verbs]
        verbs.append(f"{after_writes_verb(family.busy_verb)} N")
        lines.append(f"{name}: {', '.join(verbs)}, status")
    return "; ".join(lines)


def _sim_busy() -> str:
    """What each family's simulator does when it is made busy, for its help."""
    from ..families import names
    from ..sim import sim_family

    parts = []
    for name in names():
        family = sim_family(name)
        does = [v.does for v in family.verbs if v.name == family.busy_verb]
        parts.append(f"{name}: {does[0] if does else family.busy_verb}")
    return "; ".join(parts)


def _sim_variants() -> str:
    """Each family's simulator variants (the guesses it can make otherwise), for its help."""
    from ..families import names
    from ..sim import sim_family

    parts = []
    for name in names():
        declared = sim_family(name).variants
        parts.append(f"{name}: {', '.join(str(v) for v in declared) or 'none'}")
    return "; ".join(parts)


class _SimHelp(_Help):
    """Fills in :func:`_sim_verbs` when the help is shown: only then are the
    families' simulators imported."""

    VERBS = "<verbs>"
    BUSY = "<busy>"
    VARIANTS = "<variants>"

    def add_text(self, text: str | None) -> None:
        if text and self.VERBS in text:
            text = text.replace(self.VERBS, _sim_verbs())
        super().add_text(text)

    def _expand_help(self, action: argparse.Action) -> str:
        text = super()._expand_help(action)
        if self.BUSY in text:
            text = text.replace(self.BUSY, _sim_busy())
        if self.VARIANTS in text:
            text = text.replace(self.VARIANTS, _sim_variants())
        return text


def _add_sim(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:

    p = sub.add_parser(
        "sim",
        help="run a simulated controller of any family (on a pty and/or a TCP port, or "
        "over the family's own protocol)",
        description=(
            "Serve a simulated controller of one family. It prints the pty device path and the "
            "socket:// URL to connect to (a family with a server of its own: its URL, "
            "--listen only), then reads control commands on standard input "
            f"(STATION as the family writes it, default the lowest): {_SimHelp.VERBS}. "
            "Stop it with Ctrl-C, SIGTERM or end of input. In the background (&, a service) "
            "give --no-input: it then serves until SIGTERM; started with & from a terminal it "
            "reads no commands either."
        ),
        formatter_class=_SimHelp,
    )
    p.add_argument(
        "--family",
        default=None,
        choices=_family_names(),
        help=f"the controller family (default: {DEFAULT}, or with --project the one "
        "its robot.yaml names)",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--project", metavar="DIR", help="serve the robot of this project directory")
    src.add_argument(
        "--seed",
        type=int,
        default=0,
        help="generate a realistic robot (programs, positions) from SEED",
    )
    p.add_argument(
        "--stations",
        default=None,
        metavar="N[,N...]",
        help="stations on the line, in the family's notation ("
        + _per_family("stations")
        + "; default: the project's station, or the family's default)",
    )
    p.add_argument("--listen", metavar="HOST:PORT", help="also serve over TCP (socket://HOST:PORT)")
    p.add_argument("--no-pty", action="store_true", help="do not open a pty (needs --listen)")
    p.add_argument(
        "--no-input",
        action="store_true",
        help="read no commands: serve until SIGTERM or Ctrl-C, to run in the "
        "background or under a service manager (the mode then changes only "
        "through --auto and --auto-after-writes)",
    )
    p.add_argument(
        "--baud",
        type=int,
        default=9600,
        help="delay each reply by its time on the wire at this speed; 0 turns it off (default 9600)",
    )
    p.add_argument(
        "--turnaround",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="extra delay before each reply",
    )
    p.add_argument(
        "--faults",
        default="",
        metavar="NAME=RATE,...",
        help="fault injection: noise, drop, bad_checksum, fragment, slow (rates 0-1), "
        "slow_delay (seconds), seed",
    )
    p.add_argument(
        "--variant",
        default="",
        metavar="NAME=VALUE,...",
        help="answer as a controller that fills a silence of its manual another way than "
        "the profile's choice, the first value of each (docs/profile.md): "
        f"{_SimHelp.VARIANTS}",
    )
    p.add_argument(
        "--auto",
        "--run",
        dest="busy",
        action="store_true",
        help=f"start busy ({_SimHelp.BUSY})",
    )
    p.add_argument(
        "--auto-after-writes",
        "--run-after-writes",
        dest="busy_after_writes",
        type=int,
        default=0,
        metavar="N",
        help="become busy after N writes, once (see --auto); 'stop' disarms it",
    )
    p.add_argument(
        "--record",
        metavar="FILE",
        help="append every request received to FILE as JSON lines (station, "
        "payload, busy: whether the station was not idle, client: 'pty' or "
        "the TCP peer)",
    )
    p.add_argument(
        "--state",
        metavar="DIR",
        help="battery-backed memory: keep each station in DIR/station-N, "
        "saved after every write and loaded again when the simulator restarts",
    )
    p.set_defaults(func=_cmd_sim)


def _cmd_sim(args: argparse.Namespace) -> int:
    from ..sim.control import apply_command
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
    for line in running.said:
        _print(line)
    control = (lambda line: apply_command(running.sim, line)) if _reads_input(args) else None
    _serve(running, stopped, control)
    return EXIT_OK


def _reads_input(args: argparse.Namespace) -> bool:
    """Whether ``harlsync sim`` reads control commands on its standard input: not
    with --no-input, nor when started in the background of a terminal (``&``), where
    a read would stop it (SIGTTIN)."""
    if args.no_input:
        return False
    try:
        background = os.isatty(0) and os.tcgetpgrp(0) != os.getpgrp()
    except OSError:  # no controlling terminal: stdin is what it is
        background = False
    if background:
        print(
            "harlsync sim: started in the background: not reading commands; stop it with "
            "kill (SIGTERM)",
            file=sys.stderr,
            flush=True,
        )
    return not background


def _serve(running: Running, done: threading.Event, control: Callable[[str], str] | None) -> None:
    """Serve until ``done`` is set (SIGTERM), Ctrl-C, or the end of the input
    ``control`` takes its commands from (every line, its answer printed); without
    ``control``, until one of the first two."""

    def read_commands(run: Callable[[str], str]) -> None:
        for line in sys.stdin:
            try:
                answer = run(line)
            except (ValueError, IndexError) as exc:
                answer = f"error: {exc}"
            if answer:
                _print(answer)
        print(
            "harlsync sim: end of input: stopping (--no-input serves until SIGTERM)",
            file=sys.stderr,
            flush=True,
        )
        done.set()

    if control is not None:
        threading.Thread(target=read_commands, args=(control,), daemon=True).start()
    try:
        done.wait()
    except KeyboardInterrupt:
        pass
    running.stop()
