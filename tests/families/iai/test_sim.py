"""The simulated IAI controller, over a real pty and a real TCP socket, driven with
frames written by hand.

Every request here, and every short reply, is golden bytes: taken from the digest
(through tests/families/iai/test_protocol.py) or written from its field tables with the SC
summed by hand, never made by our encoder.  Long replies (22DH pages) are checked
field by field with the codec, whose own golden tests cover its decoding.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from itertools import pairwise
from pathlib import Path

import pytest
import serial
from simprocess import harlsync_sim

from harlsync.families.iai import protocol as p
from harlsync.families.iai.model import Position, Version
from harlsync.families.iai.sim import MANUAL, SimState, Simulator, codes
from harlsync.sim import Faults, project_family
from harlsync.sim.control import apply_command
from harlsync.sim.memory import keep_state
from harlsync.sim.protocol_sim import simulator_from_url
from harlsync.sim.serve import PtyServer, TcpServer

from .test_protocol import (
    AXIS_REPLY,
    FLAG_WRITE_Q,
    FLAG_WRITE_REPLY,
    FLAGS_Q,
    POSITIONS_Q,
    POSITIONS_Q_2_3,
    POSITIONS_REPLY,
    POSITIONS_REPLY_2_3,
    STATUS_IDLE,
    SYSTEM_STATUS_Q,
    VERSION_Q,
    VERSION_REPLY,
    WRITE_INTEGERS_Q,
    WRITE_Q,
    WRITE_Q_3_4,
    WRITE_REPLY,
    WRITE_REPLY_2,
)

if "harlsync.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("harlsync.sim")

CRLF = b"\r\n"

# --- golden frames ----------------------------------------------------------------------

AXIS_2_Q = b"!99212028A" + CRLF  # axis status of axis 2
AXIS_4_Q = b"!992120890" + CRLF  # axis 4: not on a 3-axis robot
AXIS_NONE_Q = b"!992120088" + CRLF  # axis pattern 00
AXIS_NONE_REPLY = b"#99212008A" + CRLF  # no axis reported: "driver not connected"
STATUS_MANUAL = b"#9921520000000100040004" + CRLF  # mode 2, byte 1 bit 0 (mode switch)
STATUS_RUNNING = b"#9921510000000020060006" + CRLF  # byte 2 bit 5, byte 3 bit 1
STATUS_ESTOP = b"#992151000000080005000B" + CRLF  # byte 1 bit 3, byte 3 bit 0 (drive cut)
STATUS_FLASH = b"#9921510000000001040003" + CRLF  # byte 2 bit 0
FOREIGN_Q = b"!982152A" + CRLF  # 215H to station 98
SERVO_Q = b"!99232071C2" + CRLF  # 232H servo ON, axes 1-3: off the allow-list
PROGRAM_RUN_Q = b"!99253018E" + CRLF  # 253H run program 1: off the allow-list
FLAGS_605_Q = b"!9920D00025D00083C" + CRLF  # 20DH 8 flags from 605: not a multiple of 8
PAGE_20_Q = b"!9922D000001001421" + CRLF  # 22DH positions 1-20
PAGE_12_Q = b"!9922D000001000C2F" + CRLF  # 22DH positions 1-12
# 291H positions 5 and 6: 5 = axis 1 at 1.000, then 6 as each case says.
WRITE_5_6 = b"!99291000005000201000000000000000003E80002000000000000000007D00054" + CRLF
WRITE_6_AXIS_4 = b"!99291000005000201000000000000000003E80008000000000000000007D0005A" + CRLF
WRITE_6_PATTERN_00 = b"!99291000005000201000000000000000003E8000000000000000000B7" + CRLF
WRITE_6_EXTENDED_01 = b"!99291000005000201000000000000000003E80001000000000000000007D00154" + CRLF
WRITE_1001 = b"!992910003E9000101000000000000000003E800D2" + CRLF  # outside 1-1000


def error(code: str) -> bytes:
    """The ``&`` reply with ``code``: the placeholder codes are summed here by hand too."""
    return {
        "0A1": b"&990A13A",
        "0A2": b"&990A23B",
        "0A3": b"&990A33C",
        "0B1": b"&990B13B",
        "0B2": b"&990B23C",
        "0B3": b"&990B33D",
        "0B4": b"&990B43E",
        "0C1": b"&990C13C",
    }[code] + CRLF


POSITION_1 = Position(1, (1,), "0.00", "0.00", 0, ("100.000",))
POSITION_3 = Position(3, (1,), "0.00", "0.00", 0, ("10.005",))
POSITION_4 = Position(4, (1, 3), "0.30", "0.30", 100, ("-1.000", "3.000"), 1, 2)
VERSION = Version(0, 0, "12", "34", "0041", "2019-03-05 14:07:09")


def controller() -> SimState:
    """A TTA with axes 1-3 holding positions 1, 3 and 4, axis 2 at 10.005 mm."""
    state = SimState.from_positions(
        [POSITION_1, POSITION_3, POSITION_4], axes=(1, 2, 3), version=VERSION
    )
    state.current[2] = "10.005"
    return state


# --- the line: a real pty or a real TCP socket -----------------------------------------------


class Line:
    """A client's end of the served simulator."""

    def __init__(self, sim: Simulator, port: serial.Serial) -> None:
        self.sim = sim
        self.port = port

    @property
    def state(self) -> SimState:
        return self.sim.stations[0x99]

    def ask(self, request: bytes, deadline: float = 3.0) -> bytes:
        """Send ``request`` and return the bytes read up to the first LF."""
        self.port.write(request)
        reply = read_line(self.port, deadline)
        assert reply.endswith(b"\n"), f"no reply to {request!r} (got {reply!r})"
        return reply

    def silent(self, request: bytes) -> None:
        """``request`` gets no reply: the reply to a 215H sent after it is the first
        thing to arrive (one command outstanding at a time: nothing else can be late)."""
        assert self.ask(request + SYSTEM_STATUS_Q) == STATUS_IDLE


@pytest.fixture(params=["pty", "tcp"])
def line(request: pytest.FixtureRequest) -> Iterator[Line]:
    sim = Simulator(controller())
    if request.param == "pty":
        with PtyServer(sim) as server, serial.serial_for_url(server.device, timeout=0.05) as port:
            yield Line(sim, port)
    else:
        with TcpServer(sim) as tcp, serial.serial_for_url(tcp.url, timeout=0.05) as port:
            yield Line(sim, port)


# --- the allow-listed messages -----------------------------------------------------------------


def test_201h_reports_the_version(line: Line) -> None:
    assert line.ask(VERSION_Q) == VERSION_REPLY


@pytest.mark.parametrize(
    ("verb", "reply"),
    [
        ("stop", STATUS_IDLE),
        ("manual", STATUS_MANUAL),
        ("run", STATUS_RUNNING),
        ("estop", STATUS_ESTOP),
        ("flash", STATUS_FLASH),
    ],
)
def test_215h_reports_each_mode_in_its_status_bits(line: Line, verb: str, reply: bytes) -> None:
    apply_command(line.sim, verb)
    assert line.ask(SYSTEM_STATUS_Q) == reply


def test_212h_reports_the_axes_asked_for_that_the_robot_has(line: Line) -> None:
    assert line.ask(AXIS_2_Q) == AXIS_REPLY  # the real TT reply: axis 2 at 10.005 mm, idle
    assert line.ask(AXIS_4_Q) == AXIS_NONE_REPLY
    assert line.ask(AXIS_NONE_Q) == error(codes.PATTERN_ZERO)


def test_212h_shows_an_axis_in_use(line: Line) -> None:
    apply_command(line.sim, "hold 99 2")
    assert line.ask(AXIS_2_Q) == b"#99212020D00000000002715AF" + CRLF  # bit 0 on, bit 4 off


def test_22dh_returns_only_the_defined_positions(line: Line) -> None:
    assert line.ask(POSITIONS_Q) == POSITIONS_REPLY
    assert line.ask(POSITIONS_Q_2_3) == POSITIONS_REPLY_2_3  # 2 is undefined: absent


def test_22dh_pages_never_exceed_the_send_buffer(line: Line) -> None:
    # A TT (1024-byte send buffer) with 8 axes: every record is the longest, 84 bytes.
    eight = tuple(range(1, 9))
    line.sim.stations[0x99] = SimState.from_positions(
        [Position(n, eight, "0.10", "0.10", 100, (f"{n}.000",) * 8) for n in range(1, 21)],
        axes=eight,
        model="TT",
    )
    reply = line.ask(PAGE_20_Q)
    assert len(reply) <= 1024
    frame = frame_of(reply)
    assert frame.data[:6] == "00000C"  # 12 whole records fit: the count says so
    got = p.read_positions(1, 20).decode(frame)
    assert isinstance(got, tuple)  # positions, not an error reply
    assert [pos.number for pos in got] == list(range(1, 13))
    # Sized as the client sizes it (12 for a TT), a query gets every record it asks for.
    assert len(line.ask(PAGE_12_Q)) == len(reply)


def test_291h_writes_a_run_of_positions(line: Line) -> None:
    assert line.ask(WRITE_Q) == WRITE_REPLY  # digest: position 1, axis 1 = 100.000
    assert line.ask(WRITE_Q_3_4) == WRITE_REPLY_2
    assert line.ask(POSITIONS_Q_2_3) == POSITIONS_REPLY_2_3  # as written
    assert line.ask(WRITE_5_6) == WRITE_REPLY_2
    assert sorted(line.state.positions) == [1, 3, 4, 5, 6]
    assert line.state.positions[6] == Position(6, (2,), "0.00", "0.00", 0, ("2.000",))
    assert line.sim.writes == 3


@pytest.mark.parametrize(
    ("request_", "code"),
    [
        (WRITE_6_AXIS_4, codes.NO_AXIS),
        (WRITE_6_PATTERN_00, codes.PATTERN_ZERO),
        (WRITE_6_EXTENDED_01, codes.EXTENDED_BITS),
        (WRITE_1001, codes.OUT_OF_RANGE),
        (b"!99291000005000101000000000000000003E856" + CRLF, codes.BAD_DATA),  # no extended
    ],
    ids=["axis the robot lacks", "pattern 00", "extended bits 0-3", "out of range", "short"],
)
def test_291h_with_a_bad_record_is_refused_and_writes_nothing(
    line: Line, request_: bytes, code: str
) -> None:
    before = dict(line.state.positions)
    assert line.ask(request_) == error(code)
    assert line.state.positions == before  # not even position 5, which was fine
    assert line.sim.writes == 0
    [record] = line.sim.writes_received()
    assert record.command == "291" and not record.busy


@pytest.mark.parametrize("verb", ["run", "manual", "estop", "flash", "hold"])
def test_a_write_while_not_idle_is_refused_and_recorded_as_busy(line: Line, verb: str) -> None:
    apply_command(line.sim, verb)
    before = dict(line.state.positions)
    assert line.ask(WRITE_5_6) == error(codes.NOT_IDLE)
    assert line.state.positions == before
    assert [r.busy for r in line.sim.writes_while_busy()] == [True]
    apply_command(line.sim, "stop")
    assert line.ask(WRITE_5_6) == WRITE_REPLY_2
    assert [r.busy for r in line.sim.writes_received()] == [True, False]


def test_reads_are_answered_whatever_the_mode(line: Line) -> None:
    line.state.mode = MANUAL
    assert line.ask(POSITIONS_Q) == POSITIONS_REPLY
    assert line.ask(VERSION_Q) == VERSION_REPLY


def test_the_opt_in_flags_read_back_as_written(line: Line) -> None:
    assert line.ask(FLAG_WRITE_Q) == FLAG_WRITE_REPLY  # global flag 5 on
    assert line.ask(FLAGS_Q) == b"#9920D00000000102000DE" + CRLF  # flags 0-15: 20h, 00h


def test_a_flag_query_that_starts_between_multiples_of_8_is_refused(line: Line) -> None:
    assert line.ask(FLAGS_605_Q) == error(codes.BAD_DATA)  # p.22: category head + 8n


# --- what gets no reply, and what gets an error ------------------------------------------------


def test_a_bad_sc_a_foreign_station_or_a_reply_frame_gets_silence(line: Line) -> None:
    line.silent(b"!992152C" + CRLF)  # SC off by one
    line.silent(FOREIGN_Q)
    line.silent(STATUS_IDLE)  # a '#' frame is no command
    line.silent(b"!99215" + CRLF)  # too short to hold an SC
    assert line.sim.ignored == 4
    assert [r.command for r in line.sim.received] == ["215"] * 4  # only the 215H after each


def test_a_command_without_lf_is_dropped_at_the_next_header(line: Line) -> None:
    line.silent(b"!992152B\r")


def test_messages_off_the_allow_list_are_refused_and_recorded(line: Line) -> None:
    assert line.ask(SERVO_Q) == error(codes.NOT_SUPPORTED)
    assert line.ask(PROGRAM_RUN_Q) == error(codes.NOT_SUPPORTED)
    assert [(r.command, r.payload) for r in line.sim.off_list()] == [
        ("232", "232071"),
        ("253", "25301"),
    ]
    assert line.state.idle and not line.state.program_running


def test_a_command_larger_than_the_receive_buffer_is_refused(line: Line) -> None:
    line.state.model = "TT"  # receives 1023 bytes a frame
    records = "01000000000000000003E800" * 45  # 10 + 10 + 45 x 24 = 1100 bytes
    body = f"!99291000001002D{records}".encode()
    sc = f"{sum(body) & 0xFF:02X}".encode()  # summed here: too long to write out by hand
    assert line.ask(body + sc + CRLF) == error(codes.TOO_LONG)
    assert 2 not in line.state.positions


# --- faults -------------------------------------------------------------------------------------


def test_a_bad_checksum_fault_corrupts_only_the_sc(line: Line) -> None:
    line.sim.faults = Faults(bad_checksum=1.0)
    reply = line.ask(SYSTEM_STATUS_Q)
    assert reply[:-4] == STATUS_IDLE[:-4] and reply[-2:] == CRLF and reply != STATUS_IDLE
    dec = p.FrameDecoder()
    dec.feed(reply)
    with pytest.raises(p.ChecksumError):
        dec.next_frame()


def test_noise_and_fragments_reach_the_client_around_a_whole_reply(line: Line) -> None:
    line.sim.faults = Faults(noise=1.0, fragment=1.0, seed=3)
    for _ in range(5):
        reply = line.ask(VERSION_Q)
        assert reply.endswith(VERSION_REPLY) and len(reply) > len(VERSION_REPLY)


def test_a_dropped_reply_is_recorded_as_unanswered(line: Line) -> None:
    line.sim.faults = Faults(drop=1.0)
    recorded = threading.Event()
    line.sim.listeners.append(lambda _: recorded.set())
    line.port.write(VERSION_Q)
    assert recorded.wait(3.0), "the request never arrived"
    line.sim.faults = Faults()
    assert line.ask(SYSTEM_STATUS_Q) == STATUS_IDLE
    assert [(r.command, r.answered) for r in line.sim.received] == [("201", False), ("215", True)]


# --- the framework's side: generation, control, URLs, memory, the command -------------------------


def test_a_generated_controller_is_realistic_and_reproducible() -> None:
    a, b = SimState.generate(5), SimState.generate(5)
    assert a.positions == b.positions and a.axes == b.axes
    assert len(a.axes) in (3, 4)
    numbers = sorted(a.positions)
    assert 100 <= len(numbers) <= 700 and 1 <= numbers[0] and numbers[-1] <= 1000
    assert any(y - x > 1 for x, y in pairwise(numbers))  # gaps
    assert all(not a.position_problems(pos) for pos in a.positions.values())
    assert SimState.generate(6).positions != a.positions
    assert (a.flags, a.integers, a.reals) == (b.flags, b.integers, b.reals)
    assert a.flags and min(a.flags) >= 600 and max(a.flags) <= 899
    assert a.integers and all(200 <= n <= 299 for n in a.integers)
    assert a.reals and all(300 <= n <= 399 for n in a.reals)


def test_a_controller_refuses_positions_it_could_not_hold() -> None:
    with pytest.raises(ValueError, match=r"position 4: axes \[3\] not on this robot"):
        SimState.from_positions([POSITION_4], axes=(1, 2))
    with pytest.raises(ValueError, match="unknown model"):
        SimState(model="RCON")


def test_control_verbs_take_hex_stations_and_run_after_writes(tmp_path: Path) -> None:
    sim = Simulator({0x99: controller(), 0xA0: controller()})
    assert apply_command(sim, "status") == "station 99: idle; station A0: idle; 0 writes received"
    assert "station A0: MANUAL mode" in apply_command(sim, "manual A0")
    with pytest.raises(ValueError, match="unknown command 'auto'"):
        apply_command(sim, "auto")
    apply_command(sim, "run-after-writes 1")
    dec = p.FrameDecoder()
    for _, chunk in sim.receive(WRITE_5_6):
        dec.feed(chunk)
    assert dec.next_frame() == p.Frame("#", 0x99, 0x291, "000002")
    assert sim.stations[0x99].program_running  # the schedule started a program


def test_sim_urls_build_iai_controllers_on_hex_stations() -> None:
    sim = simulator_from_url("sim://?family=iai&seed=3&stations=99,A0&run_after_writes=2")
    assert isinstance(sim, Simulator)
    assert sorted(sim.stations) == [0x99, 0xA0] and sim.busy_after_writes == 2
    with serial.serial_for_url("sim://?family=iai&seed=3", timeout=0.05) as port:
        port.write(SYSTEM_STATUS_Q)
        assert read_line(port) == STATUS_IDLE
    with pytest.raises(serial.SerialException, match="unknown sim:// option"):
        simulator_from_url("sim://?family=iai&auto_after_writes=2")


def test_a_project_names_its_family_in_robot_yaml(tmp_path: Path) -> None:
    (tmp_path / "robot.yaml").write_text("name: cell\nfamily: iai\nport: sim://x\n")
    assert project_family(tmp_path) == "iai"
    (tmp_path / "robot.yaml").write_text("name: cell\nport: sim://x\n")
    assert project_family(tmp_path) == "harl-u2"


def test_battery_backed_memory_keeps_the_table_across_a_restart(tmp_path: Path) -> None:
    sim = Simulator(controller())
    keep_state(sim, tmp_path)
    sim.receive(WRITE_5_6)
    sim.receive(WRITE_INTEGERS_Q)  # digest: integer 1 <- -1000
    apply_command(sim, "run")
    again = Simulator(SimState())
    keep_state(again, tmp_path)
    kept = again.stations[0x99]
    assert kept.positions == sim.stations[0x99].positions and 6 in kept.positions
    assert kept.integers == {1: -1000} and kept.idle  # a restarted controller is idle


def test_harlsync_sim_family_iai_serves_pty_and_tcp(tmp_path: Path) -> None:
    record = tmp_path / "requests.jsonl"
    with harlsync_sim(
        "--family",
        "iai",
        "--seed",
        "3",
        "--baud",
        "0",
        "--listen",
        "127.0.0.1:0",
        "--stations",
        "99,A0",
        "--record",
        str(record),
    ) as (proc, lines):
        assert lines["stations"] == "99, A0"
        with serial.serial_for_url(lines["pty"], timeout=0.05) as port:
            port.write(SYSTEM_STATUS_Q)
            assert read_line(port) == STATUS_IDLE
        with serial.serial_for_url(lines["tcp"], timeout=0.05) as port:
            assert proc.stdin is not None and proc.stdout is not None
            proc.stdin.write("run 99\n")
            proc.stdin.flush()
            assert proc.stdout.readline().startswith("station 99: program running")
            port.write(SYSTEM_STATUS_Q)
            assert read_line(port) == STATUS_RUNNING
    records = [json.loads(line) for line in record.read_text().splitlines()]
    assert [(r["station"], r["payload"], r["busy"]) for r in records] == [
        (0x99, "215", False),
        (0x99, "215", True),
    ]


def test_harlsync_sim_help_lists_each_familys_verbs() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "harlsync", "sim", "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    text = " ".join(out.split())
    assert "harl-u2: auto [STATION [TASK]]" in text
    assert "iai: run [STATION], manual [STATION], estop [STATION]" in text
    assert "run-after-writes N, status" in text


# --- helpers ------------------------------------------------------------------------------------


def frame_of(reply: bytes) -> p.Frame:
    dec = p.FrameDecoder()
    dec.feed(reply)
    frame = dec.next_frame()
    assert frame is not None
    return frame


def read_line(port: serial.Serial, deadline: float = 3.0) -> bytes:
    """The bytes read up to the first LF, or all that came before the deadline."""
    out = bytearray()
    end = time.monotonic() + deadline
    while not out.endswith(b"\n") and time.monotonic() < end:
        out += port.read(port.in_waiting or 1)
    return bytes(out)
