"""A bench robot (or several, one per line) served over ptys or TCP, in its own process.

    python bench/simserver.py ROBOT [--baud N] [--lines K] [--tcp] [--tick S]

Prints one JSON line ``{"ports": [...]}``, then answers commands on stdin with one
JSON line each: ``stats`` (per line: exchanges, bytes each way, requests by command
letters), ``reset``.  Exits at end of input.  bench/machine.py's SimProcess runs it.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter

from machine import ROBOTS

from harlsync.families.harl_u2.sim import Simulator
from harlsync.sim import Received, serve
from harlsync.sim.serve import PtyServer, TcpServer


class CountingSimulator(Simulator):
    """Keeps counts, not the request log (a full pull is 12,663 requests)."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.letters: Counter[str] = Counter()
        self.listeners.append(self._count)

    def _count(self, record: Received) -> None:
        self.letters[record.command] += 1
        self.received.clear()

    def stats(self) -> dict[str, object]:
        with self.lock:
            return {
                "exchanges": sum(self.letters.values()),
                "bytes_in": self.bytes_in,
                "bytes_out": self.bytes_out,
                "letters": dict(self.letters),
            }

    def reset(self) -> None:
        with self.lock:
            self.letters.clear()
            self.bytes_in = self.bytes_out = 0


def late(server: PtyServer | TcpServer) -> dict[str, float]:
    """How late the pty's paced writes were, in seconds (nothing for TCP)."""
    replies = server.replies if isinstance(server, PtyServer) else None
    if replies is None or not replies.writes:
        return {}
    return {"late_mean": replies.late_total / replies.writes, "late_worst": replies.late_worst}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("robot", choices=sorted(ROBOTS))
    parser.add_argument("--baud", type=int, default=0, help="wire-time emulation (0: none)")
    parser.add_argument("--lines", type=int, default=1)
    parser.add_argument("--tcp", action="store_true", help="TCP ports instead of ptys")
    parser.add_argument("--tick", type=float, default=0.0, help="pacing tick, seconds")
    args = parser.parse_args()
    if args.tick:
        serve.TICK = args.tick
    sims = [CountingSimulator(ROBOTS[args.robot](), baudrate=args.baud or None)
            for _ in range(args.lines)]
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
