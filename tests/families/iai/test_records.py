"""Issue 20 item 4: IAI records.  The work and tool coordinate system definitions
(2A0H, p.65) and the global string variables (210H, p.26) are stored in
records.yaml when robot.yaml gives their ranges, and diffed; no message on the
allow-list writes a coordinate system, so a push that would change one refuses
with one line; the string variables are written back with 24EH (p.51, issue 34
item 18).  The simulator serves them.  Every check of the controller reads its
own state."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.families.iai import profile
from harlsync.families.iai.protocol import (
    Frame,
    FrameDecoder,
    read_coordinate_systems,
    read_strings,
    write_strings,
)
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import load_project
from harlsync.sim.serve import TcpServer

from .backups import first_backup

STATION = 0x99


def frame(body: str) -> Frame:
    """A reply frame written by hand: its SC is the byte sum of ``body`` mod 256 (p.9)."""
    raw = body.encode() + f"{sum(body.encode()) & 0xFF:02X}\r\n".encode()
    decoder = FrameDecoder()
    decoder.feed(raw)
    got = decoder.next_frame()
    assert got is not None
    return got


def test_a_2a0h_reply_gives_each_definitions_offsets() -> None:
    # work coordinate system 1: X 100.000, Y 50.000, Z -1.000 mm, R 90.000 deg
    request = read_coordinate_systems(0, 1, 1)
    assert request.payload == "2A000101"
    reply = frame("#992A0" + "0" + "01" + "01" + "000186A00000C350FFFFFC1800015F90")
    assert request.decode(reply) == (("100.000", "50.000", "-1.000", "90.000"),)


def test_a_210h_reply_gives_one_character_a_column() -> None:
    request = read_strings(1, 5)
    assert request.payload == "2100000105"
    assert request.decode(frame("#99210" + "00" + "001" + "05" + "48454C4C4F")) == (
        0x48,
        0x45,
        0x4C,
        0x4C,
        0x4F,
    )


def controller() -> SimState:
    state = SimState.generate(6, position_range=(1, 30))
    state.work_coordinates = {1: ("100.000", "50.000", "-1.000", "90.000")}
    state.tool_coordinates = {0: ("0.000", "0.000", "35.500", "0.000")}
    state.strings = {n: ord(c) for n, c in zip(range(1, 8), 'AB\\C"\x01Z')}
    return state


RANGES = (
    "  work_coordinates: {first: 1, last: 3}\n"
    "  tool_coordinates: {first: 0, last: 1}\n"
    "  strings: {first: 1, last: 40}\n"
)


@pytest.fixture
def served() -> Iterator[tuple[Simulator, str]]:
    sim = Simulator({STATION: controller()})
    server = TcpServer(sim)
    url = server.start()
    yield sim, url
    server.stop()


def pulled(repo: Path, url: str) -> Path:
    project = repo / "cell"
    first_backup(project, url, last=30, controller=RANGES)
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup with records")
    return project


def test_records_are_backed_up_exactly_and_diff_finds_no_difference(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = pulled(repo, url)
    text = (project / "records.yaml").read_text()
    assert "work_coordinates:\n  1: [100.000, 50.000, -1.000, 90.000]\n" in text
    assert "  2: [0.000, 0.000, 0.000, 0.000]\n" in text
    assert "tool_coordinates:\n  0: [0.000, 0.000, 35.500, 0.000]\n" in text
    assert '  1: "41425C4322015A' + "00" * 25 + '"\n' in text  # columns 1-32
    assert '  33: "' + "00" * 8 + '"\n' in text  # columns 33-40
    data = load_project(project).data
    assert data.work_coordinates[1] == ("100.000", "50.000", "-1.000", "90.000")
    assert cli.main(["diff", str(project)]) == 0
    assert not sim.off_list() and not sim.writes_received()


def test_a_record_changed_on_the_controller_is_diffed_and_a_push_refuses_it(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    state = sim.stations[STATION]
    state.work_coordinates[1] = ("100.000", "51.000", "-1.000", "90.000")
    state.strings[2] = ord("b")
    capsys.readouterr()
    assert cli.main(["diff", str(project)]) == 1
    out = capsys.readouterr().out
    assert "x 100.000 y 51.000 z -1.000 r 90.000" in out
    # readable, exact text: the backslash doubled, other codes as \xNN
    assert '-1: "Ab\\\\C"\\x01Z" and 25 x \\x00' in out

    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert "work coordinate system 1: differs on the robot, and no message harlsync sends" in err
    # issue 34 item 18: string variables are written back with 24EH; only the coordinate
    # systems, which no message writes, refuse the push (changed on purpose)
    assert "string variables" not in err
    assert not sim.writes_received() and not sim.off_list()


def test_a_record_edited_in_the_project_is_refused_and_nothing_written(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    path = project / "records.yaml"
    path.write_text(path.read_text().replace("35.500", "36.000"))
    git(repo, "commit", "-qam", "tool 0 edited")
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    err = capsys.readouterr().err
    assert "tool coordinate system 0: differs on the robot" in err
    assert not sim.writes_received()
    assert sim.stations[STATION].tool_coordinates[0][2] == "35.500"


def test_a_project_without_record_ranges_reads_none(
    served: tuple[Simulator, str], repo: Path
) -> None:
    sim, url = served
    project = repo / "plain"
    assert (
        cli.main(["pull", str(project), "--family", "iai", "--port", url, "--station", "99"]) == 0
    )
    assert not (project / "records.yaml").exists()
    assert not [r for r in sim.received if r.command in ("2A0", "210")]


def test_issue_34_item_18_a_string_variable_row_is_written_back_with_24eh(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The string variables are backed up, and 24EH (p.51) writes them: a push
    brings back a row changed on the controller, one 24EH a changed row, the
    interlock read just before it; an unchanged row is not written."""
    sim, url = served
    project = pulled(repo, url)
    state = sim.stations[STATION]
    state.strings[2] = ord("b")
    state.strings[40] = ord("?")
    capsys.readouterr()
    assert cli.main(["plan", str(project), "-v"]) == 0
    out = capsys.readouterr().out
    assert "# string variables from column 1: 24EH 00 001 20 | 41425C4322015A" + "00" * 25 in out
    assert "# string variables from column 33: 24EH 00 021 08 | " + "00" * 8 in out
    before = len(sim.received)
    assert cli.main(["push", str(project), "--yes"]) == 0, capsys.readouterr().err
    writes = [r for r in sim.received[before:] if r.is_write]
    assert [r.payload[:12] for r in writes] == ["24E000012041", "24E000210800"]
    sent = [r.command for r in sim.received[before:]]
    for at in (i for i, command in enumerate(sent) if command == "24E"):
        assert sent[at - 2 : at] == ["212", "215"]  # the interlock, just before
    assert state.strings[2] == ord("B") and state.strings[40] == 0
    assert cli.main(["diff", str(project)]) == 0
    assert not sim.writes_while_busy() and not sim.off_list()


def test_issue_34_item_18_no_string_variable_is_written_to_a_robot_that_is_not_idle(
    served: tuple[Simulator, str], repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    project = pulled(repo, url)
    state = sim.stations[STATION]
    state.strings[2] = ord("b")
    sim.control("run", state, ())
    capsys.readouterr()
    assert cli.main(["push", str(project), "--yes"]) == 3
    assert "program running" in capsys.readouterr().err
    assert not sim.writes_received()


def test_issue_34_item_18_the_24eh_frame_is_the_manuals() -> None:
    """p.51: program 'XX', start 'XXX', count 'XX', then each character's code as
    'XX'; the normal reply is 10 bytes with no data.  Frames written by hand."""
    request = write_strings(1, [0x48, 0x45, 0x4C, 0x4C, 0x4F])
    assert request.encode(STATION) == b"!9924E000010548454C4C4FD1\r\n"
    assert request.is_write and request.message_id in profile.WRITE_MESSAGE_IDS
    assert request.decode(Frame("#", STATION, 0x24E, "")) is None
    with pytest.raises(ValueError, match="string variable column 2"):
        write_strings(1, [0x41, 0x100])
