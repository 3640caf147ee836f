"""The sans-I/O codec: golden frames written by hand, decoded three ways."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from conftest import examples
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from harlsync.errors import ChecksumError, FrameError, ProtocolError, ReplyError
from harlsync.families.harl_u2.model import (
    Config,
    OffsetTable,
    Parameters,
    ProgramArea,
    ProgramType,
    Status,
    Step,
)
from harlsync.families.harl_u2.protocol import (
    Frame,
    FrameDecoder,
    decode_reply,
    encode_frame,
    lrc,
    profile,
)
from harlsync.families.harl_u2.protocol import commands as c
from harlsync.families.harl_u2.protocol.commands import Ack, ErrorReply
from harlsync.families.harl_u2.protocol.frame import off_allow_list
from harlsync.families.harl_u2.protocol.readback import read_back
from harlsync.families.harl_u2.sim import SimState, Simulator
from harlsync.families.harl_u2.sim.state import DEFAULT_PARAMETERS

STX, ETX = b"\x02", b"\x03"

# Golden frames. Each LRC was worked out by hand, XOR of the bytes after STX
# through ETX, as the manual's section 2.3 describes; none comes from our encoder.
WORKED_REQUEST = STX + b"1 LNM 2 3" + ETX + b"\x5c"  # the profile's worked example
WORKED_REPLY = STX + b"1 3 MOVE P010 S50" + ETX + b"\x27"
LNV_REQUEST = STX + b"1 LNV" + ETX + b"\x46"
LNV_REPLY = STX + b"1 5.00" + ETX + b"\x09"
ERROR_REPLY = STX + b"1 E21" + ETX + b"\x54"
LNT_REQUEST_ST2 = STX + b"2 LNT 5" + ETX + b"\x52"
LNT_REPLY_ST2 = STX + b"2 1.50" + ETX + b"\x0b"
# LRCs that happen to equal STX and ETX: a reader must take them as one raw byte.
LRC_IS_STX = STX + b"1 0.68" + ETX + b"\x02"
LRC_IS_ETX = STX + b"2 0.48" + ETX + b"\x03"

GOLDEN = [
    (WORKED_REQUEST, 1, "LNM 2 3"),
    (WORKED_REPLY, 1, "3 MOVE P010 S50"),
    (LNV_REQUEST, 1, "LNV"),
    (LNV_REPLY, 1, "5.00"),
    (ERROR_REPLY, 1, "E21"),
    (LNT_REQUEST_ST2, 2, "LNT 5"),
    (LNT_REPLY_ST2, 2, "1.50"),
    (LRC_IS_STX, 1, "0.68"),
    (LRC_IS_ETX, 2, "0.48"),
]


def feed_whole(data: bytes) -> tuple[list[Frame | ProtocolError], FrameDecoder]:
    dec = FrameDecoder()
    dec.feed(data)
    return drain(dec), dec


def feed_bytewise(data: bytes) -> tuple[list[Frame | ProtocolError], FrameDecoder]:
    dec = FrameDecoder()
    out = []
    for i in range(len(data)):
        dec.feed(data[i : i + 1])
        out += drain(dec)
    return out, dec


NOISE = b"\x00\xff garbage\x7f"


def feed_with_garbage(data: bytes) -> tuple[list[Frame | ProtocolError], FrameDecoder]:
    dec = FrameDecoder()
    dec.feed(NOISE + data + NOISE)
    return drain(dec), dec


def drain(dec: FrameDecoder) -> list[Frame | ProtocolError]:
    """Every frame and every protocol error the buffered bytes give, in order."""
    out: list[Frame | ProtocolError] = []
    while True:
        try:
            frame = dec.next_frame()
        except ProtocolError as exc:
            out.append(exc)
            continue
        if frame is None:
            return out
        out.append(frame)


#: How a test feeds bytes to a decoder: whole, byte by byte, or with garbage between.
Feed = Callable[[bytes], tuple[list[Frame | ProtocolError], FrameDecoder]]

THREE_WAYS = pytest.mark.parametrize(
    "feed", [feed_whole, feed_bytewise, feed_with_garbage], ids=["whole", "bytewise", "garbage"]
)


def test_lrc_is_the_xor_of_the_bytes_after_stx_through_etx() -> None:
    assert lrc(b"1 LNM 2 3\x03") == 0x5C
    assert lrc(b"") == 0


@pytest.mark.parametrize("frame,station,payload", GOLDEN)
def test_the_encoder_produces_the_golden_frames(frame: bytes, station: int, payload: str) -> None:
    assert encode_frame(station, payload) == frame


@THREE_WAYS
@pytest.mark.parametrize("frame,station,payload", GOLDEN)
def test_the_decoder_reads_each_golden_frame(
    feed: Feed, frame: bytes, station: int, payload: str
) -> None:
    out, _ = feed(frame)
    assert [(f.station, f.payload) if isinstance(f, Frame) else f for f in out] == [
        (station, payload)
    ]


@THREE_WAYS
def test_back_to_back_frames_come_out_in_order(feed: Feed) -> None:
    out, _ = feed(WORKED_REQUEST + LRC_IS_ETX + LRC_IS_STX + WORKED_REPLY)
    assert [f.payload if isinstance(f, Frame) else f for f in out] == [
        "LNM 2 3",
        "0.48",
        "0.68",
        "3 MOVE P010 S50",
    ]


def test_noise_before_stx_is_dropped_and_counted() -> None:
    out, dec = feed_with_garbage(WORKED_REPLY)
    assert [f.payload if isinstance(f, Frame) else f for f in out] == ["3 MOVE P010 S50"]
    assert dec.dropped == 2 * len(NOISE)


@THREE_WAYS
def test_a_bad_lrc_is_an_error_and_the_next_frame_still_decodes(feed: Feed) -> None:
    bad = WORKED_REPLY[:-1] + b"\x28"
    out, _ = feed(bad + LNV_REPLY)
    assert isinstance(out[0], ChecksumError)
    assert [f.payload if isinstance(f, Frame) else f for f in out[1:]] == ["5.00"]


@THREE_WAYS
def test_a_frame_cut_short_by_a_new_stx_is_dropped(feed: Feed) -> None:
    out, dec = feed(STX + b"1 3 MO" + LNV_REPLY)
    assert [f.payload if isinstance(f, Frame) else f for f in out] == ["5.00"]
    assert dec.dropped >= len(b"\x021 3 MO")


@pytest.mark.parametrize(
    "body",
    [b"x LNV", b"1LNV", b"1 LNV  2", b"1 LN\x07V", b"123 LNV", b"1 \xe9"],
    ids=["letter station", "no space", "empty field", "control byte", "long station", "non-ascii"],
)
def test_malformed_frames_are_frame_errors(body: bytes) -> None:
    raw = body + ETX
    out, _ = feed_whole(STX + raw + bytes([lrc(raw)]))
    assert len(out) == 1 and isinstance(out[0], FrameError)


def test_a_frame_without_etx_is_dropped_at_the_length_limit() -> None:
    dec = FrameDecoder(max_frame=32)
    dec.feed(STX + b"1 " + b"A" * 40)
    with pytest.raises(FrameError):
        dec.next_frame()
    dec.feed(LNV_REPLY)
    frame = dec.next_frame()
    assert frame is not None and frame.payload == "5.00"


@settings(max_examples=examples(300))
@given(st.lists(st.binary(max_size=40), max_size=8))
def test_arbitrary_bytes_only_ever_give_frames_or_protocol_errors(chunks: list[bytes]) -> None:
    dec = FrameDecoder(max_frame=64)
    for chunk in chunks:
        dec.feed(chunk)
        drain(dec)  # any other exception fails the test
    assert dec.pending <= 64 + 2


@given(
    st.integers(1, 99),
    st.lists(
        st.text(st.characters(min_codepoint=0x21, max_codepoint=0x7E), min_size=1), max_size=6
    ),
    st.binary(max_size=10),
)
def test_any_encoded_frame_decodes_to_itself_after_noise(
    station: int, fields: list[str], noise: bytes
) -> None:
    payload = " ".join(fields)
    assume(off_allow_list(payload) is None)  # those are refused, tested above
    dec = FrameDecoder()
    dec.feed(noise.replace(STX, b"") + encode_frame(station, payload))
    frame = dec.next_frame()
    assert frame is not None and (frame.station, frame.payload) == (station, payload)


# --- commands -------------------------------------------------------------------------

REQUESTS = [
    (c.read_step(ProgramType.START, 0, 7), "LNA 7"),
    (c.read_step(ProgramType.MAIN, 2, 3), "LNM 2 3"),
    (c.read_step(ProgramType.SUB, 15, 255), "LNS 15 255"),
    (c.read_step(ProgramType.HAND, 1, 0), "LNH 1 0"),
    (c.read_timer(5), "LNT 5"),
    (c.read_register(12), "LND 12"),
    (c.read_offset(99), "LNL 99"),
    (c.read_di_bit(200), "LNIB 200"),
    (c.read_di_port(31), "LNID 31"),
    (c.read_do_bit(3), "LNOB 3"),
    (c.read_do_port(0), "LNOD 0"),
    (c.read_mem_bit(383), "LNBB 383"),
    (c.read_mem_port(15), "LNBD 15"),
    (c.read_parameters(), "LNE"),
    (c.read_status(), "LNR"),
    (c.read_version(), "LNV"),
    (c.read_config(), "LNX"),
    (c.write_step(ProgramType.START, 0, 0, Step("CALL", ("M01",))), "SNA 0 CALL M01"),
    (c.write_step(ProgramType.MAIN, 2, 3, Step.parse("MOVE P010 S50")), "SNM 2 3 MOVE P010 S50"),
    (c.write_step(ProgramType.SUB, 1, 4, Step.parse("A 1 2 3 4")), "SNS 1 4 A 1 2 3 4"),
    (c.write_step(ProgramType.HAND, 0, 9, Step()), "SNH 0 9"),
    (c.write_timer(3, "1.50"), "SNT 3 1.50"),
    (c.write_register(1, "0012"), "SND 1 0012"),
    (
        c.write_offset(
            7, OffsetTable("120.50", "-35.00", "0.00", "1.25", "90.00", "0.00", "0", "3")
        ),
        "SNL 7 120.50 -35.00 0.00 1.25 90.00 0.00 0 3",
    ),
    (
        c.write_config(
            Config(
                ProgramArea(1, 64),
                ProgramArea(4, 128),
                ProgramArea(4, 64),
                ProgramArea(2, 32),
                16,
                128,
                16,
            )
        ),
        "SNX 1 64 4 128 4 64 2 32",
    ),
]


@pytest.mark.parametrize("request_,payload", REQUESTS, ids=[p for _, p in REQUESTS])
def test_every_command_encodes_as_the_profile_says(
    request_: c.Request[object], payload: str
) -> None:
    assert request_.payload == payload
    assert c.parse_request(payload) == request_


def test_every_command_harlsync_sends_has_a_builder_and_no_other_does() -> None:
    built = {r.letters for r, _ in REQUESTS} | {"SNE"}
    assert built == profile.SENT_COMMANDS
    assert (c.READ_LETTERS | c.WRITE_LETTERS) - built == {"SNOB", "SNOD", "SNBB", "SNBD"}


# Issue 19: SNO drives physical outputs and SNB memory bits (process state, not
# program data); harlsync never sends them, nor anything else off the allow-list.
NEVER_SENT = ["SNOB 5 1", "SNOD 2 255", "SNBB 256 0", "SNBD 1 9", "SNZ 1", "snob 5 1", "SNO 1 1"]


@pytest.mark.parametrize("payload", NEVER_SENT)
def test_the_encoder_cannot_encode_sno_snb_or_any_command_off_the_allow_list(payload: str) -> None:
    with pytest.raises(FrameError, match="not on the HARL-U2 allow-list"):
        encode_frame(1, payload)
    letters, *args = payload.split(" ")
    with pytest.raises(FrameError, match="not on the HARL-U2 allow-list"):
        c.Request(letters, tuple(args)).encode(1)


# Issue 19, review finding 9: the frame layer read the allow-list off a first field
# of letters alone, so "SNOB1 1" and " SNOB 1 1" were encoded.  A request's first
# field is exactly a sent command, and fields are separated by exactly one space.
SIDESTEPS = ["SNOB1 1", " SNOB 1 1", "SN 1 1", "SnOB 5 1", "LNZ9", "sna 1", "LNT  1", "SNT 1 1.00 "]


@pytest.mark.parametrize("payload", SIDESTEPS)
def test_issue_19_a_request_needs_a_sent_command_as_its_exact_first_field_and_single_spaces(
    payload: str,
) -> None:
    with pytest.raises(FrameError, match="allow-list|empty field"):
        encode_frame(1, payload)


# Last session's closing note: a first field of letters that does not begin LN or SN
# ("S NOB 1", split so that no field reads as a command) was still encoded.  A first
# field that begins with a letter is a command unless it is an error reply.
LETTER_FIRST = ["S NOB 1", "N 1", "X1", "L NT 1", "s nob 5 1", "MOVE P010", "e21"]


@pytest.mark.parametrize("payload", LETTER_FIRST)
def test_a_first_field_of_letters_off_the_allow_list_is_refused_however_it_is_split(
    payload: str,
) -> None:
    with pytest.raises(FrameError, match="not on the HARL-U2 allow-list"):
        encode_frame(1, payload)


@pytest.mark.parametrize("payload", ["LNT 1", "SNT 1 1.00", "5.00", "E21", "3 MOVE P010 S50", ""])
def test_issue_19_requests_and_replies_with_single_spaces_still_encode(payload: str) -> None:
    assert encode_frame(1, payload).startswith(STX + b"1 " + payload.encode())


def test_issue_19_a_parameter_reply_that_would_read_as_a_command_is_refused_by_validate() -> None:
    # The simulator's LNE reply is the 13 values: one beginning "SN" cannot be framed.
    values = ["SNOB1", *DEFAULT_PARAMETERS.values[1:]]
    back = read_back(c.write_parameters(Parameters.from_values(values)))
    assert back.misread is not None and "'SNOB1'" in back.misread


@pytest.mark.parametrize("letters", ["FOO", "LNZ", "SN", "SNOB"])
def test_a_request_off_the_allow_list_is_refused_whatever_its_letters(letters: str) -> None:
    with pytest.raises(FrameError, match="not on the HARL-U2 allow-list"):
        c.Request(letters, ("1",)).encode(1)


def test_the_sn_writes_harlsync_sends_are_program_data_only() -> None:
    sent = {x for x in profile.SENT_COMMANDS if x.startswith("SN")}
    assert sent == {"SNA", "SNM", "SNS", "SNH", "SNT", "SND", "SNL", "SNE", "SNX"}


def test_the_unsafe_commands_are_the_six_the_manual_marks() -> None:
    assert c.UNSAFE_LETTERS == {"SNA", "SNM", "SNS", "SNH", "SNE", "SNX"}
    assert all(c.Request(x).is_write for x in c.UNSAFE_LETTERS)


@pytest.mark.parametrize(
    "build",
    [
        lambda: c.write_timer(0, "10.00"),
        lambda: c.write_timer(0, "1.5"),
        lambda: c.write_register(0, "12"),
        lambda: c.write_offset(0, OffsetTable(x="10000.00")),
        lambda: c.write_offset(0, OffsetTable(m="100")),
        lambda: c.write_step(ProgramType.MAIN, 0, 0, Step("A", ("1", "2", "3", "4", "5"))),
        lambda: c.write_step(ProgramType.MAIN, 0, 0, Step("MO VE")),
        lambda: c.write_step(ProgramType.START, 1, 0, Step("END")),
    ],
)
def test_out_of_range_writes_are_refused_before_they_reach_the_wire(
    build: Callable[[], c.Request[object]],
) -> None:
    with pytest.raises(ValueError):
        build()


def test_a_step_reply_decodes_into_command_and_data() -> None:
    req = c.read_step(ProgramType.MAIN, 2, 3)
    assert decode_reply(req, "3 MOVE P010 S50") == Step("MOVE", ("P010", "S50"))
    assert decode_reply(req, "3") == Step()


def test_a_step_reply_for_another_step_is_refused() -> None:
    with pytest.raises(ReplyError, match="asked for 3"):
        decode_reply(c.read_step(ProgramType.MAIN, 2, 3), "4 MOVE P010")


def test_an_error_reply_keeps_the_raw_status() -> None:
    assert decode_reply(c.read_timer(99), "E21") == ErrorReply("21")
    assert decode_reply(c.write_timer(1, "1.00"), "E0x7") == ErrorReply("0x7")


def test_a_write_is_acknowledged_by_0() -> None:
    assert decode_reply(c.write_timer(1, "1.00"), "0") == Ack("0")
    with pytest.raises(ReplyError):
        decode_reply(c.write_timer(1, "1.00"), "1")


def test_typed_values_of_every_read() -> None:
    assert decode_reply(c.read_timer(1), "1.50") == "1.50"
    assert decode_reply(c.read_register(1), "0012") == "0012"
    table = decode_reply(c.read_offset(1), "120.50 -35.00 0.00 1.25 90.00 0.00 0 3")
    assert isinstance(table, OffsetTable)
    assert table.x == "120.50" and table.y == "-35.00" and table.w == "1.25" and table.f == "3"
    assert decode_reply(c.read_di_bit(1), "1") == 1
    assert decode_reply(c.read_do_port(1), "255") == 255
    assert decode_reply(c.read_mem_port(1), "0") == 0
    assert decode_reply(c.read_version(), "5.00") == "5.00"
    params = decode_reply(
        c.read_parameters(), "100 1 0 20.00 20.00 30.00 30.00 40.00 40.00 50 0 0.00 7"
    )
    assert isinstance(params, Parameters)
    assert params.pull_limit == "100" and params.z_up_dis_2 == "30.00" and params.prg_count == "7"
    cfg = decode_reply(c.read_config(), "1 64 4 128 4 64 2 32 16 128 16")
    assert isinstance(cfg, Config)
    assert cfg.main == ProgramArea(4, 128) and cfg.hand == ProgramArea(2, 32)
    assert (cfg.timers, cfg.memory_bits, cfg.registers) == (16, 128, 16)


def test_lnr_reports_five_tasks_and_idle_only_when_none_runs() -> None:
    idle = decode_reply(c.read_status(), " ".join(["0 START 0 0"] * 4 + ["4 MAIN 3 17"]))
    assert isinstance(idle, Status) and idle.idle and len(idle.tasks) == 5
    busy = decode_reply(
        c.read_status(), " ".join(["0 START 0 0"] * 2 + ["1 MAIN 3 17"] + ["0 START 0 0"] * 2)
    )
    assert isinstance(busy, Status) and not busy.idle
    assert busy.active_tasks[0].describe() == "task 2 in execution: MAIN program 3 step 17"
    suspended = decode_reply(c.read_status(), " ".join(["2 SUB 1 4"] + ["0 START 0 0"] * 4))
    assert isinstance(suspended, Status) and not suspended.idle


@pytest.mark.parametrize(
    "payload",
    [
        " ".join(["0 START 0 0"] * 4 + ["16 MAIN 0 0"]),  # a status the manual does not list
        " ".join(["0 START 0 0"] * 4 + ["3 MAIN 0 0"]),  # both running bits
        " ".join(["0 START 0 0"] * 4),  # a task missing
    ],
    ids=["unknown status", "bits 1 and 2", "four tasks"],
)
def test_lnr_fails_safe_on_anything_unexpected(payload: str) -> None:
    status = decode_reply(c.read_status(), payload)
    assert isinstance(status, Status) and not status.idle


@pytest.mark.parametrize(
    "request_,payload",
    [
        (c.read_timer(1), "1.5"),
        (c.read_timer(1), "10.00"),
        (c.read_register(1), "12"),
        (c.read_offset(1), "1.00 2.00"),
        (c.read_di_bit(1), "2"),
        (c.read_do_port(1), "256"),
        (c.read_config(), "1 64 4"),
        (c.read_status(), "x START 0 0"),
        (c.read_parameters(), "1 2 3"),
    ],
)
def test_replies_that_do_not_fit_are_reply_errors(
    request_: c.Request[object], payload: str
) -> None:
    with pytest.raises(ReplyError):
        decode_reply(request_, payload)


@pytest.mark.parametrize("request_,payload", REQUESTS, ids=[p for _, p in REQUESTS])
def test_a_typed_request_decodes_its_reply_as_the_request_made_from_its_letters(
    request_: c.Request[object], payload: str
) -> None:
    # The builders give each request its own parser; parse_request (the replay's and the
    # simulator's side) decodes by letters.  Both must read a controller's reply alike.
    state = SimState.generate(
        2,
        Config(
            ProgramArea(1, 8), ProgramArea(4, 8), ProgramArea(4, 8), ProgramArea(2, 8), 16, 16, 16
        ),
    )
    reply = Simulator(state).handle(state, payload)
    assert request_.decode_payload(reply) == c.parse_request(payload).decode_payload(reply)
    assert request_.decode(Frame(1, reply)) == decode_reply(request_, reply)


IDLE_TASKS = ["0 START 0 0"] * 4


@pytest.mark.parametrize(
    "task",
    ["0 MAIM 0 0", "0 main 0 0", "0 MAIN 0 +7", "0 MAIN 0 1_0", "0 MAIN -1 0", "+0 MAIN 0 0"],
)
def test_issue_19_an_lnr_reply_with_a_field_not_well_formed_does_not_decode(task: str) -> None:
    with pytest.raises(ReplyError, match="task 4"):
        decode_reply(c.read_status(), " ".join([*IDLE_TASKS, task]))


@pytest.mark.parametrize("count", [4, 6])
def test_issue_19_an_lnr_reply_with_the_wrong_task_count_is_not_idle(count: int) -> None:
    status = decode_reply(c.read_status(), " ".join(["0 START 0 0"] * count))
    assert (
        isinstance(status, Status)
        and not status.idle
        and f"reported {count} tasks" in status.describe()
    )


def test_an_lnr_reply_of_five_well_formed_stopped_tasks_is_idle() -> None:
    status = decode_reply(c.read_status(), " ".join(["0 START 0 0", *["4 MAIN 3 17"] * 4]))
    assert isinstance(status, Status) and status.idle
