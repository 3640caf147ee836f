"""Issue 20 item 6, IAI: the disaster-recovery drill, end to end over a real TCP
socket and a real pty against the simulator, as docs/restore.md tells it.

Back the robot up (positions, flags and variables, coordinate systems and string
variables); bring the controller up blank, its memory lost; enter the coordinate
systems on the controller (no message writes them); push the backup (the string
variables too, with 24EH); ``diff`` exits 0, and the simulator's own state equals
the original."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import load_project
from harlsync.sim.serve import PtyServer, TcpServer

from .backups import first_backup

STATION = 0x99


def original() -> SimState:
    state = SimState.generate(11, position_range=(1, 200))  # positions in runs with gaps
    state.work_coordinates = {1: ("100.000", "50.000", "-1.000", "90.000")}
    state.tool_coordinates = {0: ("0.000", "0.000", "35.500", "0.000")}
    state.strings = {n: ord(c) for n, c in zip(range(1, 6), "PLATE")}
    return state


def blank(like: SimState) -> SimState:
    """The same controller with its memory lost: no position, every flag off,
    every variable and record 0; idle."""
    return SimState(
        axes=like.axes,
        model=like.model,
        position_range=like.position_range,
        versions=dict(like.versions),
        real_word_order=like.real_word_order,
    )


def memory(state: SimState) -> dict[str, object]:
    """What a restore must bring back, from the simulator's own record; a value
    that was never set (0, off) counts as absent."""
    return {
        "positions": state.positions,
        "flags": {n for n in state.flags if 600 <= n <= 899},
        "integers": {n: v for n, v in state.integers.items() if 200 <= n <= 299 and v},
        "reals": {n: v for n, v in state.reals.items() if 300 <= n <= 399 and v},
        "work": state.work_coordinates,
        "tool": state.tool_coordinates,
        "strings": {n: code for n, code in state.strings.items() if code},
    }


RANGES = (
    "  work_coordinates: {first: 1, last: 2}\n"
    "  tool_coordinates: {first: 0, last: 0}\n"
    "  strings: {first: 1, last: 32}\n"
)


@pytest.mark.parametrize("transport", ["tcp", "pty"])
def test_issue_20_a_dead_iai_controller_is_restored_from_its_backup(
    repo: Path, transport: str
) -> None:
    server_of = TcpServer if transport == "tcp" else PtyServer
    before = original()
    sim = Simulator({STATION: before})
    server = server_of(sim)
    project = repo / "cell"
    try:
        url = server.start()
        # 1. The nightly backup, as a site keeps it.
        first_backup(project, url, last=200, controller=RANGES, keep_registers=True)
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "nightly backup")
    finally:
        server.stop()
    want = memory(before)

    # 2. The controller dies: a replacement comes up blank on the same line.
    dead = blank(before)
    sim = Simulator({STATION: dead})
    server = server_of(sim)
    try:
        url = server.start()
        # 3. The coordinate systems are entered on the controller (pendant or PC
        # software) from records.yaml: no message harlsync sends writes them.  The
        # string variables come back with the push (24EH, issue 34 item 18).
        data = load_project(project).data
        # (a definition of all zeros is what a blank controller holds already)
        entered = {n: v for n, v in data.work_coordinates.items() if set(v) != {"0.000"}}
        dead.work_coordinates = entered
        dead.tool_coordinates = dict(data.tool_coordinates)
        # 4. Push the backup, flags and variables too; 5. diff says it matches.
        assert cli.main(["push", str(project), "--yes", "--registers", "--port", url]) == 0
        assert cli.main(["diff", str(project), "--registers", "--port", url]) == 0
    finally:
        server.stop()
    assert memory(dead) == want
    assert len(dead.positions) == len(before.positions) > 50
    assert not sim.writes_while_busy() and not sim.off_list()
