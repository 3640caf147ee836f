"""Issue 7: a pull and a push send exactly the requests they need, counted by the
simulator, so that a redundant read cannot creep back in unnoticed.  Counts, never
times (bench/requests.py prints the same for a full-size robot)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from harlsync.families.harl_u2.model import (
    OFFSET_TABLE_COUNT,
    Config,
    OffsetTable,
    ProgramArea,
    ProgramType,
    Step,
)
from harlsync.families.harl_u2.protocol.profile import IDLE_READS
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync.engine import PushOptions, pull, push

SMALL = Config(
    ProgramArea(1, 8), ProgramArea(2, 12), ProgramArea(2, 8), ProgramArea(1, 6), 4, 16, 4
)
STEP_LETTERS = {"LNA", "LNM", "LNS", "LNH", "SNA", "SNM", "SNS", "SNH"}


def sent(sim: Simulator) -> Counter[str]:
    """What the simulator received since the last call, steps counted as one kind."""
    got = Counter(
        r.command[:2] + " step" if r.command in STEP_LETTERS else r.command for r in sim.received
    )
    sim.received.clear()
    return got


def full_read(config: Config) -> Counter[str]:
    return Counter(
        {
            "LNX": 1,
            "LNV": 1,
            "LNE": 1,
            "LN step": config.step_count,
            # past the last table (issue 20): table 100, 99 again, 100 again (issue 29)
            "LNL": OFFSET_TABLE_COUNT + 3,
            "LNT": config.timers,
        }
    )


def test_issue7_a_pull_reads_each_step_table_and_timer_once(tmp_path: Path) -> None:
    sim = Simulator(SimState.generate(3, SMALL))
    url = register(sim)
    try:
        pull(tmp_path / "robot", port=url)
    finally:
        unregister(url)
    assert sent(sim) == full_read(SMALL)


def test_issue7_a_push_sends_one_write_and_its_safety_reads_per_changed_item(
    tmp_path: Path,
) -> None:
    state = SimState.generate(3, SMALL)
    sim = Simulator(state)
    url = register(sim)
    try:
        pull(tmp_path / "robot", port=url)
        sim.received.clear()
        for step in (1, 2, 3):  # changed on the robot: the push writes them back
            state.data.programs[(ProgramType.MAIN, 0)][step] = Step("MOVE", (f"P90{step}", "S10"))
        state.data.timers[0] = "9.99" if state.data.timers[0] != "9.99" else "1.11"
        state.data.offsets[5] = OffsetTable("12.34")
        push(tmp_path / "robot", PushOptions(yes=True, allow_dirty=True, outside_window="test"))
    finally:
        unregister(url)
    # LNR before reading the robot, the full read for the plan; then per item: a read
    # for drift, LNR for the interlock, the write, and a read to verify it; and LNR once
    # more after the last write (was the robot started while it was on the wire?).
    # Each interlock reading is IDLE_READS LNRs in a row (issue 19: the LRC misses two
    # flipped bits in one column).
    lnr = IDLE_READS * (1 + 5 + 1)
    expected = full_read(SMALL) + Counter(
        {"LNR": lnr, "LN step": 2 * 3, "SN step": 3, "LNT": 2, "SNT": 1, "LNL": 2, "SNL": 1}
    )
    assert sent(sim) == expected
