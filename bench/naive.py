"""Side by side: harlsync, an earlier harlsync, and the backup script a user would
write without it, in one run against the same simulated line.

    python bench/naive.py                    default-full robot (1,079 exchanges) at 9600
                                             and 115200 baud: ~3 min
    python bench/naive.py --quick            small-full robot (263 exchanges): ~45 s
    python bench/naive.py --previous /tmp/harlsync-73ddbb9     adds an earlier release
                                             (a git worktree: git worktree add --detach
                                             /tmp/harlsync-73ddbb9 73ddbb9)
    python bench/naive.py --robot max-full --baud 9600     (~30 min)

The naive script (``naive_backup`` below, ~20 lines of pyserial) writes each
request, sleeps a fixed time, then reads whatever arrived.  Its sleep is what a
careful user picks: the longest exchange's time on the wire at that baud (a
15-byte request and a 64-byte reply), plus 20 ms for the controller to answer.

harlsync runs as a user runs it: ``harlsync pull DIR --port PTY`` into an empty
directory, a process of its own (start-up, the read and the save all counted), and
so does the earlier release with ``--previous`` (its tree first on PYTHONPATH).  The
naive script runs in the bench's own process, its start-up not counted.  All run
against the same simulator process (pty, wire-time emulation), one after the
other, reading the same items; ``ok`` counts the replies that arrived whole.
Ratios: each way's time over harlsync's.
"""

from __future__ import annotations

import argparse
import functools
import operator
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import serial
from machine import (
    BITS_PER_BYTE,
    ROBOTS,
    SimProcess,
    describe,
    harlsync_command,
    minutes,
    process_env,
    timed_process,
)


def naive_backup(device: str, baud: int, pause: float) -> tuple[int, int]:
    """Read every item the way a quick script does; (replies, whole replies)."""
    port = serial.Serial(device, baud, timeout=0)

    def ask(payload: str) -> bytes:
        body = f"1 {payload}".encode() + b"\x03"
        port.write(b"\x02" + body + bytes([functools.reduce(operator.xor, body, 0)]))
        time.sleep(pause)
        return port.read(port.in_waiting)

    replies = [ask("LNX")]
    n = [int(v) for v in replies[0][3:-2].split()]
    replies += [ask("LNV"), ask("LNE")]
    for letter, (count, steps) in zip("AMSH", zip(n[0:8:2], n[1:8:2])):
        for program in range(count):
            for step in range(steps):
                replies.append(
                    ask(f"LN{letter} {step}" if letter == "A" else f"LN{letter} {program} {step}")
                )
    replies += [ask(f"LNL {t}") for t in range(100)]
    replies += [ask(f"LNT {t}") for t in range(n[8])]
    port.close()
    return len(replies), sum(r.startswith(b"\x02") and r[-2:-1] == b"\x03" for r in replies)


def pull_process(sim: SimProcess, baud: int, into: Path, tree: str | None) -> dict[str, Any]:
    """``harlsync pull into --port PTY`` as a process; ``tree``: an earlier harlsync's."""
    env = process_env(into.parent / "locks")
    command = [*harlsync_command(), "pull", str(into), "--port", sim.ports[0]]
    if tree is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [tree, env.get("PYTHONPATH")]))
        command = [sys.executable, "-m", "harlsync", *command[len(harlsync_command()) :]]
    return timed_process(sim, baud, command, env)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the small-full robot")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="default: default-full")
    parser.add_argument(
        "--baud", default="9600,115200", help="comma-separated (default: %(default)s)"
    )
    parser.add_argument(
        "--margin",
        type=float,
        default=0.020,
        help="seconds the naive script adds to the longest exchange (default 0.020)",
    )
    parser.add_argument(
        "--previous",
        metavar="TREE",
        help="a checkout of an earlier harlsync to run beside this one",
    )
    args = parser.parse_args()
    robot = args.robot or ("small-full" if args.quick else "default-full")

    print(f"harlsync side by side: {describe()}")
    print(
        f"robot {robot}; naive sleep = (15 + 64) bytes on the wire + {args.margin * 1e3:.0f} ms"
        + (f"; previous: {args.previous}" if args.previous else "")
        + "\n"
    )
    print(
        f"{'baud':>6} {'way':9} {'exchanges':>9} {'ok':>6} {'line limit':>10} {'time':>9} "
        f"{'/limit':>7} {'ms/exch':>8} {'/ harlsync':>10}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for baud in (int(b) for b in args.baud.split(",")):
            pause = (15 + 64) * BITS_PER_BYTE / baud + args.margin
            rows: list[tuple[str, int, float, int, int]] = []  # way, bytes, s, exchanges, ok
            with SimProcess(robot, baud=baud) as sim:
                ways = [("harlsync", None)] + (
                    [("previous", args.previous)] if args.previous else []
                )
                for way, tree in ways:
                    run = pull_process(sim, baud, Path(tmp) / f"{way}-{baud}", tree)
                    rows.append(
                        (way, run["bytes"], run["whole"], run["exchanges"], run["exchanges"])
                    )
                sim.reset()
                start = time.perf_counter()
                _, whole = naive_backup(sim.ports[0], baud, pause)
                naive_time = time.perf_counter() - start
                counted = sim.stats()[0]
                rows.append(
                    (
                        "naive",
                        counted["bytes_in"] + counted["bytes_out"],
                        naive_time,
                        counted["exchanges"],
                        whole,
                    )
                )
            ours = rows[0][2]
            for way, nbytes, seconds, exchanges, ok in rows:
                limit = nbytes * BITS_PER_BYTE / baud
                print(
                    f"{baud:>6} {way:9} {exchanges:>9,} {ok:>6,} {minutes(limit):>10} "
                    f"{minutes(seconds):>9} {seconds / limit:>7.2f} "
                    f"{seconds / exchanges * 1e3:>8.2f} {seconds / ours:>10.2f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
