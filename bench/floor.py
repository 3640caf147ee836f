"""The floor: a bare client that sends the requests a `harlsync pull` sends and does
nothing else, alternating in one run with the whole `harlsync pull` process.

    python bench/floor.py                     default and max-full, 19200 and 115200
                                              baud, on a pty and behind socket://,
                                              3 alternations each: ~40 min
    python bench/floor.py --quick             default at 115200, pty and socket://,
                                              2 alternations: ~1 min
    python bench/floor.py --robot default --baud 19200 --transport pty --repeat 5
    python bench/floor.py --quick --against /tmp/before    and another harlsync's tree

For each robot, baud rate and transport a simulator process (bench/simserver.py,
wire-time emulation) serves the robot, and one `harlsync pull DIR` (a first pull)
is recorded: the simulator keeps every byte each way.

- **pty**: the line is a pty, as a USB-serial adapter appears; robot.yaml names the
  pty and the line's baud rate, as bench/process.py writes it.
- **socket**: the device-server case.  The simulator serves the line over TCP (as
  `harlsync sim --listen` does), paced at the baud rate the device server would
  set, and robot.yaml names it ``socket://HOST:PORT`` and keeps the family's
  default baud rate (9600): through a device server the client cannot know the
  line's rate, and a link that times replies by robot.yaml's baud rate waits for
  the wrong times.

The family's codec cuts what the recorded pull sent into the request frames, and
what it got into the reply frames.  The floor is then a process of its own (this
script with ``--replay``: the interpreter, the os module, nothing of harlsync) that
opens the pty raw (or connects to the TCP port) and, for each request in order,
writes its bytes in one ``os.write`` and reads until the reply's bytes are all
there; at the end it checks that it got the replies byte for byte.

With ``--against TREE`` a `harlsync pull` of that tree's harlsync (its ``harlsync``
package on PYTHONPATH; e.g. ``git archive REV harlsync | tar -x -C TREE``) takes its
turn too, after this tree's: a before and after in one run, each against the floor.

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
- **CPU us/ex**: the process's user + system CPU (getrusage of the finished child:
  start-up and save included) over the exchanges; **sim us/ex**: the simulator
  process's CPU over the same run, shown apart (on a plant server the robots are
  real and that CPU is not spent);
- **whole**, and **ratio**: harlsync's whole time against the floor's, the best of
  each; **cpu x**: harlsync's CPU per exchange against the floor's, the medians.

Targets (issue 24, issue 33): the whole pull at most 1.02 x the floor at 19200 baud
and 1.10 x at 115200, on a pty and behind a device server alike (issue 29); the first
request 0.10 s after the process starts (issue 33; 0.08 s in issue 24); 0.1 ms from a reply's last byte to the next
request; CPU per exchange at most 2 x the floor's.
"""

from __future__ import annotations

import os
import sys


def replay(folder: str, port: str | None = None) -> None:
    """The floor itself: the requests of ``folder`` to the port it names (or
    ``port``: bench/fleet.py replays one recording on every line), and nothing
    else (only ``os`` and ``tty`` are imported before the first request, and
    ``socket`` for a device server)."""
    import tty

    if port is None:
        with open(os.path.join(folder, "port"), encoding="ascii") as f:
            port = f.read()
    with open(os.path.join(folder, "requests"), "rb") as f:
        requests = f.read()
    with open(os.path.join(folder, "sizes"), encoding="ascii") as f:
        sizes = [int(n) for n in f.read().split()]
    if port.startswith("socket://"):  # a device server: the TCP port, no terminal
        import socket

        host, number = port[len("socket://") :].rsplit(":", 1)
        sock = socket.create_connection((host, int(number)))
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        fd = os.dup(sock.fileno())
        sock.close()
    else:
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
    replay(sys.argv[2], *sys.argv[3:4])
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


def show(case: str, who: str, r: dict[str, Any]) -> None:
    n = r["exchanges"]
    print(
        f"{case:23} {who:8} {n:>6,} {r['limit']:>8.2f} {r['startup']:>8.3f} {r['gaps']:>7.3f} "
        f"{r['gaps'] / n * 1e3:>8.3f} {r['save']:>6.3f} {r['whole']:>7.2f} "
        f"{r['cpu'] / n * 1e6:>9.0f} {r['sim_cpu'] / n * 1e6:>9.0f}",
        flush=True,
    )


HEAD = (
    f"{'robot    baud line':23} {'client':8} {'exch':>6} {'limit s':>8} {'start-up':>8} "
    f"{'gaps s':>7} {'gap ms':>8} {'save':>6} {'whole':>7} {'CPU us/ex':>9} {'sim us/ex':>9}"
)


def pull(
    sim: Any, baud: int, text: str, project: Path, locks: Path, tree: str | None = None
) -> dict[str, Any]:
    """One whole `harlsync pull` into a new directory ``project``, timed; ``tree``: the
    harlsync of that source tree."""
    from machine import harlsync_command, process_env, timed_process

    project.mkdir()
    (project / "robot.yaml").write_text(text)
    command = [*harlsync_command(), "pull", str(project)]
    env = process_env(locks, **({"PYTHONPATH": tree} if tree else {}))
    result: dict[str, Any] = timed_process(sim, baud, command, env)
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


def differ(robot: str, sent: bytes, again: bytes) -> str:
    """Where the requests ``again`` part from the recorded ones ``sent``, in words."""
    codec = codec_of(robot)
    ours, theirs = frames(codec, sent), frames(codec, again)
    n = next(
        (n for n, (a, b) in enumerate(zip(ours, theirs)) if a != b), min(len(ours), len(theirs))
    )
    near = slice(max(0, n - 2), n + 3)
    return (
        f"{len(theirs)} requests against {len(ours)} recorded, the first other one number {n}: "
        f"{theirs[near]} where the recording has {ours[near]} (a retry: the machine too busy "
        "for the reply deadline?)"
    )


def yaml_baud(robot: str, baud: int, transport: str) -> int:
    """The baud rate robot.yaml gives: the line's on a pty, the family's default
    behind a device server (which sets the line's rate itself)."""
    if transport == "pty":
        return baud
    default: int = codec_of(robot).settings.baudrate  # type: ignore[attr-defined]
    return default


def run_case(
    robot: str, baud: int, transport: str, repeat: int, tmp: Path, tree: str | None
) -> dict[str, Any]:
    """``repeat`` pulls (of this tree, then of ``tree``) and floors, alternating: the
    runs of each client, by name."""
    from machine import SimProcess, process_env, timed_process
    from process import robot_yaml

    locks = tmp / "locks"
    case = f"{robot:9} {baud:>6} {transport}"
    name = f"{robot}-{baud}-{transport}"
    clients: list[tuple[str, str | None]] = [("harlsync", None)]
    if tree:
        clients.append(("against", tree))
    with SimProcess(robot, baud=baud, tcp=transport == "socket") as sim:
        text = robot_yaml(robot, sim.ports[0], yaml_baud(robot, baud, transport))
        sim.record()
        pull(sim, baud, text, tmp / f"{name}-recorded", locks)
        folder = tmp / f"floor-{name}"
        sent = record(sim, robot, folder)
        floor_command = [sys.executable, __file__, "--replay", str(folder)]
        runs: dict[str, list[dict[str, Any]]] = {who: [] for who, _ in clients}
        runs["floor"] = []
        for n in range(repeat):
            for who, source in clients:
                runs[who].append(pull(sim, baud, text, tmp / f"{name}-{who}-{n}", locks, source))
                again = sim.wire()[0][0]
                if again != sent:
                    sys.exit(
                        f"floor: a {who} pull sent other requests: {differ(robot, sent, again)}"
                        f"\nit said:\n{runs[who][-1]['output']}"
                    )
                show(case, who, runs[who][-1])
            runs["floor"].append(timed_process(sim, baud, floor_command, process_env(locks)))
            show(case, "floor", runs["floor"][-1])
    return {"case": case, "baud": baud, "runs": runs}


def summary(result: dict[str, Any]) -> None:
    """The best run of each client, and each harlsync's ratios to the floor."""
    runs = result["runs"]
    floors = runs["floor"]
    floor = min(floors, key=lambda r: r["whole"])
    target = TARGETS.get(result["baud"])

    def cpu(rs: list[dict[str, Any]]) -> float:
        return statistics.median(r["cpu"] / r["exchanges"] for r in rs)

    for who, rs in runs.items():
        best = min(rs, key=lambda r: r["whole"])
        show(result["case"], who, best)
        if who == "floor":
            continue
        ratio = best["whole"] / floor["whole"]
        median = statistics.median(r["whole"] for r in rs) / statistics.median(
            r["whole"] for r in floors
        )
        verdict = "" if target is None else f"{target:.2f} {'PASS' if ratio <= target else 'MISS'}"
        print(
            f"{'':>23} {who:8} ratio {ratio:.3f}, median {median:.3f}, target {verdict}; "
            f"CPU an exchange {cpu(rs) / cpu(floors):.2f} x the floor's"
        )


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
        "--transport",
        default="pty,socket",
        help="comma-separated: pty (robot.yaml at the line's baud rate) and socket "
        "(a device server, robot.yaml at the family's default); default both",
    )
    parser.add_argument(
        "--against", metavar="TREE", help="another harlsync's source tree, alternating too"
    )
    parser.add_argument(
        "--syscalls",
        action="store_true",
        help="instead: one pull and one floor under strace, system calls per exchange (pty)",
    )
    args = parser.parse_args()
    robots, bauds = cases(args, ["default", "max-full"], "default")
    transports = args.transport.split(",")
    if set(transports) - {"pty", "socket"}:
        sys.exit("floor: --transport takes pty and socket")
    tree = str(Path(args.against).resolve()) if args.against else None
    if tree and not (Path(tree) / "harlsync" / "__init__.py").exists():
        sys.exit(f"floor: {tree} holds no harlsync package")
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
        f"alternating, {repeat} of each a case"
        + (f"; `against`: the harlsync of {tree}" if tree else "")
        + "; best of each below the runs\n"
    )
    print(HEAD)
    began = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        results = [
            run_case(r, b, t, repeat, Path(tmp), tree)
            for r in robots
            for b in bauds
            for t in transports
        ]
    print(f"\nbest of {repeat} each")
    print(HEAD)
    for result in results:
        summary(result)
    late = [
        r["late_mean"]
        for result in results
        for rs in result["runs"].values()
        for r in rs
        if r["late_mean"]
    ]
    print(
        "\nstart-up: to the first request byte read; gaps: from each reply's last byte due to "
        "the next request's\nfirst byte read, in all (gap ms: per exchange); save: from the "
        "last reply byte due to the exit.\nCPU us/ex: the client process's user + system CPU "
        "over the exchanges; sim us/ex: the simulator's.\nratio: harlsync's best whole time "
        "over the floor's; median: the same of the medians.  Targets: whole\n1.02 x the floor "
        "at 19200, 1.10 x at 115200; start-up 0.10 s; 0.1 ms a gap; CPU 2 x the floor's.\n"
        "socket: a device server; robot.yaml at the family's default baud rate, not the line's."
    )
    if late:
        print(f"Simulator replies late by {sum(late) / len(late) * 1e6:.0f} us on average (pty).")
    print(f"ran in {minutes(time.monotonic() - began)}; machine at the end: {describe()}")


if __name__ == "__main__":
    main()
