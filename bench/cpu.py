"""CPU and wake-ups per exchange: what the client costs the machine while the line runs.

    python bench/cpu.py                      default-full (1,079 exchanges) at 9600 and
                                             115200 baud, over a pty and TCP: ~1.5 min
    python bench/cpu.py --quick              small-full (263 exchanges): ~25 s
    python bench/cpu.py --robot iai-mix --baud 9600,115200     an IAI table

A simulator process (bench/simserver.py) serves the robot with wire-time emulation
at the baud rate; a fresh interpreter (this script with ``--child``) opens the
family's driver on it, as a pull does, and reads everything (``read_all``).  The
child measures itself with ``getrusage`` around the read, so imports and the save
are not in these figures (bench/line.py has the whole process):

- CPU us/exch: user + system time of the process, from the OS, per exchange; ``of
  it sys``: the system (kernel) part: the port's writes, reads and waits;
- wake-ups/exch: voluntary context switches (``ru_nvcsw``) per exchange: each time
  the process blocked and the kernel woke it, for bytes or for a timer;
- over ms/exch: (read - line limit) / exchanges, the line limit being what the
  simulator counted crossing the line both ways x 10 / baud;
- read/limit.

For a HARL-U2 robot a second row, ``raw``, is the floor: as many step reads by a
loop of a few lines with no link (write, poll, read until the frame is whole,
``raw_child``) against a fresh simulator, so that what the machine, the pty or TCP
and the simulator cost each exchange shows apart from what harlsync adds.

robot.yaml's baud rate is the line's, as a site writes it.  Targets (issue 15): at
most 0.1 ms of CPU per exchange, at most 3 wake-ups per exchange, and at 115200 at
most 0.1 ms of overhead per exchange.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import select
import socket
import subprocess
import sys
import tempfile
import time
import tty
from typing import Any

from machine import (
    BITS_PER_BYTE,
    IAI_ROBOTS,
    ROBOTS,
    SimProcess,
    bench_robot,
    describe,
    minutes,
)

CPU_TARGET_US = 100
WAKE_TARGET = 3
OVER_TARGET_MS = 0.1


def child(robot: str, port: str, baud: int) -> None:
    """Read everything from ``port`` as a pull does; print one JSON line."""
    from harlsync import families

    bot = bench_robot(robot, port, baud)
    family = families.get(bot.family)
    driver = family.connect(bot, None, None, lock_timeout=5)
    try:
        before, start = resource.getrusage(resource.RUSAGE_SELF), time.monotonic()
        driver.read_all(registers=False)
        end, after = time.monotonic(), resource.getrusage(resource.RUSAGE_SELF)
    finally:
        driver.close()
    print(
        json.dumps(
            {
                "cpu": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
                "user": after.ru_utime - before.ru_utime,
                "wakeups": after.ru_nvcsw - before.ru_nvcsw,
                "preempted": after.ru_nivcsw - before.ru_nivcsw,
                "wall": end - start,
            }
        )
    )


def raw_child(port: str, count: int) -> None:
    """The floor: ``count`` step reads (MAIN 0's steps in turn) by the least a Python
    program can do, with no link: write the frame, wait in poll, read until a whole
    frame has come.  One JSON line, as :func:`child`."""
    from harlsync.families.harl_u2.model import ProgramType
    from harlsync.families.harl_u2.protocol import FrameDecoder, commands, encode_frame

    frames = [
        encode_frame(1, commands.read_step(ProgramType.MAIN, 0, n).payload) for n in range(64)
    ]
    if port.startswith("socket://"):
        host, _, number = port[len("socket://") :].rpartition(":")
        conn = socket.create_connection((host, int(number)))
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        fd = conn.fileno()
    else:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(fd)
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    decoder = FrameDecoder()
    before, start = resource.getrusage(resource.RUSAGE_SELF), time.monotonic()
    for n in range(count):
        os.write(fd, frames[n % 64])
        while decoder.next_frame() is None:
            poller.poll()
            decoder.feed(os.read(fd, 4096))
    end, after = time.monotonic(), resource.getrusage(resource.RUSAGE_SELF)
    print(
        json.dumps(
            {
                "cpu": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
                "user": after.ru_utime - before.ru_utime,
                "wakeups": after.ru_nvcsw - before.ru_nvcsw,
                "wall": end - start,
            }
        )
    )


def measure(robot: str, baud: int, tcp: bool, locks: str, raw: int = 0) -> dict[str, Any]:
    """One read (``raw``: that many exchanges of :func:`raw_child`) against a fresh
    simulator process, with what the simulator counted."""
    with SimProcess(robot, baud=baud, tcp=tcp) as sim:
        env = dict(os.environ, HARLSYNC_LOCK_DIR=locks)
        how = (
            ["--raw", sim.ports[0], str(raw)]
            if raw
            else ["--child", robot, sim.ports[0], str(baud)]
        )
        done = subprocess.run(
            [sys.executable, __file__, *how],
            capture_output=True,
            text=True,
            env=env,
            check=False,
        )
        if done.returncode:
            sys.exit(f"the reading process failed:\n{done.stderr}")
        counted = sim.stats()[0]
    result: dict[str, Any] = json.loads(done.stdout)
    nbytes = counted["bytes_in"] + counted["bytes_out"]
    result.update(
        exchanges=counted["exchanges"],
        limit=nbytes * BITS_PER_BYTE / baud,
        read=counted["last_due"] - counted["first_in"],
        late=counted.get("late_mean", 0.0),
    )
    return result


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3], int(sys.argv[4]))
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--raw":
        raw_child(sys.argv[2], int(sys.argv[3]))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the small-full robot")
    parser.add_argument(
        "--robot", choices=sorted(ROBOTS | IAI_ROBOTS), help="default: default-full"
    )
    parser.add_argument(
        "--baud", default="9600,115200", help="comma-separated (default %(default)s)"
    )
    parser.add_argument(
        "--transport", default="pty,tcp", help="pty, tcp or both (default %(default)s)"
    )
    parser.add_argument(
        "--no-floor", action="store_true", help="without the raw loop's row (HARL-U2 robots)"
    )
    args = parser.parse_args()
    robot = args.robot or ("small-full" if args.quick else "default-full")

    print(f"harlsync CPU per exchange bench: {describe()}")
    print(f"robot {robot}; a fresh process reads it (read_all), measured with getrusage\n")
    print(
        f"{'baud':>6} {'over':4} {'':3} {'exch':>6} {'limit':>8} {'read':>8} {'read/lim':>8} "
        f"{'over ms/exch':>12} {'CPU us/exch':>11} {'of it sys':>9} {'wake-ups/exch':>13} "
        f"{'sim late us':>11}"
    )
    began = time.monotonic()
    with tempfile.TemporaryDirectory() as locks:
        for baud in (int(b) for b in args.baud.split(",")):
            for transport in args.transport.split(","):
                r = measure(robot, baud, transport == "tcp", locks)
                rows = [("", r)]
                if robot in ROBOTS and not args.no_floor:
                    rows.append(
                        ("raw", measure(robot, baud, transport == "tcp", locks, raw=r["exchanges"]))
                    )
                for way, r in rows:
                    n = r["exchanges"]
                    over = (r["read"] - r["limit"]) / n * 1e3
                    print(
                        f"{baud:>6} {transport:4} {way:3} {n:>6,} {minutes(r['limit']):>8} "
                        f"{minutes(r['read']):>8} {r['read'] / r['limit']:>8.3f} {over:>12.3f} "
                        f"{r['cpu'] / n * 1e6:>11.1f} {(r['cpu'] - r['user']) / n * 1e6:>9.1f} "
                        f"{r['wakeups'] / n:>13.2f} "
                        f"{r['late'] * 1e6:>11.0f}",
                        flush=True,
                    )
    print(
        f"\nTargets: CPU at most {CPU_TARGET_US} us per exchange, at most {WAKE_TARGET} "
        f"wake-ups per exchange, over at most {OVER_TARGET_MS} ms per exchange at 115200."
    )
    print(f"ran in {minutes(time.monotonic() - began)}")


if __name__ == "__main__":
    main()
