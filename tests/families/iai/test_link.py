"""The IAI codec through the shared link: the same Link, retries and deadlines as the
HARL-U2, over a real pty served by a scripted IAI controller."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import replace

import pytest

from harlsync.errors import LinkError, LinkTimeout, ProtocolError
from harlsync.families.iai import profile
from harlsync.families.iai import protocol as p
from harlsync.families.iai.codec import CODEC, SETTINGS
from harlsync.families.iai.interlock import SystemStatus
from harlsync.families.iai.model import Version
from harlsync.link import Link, SerialSettings
from harlsync.sim.serve import PtyServer

CRLF = b"\r\n"
STATION = 0x99
# Golden frames, from the digest (§2.5) and written by hand (SC summed by hand).
SYSTEM_STATUS_Q = b"!992152B" + CRLF
STATUS_IDLE = b"#9921510000000000040002" + CRLF  # AUTO, no error, ready
VERSION_REPLY = b"#992010001234004107E303050E070933" + CRLF
ERROR_REPLY = b"&990A13A" + CRLF

Chunks = list[tuple[float, bytes]]
Act = Callable[[bytes], Chunks]


def drop(frame: bytes) -> Chunks:
    return []


def bad_sc(frame: bytes) -> Chunks:
    sc = frame[-4:-2]
    return [(0.0, frame[:-4] + (b"00" if sc != b"00" else b"11") + CRLF)]


class ScriptedIai:
    """An IAI controller at station 99 that answers 215H idle and 201H its version,
    on the wire as :class:`~harlsync.sim.serve.PtyServer` serves a simulator; ``plan``
    shapes the next replies (dropped, corrupted ...), ``reply`` replaces what it
    answers.  ``echo`` sends every byte back first (2-wire RS-485), ``repeat`` sends
    every reply twice, 3 ms apart."""

    char_time = 0.0

    def __init__(self, *, echo: bool = False, repeat: bool = False) -> None:
        self.decoder = p.FrameDecoder()
        self.received: list[bytes] = []
        self.acts: list[Act] = []
        self.reply: bytes | None = None
        self.echo = echo
        self.repeat = repeat

    def plan(self, *acts: Act) -> None:
        self.acts += acts

    def receive(self, data: bytes, client: str = "") -> Chunks:
        self.decoder.feed(data)
        out: Chunks = [(0.0, data)] if self.echo else []
        while True:
            try:
                frame = self.decoder.next_frame()
            except ProtocolError:
                continue  # a controller says nothing to a bad frame (p.9)
            if frame is None:
                return out
            if frame.kind != "!" or frame.station != STATION:
                continue
            self.received.append(frame.encode())
            assert frame.message_id is not None  # a "!" frame names its message
            reply = self.reply or {0x215: STATUS_IDLE, 0x201: VERSION_REPLY}[frame.message_id]
            act = self.acts.pop(0) if self.acts else None
            out += act(reply) if act else [(0.0, reply)]
            if self.repeat:
                out.append((0.003, reply))


@pytest.fixture
def device() -> Iterator[ScriptedIai]:
    yield ScriptedIai()


def serve(device: ScriptedIai) -> PtyServer:
    """A pty the scripted controller answers on."""
    # A stand-in, deliberately not a Simulator: it has of one only what the server uses.
    return PtyServer(device)  # type: ignore[arg-type]


def fast(retries: int = 3) -> SerialSettings:
    return replace(SETTINGS, timeout=0.1, retries=retries)


def open_link(server: PtyServer, settings: SerialSettings) -> Link[p.Frame]:
    return Link(server.device, STATION, settings, codec=CODEC).open()


def test_a_215h_exchange_through_the_shared_link_returns_the_system_status(
    device: ScriptedIai,
) -> None:
    with serve(device) as server, open_link(server, fast()) as link:
        status = link.exchange(p.system_status())
    assert status == SystemStatus(1, "000", "000", 0, 0, 4, 0)
    assert isinstance(status, SystemStatus) and status.refusals == ()
    assert device.received == [SYSTEM_STATUS_Q]
    assert link.stats.exchanges == 1 and link.stats.retries == 0


def test_an_error_reply_is_a_value(device: ScriptedIai) -> None:
    device.reply = ERROR_REPLY
    with serve(device) as server, open_link(server, fast()) as link:
        assert link.exchange(p.system_status()) == p.ErrorReply("0A1")


def test_a_silent_controller_times_out_naming_what_to_check_on_an_iai(
    device: ScriptedIai,
) -> None:
    device.plan(drop, drop)
    with (
        serve(device) as server,
        open_link(server, fast(retries=1)) as link,
        pytest.raises(LinkTimeout) as info,
    ):
        link.exchange(p.system_status())
    message = str(info.value)
    # The deadline is the profile's: the timeout plus 1.5 x the wire time of 25 bytes,
    # said as configured and the wire's part apart (issue 22 item 11).
    wire = profile.REPLY_DEADLINE_FACTOR * 25 * 10 / 9600
    assert f"(last: no reply within 0.1 s (+{wire:.3f} s for its time on the wire))" in message
    assert message.endswith(
        "check that the controller speaks protocol B (I/O parameter No. 90 = 2), that its "
        "station is 99 (hex, as --station and robot.yaml give it), that it is in AUTO mode "
        "(it answers nothing in MANUAL), the cable, and the baud rate in robot.yaml"
    )
    assert "PENDANT" not in message.upper()
    assert device.received == [SYSTEM_STATUS_Q] * 2 and link.stats.timeouts == 2


def test_a_reply_with_a_bad_sc_is_retried_and_the_good_one_taken(device: ScriptedIai) -> None:
    device.plan(bad_sc)
    with serve(device) as server, open_link(server, fast()) as link:
        status = link.exchange(p.system_status())
    assert isinstance(status, SystemStatus) and status.mode == 1
    assert device.received == [SYSTEM_STATUS_Q] * 2
    assert (link.stats.bad_frames, link.stats.retries) == (1, 1)
    assert "bad frame: SC 00 does not match 02" in link.stats.reasons[0]


def test_the_reply_deadline_grows_with_the_longest_reply_a_request_can_get() -> None:
    status, positions = p.system_status(), p.read_positions(1, 24)
    assert CODEC.reply_timeout(status, SETTINGS) == pytest.approx(profile.reply_deadline(25))
    assert CODEC.reply_timeout(positions, SETTINGS) == pytest.approx(
        profile.reply_deadline(positions.reply_bytes)
    )
    at_115200 = replace(SETTINGS, baudrate=115200)
    assert CODEC.reply_timeout(positions, at_115200) < CODEC.reply_timeout(positions, SETTINGS)


def test_issue_11_a_line_that_echoes_commands_is_recognised_not_taken_for_a_misfit() -> None:
    device = ScriptedIai(echo=True)
    with serve(device) as server, open_link(server, fast()) as link:
        assert isinstance(link.exchange(p.system_status()), SystemStatus)
        assert isinstance(link.exchange(p.system_status()), SystemStatus)
    assert (link.stats.echoes, link.stats.unfitting, link.stats.retries) == (2, 0, 0)


def test_issue_11_a_line_that_repeats_replies_fails_the_read_on_the_iai_too() -> None:
    # The reply's message id binds it to its kind of request, so a repeated version
    # never answers a status read; the frames it leaves over still fail the read.
    device = ScriptedIai(repeat=True)
    with (
        serve(device) as server,
        open_link(server, fast()) as link,
        pytest.raises(LinkError) as info,
    ):
        for _ in range(20):
            assert isinstance(link.exchange(p.version()), Version)
            assert isinstance(link.exchange(p.system_status()), SystemStatus)
    assert re.fullmatch(
        rf"port {server.device}, station 99: the line delivers replies nobody asked for "
        r"\(\d+ unrequested frames\): two devices answering, or a device server "
        r"retransmitting; fix the line",
        str(info.value),
    )
    assert link.stats.unrequested >= 2
