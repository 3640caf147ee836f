"""Recorded traffic replayed as regression fixtures (the issue: "Recorded traffic from a
real controller (pyserial's spy:// can capture it) can be replayed as a regression fixture").

Every ``tests/families/harl_u2/fixtures/traffic/*.txt`` is a pyserial ``spy://`` capture.  Each one
is replayed against the real Controller: every request of the capture must be
sent as recorded and get its recorded outcome, and with ``NAME.expect.yaml`` the
typed values must be the expected ones.  To add a real controller's capture, see
the header of tests/families/harl_u2/fixtures/traffic/record.py.
"""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial
from hypothesis import given
from hypothesis import strategies as st
from serial.urlhandler.protocol_spy import FormatHexdump

from harlsync.errors import LinkTimeout, PortError, ProtocolError
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import (
    Config,
    OffsetTable,
    Parameters,
    ProgramArea,
    Status,
    Step,
)
from harlsync.families.harl_u2.protocol import Ack, encode_frame
from harlsync.families.harl_u2.sim import SimState
from harlsync.link import SerialSettings
from harlsync.sim.protocol_replay import register, replay_from_url, unregister
from harlsync.sim.replay import Chunk, Replay, ReplayMismatch, load_spy_log, parse_spy_log
from harlsync.sim.serve import PtyServer

from .traffic import TRAFFIC, captures, load_expectations, play

if "harlsync.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("harlsync.sim")

FAST = SerialSettings(timeout=0.3, retries=0)

# Written by hand in pyserial's FormatHexdump layout: LNV answered "5.00", then an
# LNE reply of 58 bytes read in one go (four lines), with spy's control lines.
DUMP = """\
000000.000 Q-RX reset_input_buffer
000000.002 TX   0000  02 31 20 4C 4E 56 03 46                           .1 LNV.F        
000000.002 Q-TX flush
000000.020 RX   0000  02 31 20 35 2E 30 30 03  09                       .1 5.00..       
000000.031 TX   0000  02 31 20 4C 4E 45 03 55                           .1 LNE.U        
000000.031 Q-TX flush
000000.095 RX   0000  02 31 20 31 30 34 20 31  20 30 20 32 30 2E 30 30  .1 104 1 0 20.00
000000.095 RX   0010  20 32 30 2E 30 30 20 33  30 2E 30 30 20 33 30 2E   20.00 30.00 30.
000000.095 RX   0020  30 30 20 34 30 2E 30 30  20 34 30 2E 30 30 20 35  00 40.00 40.00 5
000000.095 RX   0030  30 20 30 20 30 2E 30 30  20 30 03 3D              0 0 0.00 0.=    
"""
LNV = b"\x021 LNV\x03F"
LNV_REPLY = b"\x021 5.00\x03\x09"
LNE = b"\x021 LNE\x03U"
LNE_REPLY = b"\x021 104 1 0 20.00 20.00 30.00 30.00 40.00 40.00 50 0 0.00 0\x03="


@pytest.fixture
def served() -> Iterator[list[str]]:
    """URLs registered during the test, unregistered after it."""
    urls: list[str] = []
    yield urls
    for url in urls:
        unregister(url)


# --- reading spy:// dumps -----------------------------------------------------------


def test_a_spy_dump_gives_each_write_and_read_with_its_direction_and_time() -> None:
    assert parse_spy_log(DUMP) == [
        Chunk("TX", LNV, 0.002),
        Chunk("RX", LNV_REPLY, 0.020),
        Chunk("TX", LNE, 0.031),
        Chunk("RX", LNE_REPLY, 0.095),
    ]


def test_a_read_of_exactly_16_bytes_ends_where_the_next_chunk_starts() -> None:
    dump = (
        "000001.000 RX   0000  41 42 43 44 45 46 47 48  49 4A 4B 4C 4D 4E 4F 50  ABCDEFGHIJKLMNOP\n"
        "000001.500 RX   0000  51                                                Q               \n"
    )
    assert parse_spy_log(dump) == [
        Chunk("RX", b"ABCDEFGHIJKLMNOP", 1.0),
        Chunk("RX", b"Q", 1.5),
    ]


def test_stripped_trailing_blanks_crlf_colour_codes_and_hash_notes_are_tolerated() -> None:
    edited = "# captured at cell 3, 2024-05-02\n\n" + "".join(
        "\x1b[31m" + line.rstrip() + "\r\n" for line in DUMP.splitlines()
    )
    assert parse_spy_log(edited) == parse_spy_log(DUMP)


@pytest.mark.parametrize(
    "line, problem",
    [
        (
            "000000.002 TX   0000  02 31 20 4C 4E 57 03 46                           .1 LNV.F",
            "ASCII",
        ),
        ("000000.002 TX   0010  02 31                                             .1", "offset"),
        ("000000.002 TX   0000  02 3G                                             .?", "hex"),
        ("000000.002 TX   02 31", "offset"),
        ("TX 02 31 20", "not a spy"),
    ],
)
def test_a_line_that_is_not_pyserials_format_is_refused_by_number(line: str, problem: str) -> None:
    with pytest.raises(ValueError, match=f"line 2: .*{problem}"):
        parse_spy_log("000000.000 Q-RX reset_input_buffer\n" + line + "\n")


@given(st.lists(st.tuples(st.sampled_from(["TX", "RX"]), st.binary(min_size=1, max_size=60))))
def test_whatever_bytes_pyserial_dumps_parse_back_to_the_same_chunks(
    moves: list[tuple[str, bytes]],
) -> None:
    out = io.StringIO()
    formatter = FormatHexdump(out, color=False)
    for direction, data in moves:
        (formatter.tx if direction == "TX" else formatter.rx)(data)
    assert [(c.direction, c.data) for c in parse_spy_log(out.getvalue())] == moves


# --- playing a capture -----------------------------------------------------------------


def test_each_recorded_request_is_answered_with_what_followed_it_in_the_capture() -> None:
    replay = Replay(parse_spy_log(DUMP))
    assert replay.start() == []
    first = replay.next_request()
    assert first is not None and (first.station, first.payload) == (1, "LNV")
    # pytest.approx is no float, and compares equal to one: the point of it.
    assert replay.receive(LNV) == [(pytest.approx(0.018), LNV_REPLY)]  # type: ignore[comparison-overlap]
    assert replay.receive(LNE[:3]) == []  # a request may come in pieces
    assert replay.receive(LNE[3:]) == [(pytest.approx(0.064), LNE_REPLY)]  # type: ignore[comparison-overlap]
    assert replay.done and replay.next_request() is None


def test_without_timing_every_reply_is_due_at_once() -> None:
    replay = Replay(parse_spy_log(DUMP), timing=False)
    assert replay.receive(LNV + LNE) == [(0.0, LNV_REPLY), (0.0, LNE_REPLY)]


def test_bytes_read_before_the_first_request_are_there_when_the_port_opens() -> None:
    chunks = [Chunk("RX", b"\x00\xff", 0.001), *parse_spy_log(DUMP)]
    assert Replay(chunks).start() == [(0.001, b"\x00\xff")]


def test_a_request_the_capture_does_not_hold_next_is_a_mismatch_naming_both() -> None:
    replay = Replay(parse_spy_log(DUMP))
    with pytest.raises(
        ReplayMismatch, match=r"request 1 .* is '1 LNV', but the client sent '1 LNE'"
    ):
        replay.receive(LNE)
    with pytest.raises(ReplayMismatch):  # and it stays broken
        replay.receive(LNV)


def test_a_request_after_the_end_of_the_capture_is_a_mismatch() -> None:
    replay = Replay(parse_spy_log(DUMP))
    replay.receive(LNV + LNE)
    with pytest.raises(ReplayMismatch, match="the capture ends here, but the client sent '1 LNV'"):
        replay.receive(LNV)


def test_a_capture_cut_inside_a_request_says_so() -> None:
    replay = Replay([Chunk("TX", LNV[:4], 0.0)])
    with pytest.raises(ProtocolError, match="ends inside a request"):
        replay.next_request()


def test_replay_urls_open_capture_files_and_refuse_bad_ones(tmp_path: Path) -> None:
    path = tmp_path / "capture.txt"
    path.write_text(DUMP)
    assert replay_from_url(f"replay://{path}?timing=0").chunks == parse_spy_log(DUMP)
    with pytest.raises(serial.SerialException, match="only timing"):
        replay_from_url(f"replay://{path}?speed=2")
    with pytest.raises(serial.SerialException, match="cannot replay"):
        replay_from_url(f"replay://{tmp_path / 'missing.txt'}")
    path.write_text("not a capture\n")
    with pytest.raises(serial.SerialException, match="line 1"):
        replay_from_url(f"replay://{path}")
    with pytest.raises(serial.SerialException, match="no replay peer registered"):
        replay_from_url("replay://@nobody")


def test_a_capture_file_replays_through_the_controller(tmp_path: Path) -> None:
    path = tmp_path / "capture.txt"
    path.write_text(DUMP)
    with Controller.from_url(f"replay://{path}", settings=FAST, lock_dir=tmp_path) as robot:
        assert robot.version() == "5.00"
        assert robot.read_parameters().pull_limit == "104"


def test_a_client_that_strays_from_the_capture_gets_a_port_error_saying_what_was_due(
    served: list[str],
) -> None:
    replay = Replay(parse_spy_log(DUMP))
    served.append(url := register(replay))
    due = r"is '1 LNV', but the client sent '1 LNE'"
    with Controller.from_url(url, settings=FAST) as robot, pytest.raises(PortError, match=due):
        robot.read_parameters()
    assert isinstance(replay.mismatch, ReplayMismatch)


def test_a_late_reply_replays_late_so_it_is_not_taken_for_the_next_answer(
    served: list[str], tmp_path: Path
) -> None:
    # The recorded link gave up on LNT 1 after 0.3 s; its reply came at 0.8 s and was
    # discarded as late before LNT 2 was sent.  Answered at once, it would have fitted.
    capture = [
        Chunk("TX", encode_frame(1, "LNT 1"), 0.0),
        Chunk("RX", encode_frame(1, "1.50"), 0.8),
        Chunk("TX", encode_frame(1, "LNT 2"), 0.85),
        Chunk("RX", encode_frame(1, "2.50"), 0.86),
    ]
    served.append(url := register(Replay(capture)))
    with Link(url, settings=FAST, lock_dir=tmp_path, late_window=1.0) as link:
        robot = Controller(link)
        with pytest.raises(LinkTimeout):
            robot.read_timer(1)
        assert robot.read_timer(2) == "2.50"
        assert link.stats.late_replies == 1

    served.append(url := register(Replay(capture, timing=False)))
    with Link(url, settings=FAST, lock_dir=tmp_path) as link:
        assert Controller(link).read_timer(1) == "1.50"


def test_a_captured_pull_replays_into_the_same_project(tmp_path: Path) -> None:
    from harlsync.families.harl_u2.sim import Simulator
    from harlsync.project import load_project
    from harlsync.sync.engine import pull

    small = Config(
        ProgramArea(1, 4), ProgramArea(2, 6), ProgramArea(1, 4), ProgramArea(1, 4), 4, 16, 4
    )
    capture = tmp_path / "pull.txt"
    with PtyServer(Simulator(SimState.generate(3, small))) as server:
        pull(tmp_path / "live", port=f"spy://{server.device}?file={capture}", station=1)
    pull(tmp_path / "replayed", port=f"replay://{capture}", station=1)
    assert load_project(tmp_path / "replayed").data == load_project(tmp_path / "live").data


# --- the fixtures -----------------------------------------------------------------------


@pytest.mark.parametrize("capture", captures(), ids=lambda p: p.name)
def test_every_recorded_request_gets_its_recorded_outcome_from_the_controller(
    capture: Path, tmp_path: Path, served: list[str]
) -> None:
    replay = Replay(load_spy_log(capture))
    served.append(url := register(replay))
    settings, expected = load_expectations(capture)
    got = [exchange.plain() for exchange in play(replay, url, settings, tmp_path)]
    assert replay.mismatch is None
    assert replay.done, "the client stopped before the end of the capture"
    if expected is not None:
        assert got == expected


def test_the_simulator_capture_holds_the_typed_values_of_every_kind(
    tmp_path: Path, served: list[str]
) -> None:
    capture = TRAFFIC / "sim-two-stations.txt"
    replay = Replay(load_spy_log(capture))
    served.append(url := register(replay))
    settings, _ = load_expectations(capture)
    got = {e.request: e for e in play(replay, url, settings, tmp_path)}

    assert got["1 LNV"].value == "5.00"
    assert got["1 LNX"].value == Config(
        ProgramArea(1, 8), ProgramArea(2, 12), ProgramArea(1, 8), ProgramArea(1, 4), 8, 128, 8
    )
    assert isinstance(got["1 LNE"].value, Parameters)
    assert isinstance(got["1 LNR"].value, Status) and got["1 LNR"].value.idle
    assert not got["2 LNR"].value.idle  # station 2 was in automatic operation
    assert got["1 LNM 1 11"].value == Step("END")
    assert got["1 LNM 1 0"].value.command == "MOVE"
    assert isinstance(got["1 LNL 0"].value, OffsetTable)
    assert got["1 LNID 1"].value == 0b01000110  # DI 9, 10 and 14
    assert got["1 LNOB 3"].value == 1
    assert got["1 SNT 3 0.75"].value == Ack("0")
    assert got["1 LNT 3"].value == "0.75"
    assert got["1 LNM 9 0"].error is not None and got["1 LNM 9 0"].error.status == "21"
    assert got["3 LNV"].timeout is not None  # no robot with station 3: silence
