"""The link: one port, requests and replies, retries, late replies, the port lock.

Everything runs over a real pty (or a real TCP socket) served by the simulator.
"""

from __future__ import annotations

import logging
import os
import select
import socket
import subprocess
import sys
import tempfile
import termios
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
import serial
from simline import (
    JUNK,
    LOSE,
    SMALL,
    Act,
    ScriptedSim,
    bad_lrc,
    bytewise,
    drop,
    noise,
    preceded_by,
    slow,
    watch_waits,
)

from harlsync.errors import (
    ChecksumError,
    FrameError,
    LinkError,
    LinkTimeout,
    PortBusyError,
    PortError,
    ProjectError,
    WriteUnconfirmed,
)
from harlsync.families.harl_u2.link import Link
from harlsync.families.harl_u2.model import ProgramType, Status, Step
from harlsync.families.harl_u2.protocol import Ack, ErrorReply, encode_frame
from harlsync.families.harl_u2.protocol import commands as cmd
from harlsync.families.harl_u2.sim import SimState
from harlsync.link import SerialSettings, default_lock_dir, lock_key, lock_path
from harlsync.link import lock as lockmod
from harlsync.project.lock import project_lock
from harlsync.sim.serve import PtyServer, TcpServer

FAST = SerialSettings(timeout=0.25, retries=3)


@pytest.fixture
def sim() -> ScriptedSim:
    state = SimState.generate(3, SMALL)
    assert state.data.registers is not None
    for n in range(SMALL.registers):  # every register different: a wrong answer shows
        state.data.registers[n] = f"{1000 + n:04d}"
    for n in range(SMALL.timers):
        state.data.timers[n] = f"{n + 1}.{n}0"
    return ScriptedSim(state)


@pytest.fixture
def device(sim: ScriptedSim) -> Iterator[str]:
    with PtyServer(sim) as server:
        yield server.device


@pytest.fixture
def link(device: str) -> Iterator[Link]:
    link = Link(device, 1, FAST)
    with link:
        yield link


def timers(sim: ScriptedSim) -> dict[int, str]:
    return sim.stations[1].data.timers


# --- plain exchanges --------------------------------------------------------------------


def test_a_read_over_a_pty_returns_the_typed_value(link: Link, sim: ScriptedSim) -> None:
    assert link.exchange(cmd.read_version()) == "5.00"
    assert link.exchange(cmd.read_timer(2)) == "3.20"
    step = link.exchange(cmd.read_step(ProgramType.MAIN, 0, 0))
    assert step == sim.stations[1].data.programs[(ProgramType.MAIN, 0)][0]
    assert link.stats.exchanges == 3 and link.stats.retries == 0


def test_a_read_over_tcp_returns_the_typed_value(sim: ScriptedSim) -> None:
    with TcpServer(sim) as server, Link(server.url, 1, FAST) as link:
        assert link.exchange(cmd.read_register(3)) == "1003"


def test_a_sim_url_opens_the_in_process_simulator() -> None:
    with Link("sim://?seed=1", 1, FAST) as link:
        assert link.exchange(cmd.read_version()) == "5.00"


def test_an_error_reply_is_a_value_not_an_exception(link: Link) -> None:
    assert isinstance(link.exchange(cmd.read_timer(99)), ErrorReply)
    assert link.exchange(cmd.write_timer(1, "1.11")) == Ack("0")


def test_traffic_is_logged_as_hex_at_debug(link: Link, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger="harlsync.link")
    link.exchange(cmd.read_version())
    sent = [r.getMessage() for r in caplog.records if " -> " in r.getMessage()]
    got = " ".join(
        r.getMessage().split(" <- ")[1] for r in caplog.records if " <- " in r.getMessage()
    )
    assert sent == [f"{link.url} -> 02 31 20 4C 4E 56 03 46"]  # LRC worked by hand
    assert got == "02 31 20 35 2E 30 30 03 09"


def test_a_reply_in_single_bytes_is_logged_once_as_one_frame(
    link: Link, sim: ScriptedSim, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG, logger="harlsync.link")
    sim.plan("LNV", Act(wire=bytewise))
    sim.plan("LND 1", Act(wire=noise))
    assert link.exchange(cmd.read_version()) == "5.00"
    assert link.exchange(cmd.read_register(1)) == "1001"
    got = [r.getMessage() for r in caplog.records if " <- " in r.getMessage()]
    assert got == [
        f"{link.url} <- 02 31 20 35 2E 30 30 03 09",
        f"{link.url} <- {JUNK.hex(' ').upper()} 02 31 20 31 30 30 31 03 12",  # LRC by hand
    ]


def test_threads_sharing_one_link_never_interleave_frames(link: Link, sim: ScriptedSim) -> None:
    def worker(k: int) -> list[bool]:
        out = []
        for i in range(15):
            n = (k + i) % SMALL.registers
            out.append(link.exchange(cmd.read_register(n)) == f"{1000 + n:04d}")
            t = (k * i) % SMALL.timers
            out.append(link.exchange(cmd.read_timer(t)) == timers(sim)[t])
        return out

    with ThreadPoolExecutor(8) as pool:
        results = [ok for part in pool.map(worker, range(8)) for ok in part]
    assert len(results) == 8 * 30 and all(results)
    assert sim.ignored == 0, "the simulator saw garbled (interleaved) requests"
    assert link.stats.retries == 0


def test_one_link_serves_several_stations_on_the_line() -> None:
    sim = ScriptedSim({1: SimState.generate(1, SMALL), 2: SimState.generate(2, SMALL)})
    sim.stations[2].data.version = "6.10"
    with PtyServer(sim) as server, Link(server.device, 1, FAST) as link:
        assert link.exchange(cmd.read_version()) == "5.00"
        assert link.exchange(cmd.read_version(), station=2) == "6.10"


# --- faults on the wire ----------------------------------------------------------------------


def test_a_dropped_reply_is_retried_and_the_reason_logged(
    link: Link, sim: ScriptedSim, caplog: pytest.LogCaptureFixture
) -> None:
    sim.plan("LNT 3", Act(wire=drop))
    with caplog.at_level(logging.WARNING, logger="harlsync.link"):
        assert link.exchange(cmd.read_timer(3)) == "4.30"
    assert sim.sent("LNT 3") == ["LNT 3", "LNT 3"]
    assert (link.stats.retries, link.stats.timeouts) == (1, 1)
    (warning,) = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert f"port {link.url}, station 1, command LNT 3: retry 1/3 after no reply" in warning
    assert link.stats.reasons == [warning]
    # the lost reply never comes: the next request still gets its own answer
    assert link.exchange(cmd.read_timer(2)) == "3.20"


def test_a_reply_with_a_bad_lrc_is_retried(link: Link, sim: ScriptedSim) -> None:
    sim.plan("LND 2", Act(wire=bad_lrc))
    assert link.exchange(cmd.read_register(2)) == "1002"
    assert link.stats.bad_frames == 1 and link.stats.retries == 1
    assert "LRC" in link.stats.reasons[0]


def test_noise_before_a_reply_is_dropped_without_a_retry(link: Link, sim: ScriptedSim) -> None:
    sim.plan("LND 1", Act(wire=noise))
    assert link.exchange(cmd.read_register(1)) == "1001"
    assert link.stats.retries == 0
    assert link.stats.noise_bytes == len(JUNK)


def test_a_reply_in_single_bytes_is_put_together_without_a_retry(
    link: Link, sim: ScriptedSim
) -> None:
    sim.plan("LNM 0 0", Act(wire=bytewise))
    step = link.exchange(cmd.read_step(ProgramType.MAIN, 0, 0))
    assert step == sim.stations[1].data.programs[(ProgramType.MAIN, 0)][0]
    assert link.stats.retries == 0 and link.stats.bad_frames == 0


def test_a_frame_for_another_station_is_ignored(link: Link, sim: ScriptedSim) -> None:
    sim.plan("LNT 1", Act(wire=preceded_by(encode_frame(2, "9.99"))))
    assert link.exchange(cmd.read_timer(1)) == "2.10"
    assert link.stats.other_station == 1 and link.stats.retries == 0


def test_issue_11_an_echo_of_our_request_is_never_taken_for_the_reply(
    link: Link, sim: ScriptedSim, caplog: pytest.LogCaptureFixture
) -> None:
    # A 2-wire RS-485 adapter hears its own transmitter: "1 LNV" comes back before the
    # reply, and as a version it is a valid token ("version: LNV" in controller.yaml).
    sent = b"\x021 LNV\x03\x46"  # the golden LNV request, LRC worked by hand
    sim.plan("LNV", Act(wire=preceded_by(sent)))
    with caplog.at_level(logging.INFO, logger="harlsync.link"):
        assert link.exchange(cmd.read_version()) == "5.00"
        sim.plan("LND 1", Act(wire=preceded_by(encode_frame(1, "LND 1"))))
        assert link.exchange(cmd.read_register(1)) == "1001"
    assert (link.stats.echoes, link.stats.unfitting, link.stats.retries) == (2, 0, 0)
    said = [r.getMessage() for r in caplog.records if r.levelno == logging.INFO]
    assert [m for m in said if "echo" in m] == [
        (
            f"{link.url} station 1: skipped the echo of our own request LNV (the line echoes "
            "what we send, as 2-wire RS-485 adapters do)"
        )
    ]  # said once at -v, not once per request


def test_a_reply_that_does_not_fit_is_discarded_and_the_real_one_taken(
    link: Link, sim: ScriptedSim
) -> None:
    sim.stations[1].data.programs[(ProgramType.MAIN, 1)][5] = Step.parse("MOVE P005 S50")
    stale = encode_frame(1, "4 MOVE P004 S20")  # a late answer to step 4
    sim.plan("LNM 1 5", Act(wire=preceded_by(stale)))
    assert link.exchange(cmd.read_step(ProgramType.MAIN, 1, 5)) == Step.parse("MOVE P005 S50")
    assert link.stats.unfitting == 1 and link.stats.retries == 0


def test_issue_11_a_second_frame_nobody_asked_for_fails_the_read_and_nothing_more_is_sent(
    link: Link, sim: ScriptedSim
) -> None:
    # One stray frame is tolerated (the test above); a second says the line repeats
    # replies, and a repeated reply could answer the next request.
    sim.plan("LNT 2", Act(wire=preceded_by(encode_frame(1, "4 MOVE P004 S20"))))
    assert link.exchange(cmd.read_timer(2)) == "3.20"
    sim.plan("LNT 3", Act(wire=preceded_by(encode_frame(1, "1 MOVE P001 S20"))))
    with pytest.raises(LinkError) as info:
        link.exchange(cmd.read_timer(3))
    assert str(info.value) == (
        f"port {link.url}, station 1: the line delivers replies nobody asked for (2 unrequested "
        "frames): two devices answering, or a device server retransmitting; fix the line"
    )
    assert not isinstance(info.value, LinkTimeout)
    with pytest.raises(LinkError, match="nobody asked for"):
        link.exchange(cmd.write_timer(1, "1.11"))
    assert sim.sent("SNT") == [] and link.stats.unrequested == 2


def test_issue_11_replies_later_than_their_window_are_late_replies_not_unrequested(
    device: str, sim: ScriptedSim
) -> None:
    # A slow line is not a repeating one: a write's "0" that comes after its late
    # window is still the answer to a request of ours, however late, and the read
    # back that it lands in is answered by its own reply.
    settings = SerialSettings(timeout=0.5, retries=3)
    with Link(device, 1, settings, late_window=0.05) as link:
        for n, value in ((2, "5.55"), (3, "6.66")):
            sim.plan(f"SNT {n}", Act(wire=slow(0.8)))  # after 0.5 s + 0.05 s, within the next
            with pytest.raises(WriteUnconfirmed):
                link.exchange(cmd.write_timer(n, value))
            assert link.exchange(cmd.read_timer(n)) == value
        assert link.exchange(cmd.read_version()) == "5.00"
    assert (link.stats.late_replies, link.stats.unrequested, link.stats.retries) == (2, 0, 0)


def test_a_slow_reply_is_never_taken_for_the_answer_to_the_next_request(
    link: Link, sim: ScriptedSim
) -> None:
    # Register replies carry no register number: the late "1000" would pass for LND 1.
    # The first reply comes after the deadline (and is taken for the retry); the retry's
    # own reply comes after LND 0 has returned, while LND 1 would be waiting.
    sim.plan("LND 0", Act(wire=slow(FAST.timeout * 1.5)), Act(wire=slow(FAST.timeout * 1.2)))
    assert link.exchange(cmd.read_register(0)) == "1000"
    assert link.exchange(cmd.read_register(1)) == "1001"
    assert link.exchange(cmd.read_register(2)) == "1002"
    assert link.stats.retries == 1 and link.stats.late_replies == 1


def test_issue_6_a_status_retry_is_answered_by_itself_never_by_the_late_first_reply(
    link: Link, sim: ScriptedSim
) -> None:
    # Task states change on their own: the first LNR's late "idle" is stale by the
    # time the retry is answered "task 0 in execution", and must be discarded.
    def started(state: SimState) -> None:
        state.start_task(0, "MAIN", 1, 2)

    sim.plan("LNR", Act(wire=slow(FAST.timeout * 1.5)), Act(before=started))
    status = link.exchange(cmd.read_status())
    assert isinstance(status, Status)
    assert not status.idle and "task 0 in execution" in status.describe()
    assert link.stats.retries == 1 and link.stats.late_replies == 1


def test_a_read_gives_up_after_its_retries_with_link_timeout(link: Link, sim: ScriptedSim) -> None:
    sim.plan("LNT 1", *[Act(wire=drop)] * 3, Act(wire=bad_lrc))
    with pytest.raises(LinkTimeout) as info:
        link.exchange(cmd.read_timer(1))
    assert isinstance(info.value, TimeoutError)
    assert (info.value.port, info.value.station, info.value.command) == (link.url, 1, "LNT 1")
    message = str(info.value)
    assert message.startswith(f"port {link.url}, station 1, command LNT 1: no valid reply after 4 ")
    assert "(last: bad frame: LRC " in message and " for frame '1 2.10')" in message
    assert message.endswith(
        "; check the station number (pendant: SYSTEM GENERATION > MAINTENANCE > STATION NO.), "
        "the cable, and the serial settings (baud, parity) in robot.yaml"
    )
    assert "b'" not in message and "\n" not in message
    assert isinstance(info.value.__cause__, ChecksumError)
    assert len(sim.sent("LNT 1")) == 4 and link.stats.retries == 3


def test_a_malformed_frame_is_reported_as_the_cause_of_the_timeout(
    device: str, sim: ScriptedSim
) -> None:
    garbled = b"\x021 \x01\x03" + bytes([0x31 ^ 0x20 ^ 0x01 ^ 0x03])  # right LRC, control byte
    sim.plan("LNT 1", *[Act(wire=lambda frame: [(0.0, garbled)])] * 2)
    link = Link(device, 1, SerialSettings(timeout=0.2, retries=1))
    with link, pytest.raises(LinkTimeout, match="bad frame") as info:
        link.exchange(cmd.read_timer(1))
    assert isinstance(info.value.__cause__, FrameError)
    assert "control or non-ASCII byte in frame '1 \\x01')" in str(info.value)
    assert "b'" not in str(info.value)
    assert link.stats.bad_frames == 2


def test_a_station_without_a_robot_times_out(device: str, sim: ScriptedSim) -> None:
    link = Link(device, 3, SerialSettings(timeout=0.1, retries=1))
    with link, pytest.raises(LinkTimeout, match="station 3, command LNV"):
        link.exchange(cmd.read_version())
    assert sim.ignored == 2 and sim.received == []


def test_a_write_whose_reply_is_lost_is_never_resent_by_the_link(
    link: Link, sim: ScriptedSim
) -> None:
    sim.plan("SNT 2", Act(wire=drop))
    with pytest.raises(WriteUnconfirmed, match="command SNT 2 5.55: no valid reply"):
        link.exchange(cmd.write_timer(2, "5.55"))
    # a read answered: the simulator has taken every request before it (on a loaded
    # machine its thread may not have run within the write's timeout)
    assert link.exchange(cmd.read_version()) == "5.00"
    assert sim.sent("SNT 2") == ["SNT 2 5.55"]
    assert timers(sim)[2] == "5.55"  # it took; only the controller may find that out
    assert link.stats.unconfirmed_writes == 1 and link.stats.retries == 0


def test_a_write_that_was_never_received_is_not_resent_either(link: Link, sim: ScriptedSim) -> None:
    sim.plan("SND 0", LOSE)
    with pytest.raises(WriteUnconfirmed):
        link.exchange(cmd.write_register(0, "0042"))
    assert link.exchange(cmd.read_version()) == "5.00"  # the simulator has taken it
    assert len(sim.sent("SND 0")) == 1
    assert sim.stations[1].data.registers == {0: "1000", 1: "1001", 2: "1002", 3: "1003"}


def test_an_exchange_on_a_closed_link_raises(device: str) -> None:
    link = Link(device, 1, FAST)
    with pytest.raises(LinkError, match="not open"):
        link.exchange(cmd.read_version())


# --- the port -------------------------------------------------------------------------------


def test_a_missing_port_raises_port_error_with_a_hint(tmp_path: Path) -> None:
    missing = str(tmp_path / "ttyUSB9")
    with pytest.raises(PortError) as info:
        Link(missing).open()
    assert str(info.value) == (
        f"port {missing}: no such device; check that the USB-serial adapter is plugged in "
        "and the port name (ls /dev/ttyUSB* /dev/ttyACM*)"
    )
    assert isinstance(info.value.__cause__, serial.SerialException)
    # the port lock was given back
    with pytest.raises(PortError):
        Link(missing, lock_timeout=0).open()


def test_an_unknown_url_scheme_names_the_port_types_not_the_cable() -> None:
    with pytest.raises(PortError) as info:
        Link("sokcet://x:1").open()
    assert str(info.value) == (
        "port sokcet://x:1: unknown port type 'sokcet://'; use a device path "
        "(/dev/ttyUSB0, COM3), socket://HOST:PORT, rfc2217://HOST:PORT or sim://PROJECT_DIR"
    )
    assert isinstance(info.value.__cause__, ValueError)


@pytest.mark.parametrize("scheme", ["socket", "rfc2217"])
def test_a_refused_connection_says_nothing_listens_there(scheme: str) -> None:
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"{scheme}://127.0.0.1:{port}"
    with pytest.raises(PortError) as info:
        Link(url).open()
    assert str(info.value) == (
        f"port {url}: nothing accepts connections at 127.0.0.1:{port}; is the serial device "
        "server (or harlsync sim --listen) running, and is the address right?"
    )


class _Unopenable:
    """What serial_for_url returns for a port whose open() fails with ``exc``."""

    def __init__(self, exc: BaseException) -> None:
        self.exc = exc

    def open(self) -> None:
        raise self.exc


def test_a_port_without_permission_says_which_group(monkeypatch: pytest.MonkeyPatch) -> None:
    denied = serial.SerialException(
        13, "could not open port /dev/ttyS7: [Errno 13] Permission denied: '/dev/ttyS7'"
    )
    monkeypatch.setattr(serial, "serial_for_url", lambda url, **kw: _Unopenable(denied))
    with pytest.raises(PortError) as info:
        Link("/dev/ttyS7").open()
    assert str(info.value) == (
        "port /dev/ttyS7: permission denied; add your user to the group that owns the device "
        "(ls -l /dev/ttyS7, usually dialout) and log in again"
    )


def test_any_other_open_failure_is_one_line_without_the_port_twice(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    odd = termios.error(22, "Invalid argument")  # not a SerialException, not an OSError
    monkeypatch.setattr(serial, "serial_for_url", lambda url, **kw: _Unopenable(odd))
    with pytest.raises(PortError) as info:
        Link("/dev/ttyS7").open()
    assert str(info.value) == (
        "port /dev/ttyS7: cannot open: [Errno 22] Invalid argument; check the cable/adapter "
        "and the port name"
    )
    assert info.value.__cause__ is odd


def test_a_port_that_fails_right_after_opening_is_closed_and_let_go(
    device: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    opened: list[Any] = []

    def fail(self: Any) -> None:
        opened.append(self)
        raise termios.error(5, "Input/output error")

    with monkeypatch.context() as patch:
        patch.setattr(serial.Serial, "reset_input_buffer", fail)
        with pytest.raises(PortError, match="went away") as info:
            Link(device, 1, FAST).open()
    assert isinstance(info.value.__cause__, termios.error)
    assert [port.is_open for port in opened] == [False]
    with Link(device, 1, FAST, lock_timeout=0) as link:
        assert link.exchange(cmd.read_version()) == "5.00"


# --- a port that fails mid-exchange ------------------------------------------------------


class _Failing:
    """An open port whose attribute ``name`` raises ``exc``; everything else is the real port."""

    def __init__(self, real: Any, name: str, exc: BaseException) -> None:
        self.real, self.name, self.exc = real, name, exc

    def __getattr__(self, attr: str) -> Any:
        if attr == self.name:
            raise self.exc
        return getattr(self.real, attr)


@pytest.mark.parametrize(
    ("name", "exc"),
    [
        ("write", termios.error(5, "Input/output error")),  # a pty that went away
        ("in_waiting", termios.error(5, "Input/output error")),
        ("read", TypeError("'NoneType' object cannot be interpreted as an integer")),
        ("write", OSError(5, "Input/output error")),
    ],
)
def test_any_exception_from_port_io_becomes_port_error(
    link: Link, monkeypatch: pytest.MonkeyPatch, name: str, exc: BaseException
) -> None:
    monkeypatch.setattr(link, "_port", _Failing(link._port, name, exc))
    monkeypatch.setattr(link, "_direct", None)  # read through pyserial, as sim:// and spy://
    with pytest.raises(PortError) as info:
        link.exchange(cmd.read_version())
    message = str(info.value)
    assert message.startswith(f"port {link.url}, station 1, command LNV: port went away")
    assert "check that the USB-serial adapter is still plugged in" in message
    assert "\n" not in message
    assert info.value.__cause__ is exc


def test_a_failed_read_of_the_descriptor_the_link_reads_itself_becomes_port_error(
    link: Link, monkeypatch: pytest.MonkeyPatch
) -> None:

    gone = OSError(5, "Input/output error")

    def read(fd: int, size: int) -> bytes:
        raise gone

    assert link._direct is not None  # a pty: read with os.read, not through pyserial
    monkeypatch.setattr(os, "read", read)  # the os module the link's reads go through
    with pytest.raises(PortError) as info:
        link.exchange(cmd.read_version())
    assert str(info.value) == (
        f"port {link.url}, station 1, command LNV: port went away: [Errno 5] Input/output "
        "error; check that the USB-serial adapter is still plugged in and the cable is seated"
    )
    assert info.value.__cause__ is gone


def test_a_peer_that_closes_its_socket_is_a_port_gone_not_a_silent_line(
    sim: ScriptedSim,
) -> None:
    with TcpServer(sim) as server, Link(server.url, 1, FAST) as link:
        assert link.exchange(cmd.read_version()) == "5.00"
        server.stop()
        with pytest.raises(PortError, match="port went away: the other end closed") as info:
            link.exchange(cmd.read_timer(2))
    assert "\n" not in str(info.value)


class _Counted:
    """os.read and os.write as the link module calls them, on one descriptor: the
    writes, and the reads that got bytes (a read that finds nothing, a timer that woke
    before the reply on a busy machine, is no receive)."""

    def __init__(self, fd: int) -> None:
        self.fd, self.reads, self.writes = fd, 0, 0
        self._read, self._write = os.read, os.write

    def read(self, fd: int, size: int) -> bytes:
        data = self._read(fd, size)  # nothing there raises: only reads that got bytes count
        self.reads += fd == self.fd
        return data

    def write(self, fd: int, data: bytes) -> int:
        self.writes += fd == self.fd
        return self._write(fd, data)


def test_issue_24_a_read_after_a_read_is_one_write_and_one_read_and_no_terminal_call(
    link: Link, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert link.exchange(cmd.read_timer(0)) == "1.00"
    assert link._direct is not None
    counted = _Counted(link._direct)
    monkeypatch.setattr(os, "read", counted.read)  # the link's and pyserial's os module
    monkeypatch.setattr(os, "write", counted.write)

    def terminal_call(self: Any) -> int:
        raise AssertionError("in_waiting asked during an exchange")

    monkeypatch.setattr(type(link._port), "in_waiting", property(terminal_call))
    for n in [1, 2, 3, 0] * 2:
        assert link.exchange(cmd.read_timer(n)) == f"{n + 1}.{n}0"
    # The simulator writes each reply at once: one read takes it whole, after the
    # drain's one read that finds the line empty (a read after a read is drained too).
    assert (counted.writes, counted.reads) == (8, 8 + 8)


def test_issue_24_review_a_frame_begun_before_a_read_after_a_read_is_not_taken_for_its_reply(
    link: Link, sim: ScriptedSim
) -> None:
    # A second device, or a device server that repeats: a frame that fits any timer
    # read, its first bytes on the line before the next request, the rest after.
    stray = encode_frame(1, "9.99")
    sim.plan(
        "LNT 2", Act(wire=lambda frame: [(0.0, frame), (0.0005, stray[:3]), (0.01, stray[3:])])
    )
    assert link.exchange(cmd.read_timer(2)) == "3.20"
    assert link._fd is not None
    assert select.select([link._fd], [], [], 5)[0], "the stray's first bytes never came"
    assert link.exchange(cmd.read_timer(3)) == "4.30"  # not 9.99, the stray's value
    assert link.exchange(cmd.read_timer(1)) == "2.10"


def test_issue_24_a_repeated_reply_read_with_the_reply_is_drained_before_the_next_read(
    link: Link, sim: ScriptedSim
) -> None:
    sim.plan("LNT 2", Act(wire=lambda frame: [(0.0, frame + frame)]))
    assert link.exchange(cmd.read_timer(2)) == "3.20"
    assert link.exchange(cmd.read_timer(3)) == "4.30"  # not the repeated 3.20
    assert link.stats.unrequested == 1 and link.stats.unfitting == 0


def _wait_for_the_stray(link: Link) -> None:
    """Until the stray frame is on the port, or read with the reply (a busy machine)."""
    assert link._fd is not None
    if not link._decoder.pending:
        assert select.select([link._fd], [], [], 5)[0], "the stray frame never came"


@pytest.mark.parametrize(
    "request_",
    [cmd.write_timer(1, "1.11"), cmd.read_status()],
    ids=["write", "volatile read"],
)
def test_issue_24_a_frame_that_came_after_the_reply_is_drained_before_a_write_or_volatile_read(
    link: Link, sim: ScriptedSim, request_: Any
) -> None:
    stray = encode_frame(1, "4 MOVE P004 S20")
    sim.plan("LNT 2", Act(wire=lambda frame: [(0.0, frame), (0.002, stray)]))
    assert link.exchange(cmd.read_timer(2)) == "3.20"
    _wait_for_the_stray(link)
    link.exchange(request_)
    assert link.stats.unrequested == 1 and link.stats.unfitting == 0  # drained, not decoded


def test_issue_24_a_frame_that_came_after_the_reply_is_drained_before_the_next_read(
    link: Link, sim: ScriptedSim
) -> None:
    sim.plan("LNT 2", Act(wire=lambda frame: [(0.0, frame), (0.002, encode_frame(1, "3.20"))]))
    assert link.exchange(cmd.read_timer(2)) == "3.20"
    _wait_for_the_stray(link)
    assert link.exchange(cmd.read_timer(3)) == "4.30"  # not the stray 3.20
    assert link.stats.unrequested == 1


def test_a_write_timeout_blames_flow_control_not_a_lost_port(
    link: Link, monkeypatch: pytest.MonkeyPatch
) -> None:
    stuck = serial.SerialTimeoutException("Write timeout")
    monkeypatch.setattr(link, "_port", _Failing(link._port, "write", stuck))
    with pytest.raises(PortError, match="write timed out after 1.0 s: ") as info:
        link.exchange(cmd.read_version())
    assert "rtscts" in str(info.value) and info.value.__cause__ is stuck


def test_a_port_that_fails_to_close_is_still_let_go(
    device: str, caplog: pytest.LogCaptureFixture
) -> None:
    link = Link(device, 1, FAST).open()
    real = link._port
    assert real is not None
    link._port = _Failing(real, "close", termios.error(5, "Input/output error"))
    with caplog.at_level(logging.WARNING, logger="harlsync.link"):
        link.close()  # a finished job must not fail, nor hide its own error, over this
    real.close()
    assert not link.is_open
    assert [r.getMessage() for r in caplog.records] == [
        f"port {device}: closing failed: [Errno 5] Input/output error"
    ]
    with Link(device, 1, FAST, lock_timeout=0) as again:
        assert again.exchange(cmd.read_version()) == "5.00"


def test_a_port_that_goes_away_raises_port_error(sim: ScriptedSim) -> None:
    server = TcpServer(sim)
    server.start()
    with Link(server.url, 1, FAST) as link:
        assert link.exchange(cmd.read_version()) == "5.00"
        server.stop()
        with pytest.raises(PortError, match="went away"):
            for _ in range(3):  # the first send may still be accepted by the socket
                link.exchange(cmd.read_version())


def test_a_second_link_on_the_same_port_is_refused(link: Link, device: str) -> None:
    with pytest.raises(PortBusyError) as info:
        Link(device, 2, lock_timeout=0.1).open()
    assert str(info.value).startswith(f"port {device}: in use by another Link of this process")
    assert "--lock-timeout" in str(info.value) and str(link.lock_path) in str(info.value)
    assert link.exchange(cmd.read_version()) == "5.00"  # the holder is not disturbed


def test_a_symlink_to_the_port_shares_its_lock(link: Link, device: str, tmp_path: Path) -> None:
    alias = tmp_path / "ttyROBOT"
    alias.symlink_to(device)
    with pytest.raises(PortBusyError):
        Link(str(alias), lock_timeout=0).open()


def test_the_port_is_free_again_once_the_link_is_closed(device: str) -> None:
    first = Link(device, 1, FAST).open()
    first.close()
    with Link(device, 1, FAST, lock_timeout=0) as second:
        assert second.exchange(cmd.read_version()) == "5.00"


def test_a_second_process_is_refused_and_told_who_holds_the_port(link: Link, device: str) -> None:
    code = (
        "import sys\n"
        "from harlsync.errors import PortBusyError\n"
        "from harlsync.families.harl_u2.link import Link\n"
        "try:\n"
        "    Link(sys.argv[1], lock_timeout=0.2).open()\n"
        "except PortBusyError as exc:\n"
        "    print(exc)\n"
        "    sys.exit(3)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, device],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 3, done.stderr
    assert f"port {device}: in use by another harlsync (pid {os.getpid()})" in done.stdout


def test_a_waiting_link_gets_the_port_when_the_holder_closes(device: str) -> None:
    holder = Link(device, 1, FAST).open()
    got: list[str | ErrorReply] = []
    waiting = threading.Event()

    def wait_for_port() -> None:
        waiting.set()
        with Link(device, 1, FAST, lock_timeout=20) as link:
            got.append(link.exchange(cmd.read_version()))

    thread = threading.Thread(target=wait_for_port)
    thread.start()
    waiting.wait(10)
    holder.close()
    thread.join(30)
    assert got == ["5.00"]


# --- lock file names --------------------------------------------------------------------------


def test_lock_keys_name_the_line_not_the_spelling(tmp_path: Path) -> None:
    real = tmp_path / "ttyUSB0"
    real.touch()
    (tmp_path / "by-id").symlink_to(real)
    assert lock_key(str(tmp_path / "by-id")) == str(real)
    assert lock_key(f"spy://{real}?file=x.txt") == str(real)
    assert lock_key("com3") == lock_key(r"\\.\COM3") == "COM3"
    assert lock_key("socket://Robot-Cell.invalid:4001?logging=debug") == (
        "socket://robot-cell.invalid:4001"
    )
    assert lock_key("rfc2217://10.0.0.5:2217") == "rfc2217://10.0.0.5:2217"
    # A port number out of range is the open's error to report, not a crash here (the
    # audit log keeps every port ever given, and is read before every push).
    assert lock_key("socket://gw:99999") == "socket://gw:99999"
    # One device server, however it is spelled: a second harlsync must wait.
    assert (
        lock_key("socket://localhost:4001")
        == lock_key("socket://127.0.0.1:4001")
        == (lock_key("socket://[::1]:4001"))
        != lock_key("socket://127.0.0.1:4002")
    )
    assert lock_key("loop://") is None
    assert lock_path("loop://") is None


def machine(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, *, run_lock: int | None) -> Path:
    """A machine whose ``/run/lock`` is ``tmp_path/run-lock`` with mode ``run_lock``
    (None: it has none), with no ``HARLSYNC_LOCK_DIR``; its ``/run/lock``."""
    base = tmp_path / "run-lock"
    if run_lock is not None:
        base.mkdir()
        base.chmod(run_lock)
    monkeypatch.setattr(lockmod, "SYSTEM_LOCK_DIRS", (base,), raising=False)
    monkeypatch.delenv("HARLSYNC_LOCK_DIR")
    return base


def another_tmpdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    """This process now has a temporary directory of its own, as one started with
    another TMPDIR, or by systemd with PrivateTmp, does."""
    (tmp_path / name).mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / name))
    monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() reads TMPDIR again


def test_the_lock_directory_is_chosen_from_argument_env_and_the_machine_never_the_session(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HARLSYNC_LOCK_DIR", str(tmp_path / "env"))
    chosen = lock_path("COM3", tmp_path / "arg")
    assert chosen is not None and chosen.parent == tmp_path / "arg"
    assert default_lock_dir() == tmp_path / "env"
    # /run/lock that every user may write (Debian, Ubuntu: 1777): harlsync's directory there.
    run_lock = machine(tmp_path, monkeypatch, run_lock=0o1777)
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    assert default_lock_dir() == run_lock / "harlsync"
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))  # a login session: same place
    another_tmpdir(tmp_path, monkeypatch, "tmp-1")
    assert default_lock_dir() == run_lock / "harlsync"
    # /run/lock only root may write (Fedora: 755): the same fixed directory for every
    # user, root included, unless an administrator made harlsync's there.
    run_lock.chmod(0o755)
    assert default_lock_dir() == Path("/tmp/harlsync-locks")
    (run_lock / "harlsync").mkdir()
    assert default_lock_dir() == run_lock / "harlsync"


def test_without_run_lock_the_lock_directory_is_a_fixed_one_whatever_tmpdir_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    machine(tmp_path, monkeypatch, run_lock=None)
    another_tmpdir(tmp_path, monkeypatch, "tmp-1")
    shared = default_lock_dir()
    another_tmpdir(tmp_path, monkeypatch, "tmp-2")
    assert default_lock_dir() == shared == Path("/tmp/harlsync-locks")


def test_issue_11_a_harlsync_with_another_tmpdir_still_sees_the_line_and_project_locks(
    sim: ScriptedSim, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Issue 11: the lock directory followed TMPDIR, so a cron job with another TMPDIR
    # (or a service with systemd's PrivateTmp) took the line a push was using.  Over
    # TCP the lock file is all that keeps a second harlsync off the line.
    machine(tmp_path, monkeypatch, run_lock=0o1777)
    another_tmpdir(tmp_path, monkeypatch, "tmp-shell")
    project = tmp_path / "cell"

    def backup() -> None:
        with project_lock(project, command="backup"):
            pass

    with (
        TcpServer(sim) as server,
        Link(server.url, 1, FAST) as first,
        project_lock(project, command="pull"),
    ):
        another_tmpdir(tmp_path, monkeypatch, "tmp-cron")
        with pytest.raises(PortBusyError):
            Link(server.url, 2, FAST, lock_timeout=0).open()
        with ThreadPoolExecutor(1) as other, pytest.raises(ProjectError, match="is in use by pid"):
            other.submit(backup).result()  # another thread: the lock is reentrant per thread
        assert first.exchange(cmd.read_version()) == "5.00"


@pytest.mark.parametrize("url", ["socket://gw:99999", "rfc2217://gw:x", "socket://gw"])
def test_a_device_server_address_without_a_port_number_says_what_to_give(url: str) -> None:
    with pytest.raises(
        PortError,
        match=r"not a \w+:// address; give \w+://HOST:PORT, PORT a "
        r"number from 1 to 65535",
    ):
        Link(url).open()


def test_issue_24_replies_that_came_late_once_set_no_pace_for_the_later_ones(
    link: Link, sim: ScriptedSim, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A busy start: the first replies of a kind came late.  The link learns no pace
    from them (it once timed the kind by them and waited as long for the rest of the
    pull): each later exchange waits for its reply's bytes, up to its deadline, and
    for nothing else."""
    sim.plan("LNT 2", *[Act(wire=slow(0.04))] * 3)
    for _ in range(3):
        assert link.exchange(cmd.read_timer(2)) == "3.20"
    clock = watch_waits(link, monkeypatch)
    for _ in range(20):
        assert link.exchange(cmd.read_timer(2)) == "3.20"
    assert clock.sleeps == []
    assert clock.polls and all(wait == pytest.approx(FAST.timeout) for wait in clock.polls)
