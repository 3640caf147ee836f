"""Line efficiency: a full pull against the line limit, at several baud rates.

    python bench/line.py                     max-full robot at 9600, 19200, 38400, 115200
                                             baud: ~16 min (8 of them at 9600)
    python bench/line.py --quick             small-full robot (263 exchanges): ~20 s
    python bench/line.py --robot default-full --baud 9600,115200

For each baud rate a simulator process (bench/simserver.py) serves the robot on
a pty with wire-time emulation: each reply's last byte is due when the request
and the reply would have crossed the line at that speed, and the reply's bytes
are paced at the character rate.  harlsync pulls it (harlsync.sync.engine.pull).
The line limit is what the simulator counted crossing the line, both ways, at
10 bits per character (8N1): bytes x 10 / baud.  A ratio of 1.00 is a client
that costs nothing; the target is at most 1.03.  ``read`` is until the last item
was read; ``pull`` includes writing the YAML project and git's status check.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from machine import BITS_PER_BYTE, ROBOTS, SimProcess, describe, minutes, timed_pull

BAUDS = (9600, 19200, 38400, 115200)
TARGET = 1.03


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the small-full robot")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="default: max-full")
    parser.add_argument(
        "--baud",
        default=",".join(map(str, BAUDS)),
        help="comma-separated baud rates (default: %(default)s)",
    )
    args = parser.parse_args()
    robot = args.robot or ("small-full" if args.quick else "max-full")
    bauds = [int(b) for b in args.baud.split(",")]

    print(f"harlsync line efficiency bench: {describe()}")
    print(f"robot {robot}, pulled over a pty from a simulator process\n")
    print(
        f"{'baud':>6} {'exchanges':>9} {'bytes':>9} {'line limit':>10} {'read':>9} "
        f"{'pull':>9} {'read/limit':>10} {'pull/limit':>10} {'ms/exch over':>12}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for baud in bauds:
            with SimProcess(robot, baud=baud) as sim:
                read, whole = timed_pull(sim.ports[0], Path(tmp) / f"robot-{baud}")
                counted = sim.stats()[0]
            nbytes = counted["bytes_in"] + counted["bytes_out"]
            limit = nbytes * BITS_PER_BYTE / baud
            over = (read - limit) / counted["exchanges"] * 1e3
            print(
                f"{baud:>6} {counted['exchanges']:>9,} {nbytes:>9,} {minutes(limit):>10} "
                f"{minutes(read):>9} {minutes(whole):>9} {read / limit:>10.3f} "
                f"{whole / limit:>10.3f} {over:>12.3f}",
                flush=True,
            )
    print(f"\nTarget: pull/limit at most {TARGET}.")


if __name__ == "__main__":
    main()
