"""The floor: a bare client that sends the requests a `harlsync pull` sends and does
nothing else, alternating in one run with the whole `harlsync pull` process.

    python bench/floor.py                     default and max-full, 19200 and 115200
                                              baud, 3 alternations each: ~20 min
    python bench/floor.py --quick             default at 115200, 2 alternations: ~30 s
    python bench/floor.py --robot default --baud 19200 --repeat 5

For each robot and baud rate a simulator process (bench/simserver.py, wire-time
emulation on a pty) serves the robot, and one `harlsync pull DIR` (a first pull,
robot.yaml naming the pty and the baud rate, as bench/process.py runs it) is
recorded: the simulator keeps every byte each way.  The family's codec cuts what
it read into the request frames, and what it sent into the reply frames.  The floor
is then a process of its own (this script with ``--replay``: the interpreter, the
os module, nothing of harlsync) that opens the pty raw and, for each request in
order, writes its bytes in one ``os.write`` and reads until the reply's bytes are
all there; at the end it checks that it got the replies byte for byte.

Then ``--repeat`` times: a whole `harlsync pull` into a fresh directory, the floor,
each timed as bench/process.py times a pull (machine.timed_process, the clock every
process shares).  Every harlsync pull must send the recorded requests again, byte
for byte, or the bench stops.  Printed per run, and the best of each:

- **start-up**: from starting the process to the simulator reading the first
  request byte;
- **gaps**: from each reply's last byte due on the line to the next request's first
  byte read, in all (the client's turnaround, plus the simulator's wake-up to read
  the request, which both clients pay alike); **gap/exch**, the same per exchange;
- **save**: from the last reply byte due to the process's exit;
- **whole**, and **ratio**: harlsync's whole time against the floor's, the best of
  each.

Targets (issue 24): the whole pull at most 1.02 x the floor at 19200 baud and
1.10 x at 115200; the first request 0.08 s after the process starts; 0.1 ms from a
reply's last byte to the next request.
"""

from __future__ import annotations

import os
import sys


def replay(folder: str) -> None:
    """The floor itself: the requests of ``folder`` to the port it names, and nothing
    else (only ``os`` and ``tty`` are imported before the first request)."""
    import tty

    with open(os.path.join(folder, "port"), encoding="ascii") as f:
        port = f.read()
    with open(os.path.join(folder, "requests"), "rb") as f:
        requests = f.read()
    with open(os.path.join(folder, "sizes"), encoding="ascii") as f:
        sizes = [int(n) for n in f.read().split()]
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    got = bytearray()
    at = 0
    write, read = os.write, os.read
    for n in range(0, len(sizes), 2):
        ask, reply = sizes[n], sizes[n + 1]
        write(fd, requests[at : at + ask])
        at += ask
        want = len(got) + reply
        while len(got) < want:
            got += read(fd, 4096)
    os.close(fd)
    with open(os.path.join(folder, "replies"), "rb") as f:
        if f.read() != got:
            sys.exit("floor: the replies differ from the recorded ones")


if __name__ == "__main__" and sys.argv[1:2] == ["--replay"]:
    replay(sys.argv[2])
    sys.exit(0)

# The rest is the bench around the floor, which the floor's own process never imports.
import argparse
import re
import shutil
import statistics
import subprocess
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any


def frames(codec: object, data: bytes) -> list[bytes]:
    """``data`` cut into the frames the codec's decoder finds in it (noise before a
    frame goes with it)."""
    decoder = codec.decoder()  # type: ignore[attr-defined]
    decoder.feed(data)
    out = []
    start = 0
    while True:
        frame = decoder.next_frame()
        if frame is None:
            break
        end = len(data) - decoder.pending
        out.append(data[start:end])
        start = end
    if start != len(data):
        sys.exit(f"floor: {len(data) - start} recorded bytes are no whole frame")
    return out


TARGETS = {19200: 1.02, 115200: 1.10}


def codec_of(robot: str) -> object:
    """The codec of ``robot``'s family (the one that cuts its traffic into frames)."""
    from machine import IAI_ROBOTS

    if robot in IAI_ROBOTS:
        from harlsync.families.iai.codec import CODEC as IAI

        return IAI
    from harlsync.families.harl_u2.protocol.codec import CODEC

    return CODEC


def show(robot: str, baud: int, who: str, r: dict[str, Any]) -> None:
    print(
        f"{robot:9} {baud:>6} {who:8} {r['exchanges']:>6,} {r['limit']:>8.2f} "
        f"{r['startup']:>8.3f} {r['gaps']:>7.3f} {r['gaps'] / r['exchanges'] * 1e3:>8.3f} "
        f"{r['save']:>6.3f} {r['whole']:>7.2f} {r['cpu']:>6.2f}",
        flush=True,
    )


HEAD = (
    f"{'robot':9} {'baud':>6} {'client':8} {'exch':>6} {'limit s':>8} {'start-up':>8} "
    f"{'gaps s':>7} {'gap ms':>8} {'save':>6} {'whole':>7} {'CPU s':>6}"
)


def pull(sim: Any, baud: int, text: str, project: Path, locks: Path) -> dict[str, Any]:
    """One whole `harlsync pull` into a new directory ``project``, timed."""
    from machine import harlsync_command, process_env, timed_process

    project.mkdir()
    (project / "robot.yaml").write_text(text)
    command = [*harlsync_command(), "pull", str(project)]
    result: dict[str, Any] = timed_process(sim, baud, command, process_env(locks))
    shutil.rmtree(project)
    return result


def record(sim: Any, robot: str, folder: Path) -> bytes:
    """What the last pull sent and got, cut into frames and written to ``folder`` for
    the floor; the requests it sent."""
    sent, replies = sim.wire()[0]
    codec = codec_of(robot)
    asked, answered = frames(codec, sent), frames(codec, replies)
    if len(asked) != len(answered):
        sys.exit(f"floor: {len(asked)} requests, {len(answered)} replies")
    folder.mkdir()
    (folder / "port").write_text(sim.ports[0])
    (folder / "requests").write_bytes(sent)
    (folder / "replies").write_bytes(replies)
    (folder / "sizes").write_text(" ".join(f"{len(a)} {len(b)}" for a, b in zip(asked, answered)))
    return sent


def run_case(robot: str, baud: int, repeat: int, tmp: Path) -> tuple[Any, ...]:
    """``repeat`` pulls and floors, alternating: the best of each, the ratios."""
    from machine import SimProcess, process_env, timed_process
    from process import robot_yaml

    locks = tmp / "locks"
    with SimProcess(robot, baud=baud) as sim:
        text = robot_yaml(robot, sim.ports[0], baud)
        sim.record()
        pull(sim, baud, text, tmp / f"{robot}-{baud}-recorded", locks)
        folder = tmp / f"floor-{robot}-{baud}"
        sent = record(sim, robot, folder)
        floor_command = [sys.executable, __file__, "--replay", str(folder)]
        ours, floors = [], []
        for n in range(repeat):
            ours.append(pull(sim, baud, text, tmp / f"{robot}-{baud}-{n}", locks))
            if sim.wire()[0][0] != sent:
                sys.exit("floor: a harlsync pull sent other requests than the recorded one")
            show(robot, baud, "harlsync", ours[-1])
            floors.append(timed_process(sim, baud, floor_command, process_env(locks)))
            show(robot, baud, "floor", floors[-1])
    best = min(ours, key=lambda r: r["whole"])
    floor = min(floors, key=lambda r: r["whole"])
    median = statistics.median(r["whole"] for r in ours) / statistics.median(
        r["whole"] for r in floors
    )
    return robot, baud, best, floor, best["whole"] / floor["whole"], median


SYSCALLS = (
    "read,write,ioctl,fcntl,poll,ppoll,select,pselect6,epoll_wait,clock_nanosleep,"
    "nanosleep,openat,recvfrom,sendto"
)
_CALL = re.compile(r"^(\d+)\s+(\w+)\((.*)")


def count_syscalls(trace: Path, port: str) -> tuple[int, Counter[str]]:
    """The system calls of an ``strace -f`` log from the first request written to the
    port to the last reply read from it, by name, on the port's descriptor (waits:
    on any); and the thread that did them.  Calls on other descriptors in that
    span are counted as ``other``."""
    lines = trace.read_text().splitlines()
    fd = None
    calls: list[tuple[int, str, str]] = []
    for line in lines:
        m = _CALL.match(line)
        if not m:
            continue
        pid, name, rest = int(m[1]), m[2], m[3]
        if name == "openat" and f'"{port}"' in rest and fd is None:
            fd = int(rest.rsplit("=", 1)[1].split()[0])
            continue
        calls.append((pid, name, rest))
    if fd is None:
        sys.exit(f"floor: {port} is never opened in {trace}")
    mine = f"{fd},"
    on_port = [
        n
        for n, (_, name, rest) in enumerate(calls)
        if name in ("read", "write") and rest.startswith(mine)
    ]
    first = next(n for n in on_port if calls[n][1] == "write")
    last = next(n for n in reversed(on_port) if calls[n][1] == "read")
    thread = calls[first][0]
    counted: Counter[str] = Counter()
    for pid, name, rest in calls[first : last + 1]:
        if pid != thread:
            counted["other thread"] += 1
        elif rest.startswith(mine) or f"fd={fd}," in rest or name.endswith("sleep"):
            counted[name + (" (nothing there)" if "EAGAIN" in rest else "")] += 1
        else:
            counted["other"] += 1
    return thread, counted


def syscalls(robot: str, baud: int, tmp: Path) -> None:
    """One harlsync pull and one floor under ``strace -f``: system calls per exchange."""
    from machine import SimProcess, harlsync_command, process_env
    from process import robot_yaml

    if not shutil.which("strace"):
        sys.exit("floor: --syscalls needs strace (apt-get install strace)")
    locks = tmp / "locks"
    with SimProcess(robot, baud=baud) as sim:
        text = robot_yaml(robot, sim.ports[0], baud)
        sim.record()
        pull(sim, baud, text, tmp / "recorded", locks)
        record(sim, robot, tmp / "floor")
        exchanges = sim.stats()[0]["exchanges"]
        project = tmp / "traced"
        project.mkdir()
        (project / "robot.yaml").write_text(text)
        for who, command in (
            ("harlsync", [*harlsync_command(), "pull", str(project)]),
            ("floor", [sys.executable, __file__, "--replay", str(tmp / "floor")]),
        ):
            trace = tmp / f"{who}.strace"
            traced = ["strace", "-f", "-qq", "-e", f"trace={SYSCALLS}", "-o", str(trace)]
            subprocess.run([*traced, *command], env=process_env(locks), check=True)
            _, counted = count_syscalls(trace, sim.ports[0])
            total = sum(counted.values())
            print(f"{robot} at {baud}, {who}: {total / exchanges:.2f} system calls an exchange")
            for name, n in counted.most_common():
                print(f"    {name:28} {n:>7,}  {n / exchanges:6.2f} an exchange")


def main() -> None:
    from machine import case_options, cases, describe, minutes

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    case_options(parser, ["default", "max-full"], "default")
    parser.add_argument("--repeat", type=int, help="alternations per case (default 3, --quick 2)")
    parser.add_argument(
        "--syscalls",
        action="store_true",
        help="instead: one pull and one floor under strace, system calls per exchange",
    )
    args = parser.parse_args()
    robots, bauds = cases(args, ["default", "max-full"], "default")
    repeat = args.repeat or (2 if args.quick else 3)
    if args.syscalls:
        print(f"harlsync floor bench, system calls: {describe()}")
        for robot in robots:
            for baud in bauds:
                with tempfile.TemporaryDirectory() as tmp:
                    syscalls(robot, baud, Path(tmp))
        return

    print(f"harlsync floor bench: {describe()}")
    print(
        "`harlsync pull DIR` and a bare client sending the same requests (the floor), "
        f"alternating, {repeat} of each a case; best of each below the runs\n"
    )
    print(HEAD)
    began = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        summary = [run_case(r, b, repeat, Path(tmp)) for r in robots for b in bauds]
    print(f"\nbest of {repeat} each")
    print(HEAD + f" {'ratio':>6} {'median':>6} target")
    for robot, baud, best, floor, ratio, median in summary:
        target = TARGETS.get(baud)
        verdict = "" if target is None else f"{target:.2f} {'PASS' if ratio <= target else 'MISS'}"
        for who, r in (("harlsync", best), ("floor", floor)):
            show(robot, baud, who, r)
        print(f"{'':>84} {ratio:>6.3f} {median:>6.3f} {verdict}")
    late = [r["late_mean"] for _, _, b, f, _, _ in summary for r in (b, f) if r["late_mean"]]
    print(
        "\nstart-up: to the first request byte read; gaps: from each reply's last byte due to "
        "the next request's\nfirst byte read, in all (gap ms: per exchange); save: from the "
        "last reply byte due to the exit.\nratio: harlsync's best whole time over the floor's; "
        "median: the same of the medians.  Targets: whole\n1.02 x the floor at 19200, 1.10 x "
        "at 115200; start-up 0.08 s; 0.1 ms a gap."
    )
    if late:
        print(f"Simulator replies late by {sum(late) / len(late) * 1e6:.0f} us on average.")
    print(f"ran in {minutes(time.monotonic() - began)}; machine at the end: {describe()}")


if __name__ == "__main__":
    main()
