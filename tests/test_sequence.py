"""Issue 23: a program is a sequence of steps.  A step inserted on the pendant reads
as one step inserted: in the backup's git diff, in ``harlsync diff`` and in ``plan``."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.serve import TcpServer
from harlsync.sync import engine

MAIN = ProgramType.MAIN
#: Room for a 17-step MAIN program and a step more.
CONFIG = Config(
    ProgramArea(1, 8), ProgramArea(2, 24), ProgramArea(1, 8), ProgramArea(1, 6), 4, 16, 4
)
#: MAIN 0 as the issue tells it: 17 steps, every one different.
PROGRAM = [
    "OFFSET L00",
    *(f"MOVE P{n:03d} S{50 + n}" for n in range(1, 16)),
    "END",
]
INSERTED = "WAIT DI05 ON"


@pytest.fixture
def robot() -> Iterator[tuple[Simulator, str]]:
    state = SimState.generate(23, CONFIG)
    state.data.programs[(MAIN, 0)] = {n: Step.parse(t) for n, t in enumerate(PROGRAM)}
    sim = Simulator(state)
    server = TcpServer(sim)
    server.start()
    try:
        yield sim, server.url
    finally:
        server.stop()


def insert_step(steps: dict[int, Step], at: int, step: Step) -> None:
    """What inserting a line on the pendant does: every later step moves down one."""
    for n in sorted((n for n in steps if n >= at), reverse=True):
        steps[n + 1] = steps.pop(n)
    steps[at] = step


def delete_step(steps: dict[int, Step], at: int) -> None:
    """What deleting a line on the pendant does: every later step moves up one."""
    del steps[at]
    for n in sorted(n for n in steps if n > at):
        steps[n - 1] = steps.pop(n)


def changed_lines(repo: Path, *args: str) -> list[str]:
    """The ``+``/``-`` lines of a git diff, without its file headers."""
    out = git(repo, "diff", "--no-color", *args)
    return [
        line
        for line in out.splitlines()
        if line[:1] in "+-" and not line.startswith(("+++", "---"))
    ]


def test_a_step_inserted_on_the_pendant_is_one_added_line_in_the_backups_git_diff(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    project = repo / "cell"
    engine.pull(project, port=url)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "first backup")

    insert_step(sim.stations[1].data.programs[(MAIN, 0)], 4, Step.parse(INSERTED))
    engine.pull(project, commit=True)

    # 17 steps, one inserted at step 4: one line added, none of the 13 after it changed.
    assert changed_lines(repo, "HEAD~1", "HEAD") == [f"+  - {INSERTED}"]
    assert git(repo, "diff", "--stat", "HEAD~1", "HEAD").splitlines()[-1].strip() == (
        "1 file changed, 1 insertion(+)"
    )


def test_a_step_deleted_on_the_pendant_is_one_removed_line(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    project = repo / "cell"
    engine.pull(project, port=url)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "first backup")

    delete_step(sim.stations[1].data.programs[(MAIN, 0)], 6)
    engine.pull(project, commit=True)

    assert changed_lines(repo, "HEAD~1", "HEAD") == [f"-  - {PROGRAM[6]}"]
