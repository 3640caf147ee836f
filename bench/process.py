"""`harlsync pull` as a site runs it, a process of its own: start-up, read and save
against the line limit.

    python bench/process.py                  medium and max-full at 19200 and 115200
                                             baud, first pull and again: ~13 min
    python bench/process.py --quick          medium at 115200: ~15 s
    python bench/process.py --robot medium --baud 19200,115200 --repeat 3

For each robot and baud rate a simulator process (bench/simserver.py) serves the
robot on a pty with wire-time emulation.  The project directory holds a robot.yaml
that names the pty and the baud rate, as a site writes it, and ``harlsync pull DIR``
runs in a process of its own.  ``first``: into a directory with nothing else (a
first backup); ``again``: over the project the first one saved, the robot unchanged
(a nightly backup: the previous project is loaded for the diff before the read).

Times come from the monotonic clock that the bench, the simulator and the pull
share: **start-up** from starting the process to the simulator reading the first
request byte (the interpreter, the imports, robot.yaml, the previous project, the
line lock, opening the port); **read** from there to the moment the last reply byte
is due on the emulated line; **save** from there to the process's exit (the last
reply's decoding, rendering, checking and writing the project, the diff, exiting).
**whole** is all three, against the line limit (bytes both ways x 10 / baud).
**CPU s** is the pull process's user + system time.  With ``--repeat`` the pull with
the best whole time is shown.

Target (issue 15): whole / limit at most 1.03.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from machine import (
    SimProcess,
    bench_robot,
    case_options,
    cases,
    describe,
    harlsync_command,
    minutes,
    process_env,
    timed_process,
)

from harlsync import families

TARGET = 1.03


def robot_yaml(robot: str, port: str, baud: int) -> str:
    """robot.yaml for ``robot`` on ``port`` at ``baud``, as its family writes it."""
    bot = bench_robot(robot, port, baud)
    text = families.get(bot.family).robot_text(bot)
    assert text is not None
    return text


def pull_once(sim: SimProcess, baud: int, project: Path) -> dict[str, Any]:
    """``harlsync pull DIR`` as a process of its own, timed against the simulator's clock."""
    return timed_process(
        sim,
        baud,
        [*harlsync_command(), "pull", str(project)],
        process_env(project.parent / "locks"),
    )


def run_case(robot: str, baud: int, repeat: int, tmp: Path) -> list[dict[str, Any]]:
    """The first pull and a pull again, each the best of ``repeat``."""
    rows = []
    with SimProcess(robot, baud=baud) as sim:
        text = robot_yaml(robot, sim.ports[0], baud)
        for mode in ("first", "again"):
            runs = []
            for r in range(repeat):
                project = tmp / f"{robot}-{baud}-{mode}-{r}"
                if mode == "first":
                    project.mkdir()
                    (project / "robot.yaml").write_text(text)
                else:
                    shutil.copytree(tmp / f"{robot}-{baud}-first-0", project)
                runs.append(pull_once(sim, baud, project))
            rows.append(
                {
                    "robot": robot,
                    "baud": baud,
                    "mode": mode,
                    **min(runs, key=lambda run: run["whole"]),
                }
            )
            show(rows[-1])
    return rows


def show(r: dict[str, Any]) -> None:
    verdict = "PASS" if r["whole"] / r["limit"] <= TARGET else "MISS"
    print(
        f"{r['robot']:12} {r['baud']:>6} {r['mode']:5} {r['exchanges']:>6,} {r['limit']:>8.2f} "
        f"{r['startup']:>8.3f} {r['read']:>7.2f} {r['save']:>6.3f} {r['whole']:>7.2f} "
        f"{r['read'] / r['limit']:>8.3f} {r['whole'] / r['limit']:>9.3f} {r['cpu']:>6.2f}  "
        f"{verdict}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    case_options(parser, ["medium", "max-full"], "medium")
    parser.add_argument("--repeat", type=int, default=1, help="pulls per case (the best is shown)")
    args = parser.parse_args()
    robots, bauds = cases(args, ["medium", "max-full"], "medium")

    print(f"harlsync pull process bench: {describe()}")
    print(
        f"`harlsync pull DIR` as a process of its own, over a pty from a simulator process; "
        f"best of {args.repeat}\n"
    )
    began = time.monotonic()
    print(
        f"{'robot':12} {'baud':>6} {'pull':5} {'exch':>6} {'limit s':>8} {'start-up':>8} "
        f"{'read':>7} {'save':>6} {'whole':>7} {'read/lim':>8} {'whole/lim':>9} {'CPU s':>6}"
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for robot in robots:
            for baud in bauds:
                rows += run_case(robot, baud, args.repeat, Path(tmp))
    late = [r["late_mean"] for r in rows if r["late_mean"]]
    print(
        f"\nTarget: whole/limit at most {TARGET}.  start-up: to the first request byte; read: "
        "to the last reply byte due;\nsave: to the process's exit.  first: a first pull; "
        "again: the same pull over its project."
    )
    if late:
        print(f"Simulator replies late by {sum(late) / len(late) * 1e6:.0f} us on average.")
    print(f"ran in {minutes(time.monotonic() - began)}")


if __name__ == "__main__":
    main()
