"""Issue 20 item 1 for the HARL-U2: no silent truncation.

LNX reports how many programs, steps, timers and registers the controller has,
and a pull reads them all; it does not report the offset tables, which the
manual gives as 0-99 "(variable)".  A pull reads robot.yaml's ``offset_tables``
(100 by default) and then asks for the next one: a controller that answers it
has more, and the pull fails in one line naming the table and the setting,
saving nothing.  Through the ``harlsync`` command over a real TCP socket.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from harlsync.cli import main
from harlsync.families.harl_u2.model import Config, OffsetTable, ProgramArea
from harlsync.families.harl_u2.protocol import profile
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.families.harl_u2.sim.device import STATUS_BUSY
from harlsync.sim.serve import TcpServer
from harlsync.sync import engine

SMALL = Config(ProgramArea(1, 4), ProgramArea(1, 4), ProgramArea(1, 4), ProgramArea(1, 4), 4, 16, 4)
TABLE_110 = OffsetTable.from_values(["12.50", "-3.00", "0.00", "0.00", "90.00", "0.00", "1", "2"])


def robot_with(tables: int) -> Simulator:
    state = SimState.generate(5, SMALL)
    state.offset_tables = tables
    state.__post_init__()
    if tables > 110:
        state.data.offsets[110] = TABLE_110
    return Simulator(state)


def robot_yaml(project: Path, url: str, tables: int | None) -> None:
    project.mkdir(parents=True)
    extra = f"offset_tables: {tables}\n" if tables is not None else ""
    (project / "robot.yaml").write_text(
        f"format: 1\nname: cell\nconnection:\n  port: {url}\n  station: 1\n{extra}"
    )


def test_issue_20_a_pull_of_a_controller_with_more_offset_tables_fails_naming_the_setting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = robot_with(120)
    with TcpServer(sim) as server:
        assert main(["pull", str(tmp_path / "new"), "--port", server.url]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        assert "offset table 100 answers" in err[0]
        assert "set offset_tables in robot.yaml" in err[0]
        assert not (tmp_path / "new" / "offsets.yaml").exists()
        assert not sim.writes_received()


def test_issue_20_with_offset_tables_set_the_pull_keeps_every_table_and_says_its_range(
    tmp_path: Path,
) -> None:
    sim = robot_with(120)
    project = tmp_path / "cell"
    with TcpServer(sim) as server:
        robot_yaml(project, server.url, 120)
        # What the pull's closing line says (on a terminal): the range it covered.
        contents = engine.pull(project).contents
        assert "120 offset tables (0-119, no table 120: E21 twice)" in contents
        assert "  110: {x: 12.50, y: -3.00" in (project / "offsets.yaml").read_text()
        assert "offset_tables: 120" in (project / "robot.yaml").read_text()
        assert main(["validate", str(project)]) == 0
        assert main(["diff", str(project)]) == 0


def test_issue_20_validate_refuses_a_table_past_robot_yamls_count(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = robot_with(120)
    project = tmp_path / "cell"
    with TcpServer(sim) as server:
        robot_yaml(project, server.url, 120)
        assert main(["pull", str(project)]) == 0
    text = (project / "robot.yaml").read_text()
    (project / "robot.yaml").write_text(text.replace("offset_tables: 120", "offset_tables: 110"))
    capsys.readouterr()
    assert main(["validate", str(project)]) == 1
    out = capsys.readouterr().out
    assert (
        "table 110 is outside the configuration (allowed: 0-109, robot.yaml offset_tables)" in out
    )


def test_issue_20_a_pull_of_the_manuals_100_tables_says_the_range_it_covered(
    tmp_path: Path,
) -> None:
    sim = robot_with(100)
    with TcpServer(sim) as server:
        contents = engine.pull(tmp_path / "cell", port=server.url).contents
    assert "100 offset tables (0-99, no table 100: E21 twice)" in contents
    # table 100 twice, table 99 read again between (issue 29)
    assert [r.payload for r in sim.received if r.command == "LNL"][-4:] == [
        "LNL 99",
        "LNL 100",
        "LNL 99",
        "LNL 100",
    ]


def test_issue_20_a_busy_answer_to_the_table_probe_fails_the_pull_it_is_not_no_such_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Review finding 7: any "E" reply to LNL 100 counted as "no such table", so a
    # robot that was busy (or had a transient fault) at the probe passed a backup
    # that may be short.  Since issue 29 a first pull takes the reply a controller
    # gives twice (no code is in the manual) and records it: a later pull that gets
    # another one there is refused once the read is over, naming both, and saves nothing.
    sim = robot_with(100)
    project = tmp_path / "cell"
    with TcpServer(sim) as server:
        assert main(["pull", str(project), "--port", server.url]) == 0
        before = (project / "offsets.yaml").read_bytes()
        sim.stations[1].errors["LNL 100"] = STATUS_BUSY
        assert STATUS_BUSY != profile.NO_SUCH_TABLE
        capsys.readouterr()
        assert main(["pull", str(project)]) == 3  # refused once the read is over
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert f"offset table 100 answered E{STATUS_BUSY} twice, not E21" in err[0]  # where, what
    assert "the tables read may be short" in err[0]
    assert "The backup was left as it was" in err[0]
    assert (project / "offsets.yaml").read_bytes() == before
    assert [r.payload for r in sim.received if r.command == "LNL"][-1] == "LNL 100"
    assert not sim.writes_received()


def test_issue_20_a_robot_busy_at_the_offset_table_probe_fails_its_backup_not_passes_it(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # (The plant backup's own tests are tests/test_backup.py's, on the toy family.)
    # Review finding 7: any E reply to the probe past the last offset table was
    # taken for "no such table".  Since issue 29 only the one the first pull got
    # twice and recorded is (controller.yaml offset_tables.no_such_table).
    sim = robot_with(100)
    loader = repo / "loader"
    with TcpServer(sim) as server:
        engine.pull(loader, port=server.url, commit=True)
        sim.stations[1].data.timers[1] = "6.66"
        sim.stations[1].errors["LNL 100"] = STATUS_BUSY
        before = {
            p: p.read_bytes()
            for p in loader.rglob("*")
            if p.is_file() and ".harlsync" not in p.parts
        }
        capsys.readouterr()
        assert main(["backup", str(repo), "--commit", "--attempts", "1"]) == 1
    rows = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()[1:2]}
    assert rows["loader"].split()[1] == "FAILED"
    assert f"offset table 100 answered E{STATUS_BUSY} twice, not E21" in rows["loader"]
    after = {
        p: p.read_bytes() for p in loader.rglob("*") if p.is_file() and ".harlsync" not in p.parts
    }
    assert after == before  # the changed timer is not saved either


def test_issue_20_the_simulator_answers_the_profiles_no_such_table_for_a_missing_table() -> None:
    sim = robot_with(100)
    state = sim.stations[1]
    assert sim.handle(state, "LNL 100") == "E" + profile.NO_SUCH_TABLE
    assert (
        sim.handle(state, "SNL 100 0.00 0.00 0.00 0.00 0.00 0.00 0 0")
        == "E" + profile.NO_SUCH_TABLE
    )
    assert sim.handle(state, "LNL 99") == "0.00 0.00 0.00 0.00 0.00 0.00 0 0"
    state.errors["LNL 99"] = STATUS_BUSY
    assert sim.handle(state, "LNL 99") == "E" + STATUS_BUSY
