"""Fleet: a nightly backup of 32 robots, each on its own line, against the slowest one alone.

    python bench/fleet.py                    32 default-full robots at 19200 baud: ~1 min
    python bench/fleet.py --quick            8 small-full robots: ~15 s
    python bench/fleet.py --robot max-full   the full-size robot: ~9 min (2 x 4.3 min)

Simulator processes (bench/simserver.py, 8 lines each, every line its own pty
with wire-time emulation) serve the robots; each robot is a project directory
whose robot.yaml names its pty, holding what the robot holds (a nightly backup
with no change).  First one robot alone is backed up (harlsync.sync.backup.backup),
then all of them at once, with --jobs as given (default: the backup's own
default).  Every robot reads the same bytes, so the one alone is the slowest
single robot; the target is a fleet time at most 1.2 x that.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

from machine import BITS_PER_BYTE, ROBOTS, SimProcess, describe, minutes

from harlsync.project import Project, new_robot, save_project
from harlsync.sync.backup import backup

LINES_PER_PROCESS = 8
TARGET = 1.2


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="8 small-full robots")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="default: default-full")
    parser.add_argument("--robots", type=int, help="how many (default 32)")
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--jobs", type=int, help="backup's --jobs (default: its default)")
    parser.add_argument("--tick", type=float, default=0.0,
                        help="the simulators' pacing tick in seconds (default 0.001; a USB "
                             "adapter's latency timer delivers bytes every 1-16 ms)")
    args = parser.parse_args()
    robot = args.robot or ("small-full" if args.quick else "default-full")
    count = args.robots or (8 if args.quick else 32)
    jobs = {} if args.jobs is None else {"jobs": args.jobs}

    print(f"harlsync fleet bench: {describe()}")
    print(f"{count} {robot} robots on separate lines at {args.baud} baud, "
          f"backup jobs: {args.jobs or 'default'}\n")
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as stack:
        os.environ["HARLSYNC_LOCK_DIR"] = str(Path(tmp) / "locks")
        sims = [stack.enter_context(SimProcess(robot, baud=args.baud, tick=args.tick, lines=min(
            LINES_PER_PROCESS, count - i))) for i in range(0, count, LINES_PER_PROCESS)]
        ports = [port for sim in sims for port in sim.ports]
        data = ROBOTS[robot]().data
        plant = Path(tmp) / "plant"
        for n, port in enumerate(ports):
            path = plant / f"robot-{n:02d}"
            save_project(path, Project(path, new_robot(path.name, port), data))

        start = time.perf_counter()
        alone = backup([plant / "robot-00"], **jobs)
        single = time.perf_counter() - start
        counted = sims[0].stats()[0]
        limit = (counted["bytes_in"] + counted["bytes_out"]) * BITS_PER_BYTE / args.baud
        for sim in sims:
            sim.reset()

        start, cpu = time.perf_counter(), os.times()
        fleet = backup([plant], **jobs)
        total = time.perf_counter() - start
        client_cpu = sum(os.times()[:2]) - sum(cpu[:2])
        stats = [line for sim in sims for line in sim.stats()]
    sims_cpu = sum(os.times()[2:4])  # the simulator processes, now ended: both phases

    assert alone.ok and fleet.ok, (alone.render(), fleet.render())
    durations = sorted(r.duration for r in fleet.robots)
    late = max(s.get("late_worst", 0.0) for s in stats)
    late_mean = sum(s.get("late_mean", 0.0) for s in stats) / len(stats)
    print(f"{'':34} {'seconds':>9} {'/ alone':>8} {'/ limit':>8}")
    print(f"{'line limit of one robot':34} {limit:>9.1f} {limit / single:>8.2f} {1:>8.2f}")
    print(f"{'one robot alone':34} {single:>9.1f} {1:>8.2f} {single / limit:>8.2f}")
    print(f"{'fleet: fastest robot':34} {durations[0]:>9.1f} {durations[0] / single:>8.2f}")
    print(f"{'fleet: median robot':34} {durations[len(durations) // 2]:>9.1f} "
          f"{durations[len(durations) // 2] / single:>8.2f}")
    print(f"{'fleet: slowest robot':34} {durations[-1]:>9.1f} {durations[-1] / single:>8.2f}")
    print(f"{'fleet: total':34} {total:>9.1f} {total / single:>8.2f} {total / limit:>8.2f}")
    print(f"\n{sum(s['exchanges'] for s in stats):,} exchanges; simulator replies late by "
          f"{late_mean * 1e6:.0f} us on average, {late * 1e3:.1f} ms at worst")
    print(f"CPU: harlsync {client_cpu:.1f} s during the fleet backup ({client_cpu / total:.0%} of "
          f"one core); the simulator processes {sims_cpu:.1f} s over both phases "
          f"({sims_cpu / (single + total):.0%} of one core), on {os.cpu_count()} cores")
    print(f"Target: fleet total at most {TARGET} x one robot alone ({minutes(single * TARGET)}).")


if __name__ == "__main__":
    main()
