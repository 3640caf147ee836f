"""Against the naive way: the backup script a user would write without harlsync.

    python bench/naive.py                    default-full robot (1,079 exchanges) at 9600
                                             and 115200 baud: ~3 min
    python bench/naive.py --quick            small-full robot (263 exchanges): ~45 s
    python bench/naive.py --robot max-full --baud 9600     (~30 min)

The naive script (``naive_backup`` below, ~20 lines of pyserial) writes each
request, sleeps a fixed time, then reads whatever arrived.  Its sleep is what a
careful user picks: the longest exchange's time on the wire at that baud (a
15-byte request and a 64-byte reply), plus 20 ms for the controller to answer.
Both run against the same simulator process (pty, wire-time emulation), one after
the other, reading the same items; ``ok`` counts the replies that arrived whole.
"""

from __future__ import annotations

import argparse
import functools
import operator
import tempfile
import time
from pathlib import Path

import serial
from machine import BITS_PER_BYTE, ROBOTS, SimProcess, describe, minutes, timed_pull


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
                replies.append(ask(f"LN{letter} {step}" if letter == "A" else
                                   f"LN{letter} {program} {step}"))
    replies += [ask(f"LNL {t}") for t in range(100)]
    replies += [ask(f"LNT {t}") for t in range(n[8])]
    port.close()
    return len(replies), sum(r.startswith(b"\x02") and r[-2:-1] == b"\x03" for r in replies)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the small-full robot")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="default: default-full")
    parser.add_argument("--baud", default="9600,115200", help="comma-separated (default: %(default)s)")
    parser.add_argument("--margin", type=float, default=0.020,
                        help="seconds the naive script adds to the longest exchange (default 0.020)")
    args = parser.parse_args()
    robot = args.robot or ("small-full" if args.quick else "default-full")

    print(f"harlsync against the naive way: {describe()}")
    print(f"robot {robot}; naive sleep = (15 + 64) bytes on the wire + {args.margin * 1e3:.0f} ms\n")
    print(f"{'baud':>6} {'way':9} {'exchanges':>9} {'ok':>6} {'line limit':>10} {'time':>9} "
          f"{'/limit':>7} {'ms/exch':>8} {'naive/harlsync':>14}")
    with tempfile.TemporaryDirectory() as tmp:
        for baud in (int(b) for b in args.baud.split(",")):
            pause = (15 + 64) * BITS_PER_BYTE / baud + args.margin
            with SimProcess(robot, baud=baud) as sim:
                read, _ = timed_pull(sim.ports[0], Path(tmp) / f"robot-{baud}")
                ours = sim.stats()[0]
                sim.reset()
                start = time.perf_counter()
                _, whole = naive_backup(sim.ports[0], baud, pause)
                naive_time = time.perf_counter() - start
                theirs = sim.stats()[0]
            rows = (("harlsync", ours, read, ours["exchanges"]), ("naive", theirs, naive_time, whole))
            for way, counted, seconds, ok in rows:
                limit = (counted["bytes_in"] + counted["bytes_out"]) * BITS_PER_BYTE / baud
                ratio = f"{naive_time / read:>14.2f}" if way == "naive" else ""
                print(f"{baud:>6} {way:9} {counted['exchanges']:>9,} {ok:>6,} {minutes(limit):>10} "
                      f"{minutes(seconds):>9} {seconds / limit:>7.2f} "
                      f"{seconds / counted['exchanges'] * 1e3:>8.2f} {ratio}", flush=True)


if __name__ == "__main__":
    main()
