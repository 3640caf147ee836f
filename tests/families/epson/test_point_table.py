"""Issue 29 and issue 34 item 12, for Epson points: where the controller's point
table ends is found from its own behaviour, what a point that is not there answers
is learned (the manual gives no code for it) and recorded in controller.yaml, and
a first pull takes in the points it finds past its default range.

Every check of what the controller was asked reads the simulator's own record."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.families.base import AnyFamily
from harlsync.families.epson.sim import SimState, Simulator
from harlsync.project import load_project

from .conftest import TEST_PROBE_END
from .projects import pulled
from .sample import sample_data


def serve(sim: Simulator) -> Iterator[tuple[Simulator, str]]:
    with sim.serve() as server:
        yield sim, server.url
    assert sim.off_list() == [] and sim.function_errors == []
    assert [c for c in sim.commands() if c.is_write] == []  # a pull never writes


@pytest.fixture
def robot() -> Iterator[tuple[Simulator, str]]:
    """The sample robot (P0, P12, P13) on the simulator."""
    yield from serve(Simulator(SimState.from_data(sample_data()), execution_time=0.0))


def point_reads(sim: Simulator, since: int = 0) -> list[tuple[int, int]]:
    """Every 1222 the simulator took from ``since``: (point, axis)."""
    found = []
    for c in sim.commands()[since:]:
        if c.number == 1222:
            words = [int(w, 16) for w in c.payload.split()]
            found.append((words[1], words[2]))
    return found


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    assert "Traceback" not in lines[0]
    return lines[0]


def test_issue_29_the_answers_past_the_table_and_of_a_point_not_defined_are_recorded(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = robot
    sim.vary({"undefined_point": "200A", "past_points": "2005"})
    sim.point_end = TEST_PROBE_END
    project = pulled(repo, url)
    text = (project / "controller.yaml").read_text()
    assert "points: {end: 199, past_end: 2005/0000, not_defined: 200A/1BBF}" in text
    table = load_project(project).data.table
    assert table is not None and (table.end, str(table.past_end)) == (199, "2005/0000")
    assert cli.main(["diff", str(project)]) == 0


def test_issue_29_an_answer_past_the_table_that_changes_fails_the_pull_in_one_line_naming_both(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A later pull (and diff, and push) whose controller answers a point past its
    point table otherwise than controller.yaml records is refused in one line naming
    both answers and what to do; nothing is saved."""
    sim, url = robot
    sim.point_end = TEST_PROBE_END
    project = pulled(repo, url)
    before = {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()}
    sim.vary({"past_points": "2005"})
    capsys.readouterr()
    assert cli.main(["pull", str(project)]) == 3
    line = one_line(capsys.readouterr().err)
    assert "answer past the point table '2005/0000 (table number specification error)'" in line
    assert "(the backup has '2004/0000 (parameter error)')" in line
    assert f"'harlsync pull {project} --new-robot'" in line
    assert {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()} == before
    taken = len(sim.commands())
    assert cli.main(["diff", str(project)]) == 2
    line = one_line(capsys.readouterr().err)
    assert "answers a point past its point table with 2005/0000" in line
    assert "controller.yaml records 2004/0000 (parameter error)" in line
    # refused at its first exchanges: the manipulator, the model, P200 twice and P199
    assert len(sim.commands()) - taken < 20
    assert cli.main(["pull", str(project), "--new-robot"]) == 0
    assert "past_end: 2005/0000" in (project / "controller.yaml").read_text()


def test_issue_29_a_not_defined_answer_that_changes_fails_the_pull_in_one_line_naming_both(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """What a point not defined answers is recorded (controller.yaml
    ``points.not_defined``) and compared once a later read is over
    (``Catalogue.other_robot``, as the HARL-U2's offset-table end and IAI's "not
    there" replies): a pull (and diff) whose controller answers otherwise is refused
    in one line naming both answers, the setting that records the expected one and
    what to do; nothing is saved."""
    sim, url = robot
    sim.point_end = TEST_PROBE_END
    project = pulled(repo, url)
    assert "not_defined: 2004/0000" in (project / "controller.yaml").read_text()
    before = {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()}
    sim.vary({"undefined_point": "200A"})  # the same table end, another "not defined"
    capsys.readouterr()
    assert cli.main(["pull", str(project)]) == 3
    line = one_line(capsys.readouterr().err)
    assert "a point not defined now answers 200A/1BBF" in line
    assert "controller.yaml points.not_defined records 2004/0000 (parameter error)" in line
    assert f"'harlsync pull {project} --new-robot'" in line
    assert {p.name: p.read_bytes() for p in project.iterdir() if p.is_file()} == before
    assert cli.main(["diff", str(project)]) == 2
    line = one_line(capsys.readouterr().err)
    assert "not compared: a point not defined now answers 200A/1BBF" in line
    assert "points.not_defined records 2004/0000" in line
    assert cli.main(["pull", str(project), "--new-robot"]) == 0
    assert "not_defined: 200A/1BBF" in (project / "controller.yaml").read_text()


def test_issue_29_a_point_table_smaller_than_robot_yaml_says_is_read_to_its_end_and_recorded(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    """The controller's table ends at P149, robot.yaml (the tests' profile) says
    P199: the pull reads to P149, finds P150 answering as the point past the table
    does (twice), stops there, records end 149 and says so; not failed."""
    sim, url = robot
    sim.vary({"undefined_point": "200A"})
    sim.point_end = 149
    project = pulled(repo, url)
    taken = len(sim.commands())
    result = cli_pull(project)
    assert "the controller's points end at P149: P150 answered 2004/0000" in result
    assert "points: {end: 149, past_end: 2004/0000, not_defined: 200A/1BBF}" in (
        (project / "controller.yaml").read_text()
    )
    assert "P0-P29 read, none defined P30-P149 when pulled" in (
        (project / "points.yaml").read_text()
    )
    numbers = [n for n, axis in point_reads(sim, taken) if axis == 0]
    assert max(numbers) == 200 and numbers.count(150) == 2  # P200, past robot.yaml's end
    # nothing read past the real end but P199, robot.yaml's last, at the end probe
    assert [n for n in numbers if 151 <= n <= 199] == [199]


def cli_pull(project: Path) -> str:
    """Pull ``project`` and return the contents line it would print."""
    from harlsync.sync import engine

    result = engine.pull(project)
    return result.contents


@pytest.mark.parametrize(
    "variant",
    [{}, {"undefined_point": "200A", "past_points": "2005"}, {"undefined_point": "2000"}],
    ids=["profile", "200A-2005", "2000"],
)
def test_issue_29_finding_the_table_end_costs_a_few_exchanges_beyond_the_tables_own_reads(
    robot: tuple[Simulator, str], repo: Path, variant: dict[str, str]
) -> None:
    """A pull reads each point number of the table once (its X); the end probe and
    the second asking of what a point not defined answers add at most four."""
    sim, url = robot
    sim.vary(variant)
    sim.point_end = TEST_PROBE_END
    project = pulled(repo, url)
    taken = len(sim.commands())
    cli_pull(project)
    firsts = [n for n, axis in point_reads(sim, taken) if axis == 0]
    assert set(firsts) == set(range(TEST_PROBE_END + 2))  # P0-P199, and P200
    assert len(firsts) - (TEST_PROBE_END + 1) <= 4


def test_issue_29_a_point_past_the_table_end_fails_the_pull_naming_the_setting(
    robot: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = robot
    project = pulled(repo, url)
    before = (project / "points.yaml").read_text()
    st = sim.stations[1]
    st.points[TEST_PROBE_END + 1] = st.points[12]
    capsys.readouterr()
    assert cli.main(["pull", str(project)]) == 2
    line = one_line(capsys.readouterr().err)
    assert "P200 is defined: the controller's points go past P199" in line
    assert "set controller.point_table_end in robot.yaml" in line
    assert (project / "points.yaml").read_text() == before


def test_issue_34_a_first_pull_takes_in_points_past_its_default_range_and_says_so(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 34 item 12: a first pull of the simulator's default robot (points past
    P99) failed, naming a robot.yaml that did not exist yet.  It takes them in,
    writes the range into robot.yaml, and says so; later pulls keep to robot.yaml."""
    sim = Simulator(SimState.generate(3), execution_time=0.0)
    assert max(sim.stations[1].points) > 99
    for _ in serve(sim):
        url = sim.server.url if sim.server else ""
        project = repo / "cell"
        capsys.readouterr()
        assert cli.main(["pull", str(project), "--family", "epson", "--port", url]) == 0
        top = max(sim.stations[1].points)
        robot_yaml = (project / "robot.yaml").read_text()
        assert f"  last_point: {top}\n" in robot_yaml
        assert set(load_project(project).data.points()) == set(sim.stations[1].points)
        said = cli_pull(project)
        assert "taken in" not in said  # a later pull keeps to robot.yaml's range
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "backup")
        from harlsync.sync import engine

        project2 = repo / "cell-2"
        result = engine.pull(project2, port=url, family=_epson())
        low = min(n for n in sim.stations[1].points if n > 99)
        assert f"P{low}-P{top} found past the default range and taken in" in result.contents
        assert f"last_point {top}" in result.contents


def _epson() -> AnyFamily:
    from harlsync import families

    return families.get("epson")


def test_issue_29_a_slave_that_applies_a_write_whole_is_a_robot_yaml_setting(
    robot: tuple[Simulator, str], repo: Path
) -> None:
    """Issue 29 item 3: the README told a site to set profile.BLOCK_WRITE_WHOLE, an
    edit of harlsync's source.  robot.yaml ``connection.writes_whole: true`` sends a
    command's words and ExtCmdSet in one Modbus write (the default map), false (the
    default) in two, the words first."""
    sim, url = robot
    project = pulled(repo, url)
    assert "  writes_whole: false\n" in (project / "robot.yaml").read_text()

    def command_writes() -> list[tuple[int, int]]:
        sim.remote().log.clear()
        assert cli.main(["diff", str(project)]) == 0
        return sorted({(a.address, a.count) for a in sim.remote().log if a.kind == "write"})

    assert command_writes() == [(0, 1), (1, 8)]  # ExtCmdSet alone, the words alone
    path = project / "robot.yaml"
    path.write_text(path.read_text().replace("writes_whole: false", "writes_whole: true"))
    assert command_writes() == [(0, 1), (0, 9)]  # ExtCmdSet with the words, in one
