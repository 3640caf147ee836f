"""What the client adds to each round trip: requests/s against an un-throttled simulator.

    python bench/overhead.py            ~20 s: 5 rounds of 2,000 requests per way
    python bench/overhead.py --quick    ~5 s

The simulator runs in a process of its own (bench/simserver.py) on a pty, with no
wire-time emulation, so a round trip is: the client encodes and writes, the pty
carries, the simulator decodes, answers and writes, the pty carries, the client
reads and decodes.  Measured side by side, in interleaved rounds (best round shown):

- raw: the least a client can do: os.write the prepared frame, then select and
  os.read until the decoder has a frame.  It is the floor: the pty and the simulator.
- Link.exchange: harlsync's link (pyserial port, retries, late-reply handling).
- Controller.read_step: the controller on top (what a pull calls per step).

The client's overhead is the difference to raw.
"""

from __future__ import annotations

import argparse
import os
import select
import statistics
import tempfile
import time
from collections.abc import Callable

from machine import SimProcess, describe

from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import ProgramType
from harlsync.families.harl_u2.protocol import FrameDecoder, commands, encode_frame

STEPS = 64  # read MAIN 0 steps 0..63 in turn (the default robot's MAIN has 128)


def raw_way(device: str) -> tuple[Callable[[int], None], Callable[[], None]]:
    fd = os.open(device, os.O_RDWR | os.O_NOCTTY)
    frames = [
        encode_frame(1, commands.read_step(ProgramType.MAIN, 0, n).payload) for n in range(STEPS)
    ]
    decoder = FrameDecoder()

    def run(count: int) -> None:
        for i in range(count):
            os.write(fd, frames[i % STEPS])
            while True:
                select.select([fd], [], [], 1.0)
                decoder.feed(os.read(fd, 4096))
                if decoder.next_frame() is not None:
                    break

    return run, lambda: os.close(fd)


def link_way(device: str) -> tuple[Callable[[int], None], Callable[[], None]]:
    link = Link(device).open()
    requests = [commands.read_step(ProgramType.MAIN, 0, n) for n in range(STEPS)]

    def run(count: int) -> None:
        for i in range(count):
            link.exchange(requests[i % STEPS])

    return run, link.close


def controller_way(device: str) -> tuple[Callable[[int], None], Callable[[], None]]:
    controller = Controller(Link(device).open())

    def run(count: int) -> None:
        for i in range(count):
            controller.read_step(ProgramType.MAIN, 0, i % STEPS)

    return run, controller.link.close


WAYS = {"raw": raw_way, "Link.exchange": link_way, "Controller.read_step": controller_way}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds of 1,000")
    parser.add_argument("--rounds", type=int, help="rounds (default 5)")
    parser.add_argument("--requests", type=int, help="requests per way per round (default 2,000)")
    args = parser.parse_args()
    rounds = args.rounds or (2 if args.quick else 5)
    count = args.requests or (1000 if args.quick else 2000)
    os.environ.setdefault("HARLSYNC_LOCK_DIR", tempfile.mkdtemp(prefix="bench-locks-"))

    print(f"harlsync client overhead bench: {describe()}")
    print(f"{rounds} rounds of {count:,} requests per way, un-throttled simulator on a pty\n")
    times: dict[str, list[float]] = {name: [] for name in WAYS}
    with SimProcess("default") as sim:
        device = sim.ports[0]
        for _ in range(rounds):
            for name, way in WAYS.items():
                run, close = way(device)
                run(50)  # warm up
                start = time.perf_counter()
                run(count)
                times[name].append((time.perf_counter() - start) / count)
                close()
    floor = min(times["raw"])
    print(
        f"{'way':22} {'us/round trip':>13} {'(median)':>9} {'requests/s':>10} {'over raw us':>11}"
    )
    for name, per in times.items():
        best = min(per)
        print(
            f"{name:22} {best * 1e6:>13.0f} {statistics.median(per) * 1e6:>9.0f} "
            f"{1 / best:>10,.0f} {(best - floor) * 1e6:>11.0f}"
        )
    print("\nTarget: at most 300 us per round trip (3,000 requests/s) through the Controller.")


if __name__ == "__main__":
    main()
