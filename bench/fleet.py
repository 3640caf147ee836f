"""Fleet: a nightly backup of many robots, each on its own line, against the slowest alone.

    python bench/fleet.py                    128 default-full robots at 19200 baud, all
                                             served by one simulator thread: ~2 min
    python bench/fleet.py --quick            32 small-full robots: ~15 s
    python bench/fleet.py --quick --workers 2,1 --rounds 3    one worker against two,
                                             in turn, each round timing one robot alone
                                             too: the ratios of one run, under one load
    python bench/fleet.py --robots 32 --processes 4     the simulators as before issue
                                             15: 8 lines a process, two threads a line
    python bench/fleet.py --workers 1        the backup in one process, as before issue 24
    python bench/fleet.py --split 4 --tick 0.004        4 backups of a share each, and
                                             bytes delivered every 4 ms as a USB
                                             adapter's latency timer does

A simulator (bench/simserver.py) serves every robot on a pty of its own, with wire-time
emulation at the baud rate.  By default one process serves all of them from one
thread and one event loop (``--loop``), so that the simulated lines take as little of
the machine's CPU as they can: ``--processes N`` splits them over N processes of the
framework's servers instead (two threads a line).  Each robot is a project directory
whose robot.yaml names its pty and the baud rate, holding what the robot holds (a
nightly backup with no change).  Each round first backs up one robot alone
(harlsync.sync.backup.backup), then all of them at once, every line at once (the
backup's default) or ``--jobs``, once for each ``--workers`` count.  Every robot
reads the same bytes, so the one alone is the slowest single robot.

The floor (issue 33): in the first round the robot alone's requests and replies are
recorded, and bench/floor.py's bare client (``--replay``: write each request, read
until its reply is there, nothing else) replays them, a process a line, on the first
line alone and then on every line at once, each round, before harlsync's fleet: the
same simulator, the same load.  Printed: its time alone and all at once, and its CPU
an exchange (user + system of every replaying process, ``os.wait4``), beside
harlsync's (every harlsync process of the run: this one, its workers, the git they
ask, over the exchanges the simulator counted), and the simulator's apart.  The last
lines give, per round, harlsync's fleet against one robot alone, the floor's fleet
against its line alone, harlsync's fleet time over the floor's (what the simulators'
cost, which both pay, leaves of harlsync's own) and the CPU ratios.

Printed beside the times: harlsync's CPU during the fleet backup (the worker
processes, one per core by default, and this process, which coordinates them) and
its share of one core; the simulator's CPU and how late its replies were (the
emulation's own error, on top of the figures); the load average.  Then, per
process, from the fleet's debug records (harlsync.sync.fleet) and the simulator's
counts: its lines, the exchanges its share was weighed at and those it made, when
it was ready (imports done) and when its lines' first requests went out (after the
run started), when their last replies were due, the gaps between a reply and the
next request per line, and its CPU.  Load-independent: the exchanges and the CPU.

The simulator runs on the same cores as harlsync: its cost is printed, not kept off
them (there is no third core).

Targets (issue 33): 128 robots at 19200 baud in at most 1.25 x one robot alone with the
simulator on the same cores, and 1.10 x with its cost taken out (here: harlsync's
fleet time over the floor's on the same lines, which pays it too); 32 robots in at
most 1.05 x; CPU per exchange at most 2 x the floor's.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import select
import subprocess
import sys
import tempfile
import time
import tty
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from machine import BITS_PER_BYTE, PYCACHE, ROBOTS, SimProcess, describe, minutes

from harlsync.families.harl_u2.layout import render_robot
from harlsync.families.harl_u2.model import ProgramType
from harlsync.families.harl_u2.protocol import FrameDecoder, commands, encode_frame
from harlsync.project import Project, new_robot, save_project
from harlsync.settings import SerialSettings
from harlsync.sync.backup import BackupReport, backup, line_of
from harlsync.sync.fleet import default_workers

TARGET = 1.25


def one_thread_floor(ports: list[str], seconds: float) -> tuple[int, float, float]:
    """What one thread that drives every line from one epoll loop gets through: each
    line reads MAIN 0's steps in turn (request, wait for the whole reply frame, next),
    raw frames and the codec, no link.  (exchanges, seconds, CPU seconds)."""
    fds = [os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK) for port in ports]
    for fd in fds:
        tty.setraw(fd)
    decoders = {fd: FrameDecoder() for fd in fds}
    frames = [
        encode_frame(1, commands.read_step(ProgramType.MAIN, 0, n).payload) for n in range(64)
    ]
    poller = select.epoll()
    sent = dict.fromkeys(fds, 0)
    for fd in fds:
        poller.register(fd, select.EPOLLIN)
        os.write(fd, frames[0])
    done, start, cpu = 0, time.perf_counter(), os.times()
    while time.perf_counter() - start < seconds:
        for fd, _ in poller.poll(1.0):
            decoder = decoders[fd]
            decoder.feed(os.read(fd, 4096))
            if decoder.next_frame() is not None:
                done += 1
                sent[fd] += 1
                os.write(fd, frames[sent[fd] % 64])
    took, used = time.perf_counter() - start, sum(os.times()[:2]) - sum(cpu[:2])
    time.sleep(0.2)  # the replies still on the wire
    for fd in fds:
        os.close(fd)
    return done, took, used


@dataclass
class Floor:
    """The bare client's run: one line alone, then every line at once."""

    alone: float  # seconds
    alone_per_exchange: float  # CPU seconds
    fleet: float
    per_exchange: float


def floor_record(sim: SimProcess, robot: str, folder: Path) -> None:
    """What the robot alone just sent and got, cut into frames for bench/floor.py's
    bare client (its ``--replay``), and the simulator told to keep no more."""
    from floor import record

    record(sim, robot, folder)
    sim.record(False)


def replay_all(folder: Path, ports: list[str]) -> tuple[float, float]:
    """bench/floor.py's bare client, a process a line, on every port of ``ports`` at
    once: the seconds until the last one ended, and their user + system CPU
    (``os.wait4`` of each)."""
    script = str(Path(__file__).with_name("floor.py"))
    start = time.perf_counter()
    children = [
        subprocess.Popen([sys.executable, script, "--replay", str(folder), port]) for port in ports
    ]
    cpu = 0.0
    for child in children:
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode:
            sys.exit(f"fleet: the bare client on a line exited {child.returncode}")
        cpu += usage.ru_utime + usage.ru_stime
    return time.perf_counter() - start, cpu


def run_floors(sims: list[SimProcess], ports: list[str], folder: Path, exchanges: int) -> Floor:
    """The bare client on the first line alone, then on every line at once; printed."""
    for sim in sims:
        sim.reset()
    alone, alone_cpu = replay_all(folder, ports[:1])
    for sim in sims:
        sim.reset()
    sim_before = sum(sim.stats()[0]["cpu"] for sim in sims)
    fleet, cpu = replay_all(folder, ports)
    stats = [line for sim in sims for line in sim.stats()]
    sim_cpu = sum(sim.stats()[0]["cpu"] for sim in sims) - sim_before
    made = sum(line["exchanges"] for line in stats)
    assert made == exchanges * len(ports), (made, exchanges, len(ports))
    print(
        f"the floor (bench/floor.py's bare client, a process a line): alone {alone:.2f} s, CPU "
        f"{alone_cpu / exchanges * 1e6:.0f} us an exchange; every line at once {fleet:.2f} s "
        f"({fleet / alone:.2f} x alone), CPU {cpu / made * 1e6:.0f} us an exchange; the "
        f"simulator {sim_cpu:.1f} s ({sim_cpu / made * 1e6:.0f} us an exchange)"
    )
    return Floor(alone, alone_cpu / exchanges, fleet, cpu / made)


def thread_per_line_floor(ports: list[str], seconds: float) -> tuple[int, float, float]:
    """The same as :func:`one_thread_floor` by a thread a line in this process, each
    blocking in ``poll`` on its own line (what the link does, without the link)."""
    import threading

    frames = [
        encode_frame(1, commands.read_step(ProgramType.MAIN, 0, n).payload) for n in range(64)
    ]
    counts = [0] * len(ports)
    start = time.perf_counter()
    end = start + seconds

    def line(n: int, port: str) -> None:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(fd)
        poller, decoder = select.poll(), FrameDecoder()
        poller.register(fd, select.POLLIN)
        while time.perf_counter() < end:
            os.write(fd, frames[counts[n] % 64])
            while decoder.next_frame() is None:
                if poller.poll(1000):
                    decoder.feed(os.read(fd, 4096))
            counts[n] += 1
        time.sleep(0.2)  # the reply still on the wire
        os.close(fd)

    cpu = os.times()
    threads = [threading.Thread(target=line, args=(n, p)) for n, p in enumerate(ports)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    took = time.perf_counter() - start - 0.2
    return sum(counts), took, sum(os.times()[:2]) - sum(cpu[:2])


def split_backup(robots: list[Path], parts: int, jobs: int | None) -> BackupReport:
    """``backup`` of ``robots`` in ``parts`` processes at once, each a share; their
    reports joined (robots and durations only)."""
    code = (
        "import json, sys; from pathlib import Path; from harlsync.sync.backup import "
        "backup; jobs = json.loads(sys.argv[1]); r = backup([Path(p) for p in "
        "sys.argv[2:]], **jobs); print(json.dumps([[x.ok, x.duration] for x in "
        "r.robots]))"
    )
    shares = [robots[n::parts] for n in range(parts)]
    extra = json.dumps({} if jobs is None else {"jobs": jobs})
    children = [
        subprocess.Popen(
            [sys.executable, "-c", code, extra, *map(str, share)], stdout=subprocess.PIPE, text=True
        )
        for share in shares
    ]
    done = [json.loads(child.communicate()[0]) for child in children]
    assert all(child.returncode == 0 for child in children)
    return BackupReport(
        [
            SimpleNamespace(ok=ok, duration=took)  # type: ignore[misc]
            for share in done
            for ok, took in share
        ]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="32 small-full robots")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="default: default-full")
    parser.add_argument("--robots", type=int, help="how many (default 128)")
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--jobs", type=int, help="backup's --jobs (default: its default)")
    parser.add_argument(
        "--workers",
        help="backup's --workers (default: its default, one per core); several, "
        "comma-separated (2,1), are run in turn in each round",
    )
    parser.add_argument(
        "--rounds", type=int, default=1, help="rounds of one robot alone, then each --workers"
    )
    parser.add_argument(
        "--processes",
        type=int,
        default=0,
        help="simulator processes of two threads a line (default: one process, one event loop)",
    )
    parser.add_argument(
        "--split",
        type=int,
        default=1,
        metavar="N",
        help="back the fleet up in N processes, each a backup of its share "
        "of the robots (what a process per core would give)",
    )
    parser.add_argument(
        "--floor",
        action="store_true",
        help="then drive every line with raw frames from one thread and one epoll loop, "
        "then from a thread a line, each blocking on its port: one against the other",
    )
    parser.add_argument(
        "--no-floor",
        action="store_true",
        help="no bare client (bench/floor.py's) replaying the requests, alone and on every line",
    )
    parser.add_argument(
        "--tick",
        type=float,
        default=0.0,
        help="the simulators' pacing tick in seconds (default 0.001; a USB "
        "adapter's latency timer delivers bytes every 1-16 ms)",
    )
    args = parser.parse_args()
    robot = args.robot or ("small-full" if args.quick else "default-full")
    count = args.robots or (32 if args.quick else 128)
    counts: list[int | None] = [int(n) for n in args.workers.split(",")] if args.workers else [None]
    processes = args.processes or 1
    per_process = -(-count // processes)
    records: list[dict[str, Any]] = []

    class Figures(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if hasattr(record, "fleet"):
                records.append(record.fleet)

    fleet_log = logging.getLogger("harlsync.sync.fleet")
    fleet_log.setLevel(logging.DEBUG)
    fleet_log.addHandler(Figures())
    fleet_log.propagate = False

    print(f"harlsync fleet bench: {describe()}")
    print(
        f"{count} {robot} robots on separate lines at {args.baud} baud, backup jobs: "
        f"{args.jobs or 'default'}, workers: "
        + ", ".join(str(n or default_workers()) for n in counts)
        + "; simulated by "
        + (
            "one process, one event loop"
            if not args.processes
            else f"{processes} processes of {per_process} lines, two threads a line"
        )
        + f", pacing tick {(args.tick or 0.001) * 1e3:g} ms\n"
    )
    summary: list[str] = []
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as stack:
        # The workers cache their bytecode, as an installed harlsync does (process_env):
        # a shell that sets PYTHONDONTWRITEBYTECODE would have every worker compile
        # harlsync's modules again, about 0.3 s of CPU no plant server pays.
        os.environ["PYTHONPYCACHEPREFIX"] = str(PYCACHE)
        os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
        os.environ["HARLSYNC_LOCK_DIR"] = str(Path(tmp) / "locks")
        os.environ["HARLSYNC_AUDIT_LOG"] = str(Path(tmp) / "audit.jsonl")
        sims = [
            stack.enter_context(
                SimProcess(
                    robot,
                    baud=args.baud,
                    tick=args.tick,
                    lines=min(per_process, count - i),
                    loop=not args.processes,
                )
            )
            for i in range(0, count, per_process)
        ]
        ports = [port for sim in sims for port in sim.ports]
        data = ROBOTS[robot]().data
        plant = Path(tmp) / "plant"
        for n, port in enumerate(ports):
            path = plant / f"robot-{n:03d}"
            bot = new_robot(path.name, port, serial=SerialSettings(baudrate=args.baud))
            save_project(path, Project(path, bot, data))
            assert f"baudrate: {args.baud}" in render_robot(bot)

        for round_ in range(1, args.rounds + 1):
            for sim in sims:
                sim.reset()
            if not args.no_floor and round_ == 1:
                sims[0].record()
            start, cpu = time.perf_counter(), os.times()
            alone = backup([plant / "robot-000"], workers=1)
            single = time.perf_counter() - start
            alone_cpu = sum(os.times()[:4]) - sum(cpu[:4])
            assert alone.ok, alone.render()
            alone_exchanges = sims[0].stats()[0]["exchanges"]
            print(
                f"one robot alone: {single:.2f} s, harlsync's CPU {alone_cpu:.2f} s, "
                f"{alone_cpu / alone_exchanges * 1e6:.0f} us an exchange"
            )
            bare: Floor | None = None
            if not args.no_floor:
                if round_ == 1:
                    floor_record(sims[0], robot, Path(tmp) / "floor")
                bare = run_floors(sims, ports, Path(tmp) / "floor", alone_exchanges)
            for workers in counts:
                label = f"workers {workers or default_workers()}"
                if args.rounds > 1 or len(counts) > 1:
                    print(f"--- round {round_}, {label}")
                took, per_exchange = run_fleet(args, sims, ports, plant, workers, single, records)
                summary.append(
                    f"round {round_}: {label}: "
                    f"{took:.1f} s / {single:.1f} s alone = {took / single:.3f}"
                    + (
                        f"; floor {bare.fleet:.1f} s / {bare.alone:.1f} s = "
                        f"{bare.fleet / bare.alone:.3f}; harlsync / floor: fleet time "
                        f"{took / bare.fleet:.3f}, CPU an exchange {per_exchange / bare.per_exchange:.2f} x "
                        f"(alone {alone_cpu / alone_exchanges / bare.alone_per_exchange:.2f} x)"
                        if bare
                        else ""
                    )
                )
        floor = one_thread_floor(ports, min(single, 10.0)) if args.floor else None
        threaded = thread_per_line_floor(ports, min(single, 10.0)) if args.floor else None
    print("\n" + "\n".join(summary))
    for what, measured in (
        ("One thread, one epoll loop, every line", floor),
        ("A thread a line, each in poll on its own", threaded),
    ):
        if measured:
            done, took, used = measured
            print(
                f"{what} (raw frames, no link, one process): {done / took:,.0f} exchanges/s, "
                f"{used / took:.0%} of one core, {used / done * 1e6:.0f} us an exchange"
            )


def run_fleet(
    args: argparse.Namespace,
    sims: list[SimProcess],
    ports: list[str],
    plant: Path,
    workers: int | None,
    single: float,
    records: list[dict[str, Any]],
) -> tuple[float, float]:
    """Back the fleet up once and print its figures; how long it took, and harlsync's
    CPU an exchange."""
    jobs: dict[str, int] = {} if args.jobs is None else {"jobs": args.jobs}
    if workers is not None:
        jobs["workers"] = workers
    for sim in sims:
        sim.reset()
    sim_before = sum(sim.stats()[0]["cpu"] for sim in sims)
    records.clear()
    load_before = os.getloadavg()
    began = time.monotonic()
    start, cpu = time.perf_counter(), os.times()
    if args.split > 1:
        fleet = split_backup(sorted(plant.iterdir()), args.split, args.jobs)
    else:
        fleet = backup([plant], **jobs)
    total = time.perf_counter() - start
    after = os.times()
    client_cpu = sum(after[:4]) - sum(cpu[:4])  # with the split's or the workers' processes
    own_cpu = sum(after[:2]) - sum(cpu[:2])  # this process alone
    load_after = os.getloadavg()
    stats = [sim.stats() for sim in sims]
    sim_cpu = sum(s[0]["cpu"] for s in stats) - sim_before
    lines = [line for s in stats for line in s]
    assert fleet.ok, fleet.render()
    first = lines[0]
    limit = (first["bytes_in"] + first["bytes_out"]) * BITS_PER_BYTE / args.baud
    durations = sorted(r.duration for r in fleet.robots)
    exchanges = sum(s["exchanges"] for s in lines)
    late = max(s.get("late_worst", 0.0) for s in lines)
    late_mean = sum(s.get("late_mean", 0.0) for s in lines) / len(lines)
    print(f"{'':34} {'seconds':>9} {'/ alone':>8} {'/ limit':>8}")
    print(f"{'line limit of one robot':34} {limit:>9.1f} {limit / single:>8.2f} {1:>8.2f}")
    print(f"{'one robot alone':34} {single:>9.1f} {1:>8.2f} {single / limit:>8.2f}")
    print(f"{'fleet: fastest robot':34} {durations[0]:>9.1f} {durations[0] / single:>8.2f}")
    print(
        f"{'fleet: median robot':34} {durations[len(durations) // 2]:>9.1f} "
        f"{durations[len(durations) // 2] / single:>8.2f}"
    )
    print(f"{'fleet: slowest robot':34} {durations[-1]:>9.1f} {durations[-1] / single:>8.2f}")
    print(f"{'fleet: total':34} {total:>9.1f} {total / single:>8.2f} {total / limit:>8.2f}")
    print(
        f"\n{exchanges:,} exchanges in the fleet backup ({exchanges / total:,.0f}/s); simulator "
        f"replies late by {late_mean * 1e6:.0f} us on average, {late * 1e3:.1f} ms at worst"
    )
    print(
        f"CPU during the fleet backup: harlsync {client_cpu:.1f} s ({client_cpu / total:.0%} of "
        f"one core, {client_cpu / exchanges * 1e6:.0f} us an exchange); the simulator "
        f"{sim_cpu:.1f} s ({sim_cpu / total:.0%} of one core, {sim_cpu / exchanges * 1e6:.0f} us "
        f"an exchange), on {os.cpu_count()} cores; "
        f"load average {load_before[0]:.1f} before, {load_after[0]:.1f} after"
    )
    print(
        f"harlsync's CPU by process: this one {own_cpu:.1f} s ({own_cpu / total:.0%} of a core), "
        f"its children (the workers; git, which a pull asks) {client_cpu - own_cpu:.1f} s "
        f"({(client_cpu - own_cpu) / total:.0%})"
    )
    by_process(records, ports, lines, began)
    print(
        f"Target: fleet total at most {TARGET} x one robot alone ({minutes(single * TARGET)}; "
        "32 lines: 1.05 x), 1.10 x the floor's fleet."
    )
    return total, client_cpu / exchanges


def by_process(
    records: list[dict[str, Any]], ports: list[str], lines: list[dict[str, Any]], began: float
) -> None:
    """Each process's share and what became of it (see the module's text)."""
    if not records:
        return
    index = {line_of(port): n for n, port in enumerate(ports)}
    workers = [r for r in records if r["process"] != "this"]
    theirs = {k for r in workers for k in r["keys"]}
    print(
        f"\n{'process':10} {'lines':>5} {'weighed':>9} {'made':>9} {'ready':>6} "
        f"{'first requests':>15} {'last replies':>15} {'gaps/line':>9} {'CPU':>6}"
    )
    for record in workers + [r for r in records if r["process"] == "this"]:
        if record["process"] == "this":
            keys = [k for k in index if k not in theirs]
            weighed, ready = "", ""
        else:
            keys = record["keys"]
            weighed, ready = f"{record['weight']:,.0f}", f"{record['ready']:.2f}s"
        own = [lines[index[k]] for k in keys if k in index]
        firsts = [s["first_in"] - began for s in own if s.get("first_in") is not None]
        lasts = [s["last_due"] - began for s in own]
        reads = (
            f"{min(firsts):>6.2f}-{max(firsts):.2f} s {min(lasts):>6.2f}-{max(lasts):.2f} s "
            f"{sum(s['gaps'] for s in own) / len(own):>8.2f}s"
            if firsts
            else f"{'':>15} {'':>15} {'':>9}"
        )
        print(
            f"{record['process']:10} {len(own):>5} {weighed:>9} "
            f"{sum(s['exchanges'] for s in own):>9,} {ready:>6} {reads} {record['cpu']:>5.2f}s"
            + (
                f"  (relayed {record['events']:,} events: {record['relay_cpu']:.3f} s of CPU)"
                if record["process"] == "this"
                else ""
            )
        )


if __name__ == "__main__":
    main()
