"""Issue 23: a program is a sequence of steps.  A step inserted on the pendant reads
as one step inserted: in the backup's git diff, in ``harlsync diff`` and in ``plan``."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git
from test_sync import pulled

from harlsync.alignment import align
from harlsync.cli import main
from harlsync.families.harl_u2.catalogue import CATALOGUE, StepKey
from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.project import load_project
from harlsync.sim.serve import TcpServer
from harlsync.sync import PushOptions, engine

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
    project = pulled(repo, url)
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
    project = pulled(repo, url)
    delete_step(sim.stations[1].data.programs[(MAIN, 0)], 6)
    engine.pull(project, commit=True)

    assert changed_lines(repo, "HEAD~1", "HEAD") == [f"-  - {PROGRAM[6]}"]


def pulled_then_inserted_in_project(
    robot: tuple[Simulator, str], repo: Path, at: int
) -> tuple[Path, str]:
    """A project pulled from the robot, then a step inserted at ``at`` in its MAIN 0
    file, as a programmer edits it: one line added, nothing renumbered."""
    _, url = robot
    project = repo / "cell"
    engine.pull(project, port=url)
    path = project / "programs" / "main-00.yaml"
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    first = next(i for i, line in enumerate(lines) if line.startswith("  - "))
    lines.insert(first + at, f"  - {INSERTED}\n")
    path.write_text("".join(lines), encoding="utf-8")
    return project, url


def test_diff_shows_an_inserted_step_as_one_insertion_with_the_steps_it_shifts(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    project, url = pulled_then_inserted_in_project(robot, repo, 4)
    capsys.readouterr()
    assert main(["diff", str(project), "--port", url]) == 1
    out = capsys.readouterr().out
    body = [line for line in out.splitlines() if line.startswith(("@@", "+", "-"))][2:]
    assert body == [
        "@@ MAIN program 0: insert at 4 (steps 4-16 move to 5-17) @@",
        f"+4: {INSERTED}",
    ]


def test_diff_shows_a_deleted_and_a_moved_step_as_such(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, url = robot
    project = repo / "cell"
    engine.pull(project, port=url)
    path = project / "programs" / "main-00.yaml"
    text = path.read_text(encoding="utf-8")
    # Delete step 2 and move step 10 to after step 12.
    text = text.replace(f"  - {PROGRAM[2]}\n", "")
    text = text.replace(f"  - {PROGRAM[10]}\n", "")
    text = text.replace(f"  - {PROGRAM[12]}\n", f"  - {PROGRAM[12]}\n  - {PROGRAM[10]}\n")
    path.write_text(text, encoding="utf-8")
    capsys.readouterr()
    assert main(["diff", str(project), "--port", url]) == 1
    body = [line for line in capsys.readouterr().out.splitlines() if line[:1] in "@+-"][2:]
    assert body == [
        (
            "@@ MAIN program 0: delete at 2, move 10 to 11 (steps 3-9 move to 2-8; steps 11-12 "
            "move to 9-10; steps 13-16 move to 12-15) @@"
        ),
        f"-2: {PROGRAM[2]}",
        f"-10: {PROGRAM[10]}",
        f"+11: {PROGRAM[10]}",
    ]


def test_plan_says_an_insertion_rewrites_the_steps_it_shifts_and_the_push_writes_just_those(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project, url = pulled_then_inserted_in_project(robot, repo, 4)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "insert a step at 4")
    capsys.readouterr()
    assert main(["plan", str(project), "--port", url]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "# note: MAIN program 0: insert at 4: rewrites steps 4-17" in out
    # Without -v the plan shows the insertion as diff does, and the count of writes.
    assert "+4: WAIT DI05 ON" in out and not any("SNM" in line for line in out)
    assert out[-1].startswith("# 14 item(s) to ")
    assert main(["-v", "plan", str(project), "--port", url]) == 0
    shown = capsys.readouterr().out.splitlines()
    writes = [line.partition(": ")[2] for line in shown if ": SNM " in line]
    # Minimal: one SN write per step whose content changed (4-17), nothing else.
    assert len(writes) == 14
    assert all(line.startswith("SNM 0 ") for line in writes)
    assert [int(line.split()[2]) for line in writes] == list(range(4, 18))

    before = len(sim.writes_received())
    result = engine.push(project, PushOptions(yes=True))
    assert len(sim.writes_received()) - before == 14
    assert "MAIN program 0: insert at 4: rewrites steps 4-17" in result.notes
    expected = [*PROGRAM[:4], INSERTED, *PROGRAM[4:]]
    steps = sim.stations[1].data.programs[(MAIN, 0)]
    assert [steps[n].text for n in sorted(steps) if not steps[n].empty] == expected
    assert engine.compare(project).changes == []  # verified: the robot is the project


def _changes(old: list[str], new: list[str]) -> list[tuple[StepKey, object, object]]:
    size = max(len(old), len(new))
    a = [*old, *[None] * (size - len(old))]
    b = [*new, *[None] * (size - len(new))]
    return [
        (StepKey("step", "MAIN", 0, n), x and Step.parse(x), y and Step.parse(y))
        for n, (x, y) in enumerate(zip(a, b))
        if x != y
    ]


def test_a_step_moved_is_one_move_and_a_step_edited_in_place_or_added_at_the_end_no_shift() -> None:
    old = [f"MOVE P{n:03d} S50" for n in range(10)]
    moved = old[:3] + old[4:8] + [old[3]] + old[8:]
    [shift] = align(CATALOGUE, _changes(old, moved))
    assert (shift.what, shift.moved, shift.rewrites) == (
        "move 3 to 7",
        ["steps 4-7 move to 3-6"],
        [3, 4, 5, 6, 7],
    )
    assert shift.lines == [("-", 3, old[3]), ("+", 7, old[3])]
    edited = [*old[:5], "END", *old[6:]]
    assert align(CATALOGUE, _changes(old, edited)) == []
    assert align(CATALOGUE, _changes(old, [*old, "END"])) == []
    assert align(CATALOGUE, _changes(old, old[:-1])) == []


def test_a_pull_into_a_format_1_backup_writes_format_2_with_the_same_steps(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    _, url = robot
    project = pulled(repo, url)
    path = project / "programs" / "main-00.yaml"
    # The file as format 1 wrote it: steps keyed by number.
    format_1 = "".join(
        [
            "# yaml-language-server: $schema=../.schemas/program.schema.json\n",
            "format: 1\ntype: MAIN\nnumber: 0\nsteps:\n",
            *(f"  {n}: {text}\n" for n, text in enumerate(PROGRAM)),
        ]
    )
    format_2 = path.read_text(encoding="utf-8")
    path.write_text(format_1, encoding="utf-8")
    git(repo, "commit", "-qam", "as format 1 wrote it")
    assert load_project(project).data.programs[(MAIN, 0)] == {
        n: Step.parse(t) for n, t in enumerate(PROGRAM)
    }

    engine.pull(project, commit=True)
    assert path.read_text(encoding="utf-8") == format_2
