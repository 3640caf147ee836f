"""Issue 29 for the HARL-U2: where the offset tables end is the controller's own answer.

LNX does not report how many offset tables a controller has, and the manual gives
no status codes (3.1.7: "E" + [Status], the codes in the HRCS-R3 manual), so a
pull no longer waits for the profile's ``E21``.  The table past the last that read
normally must answer the same error reply twice, with that last table read
normally again between the two; that reply is recorded in controller.yaml, later
reads (pull, diff, push) compare the controller's with it once they are over
(``Catalogue.other_robot``), and robot.yaml's ``no_such_table`` may pin it.  A controller with fewer tables than robot.yaml's
``offset_tables`` is read to its end and recorded.  What each test asserts of the
controller it takes from the simulator's own record.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from simline import SMALL, Act, ScriptedSim

from harlsync.cli import main
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine
from harlsync.sync.deploy import PushFailed, PushOptions, push


def tables_asked(sim: Simulator) -> list[str]:
    """The LNL requests the simulator answered, in order."""
    with sim.lock:
        return [r.payload for r in sim.received if r.command == "LNL"]


@pytest.fixture
def served() -> Iterator[tuple[ScriptedSim, str]]:
    """A small generated robot with the profile's answers, on a ``sim://`` URL."""
    sim = ScriptedSim(SimState.generate(5, SMALL))
    url = register(sim)
    yield sim, url
    unregister(url)


def files(project: Path) -> dict[str, bytes]:
    return {p.relative_to(project).as_posix(): p.read_bytes() for p in project.rglob("*.yaml")}


def one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


def test_issue_29_a_controller_that_answers_e2_for_a_missing_table_is_pulled_and_e2_recorded(
    served: tuple[ScriptedSim, str], tmp_path: Path
) -> None:
    sim, url = served
    sim.vary({"missing_table": "E2"})
    project = tmp_path / "cell"
    result = engine.pull(project, port=url)
    assert "100 offset tables (0-99, no table 100: E2 twice)" in result.contents
    controller = (project / "controller.yaml").read_text()
    assert "offset_tables: {count: 100, no_such_table: E2}" in controller
    # table 100, table 99 read normally again, table 100 again: three exchanges past the tables
    assert tables_asked(sim) == [*(f"LNL {n}" for n in range(100)), "LNL 100", "LNL 99", "LNL 100"]
    assert main(["validate", str(project)]) == 0
    assert main(["diff", str(project)]) == 0
    assert not sim.writes_received()


def test_issue_29_a_controller_with_fewer_offset_tables_is_read_to_its_end_and_recorded(
    served: tuple[ScriptedSim, str], tmp_path: Path
) -> None:
    sim, url = served
    sim.vary({"offset_tables": "64"})
    project = tmp_path / "cell"
    result = engine.pull(project, port=url)
    assert (
        "64 offset tables (0-63, no table 64: E21 twice; fewer than robot.yaml's offset_tables: 100)"
    ) in result.contents
    assert (
        "offset_tables: {count: 64, no_such_table: E21}"
        in (project / "controller.yaml").read_text()
    )
    offsets = (project / "offsets.yaml").read_text()
    assert "\n  63: {" in offsets and "\n  64: {" not in offsets
    assert tables_asked(sim)[-4:] == ["LNL 63", "LNL 64", "LNL 63", "LNL 64"]
    assert len(tables_asked(sim)) == 64 + 3  # no table past the end asked for
    assert main(["validate", str(project)]) == 0
    assert main(["diff", str(project)]) == 0
    assert not sim.writes_received()


def test_issue_34_item_6_offset_tables_101_on_a_100_table_controller_reads_the_100_it_has(
    served: tuple[ScriptedSim, str], tmp_path: Path
) -> None:
    sim, url = served
    project = tmp_path / "cell"
    project.mkdir()
    (project / "robot.yaml").write_text(
        f"format: 2\nname: cell\nconnection:\n  port: {url}\n  station: 1\noffset_tables: 101\n"
    )
    contents = engine.pull(project).contents
    assert "fewer than robot.yaml's offset_tables: 101" in contents
    assert (
        "offset_tables: {count: 100, no_such_table: E21}"
        in (project / "controller.yaml").read_text()
    )
    assert main(["validate", str(project)]) == 0
    assert main(["diff", str(project)]) == 0
    assert main(["pull", str(project)]) == 0  # and again, through the command
    assert not sim.writes_received()


def test_issue_29_a_no_such_table_reply_that_changes_between_pulls_fails_in_one_line_naming_both(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = tmp_path / "cell"
    assert main(["pull", str(project), "--port", url]) == 0
    before = files(project)
    sim.vary({"missing_table": "E2"})  # the same robot, answering otherwise now
    sim.stations[1].data.timers[0] = "7.77"  # a change the failed pull must not save
    capsys.readouterr()
    assert main(["pull", str(project)]) == 3  # refused once the read is over, as IAI's and Epson's
    err = one_line(capsys)
    assert "offset table 100 answered E2 twice, not E21" in err
    assert "controller.yaml offset_tables" in err  # where the E21 it expected comes from
    assert "set no_such_table: E2 in robot.yaml" in err  # what to do
    assert "harlsync's" not in err and "profile" not in err  # no edit of harlsync's source
    assert files(project) == before
    robot = project / "robot.yaml"  # what the line says to do takes the reply it names
    robot.write_text(robot.read_text() + "no_such_table: E2\n")
    assert main(["pull", str(project), "--allow-dirty"]) == 0
    assert "offset_tables: {count: 100, no_such_table: E2}" in (
        (project / "controller.yaml").read_text()
    )
    assert not sim.writes_received()


def test_issue_29_diff_and_push_compare_the_controller_with_the_reply_the_pull_recorded(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = tmp_path / "cell"
    assert main(["pull", str(project), "--port", url]) == 0
    sim.vary({"missing_table": "E99"})
    sim.stations[1].data.timers[0] = "7.77"  # a push would write it back
    capsys.readouterr()
    assert main(["diff", str(project)]) == 2
    assert "offset table 100 answered E99 twice, not E21" in one_line(capsys)
    first = len(sim.received)
    with pytest.raises(PushFailed, match="offset table 100 answered E99 twice, not E21"):
        push(project, PushOptions(yes=True, allow_dirty=True))
    assert not sim.writes_received()
    # compared once the read is over: the end's three exchanges, then the timers, then nothing
    pushed = [r.payload for r in sim.received[first:]]
    lnl = [p for p in pushed if p.startswith("LNL")]
    assert lnl[-3:] == ["LNL 100", "LNL 99", "LNL 100"]
    after = pushed[len(pushed) - pushed[::-1].index("LNL 100") :]
    assert after and all(p.startswith("LNT") for p in after)


def test_issue_29_robot_yaml_no_such_table_pins_the_reply_a_first_pull_takes(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.vary({"missing_table": "E2"})
    project = tmp_path / "cell"
    project.mkdir()
    robot = f"format: 2\nname: cell\nconnection:\n  port: {url}\n  station: 1\n"
    (project / "robot.yaml").write_text(robot + "no_such_table: E21\n")
    assert main(["pull", str(project)]) == 2
    err = one_line(capsys)
    assert "offset table 100 answered E2 twice, not E21 (robot.yaml's no_such_table)" in err
    assert not (project / "offsets.yaml").exists()
    (project / "robot.yaml").write_text(robot + "no_such_table: E2\n")
    assert main(["pull", str(project)]) == 0
    assert "no_such_table: E2}" in (project / "controller.yaml").read_text()


def test_issue_29_a_reply_given_once_past_the_last_table_is_not_taken_for_the_end(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.plan("LNL 100", Act(reply="E30"))  # busy at the first ask, then the real E21
    assert main(["pull", str(tmp_path / "cell"), "--port", url]) == 2
    err = one_line(capsys)
    assert "command LNL 100: offset table 100 answered E30, then E21" in err
    assert "pull again when the robot answers normally" in err
    assert not (tmp_path / "cell" / "offsets.yaml").exists()


def test_issue_29_a_robot_that_stops_answering_normally_at_the_end_saves_no_backup(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    # table 99 reads, table 100 answers E21, then table 99 does not read any more
    sim.plan("LNL 99", Act(), Act(reply="E30"))
    assert main(["pull", str(tmp_path / "cell"), "--port", url]) == 2
    err = one_line(capsys)
    assert "table 99, which read normally, answers E30 now" in err
    assert not (tmp_path / "cell" / "offsets.yaml").exists()


def test_issue_29_a_table_that_answers_an_error_once_inside_the_range_is_read_again(
    served: tuple[ScriptedSim, str], tmp_path: Path
) -> None:
    sim, url = served
    sim.plan("LNL 37", Act(reply="E30"))
    project = tmp_path / "cell"
    engine.pull(project, port=url)
    assert (
        "offset_tables: {count: 100, no_such_table: E21}"
        in (project / "controller.yaml").read_text()
    )
    asked = tables_asked(sim)
    assert asked[36:40] == ["LNL 36", "LNL 37", "LNL 36", "LNL 37"]
    assert len(asked) == 100 + 2 + 3  # the error's two more exchanges, and the end's three


def test_issue_29_no_offset_table_that_reads_means_no_backup(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.stations[1].errors["LNL 0"] = "2"
    assert main(["pull", str(tmp_path / "cell"), "--port", url]) == 2
    assert "offset table 0 answered E2 twice: no offset table reads normally" in one_line(capsys)
    assert tables_asked(sim) == ["LNL 0", "LNL 0"]


@pytest.mark.parametrize("tables", [120, 128])
def test_issue_29_a_controller_with_more_tables_is_still_refused_naming_the_setting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tables: int
) -> None:
    # The simulator's offset_tables variant covers what the defaults must pass; a
    # controller with more tables than robot.yaml's offset_tables is this case.
    state = SimState.generate(5, SMALL)
    state.offset_tables = tables
    state.__post_init__()
    sim = Simulator(state)
    url = register(sim)
    try:
        assert main(["pull", str(tmp_path / "cell"), "--port", url]) == 2
    finally:
        unregister(url)
    err = one_line(capsys)
    assert "offset table 100 answers" in err and "set offset_tables in robot.yaml" in err
    assert tables_asked(sim)[-1] == "LNL 100" and len(tables_asked(sim)) == 101
    assert not (tmp_path / "cell" / "offsets.yaml").exists()
