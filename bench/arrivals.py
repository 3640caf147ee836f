"""Instructions a link exchange costs, load-independent: a reply that arrives a byte at a time.

    python bench/arrivals.py                         this tree: ~2 min
    python bench/arrivals.py --against /tmp/before   and another tree's harlsync, in turn
    python bench/arrivals.py --baud 600 --counts 20,60

Wall-clock and CPU figures of a link on a slow line swing with the machine's load
(each arrival of bytes is a wake-up, and how many bytes one wake-up finds depends on
how late it runs).  This counts instructions instead (valgrind's callgrind, ``I
refs``, user space), with the arrivals made deterministic: a simulator process
(bench/simserver.py, not under valgrind) serves a robot on a pty at a baud rate so
low (default 1200: a byte every 8.3 ms) that every reply byte is an arrival of its
own, even for a process under valgrind.  A fresh interpreter (this script with
``--child``) opens the HARL-U2 link on the pty and reads MAIN 0's steps, N times,
through ``Link.exchange``, as a driver does (the codec encodes the request and
decodes the reply); it runs once for each of two counts, and the difference over
the difference of the counts is the instructions of one exchange, start-up and
imports taken out (after a run that compiles the bytecode, with one hash seed).  The
floor (``--bare``) sends the same requests with a bare client: write, then blocking
reads until the codec's decoder has the frame.  Per arrival: the same over the reply bytes of one exchange (the
simulator's count), each of which woke the link.

The kernel's part (the ``poll`` and ``read`` system calls, the wake-ups) is not in
these counts: bench/floor.py --syscalls counts those calls, bench/cpu.py the CPU.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from machine import SimProcess, describe, instructions, process_env


def child(port: str, baud: int, count: int) -> None:
    from harlsync.families.harl_u2.link import Link
    from harlsync.families.harl_u2.model import ProgramType
    from harlsync.families.harl_u2.protocol import commands
    from harlsync.settings import SerialSettings

    with Link(port, 1, SerialSettings(baudrate=baud, timeout=2.0)) as link:
        for n in range(count):
            link.exchange(commands.read_step(ProgramType.MAIN, 0, n % 64))


def bare(port: str, baud: int, count: int) -> None:
    """The floor: the same requests by a bare client (write, then blocking reads until
    the codec's decoder has the frame), no link."""
    import tty

    from harlsync.families.harl_u2.model import ProgramType
    from harlsync.families.harl_u2.protocol import FrameDecoder, commands, encode_frame

    frames = [
        encode_frame(1, commands.read_step(ProgramType.MAIN, 0, n).payload) for n in range(64)
    ]
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    decoder = FrameDecoder()
    for n in range(count):
        os.write(fd, frames[n % 64])
        while decoder.next_frame() is None:
            decoder.feed(os.read(fd, 4096))
    os.close(fd)


def child_instructions(
    port: str, baud: int, count: int, env: dict[str, str], mode: str = "--child"
) -> int:
    """The instructions of ``count`` exchanges of this script's ``mode`` child."""
    command = [sys.executable, __file__, mode, port, str(baud), str(count)]
    return instructions(command, env, "arrivals")


def main() -> None:
    if sys.argv[1:2] in (["--child"], ["--bare"]):
        run = child if sys.argv[1] == "--child" else bare
        run(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--baud", type=int, default=1200)
    parser.add_argument("--counts", default="10,40", help="the two exchange counts")
    parser.add_argument("--against", metavar="TREE", help="another harlsync's source tree too")
    args = parser.parse_args()
    low, high = (int(n) for n in args.counts.split(","))
    trees: list[tuple[str, str | None]] = [("this tree", None), ("the floor", None)]
    if args.against:
        trees.append((args.against, str(Path(args.against).resolve())))
    print(f"harlsync arrivals bench: {describe()}")
    print(
        f"MAIN 0's steps read through Link.exchange at {args.baud} baud (every reply byte an "
        f"arrival), {low} and {high} exchanges, under callgrind\n"
    )
    locks = Path(os.environ.get("TMPDIR", "/tmp")) / "harlsync-arrivals-locks"
    locks.mkdir(exist_ok=True)
    with SimProcess("small-full", baud=args.baud) as sim:
        print(f"{'tree':32} {'instr/exchange':>15} {'arrivals':>9} {'instr/arrival':>14}")
        for name, tree in trees:
            env = process_env(locks, PYTHONHASHSEED="0", **({"PYTHONPATH": tree} if tree else {}))
            mode = "--bare" if name == "the floor" else "--child"
            warm = [sys.executable, __file__, mode, sim.ports[0], str(args.baud), "1"]
            subprocess.run(warm, env=env, check=True)  # its bytecode compiled and cached
            counted = []
            for count in (low, high):
                sim.reset()
                counted.append(child_instructions(sim.ports[0], args.baud, count, env, mode))
                stats = sim.stats()[0]
            per = (counted[1] - counted[0]) / (high - low)
            arrivals = stats["bytes_out"] / stats["exchanges"]
            print(f"{name:32} {per:>15,.0f} {arrivals:>9.1f} {per / arrivals:>14,.0f}", flush=True)


if __name__ == "__main__":
    main()
