"""A bench robot (or several, one per line) served over ptys or TCP, in its own process.

    python bench/simserver.py ROBOT [--baud N] [--lines K] [--tcp] [--tick S] [--loop]

ROBOT is a HARL-U2 robot of ``machine.ROBOTS`` or an IAI one of ``machine.IAI_ROBOTS``.
Prints one JSON line ``{"ports": [...]}``, then answers commands on stdin with one
JSON line each: ``stats`` (per line: exchanges, bytes each way, requests by command,
when the first request byte came and the last reply byte was due, the gaps from a
reply's last byte to the next request's first, and the CPU this process used so far),
``reset``, ``record`` (from now on keep every byte each way; ``reset`` drops what was
kept; ``unrecord`` stops keeping) and ``wire`` (per line: what was kept, hex, ``in`` and ``out``: bench/floor.py
replays it).  Exits at end of input.  bench/machine.py's
SimProcess runs it.

Each line is served by the framework's PtyServer or TcpServer (two threads a line),
or with ``--loop`` every pty by one thread and one event loop (:class:`LoopServer`):
what a fleet of 128 lines needs on a 2-core machine.
"""

from __future__ import annotations

import argparse
import heapq
import json
import math
import os
import resource
import select
import sys
import threading
import time
import tty
from collections import Counter
from typing import Any

from machine import IAI_ROBOTS, ROBOTS

from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.sim import Received, serve
from harlsync.sim.device import Decoder
from harlsync.sim.serve import PtyServer, TcpServer
from harlsync.timers import precise_timers


class Counting:
    """Mixed into a family's simulator: keeps counts, not the request log (a full
    HARL-U2 pull is 12,663 requests), and when the line was first and last busy.

    ``first_in`` is when the first request bytes were read (``time.monotonic``, the
    same clock in every process of the machine); ``last_due`` when the last reply
    byte is due on the emulated line (the server writes it then, late by what
    :func:`late` reports).  ``gaps`` adds up, for every request after the first,
    the time from the last reply byte due before it to its first bytes read: the
    client's time between a reply and its next request, plus this process's wake-up
    to read it (the same for every client).  With ``recording`` every byte read and
    every reply byte is kept, in order (``wire_in``, ``wire_out``).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.letters: Counter[str] = Counter()
        self.first_in: float | None = None
        self.last_due = 0.0
        self.gaps = 0.0
        self._replied = False  # a reply is queued and no request has come since
        self.recording = False
        self.wire_in = bytearray()
        self.wire_out = bytearray()
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
            if self._replied and data:
                self.gaps += max(0.0, now - self.last_due)
                self._replied = False
            if chunks:
                self.last_due = max(self.last_due, now + max(delay for delay, _ in chunks))
                self._replied = True
            if self.recording:
                self.wire_in += data
                for _, reply in chunks:
                    self.wire_out += reply
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
                "gaps": self.gaps,
            }

    def wire(self) -> dict[str, str]:
        with self.lock:  # type: ignore[attr-defined]
            return {"in": self.wire_in.hex(), "out": self.wire_out.hex()}

    def reset(self) -> None:
        with self.lock:  # type: ignore[attr-defined]
            self.letters.clear()
            self.bytes_in = self.bytes_out = 0
            self.first_in = None
            self.last_due = 0.0
            self.gaps = 0.0
            self._replied = False
            self.wire_in.clear()
            self.wire_out.clear()


class CountingSimulator(Counting, HarlSimulator):
    """A HARL-U2 robot, counted."""


class CountingIaiSimulator(Counting, IaiSimulator):
    """An IAI controller (station 99h), counted."""


def simulator(robot: str, baud: int) -> CountingSimulator | CountingIaiSimulator:
    if robot in IAI_ROBOTS:
        return CountingIaiSimulator(IAI_ROBOTS[robot](), baudrate=baud or None)
    return CountingSimulator(ROBOTS[robot](), baudrate=baud or None)


#: The --loop simulator's nice value, when the machine allows it: on a machine as
#: busy as a fleet makes it, the line's bytes are due whatever else runs.
LOOP_NICE = -10


class LoopServer:
    """Every simulated line on its own pty, all served by one thread: an epoll loop
    that reads requests as they come and writes each reply's bytes when due.

    The due times are :class:`~harlsync.sim.serve.ReplyScheduler`'s: a chunk's last
    byte at its delay after the request was read (the line's time for request and
    reply), the bytes before it paced at the character rate and grouped per ``tick``,
    a line's chunks one after the other.  The loop sleeps in epoll until the next
    write is due or a request comes (epoll counts milliseconds: the last two are
    waited in ``select``, with the timer slack lowered, not spun), so the one thread
    costs CPU for the bytes it moves, not for the time it waits.
    """

    def __init__(self, sims: list[Any], tick: float) -> None:
        self.sims = sims
        self.tick = tick
        self.devices: list[str] = []
        self._masters: list[int] = []
        self._slaves: list[int] = []
        self._free = [0.0] * len(sims)  # when each line's last queued byte has crossed it
        self._due: list[tuple[float, int, int, bytes]] = []  # (due, seq, line, bytes), a heap
        self._seq = 0
        self.writes = 0
        self.late_total = 0.0
        self.late_worst = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sim-loop", daemon=True)

    def start(self) -> list[str]:
        for _ in self.sims:
            master, slave = os.openpty()
            tty.setraw(slave)
            os.set_blocking(master, False)
            self._masters.append(master)
            self._slaves.append(slave)
            self.devices.append(os.ttyname(slave))
        self._thread.start()
        return self.devices

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        for fd in self._masters + self._slaves:
            os.close(fd)

    def late(self, line: int) -> dict[str, float]:
        if not self.writes:
            return {}
        return {"late_mean": self.late_total / self.writes, "late_worst": self.late_worst}

    def _queue(self, line: int, chunks: list[tuple[float, bytes]], since: float) -> None:
        step = self.sims[line].char_time
        per_write = max(1, int(self.tick / step)) if step else 1
        for delay, data in chunks:
            end = max(since + delay, self._free[line] + len(data) * step)
            self._free[line] = end
            n = len(data)
            for stop in range(n % per_write or per_write, n + 1, per_write):
                self._seq += 1
                heapq.heappush(
                    self._due,
                    (
                        end - (n - stop) * step,
                        self._seq,
                        line,
                        data[max(0, stop - per_write) : stop],
                    ),
                )

    def _run(self) -> None:
        precise_timers()
        poller = select.epoll()
        lines = {fd: n for n, fd in enumerate(self._masters)}
        for fd in self._masters:
            poller.register(fd, select.EPOLLIN)
        due = self._due
        while not self._stop.is_set():
            now = time.monotonic()
            while due and due[0][0] <= now:
                when, _, line, data = heapq.heappop(due)
                try:
                    os.write(self._masters[line], data)
                except OSError:
                    pass  # the client closed its side: nobody to answer
                self.writes += 1
                late = now - when
                self.late_total += late
                self.late_worst = max(self.late_worst, late)
                now = time.monotonic()
            wait = due[0][0] - now if due else 0.05
            if due and wait < 0.002:
                # epoll counts whole milliseconds; select waits for less, and still reads
                # the requests that come meanwhile (with many lines a write is due every
                # few microseconds: sleeping them out left requests unread until the
                # replies on every line were done).
                ready = select.select(self._masters, [], [], max(0.0, wait))[0]
            else:  # epoll rounds its timeout up to a millisecond: ask for the whole ones only
                ready = [
                    fd
                    for fd, _ in poller.poll(
                        math.floor((wait - 0.001) * 1000) / 1000 if due else 0.05
                    )
                ]
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                line = lines[fd]
                received = time.monotonic()
                self._queue(line, self.sims[line].receive(data, client="pty"), received)


def late(server: PtyServer | TcpServer | LoopServer, line: int = 0) -> dict[str, float]:
    """How late the pty's paced writes were, in seconds (nothing for TCP)."""
    if isinstance(server, LoopServer):
        return server.late(line)
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
    parser.add_argument(
        "--loop", action="store_true", help="serve every pty from one thread and one event loop"
    )
    args = parser.parse_args()
    if args.tick:
        serve.TICK = args.tick
    sims = [simulator(args.robot, args.baud) for _ in range(args.lines)]
    if args.loop:
        try:  # the emulated lines keep time before the client under test is served
            os.setpriority(os.PRIO_PROCESS, 0, LOOP_NICE)
        except PermissionError:
            pass  # not allowed here: the lateness printed says what it cost
        loop = LoopServer(sims, args.tick or serve.TICK)
        servers: list[Any] = [loop] * len(sims)
        ports = loop.start()
    else:
        servers = [TcpServer(sim) if args.tcp else PtyServer(sim) for sim in sims]
        ports = [server.start() for server in servers]
    print(json.dumps({"ports": ports}), flush=True)
    for command in sys.stdin:
        command = command.strip()
        if command == "stats":
            usage = resource.getrusage(resource.RUSAGE_SELF)
            cpu = {"cpu": usage.ru_utime + usage.ru_stime}
            stats = [
                sim.stats() | late(server, n) | cpu
                for n, (sim, server) in enumerate(zip(sims, servers))
            ]
            print(json.dumps(stats), flush=True)
        elif command == "reset":
            for sim in sims:
                sim.reset()
            print("{}", flush=True)
        elif command in ("record", "unrecord"):
            for sim in sims:
                sim.recording = command == "record"
            print("{}", flush=True)
        elif command == "wire":
            print(json.dumps([sim.wire() for sim in sims]), flush=True)
    for server in dict.fromkeys(servers):
        server.stop()


if __name__ == "__main__":
    main()
