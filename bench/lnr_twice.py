"""What a second LNR read before each HARL-U2 write costs (issue 19, 6c).

    python bench/lnr_twice.py              9600, 19200 and 115200 baud, best of 3 (~2 min)
    python bench/lnr_twice.py --repeat 1   once each (~45 s)

The LRC is an XOR of the frame's bytes: two flipped bits in one bit column pass
it, so an LNR reply ``1 MAIN 3 7`` (a task in execution) can arrive as
``0 MAIN 3 6`` (stopped).  ``profile.IDLE_READS`` says how many LNR replies in a
row must show the robot idle before a write.  This script measures, against the
simulator with wire-time emulation (each reply's last byte is due when the line
would have carried it), at each speed:

- one LNR exchange (request and 20-field reply), mean of 20;
- a typical push: 12 steps of one MAIN program, 1 timer and 1 offset table
  changed on the robot since the pull (14 writes), pushed back, with
  ``IDLE_READS`` = 1 and = 2; the push reads the whole (small) robot first, so
  the write phase is the push less a pull of the same robot;
- what the second read adds per write and to the push, and the LNR requests the
  simulator received.

Wire time only: the controller's own turnaround, which the manual does not give,
adds the same to every exchange (and so one more per write with two reads).
"""

from __future__ import annotations

import argparse
import copy
import os
import tempfile
import time
from pathlib import Path

from machine import describe

from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.model import Config, OffsetTable, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.protocol import profile
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync.engine import PushOptions, pull, push

BAUDS = (9600, 19200, 115200)
#: A small cell: 54 steps, so the push's read of the whole robot stays short.
CONFIG = Config(
    ProgramArea(1, 8), ProgramArea(2, 12), ProgramArea(2, 8), ProgramArea(1, 6), 4, 16, 4
)
STEPS_CHANGED = 12
WRITES = STEPS_CHANGED + 2
OPTS = PushOptions(yes=True, allow_dirty=True, outside_window="bench")


def changed(state: SimState) -> SimState:
    """The robot after a pendant edit: 12 MAIN 0 steps, timer 0 and offset table 5."""
    out = copy.deepcopy(state)
    data = out.data
    for step in range(STEPS_CHANGED):
        data.programs[(ProgramType.MAIN, 0)][step] = Step("MOVE", (f"P{900 + step}", "S10"))
    data.timers[0] = "9.99" if data.timers[0] != "9.99" else "1.11"
    data.offsets[5] = OffsetTable("12.34", "0.00", "0.00", "0.00", "0.00", "0.00", "0", "0")
    return out


def lnr_time(url: str) -> float:
    with Controller.from_url(url) as robot:
        robot.status()  # the link learns the reply's length first
        start = time.perf_counter()
        for _ in range(20):
            robot.status()
        return (time.perf_counter() - start) / 20


def timed_pull(url: str, into: Path) -> float:
    start = time.perf_counter()
    pull(into, port=url)
    return time.perf_counter() - start


def timed_push(sim: Simulator, edited: SimState, project: Path, url: str, reads: int) -> float:
    profile.IDLE_READS = reads
    sim.stations[1] = copy.deepcopy(edited)
    start = time.perf_counter()
    push(project, OPTS, port=url)
    took = time.perf_counter() - start
    assert sim.stations[1].data.timers[0] != edited.data.timers[0], "the push wrote nothing"
    return took


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of each push (best kept)")
    args = parser.parse_args()
    print(f"harlsync second-LNR bench: {describe()}")
    print(
        f"robot: {CONFIG.step_count} steps, {CONFIG.timers} timers, 100 offset tables; "
        f"push of {WRITES} writes ({STEPS_CHANGED} steps, 1 timer, 1 table); "
        f"best of {args.repeat}\n"
    )
    header = (
        f"{'baud':>7} {'LNR ms':>7} {'write ms (1 LNR)':>17} {'write ms (2 LNR)':>17} "
        f"{'+ms/write':>10} {'pull s':>7} {'push s (1)':>11} {'push s (2)':>11} {'+push':>7} "
        f"{'LNR sent':>9}"
    )
    print(header)
    kept = profile.IDLE_READS
    state = SimState.generate(19, CONFIG)
    edited = changed(state)
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["HARLSYNC_LOCK_DIR"] = str(Path(tmp) / "locks")
        os.environ["HARLSYNC_AUDIT_LOG"] = str(Path(tmp) / "audit.jsonl")
        project = Path(tmp) / "robot"
        fast = Simulator(copy.deepcopy(state))
        fast_url = register(fast)
        pull(project, port=fast_url)
        unregister(fast_url)
        try:
            for baud in BAUDS:
                sim = Simulator(copy.deepcopy(state), baudrate=baud)
                url = register(sim)
                try:
                    lnr = lnr_time(url)
                    read = timed_pull(url, Path(tmp) / f"pull-{baud}")
                    pushes: dict[int, float] = {}
                    sent: dict[int, int] = {}
                    for reads in (1, 2):
                        runs = []
                        for _ in range(args.repeat):
                            sim.received.clear()
                            runs.append(timed_push(sim, edited, project, url, reads))
                            sent[reads] = sum(r.command == "LNR" for r in sim.received)
                        pushes[reads] = min(runs)
                finally:
                    unregister(url)
                one, two = ((pushes[r] - read) / WRITES * 1000 for r in (1, 2))
                print(
                    f"{baud:>7} {lnr * 1000:>7.1f} {one:>17.1f} {two:>17.1f} {two - one:>10.1f} "
                    f"{read:>7.2f} {pushes[1]:>11.2f} {pushes[2]:>11.2f} "
                    f"{(pushes[2] / pushes[1] - 1) * 100:>6.0f}% "
                    f"{sent[1]:>4}/{sent[2]:<4}"
                )
        finally:
            profile.IDLE_READS = kept
    print(
        "\nwrite ms: (push - pull of the same robot) / writes: the drift read, the LNR "
        "read(s), the SN write and the verify read."
    )


if __name__ == "__main__":
    main()
