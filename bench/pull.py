"""How long a full backup (harlsync.sync.engine.pull) takes, and what it would take at 9600 baud.

    python bench/pull.py             quick (~25 s): each robot once over sim:// and TCP
    python bench/pull.py --full      best of 3, and a pull with 9600-baud wire-time
                                     emulation to check the projection (~75 s)

Three robots: generated with the simulator's DEFAULT_CONFIG, generated with the
largest default configuration of the manual (START 1x256, MAIN/SUB/HAND 16x256
steps: every step is one exchange), and that configuration with every step used.
Each pull runs in a fresh interpreter, so its peak RSS is its own; a second pull
under tracemalloc (over sim:// only) gives the peak of Python allocations.

The projection counts the bytes that actually crossed the line (requests and
replies) and puts them on a 9600 8N1 line, 10 bits per byte: bytes * 10 / 9600
seconds.  It leaves out the controller's own turnaround, which the manual does
not give: each millisecond of it adds (exchanges) milliseconds.  See bench/README.md.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

from machine import BITS_PER_BYTE, ROBOTS, describe, minutes, peak_rss_mib, run_child

from harlsync.families.harl_u2.protocol import FrameDecoder
from harlsync.families.harl_u2.sim import Simulator
from harlsync.sim.protocol_sim import register
from harlsync.sim.serve import TcpServer
from harlsync.sync.engine import pull

#: This script's robots (bench/machine.py has them all).
PULL_ROBOTS = ("default", "maximum", "max-full")
BAUD = 9600


class MeteredSimulator(Simulator):
    """The simulator, counting exchanges (it counts bytes each way itself).

    It keeps no request record (``received``), so that what is measured is the
    client's memory, not the simulator's log of 12,000 requests.
    """

    exchanges = 0

    def receive(
        self, data: bytes, decoder: FrameDecoder | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        chunks = super().receive(data, decoder, client)
        self.exchanges += len(self.received)
        self.received.clear()
        return chunks


def run_case(robot: str, transport: str, repeat: int, trace: bool) -> dict[str, Any]:
    """One robot over one transport, in this process: the figures as a dict."""
    state = ROBOTS[robot]()
    baud = BAUD if transport == "sim-9600" else None
    sim = MeteredSimulator(state, baudrate=baud)
    server = TcpServer(sim) if transport == "tcp" else None
    url = server.start() if server else register(sim)
    rss_before = peak_rss_mib()
    times, read_times = [], []
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["HARLSYNC_LOCK_DIR"] = str(Path(tmp) / "locks")

        def once(n: int) -> float:
            """Pull into a new directory; return when the last item was read."""
            read_done = 0.0

            def progress(done: int, total: int) -> None:
                nonlocal read_done
                read_done = time.perf_counter()

            pull(Path(tmp) / f"robot-{n}", port=url, progress=progress)
            return read_done

        for n in range(repeat):
            sim.exchanges = sim.bytes_in = sim.bytes_out = 0
            start = time.perf_counter()
            read_done = once(n)
            times.append(time.perf_counter() - start)
            read_times.append(read_done - start)
        exchanges, nbytes = sim.exchanges, sim.bytes_in + sim.bytes_out
        rss_after = peak_rss_mib()
        traced = None
        if trace:
            tracemalloc.start()
            once(repeat)
            traced = tracemalloc.get_traced_memory()[1] / 2**20
            tracemalloc.stop()
    if server:
        server.stop()
    return {
        "robot": robot,
        "transport": transport,
        "steps": state.data.config.step_count,
        "steps_used": sum(len(program) for program in state.data.programs.values()),
        "exchanges": exchanges,
        "bytes": nbytes,
        "seconds": min(times),
        "read_seconds": min(read_times),
        "rss_before": rss_before,
        "rss_peak": rss_after,
        "traced_peak": traced,
    }


def in_child(robot: str, transport: str, repeat: int, trace: bool) -> dict[str, Any]:
    """:func:`run_case` in a fresh interpreter, so that its peak RSS is its own."""
    command = [sys.executable, __file__, "--case", robot, transport, "--repeat", str(repeat)]
    if not trace:
        command.append("--no-trace")
    return run_child(command, f"{robot} over {transport}")


def show(rows: list[dict[str, Any]]) -> None:
    print(
        f"{'robot':8} {'over':9} {'exchanges':>9} {'B/exch':>6} {'pull s':>7} {'(read s)':>8} "
        f"{'exch/s':>7} {'at 9600':>9} {'RSS MiB':>7} {'(pull +)':>8} {'traced MiB':>10}"
    )
    for r in rows:
        wire = r["bytes"] * BITS_PER_BYTE / BAUD
        traced = "-" if r["traced_peak"] is None else f"{r['traced_peak']:.1f}"
        print(
            f"{r['robot']:8} {r['transport']:9} {r['exchanges']:>9,} "
            f"{r['bytes'] / r['exchanges']:>6.1f} {r['seconds']:>7.2f} ({r['read_seconds']:>6.2f}) "
            f"{r['exchanges'] / r['read_seconds']:>7,.0f} {minutes(wire):>9} "
            f"{r['rss_peak']:>7.1f} (+{r['rss_peak'] - r['rss_before']:>5.1f}) {traced:>10}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="each case once (the default)")
    mode.add_argument("--full", action="store_true", help="best of 3, plus the 9600 check")
    parser.add_argument("--repeat", type=int, help="pulls per case (best is shown)")
    parser.add_argument("--no-trace", action="store_true", help="skip the tracemalloc pull")
    parser.add_argument("--case", nargs=2, metavar=("ROBOT", "TRANSPORT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    repeat = args.repeat or (3 if args.full else 1)
    trace = not args.no_trace

    if args.case:
        robot, transport = args.case
        print(json.dumps(run_case(robot, transport, repeat, trace)))
        return

    print(f"harlsync pull bench: {describe()}")
    print(f"{'full' if args.full else 'quick'} run, best of {repeat}\n")
    # What a pull allocates does not depend on the transport: trace it over sim:// only.
    rows = [
        in_child(robot, transport, repeat, trace and transport == "sim")
        for robot in PULL_ROBOTS
        for transport in ("sim", "tcp")
    ]
    show(rows)
    print(f"\nA full backup at {BAUD} baud (wire time; each ms of controller turnaround adds")
    print("one ms per exchange, shown for 10 ms):")
    for r in rows:
        if r["transport"] != "sim":
            continue
        wire = r["bytes"] * BITS_PER_BYTE / BAUD
        print(
            f"  {r['robot']:8} {r['steps_used']:>6,} of {r['steps']:>6,} steps used: "
            f"{r['exchanges']:>6,} exchanges, {r['bytes']:>7,} bytes = {minutes(wire):>8}, "
            f"{minutes(wire + r['exchanges'] * 0.010):>8} at 10 ms"
        )
    if args.full:
        check = in_child("default", "sim-9600", 1, False)
        projected = check["bytes"] * BITS_PER_BYTE / BAUD
        print(
            f"Check: the default robot over sim:// emulating {BAUD} baud read in "
            f"{check['read_seconds']:.1f} s; projected {projected:.1f} s "
            f"({check['read_seconds'] / projected - 1:+.0%})."
        )


if __name__ == "__main__":
    main()
