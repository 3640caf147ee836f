"""Request economy: what a pull and a push send, by command, against what they must.

    python bench/requests.py                 the default robot: ~5 s
    python bench/requests.py --robot max-full

Counts what the simulator received (sim://, in process: counts, not times) for:

- pull: one request per step, offset table and timer, plus LNX, LNV, LNE, and
  one LNL past the last offset table (no more tables: issue 20);
- push of a known difference: 3 steps, 1 timer and 1 offset table changed on the
  robot since the pull, pushed back.  A push reads LNR once before it reads the
  robot, reads the whole robot to make its plan (and snapshot), then for each
  write: reads the item (drift since the plan), LNR twice (interlock:
  ``profile.IDLE_READS``), the SN write, and reads the item back (verify); and
  LNR twice more after the last write (was the robot started while it was on the
  wire?).  These are the safety design's reads
  (harlsync/sync/engine.py); the expected count is printed next to the count.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from collections import Counter
from pathlib import Path

from machine import ROBOTS, describe

from harlsync.families.harl_u2.model import OFFSET_TABLE_COUNT, OffsetTable, ProgramType, Step
from harlsync.families.harl_u2.protocol import profile
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync.engine import PushOptions, pull, push

STEP_READS = {"LNA", "LNM", "LNS", "LNH"}


def change_robot(state: SimState) -> int:
    """Change 3 steps, 1 timer and 1 offset table on the robot; return the items changed."""
    data = state.data
    for step in (1, 2, 3):
        data.programs[(ProgramType.MAIN, 0)][step] = Step("MOVE", (f"P{900 + step}", "S10"))
    data.timers[0] = "9.99" if data.timers[0] != "9.99" else "1.11"
    data.offsets[5] = OffsetTable("12.34", "0.00", "0.00", "0.00", "0.00", "0.00", "0", "0")
    return 5


def by_kind(counts: Counter[str]) -> Counter[str]:
    """Step reads (LNA/LNM/LNS/LNH) as one row "LN step", step writes as "SN step"."""
    out: Counter[str] = Counter()
    for letters, n in counts.items():
        if letters in STEP_READS:
            out["LN step"] += n
        elif letters in {"SN" + r[2] for r in STEP_READS}:
            out["SN step"] += n
        else:
            out[letters] += n
    return out


def count(sim: Simulator) -> Counter[str]:
    got = Counter(r.command for r in sim.received)
    sim.received.clear()
    return by_kind(got)


def expected_pull(state: SimState) -> Counter[str]:
    config = state.data.config
    return Counter(
        {
            "LNX": 1,
            "LNV": 1,
            "LNE": 1,
            "LN step": config.step_count,
            "LNL": OFFSET_TABLE_COUNT + 1,  # and the probe past the last table
            "LNT": config.timers,
        }
    )


def expected_push(state: SimState, steps: int, others: dict[str, int]) -> Counter[str]:
    """A full read, LNR once before it, per written item: drift read, LNR, write,
    verify read; and LNR once after the last write."""
    writes = steps + sum(others.values())
    expected = expected_pull(state)
    expected["LNR"] += profile.IDLE_READS * (1 + writes + 1)  # each reading: LNR twice
    expected["LN step"] += 2 * steps
    expected["SN step"] += steps
    for letters, n in others.items():
        expected["LN" + letters[2:]] += 2 * n
        expected[letters] += n
    return expected


def show(name: str, got: Counter[str], want: Counter[str]) -> None:
    print(f"{name}:")
    print(f"  {'request':10} {'sent':>8} {'expected':>8}")
    for key in sorted(set(got) | set(want), key=lambda k: (k.startswith("SN"), k)):
        mark = "" if got[key] == want[key] else "   <-- differs"
        print(f"  {key:10} {got[key]:>8,} {want[key]:>8,}{mark}")
    print(f"  {'total':10} {sum(got.values()):>8,} {sum(want.values()):>8,}\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", choices=sorted(ROBOTS), default="default")
    args = parser.parse_args()
    print(f"harlsync request economy bench: {describe()}")
    print(f"robot {args.robot}\n")
    state = ROBOTS[args.robot]()
    sim = Simulator(state)
    url = register(sim)
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["HARLSYNC_LOCK_DIR"] = str(Path(tmp) / "locks")
        os.environ["HARLSYNC_AUDIT_LOG"] = str(Path(tmp) / "audit.jsonl")
        project = Path(tmp) / "robot"
        pull(project, port=url)
        show("pull", count(sim), expected_pull(state))
        change_robot(state)
        push(project, PushOptions(yes=True, allow_dirty=True, outside_window="bench"))
        show(
            "push of 3 steps, 1 timer, 1 table",
            count(sim),
            expected_push(state, 3, {"SNT": 1, "SNL": 1}),
        )
    unregister(url)


if __name__ == "__main__":
    main()
