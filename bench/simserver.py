"""A bench robot (or several, one per line) served over ptys or TCP, in its own process.

    python bench/simserver.py ROBOT [--baud N] [--lines K] [--tcp] [--tick S]

ROBOT is a HARL-U2 robot of ``machine.ROBOTS`` or an IAI one of ``machine.IAI_ROBOTS``.
Prints one JSON line ``{"ports": [...]}``, then answers commands on stdin with one
JSON line each: ``stats`` (per line: exchanges, bytes each way, requests by command,
when the first request byte came and the last reply byte was due), ``reset``.
Exits at end of input.  bench/machine.py's SimProcess runs it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from typing import Any

from machine import IAI_ROBOTS, ROBOTS

from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.sim import Received, serve
from harlsync.sim.device import Decoder
from harlsync.sim.serve import PtyServer, TcpServer


class Counting:
    """Mixed into a family's simulator: keeps counts, not the request log (a full
    HARL-U2 pull is 12,663 requests), and when the line was first and last busy.

    ``first_in`` is when the first request bytes were read (``time.monotonic``, the
    same clock in every process of the machine); ``last_due`` when the last reply
    byte is due on the emulated line (the server writes it then, late by what
    :func:`late` reports).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.letters: Counter[str] = Counter()
        self.first_in: float | None = None
        self.last_due = 0.0
        self.listeners.append(self._count)  # type: ignore[attr-defined]

    def receive(
        self, data: bytes, decoder: Decoder[Any] | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        now = time.monotonic()
        chunks: list[tuple[float, bytes]] = super().receive(  # type: ignore[misc]
            data, decoder, client
        )
        with self.lock:  # type: ignore[attr-defined]
            if self.first_in is None:
                self.first_in = now
            if chunks:
                self.last_due = max(self.last_due, now + max(delay for delay, _ in chunks))
        return chunks

    def _count(self, record: Received) -> None:
        self.letters[record.command] += 1
        self.received.clear()  # type: ignore[attr-defined]

    def stats(self) -> dict[str, object]:
        with self.lock:  # type: ignore[attr-defined]
            return {
                "exchanges": sum(self.letters.values()),
                "bytes_in": self.bytes_in,
                "bytes_out": self.bytes_out,
                "letters": dict(self.letters),
                "first_in": self.first_in,
                "last_due": self.last_due,
            }

    def reset(self) -> None:
        with self.lock:  # type: ignore[attr-defined]
            self.letters.clear()
            self.bytes_in = self.bytes_out = 0
            self.first_in = None
            self.last_due = 0.0


class CountingSimulator(Counting, HarlSimulator):
    """A HARL-U2 robot, counted."""


class CountingIaiSimulator(Counting, IaiSimulator):
    """An IAI controller (station 99h), counted."""


def simulator(robot: str, baud: int) -> CountingSimulator | CountingIaiSimulator:
    if robot in IAI_ROBOTS:
        return CountingIaiSimulator(IAI_ROBOTS[robot](), baudrate=baud or None)
    return CountingSimulator(ROBOTS[robot](), baudrate=baud or None)


def late(server: PtyServer | TcpServer) -> dict[str, float]:
    """How late the pty's paced writes were, in seconds (nothing for TCP)."""
    replies = server.replies if isinstance(server, PtyServer) else None
    if replies is None or not replies.writes:
        return {}
    return {"late_mean": replies.late_total / replies.writes, "late_worst": replies.late_worst}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("robot", choices=sorted(ROBOTS | IAI_ROBOTS))
    parser.add_argument("--baud", type=int, default=0, help="wire-time emulation (0: none)")
    parser.add_argument("--lines", type=int, default=1)
    parser.add_argument("--tcp", action="store_true", help="TCP ports instead of ptys")
    parser.add_argument("--tick", type=float, default=0.0, help="pacing tick, seconds")
    args = parser.parse_args()
    if args.tick:
        serve.TICK = args.tick
    sims = [simulator(args.robot, args.baud) for _ in range(args.lines)]
    servers = [TcpServer(sim) if args.tcp else PtyServer(sim) for sim in sims]
    print(json.dumps({"ports": [server.start() for server in servers]}), flush=True)
    for command in sys.stdin:
        command = command.strip()
        if command == "stats":
            stats = [sim.stats() | late(server) for sim, server in zip(sims, servers)]
            print(json.dumps(stats), flush=True)
        elif command == "reset":
            for sim in sims:
                sim.reset()
            print("{}", flush=True)
    for server in servers:
        server.stop()


if __name__ == "__main__":
    main()
