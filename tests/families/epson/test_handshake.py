"""The §6 handshake against a fake register bank that plays the controller: the ten
steps in order, the start, slow and silent controllers, function errors, a second
command while one is unanswered, a function found in use or running, the reset."""

from __future__ import annotations

import itertools
import logging

import pytest

from harlsync.errors import InterlockError, ReplyError
from harlsync.families.epson import protocol as p
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.map_form import map_from_dict
from harlsync.families.epson.protocol import AccelReal, ErrorReply
from harlsync.families.epson.steps import FunctionBusy, FunctionError, HandshakeTimeout, Step

from .fakebank import Delays, FakeController

ACCEL_S_15 = (0x003B, 0x000F, 0x0001, 0x871B, 0x0003, 0x0D40)  # §10.2 command 59
VALUES = AccelReal("100.123", "200.000")


def controller(**kwargs: object) -> FakeController:
    """A fake whose answers are the manual's: 59 table 15, acknowledgements otherwise."""

    def answer(words: tuple[int, ...]) -> tuple[bool, tuple[int, ...]]:
        if words[:2] == (0x003B, 0x000F):
            return False, ACCEL_S_15
        return False, (words[0], 0, 0)

    kwargs.setdefault("answer", answer)
    return FakeController(**kwargs)  # type: ignore[arg-type]


def handshake(fake: FakeController) -> Handshake:
    return Handshake(fake, fake.map, clock=fake.clock)


def one_line(exc: BaseException) -> str:
    text = str(exc)
    assert "\n" not in text
    return text


def test_one_command_goes_through_the_ten_steps_in_order() -> None:
    fake = controller()
    assert handshake(fake).execute(p.read_accel_s(15)) == VALUES
    writes = [(op.address, op.values) for op in fake.writes()]
    assert writes == [
        (0, (0b100,)),  # §6.2: ExtCmdReset 1
        # step 2, the words (unused words 0), then step 3, ExtCmdSet 1: the default
        # map has ExtCmdSet's register before the words, and the profile does not
        # take it that the slave hands one write over whole (BLOCK_WRITE_WHOLE)
        (1, (0x003B, 0x000F, 0, 0, 0, 0, 0, 0)),
        (0, (0b101,)),
        (0, (0b100,)),  # step 5: ExtCmdSet 0
        (0, (0b110,)),  # step 8: ExtRespGet 1
        (0, (0b100,)),  # step 10: ExtRespGet 0
    ]
    # Ready before the reset is raised (§6.2), the step 1 check, then one poll each
    # for steps 4, 6 and 9: the least the handshake allows; its own inputs are read
    # once, at the start
    assert [op.kind for op in fake.log].count("read_input") == 5
    assert [op.kind for op in fake.log].count("read_holding") == 1
    assert fake.taken == [(0x003B, 0x000F, 0, 0, 0, 0, 0, 0)]
    assert fake.stale_requests == []
    assert fake.function_errors == []
    assert fake.state == "idle"


def test_issue_24_a_command_costs_nine_register_accesses_when_every_poll_finds_its_step() -> None:
    fake = controller()  # on a slave that hands a write over whole, with the block write
    hs = Handshake(fake, fake.map, clock=fake.clock, block_write_whole=True)
    hs.execute(p.read_tool())
    before = len(fake.log)
    hs.execute(p.read_accel_s(15))
    # the control register read back, the step 1 status, the words with ExtCmdSet,
    # a poll for ExtCmdGet, ExtCmdSet 0, a poll for ExtRespSet with the response,
    # ExtRespGet 1, a poll for ExtRespSet 0, ExtRespGet 0
    assert [op.kind for op in fake.log[before:]] == [
        "read_holding",
        "read_input",
        "write",
        "read_input",
        "write",
        "read_input",
        "write",
        "read_input",
        "write",
    ]


def test_issue_24_a_slave_that_hands_over_a_register_at_a_time_gets_the_words_first() -> None:
    # the default map has ExtCmdSet's register before the words: one write would
    # raise ExtCmdSet over the last command's words on such a slave
    careless = controller(whole_writes=False)
    hs = Handshake(careless, careless.map, clock=careless.clock, block_write_whole=True)
    with pytest.raises(ReplyError, match="response word 0 is 0000H"):
        hs.execute(p.read_tool())  # the controller took the words as they were: zeros
    assert careless.stale_requests == [(0,) * 8]  # and the fake flags it
    # so without the profile's assumption the words go first, ExtCmdSet after
    fake = controller(whole_writes=False)
    hs = Handshake(fake, fake.map, clock=fake.clock, block_write_whole=False)
    hs.execute(p.read_tool())
    assert hs.execute(p.read_accel_s(15)) == VALUES
    assert [(op.address, len(op.values)) for op in fake.writes()][1:3] == [(1, 8), (0, 1)]
    assert fake.stale_requests == [] and fake.function_errors == []
    assert fake.taken == [(0x01F5, 0, 0, 0, 0, 0, 0, 0), (0x003B, 0x000F, 0, 0, 0, 0, 0, 0)]


def test_issue_24_extcmdset_after_the_words_is_one_write_on_any_slave() -> None:
    after = map_from_dict({"in_base": 8, "command_base": 0})
    assert after.command_block(whole=False) == 0
    fake = controller(map=after, whole_writes=False)
    hs = Handshake(fake, after, clock=fake.clock, block_write_whole=False)
    hs.execute(p.read_tool())
    assert hs.execute(p.read_accel_s(15)) == VALUES
    assert fake.writes()[-4].address == 0
    assert fake.writes()[-4].values == (0x003B, 0x000F, 0, 0, 0, 0, 0, 0, 0b101)
    assert fake.stale_requests == [] and fake.function_errors == []


def test_issue_24_polls_keep_to_the_interval_however_long_a_poll_takes() -> None:
    fake = controller(delays=Delays(execute=3))
    read_input = fake.read_input

    def slow_read(address: int, count: int) -> list[int]:
        fake.clock.now += 0.002  # a line that takes 2 ms a read
        return read_input(address, count)

    fake.read_input = slow_read  # type: ignore[method-assign]
    hs = handshake(fake)
    assert hs.execute(p.read_accel_s(15)) == VALUES
    reads = [op.time for op in fake.log if op.kind == "read_input"]
    # the four polls of step 6 (3 polls' delay, then ExtRespSet): 5 ms apart, not 7
    step6 = reads[-5:-1]
    assert [round(b - a, 6) for a, b in itertools.pairwise(step6)] == [0.005, 0.005, 0.005]


def test_start_clears_the_other_inputs_before_it_raises_the_reset() -> None:
    fake = controller()
    fake.preset("ExtCmdSet", True)
    fake.preset("ExtRespGet", True)
    handshake(fake).start()
    assert [op.values for op in fake.writes()] == [(0b010,), (0b000,), (0b100,)]


def test_a_function_found_on_keeps_its_reset_and_every_bit_that_is_not_a_signal() -> None:
    fake = controller()
    fake.holding[0] = 0b1000_0000_0000_0000
    fake.preset("ExtCmdReset", True)
    hs = handshake(fake)
    hs.start()
    assert fake.writes() == []
    assert hs.execute(p.read_accel_s(15)) == VALUES
    assert all(op.values[0] & 0x8004 == 0x8004 for op in fake.writes() if op.address == 0)


def test_a_slow_controller_is_waited_for_within_the_deadline() -> None:
    fake = controller(delays=Delays(acquire=50, execute=150, release=50))
    assert handshake(fake).execute(p.read_accel_s(15)) == VALUES
    assert 1.24 < fake.clock.now < 1.27  # 250 polls 5 ms apart
    assert fake.function_errors == []


def test_a_controller_too_slow_times_out_naming_the_command_and_the_step() -> None:
    fake = controller(delays=Delays(execute=1000))
    hs = handshake(fake)
    with pytest.raises(HandshakeTimeout) as caught:
        hs.execute(p.read_accel_s(15))
    text = one_line(caught.value)
    assert "command 59 (AccelS table 15)" in text
    assert "stopped at step 6 of §6.3 (waiting for ExtRespSet 1" in text
    assert text.startswith("port fake controller, ")
    assert caught.value.step is Step.RESPONSE_SET and caught.value.acquired
    assert isinstance(caught.value, TimeoutError)
    assert fake.clock.now == pytest.approx(2.0)
    assert not fake.input_signal("ExtCmdSet") and not fake.input_signal("ExtRespGet")
    assert fake.input_signal("ExtCmdReset")
    assert hs.pending == "59 (AccelS table 15) at step 6"


def test_a_controller_that_never_raises_extcmdget_times_out_at_step_4() -> None:
    fake = controller(never_acquire=True)
    hs = handshake(fake)
    with pytest.raises(HandshakeTimeout, match=r"step 4 of §6.3 \(waiting for ExtCmdGet 1") as c:
        hs.execute(p.read_accel_s(15))
    assert not c.value.acquired
    assert not fake.input_signal("ExtCmdSet")
    # never taken: the next command goes out, and the controller takes only it
    fake.never_acquire = False
    assert hs.execute(p.read_tool()) == 0
    assert fake.taken == [(0x01F5, 0, 0, 0, 0, 0, 0, 0)]
    assert fake.function_errors == []


def test_no_second_command_goes_out_while_one_is_unanswered(
    caplog: pytest.LogCaptureFixture,
) -> None:
    fake = controller(never_answer=True)
    hs = handshake(fake)
    with pytest.raises(HandshakeTimeout, match="step 6"):
        hs.execute(p.read_accel_s(15))
    # a second attempt waits for the first, sends nothing, and names the first
    with pytest.raises(HandshakeTimeout) as caught:
        hs.execute(p.read_tool())
    text = one_line(caught.value)
    assert "command 59 (AccelS table 15): still unanswered" in text
    assert "nothing else is sent" in text
    assert len(fake.command_writes()) == 1
    assert sum(1 for op in fake.writes() if op.address == 0 and op.values[0] & 1) == 1
    assert fake.function_errors == []
    # the answer comes late: it is taken and discarded, then the new command runs
    fake.never_answer = False
    with caplog.at_level(logging.WARNING):
        assert hs.execute(p.read_tool()) == 0
    assert "answered late" in caplog.text
    assert [w[0] for w in fake.taken] == [0x003B, 0x01F5]
    assert fake.function_errors == []
    assert hs.pending is None


def test_a_write_taken_and_not_answered_may_have_taken_effect() -> None:
    fake = controller(never_answer=True)
    with pytest.raises(HandshakeTimeout, match="it may or may not have taken effect"):
        handshake(fake).execute(p.select_tool(5).requests[0])


def test_a_function_error_of_the_controller_names_its_code_and_the_remedy() -> None:
    fake = controller(fail_next=0x9901)
    hs = handshake(fake)
    with pytest.raises(FunctionError) as caught:
        hs.execute(p.read_accel_s(15))
    text = one_line(caught.value)
    assert (caught.value.code, caught.value.detail) == (0x9999, 0x9901)
    assert "function error (ExtError 1): 9999 function error, detail 9901" in text
    assert text.endswith("reset the controller")
    assert hs.pending is None


def test_a_misbehaving_client_halts_the_function_and_the_reset_brings_it_back() -> None:
    fake = controller(delays=Delays(execute=100))
    fake.preset("ExtCmdReset", True)
    # another client raises ExtCmdSet a second time while its command executes
    fake.write_holding(1, [0x01F5])
    fake.write_holding(0, [0b101])
    fake.read_input(0, 9)
    fake.write_holding(0, [0b100])
    fake.write_holding(0, [0b101])
    assert fake.function_errors == [0x0001]
    fake.write_holding(0, [0b100])
    hs = handshake(fake)
    with pytest.raises(FunctionError, match=r"detail 0001 .*--reset-function"):
        hs.execute(p.read_tool())
    before = len(fake.writes())
    hs.reset_function()
    reset_writes = fake.writes()[before:]
    assert [op.values for op in reset_writes] == [(0b000,), (0b100,)]
    assert reset_writes[1].time - reset_writes[0].time >= 0.030
    assert hs.execute(p.read_accel_s(15)) == VALUES
    assert fake.function_errors == [0x0001]


def test_the_function_reset_is_refused_on_a_running_robot_and_changes_nothing() -> None:
    fake = controller()
    fake.preset("ExtCmdReset", True)
    fake.set_signal("Running", True)
    with pytest.raises(InterlockError, match="Running 1 .* would abort motion"):
        handshake(fake).reset_function()
    assert fake.writes() == []
    blind = controller(map=map_from_dict({"signals": {"Running": None}}))
    blind.preset("ExtCmdReset", True)
    with pytest.raises(InterlockError, match="no Running signal"):
        handshake(blind).reset_function()
    assert blind.writes() == []


@pytest.mark.parametrize(
    ("signal", "map_", "said"),
    [
        ("Paused", None, "Paused 1"),
        ("EStopOn", None, "EStopOn 1"),
        ("Error", None, "Error 1"),
        (None, {"signals": {"Ready": None}}, "no Ready signal"),
    ],
)
def test_issue_22_a_reset_no_person_asked_for_needs_the_robot_at_rest(
    signal: str | None, map_: dict[str, object] | None, said: str
) -> None:
    """Review finding 1: the unattended reset checks the read just before the drop
    for every interlock signal, Ready 1 and a right map, not only Running."""
    fake = controller() if map_ is None else controller(map=map_from_dict(map_))
    fake.preset("ExtCmdReset", True)
    if signal is not None:
        fake.set_signal(signal, True)
    with pytest.raises(InterlockError, match=f"{said}.*the function is not reset"):
        handshake(fake).reset_function(at_rest=True)
    assert fake.writes() == []


def test_a_function_found_in_use_is_left_alone() -> None:
    fake = controller()
    fake.preset("ExtCmdReset", True)
    fake.set_signal("ExtRespSet", True)  # someone else's response, not yet taken
    fake.set_signal("Running", True)
    with pytest.raises(FunctionBusy) as caught:
        handshake(fake).execute(p.read_tool())
    text = one_line(caught.value)
    assert "the Remote Control function is in use (ExtRespSet 1)" in text
    assert "nothing sent" in text
    assert fake.writes() == []


def test_status_names_the_interlock_signals_and_whether_the_function_is_idle() -> None:
    fake = controller()
    hs = handshake(fake)
    status = hs.status()
    assert not status.function_idle
    assert status.describe() == "the Remote Control function is not idle (ExtCmdReset 0)"
    assert fake.writes() == []  # status sends nothing and starts nothing
    assert hs.execute(p.read_tool()) == 0  # a command starts the function first
    assert hs.status().idle and hs.status().describe() == "idle"
    assert handshake(fake).execute(p.read_accel_s(15)) == VALUES
    fake.set_signal("Paused", True)
    fake.set_signal("EStopOn", True)
    status = hs.status()
    assert status.busy == ("Paused", "EStopOn")
    assert not status.idle and status.function_idle
    assert status.describe() == "Paused 1 (a task is paused), EStopOn 1 (emergency stop)"
    assert status["SafeguardOn"] is False and status["Running"] is False
    fake.set_signal("Paused", False)
    fake.set_signal("EStopOn", False)
    fake.set_signal("Error", True)
    assert hs.status().describe() == "Error 1 (the controller is in error)"


@pytest.mark.parametrize("signal", ["Running", "Paused", "EStopOn", "Error"])
def test_a_write_is_refused_while_an_interlock_signal_is_1_and_a_read_is_not(signal: str) -> None:
    fake = controller()
    hs = handshake(fake)
    hs.start()
    fake.set_signal(signal, True)
    polls = sum(op.kind == "read_input" for op in fake.log)
    with pytest.raises(InterlockError) as caught:
        hs.execute(p.select_tool(5).requests[0])
    assert f"{signal} 1 (" in one_line(caught.value)
    assert "command 500 (Tool) not sent" in str(caught.value)
    with pytest.raises(InterlockError):
        hs.execute_sequence(p.set_base(["1", "2", "3", "4"]))
    assert fake.command_writes() == []
    assert sum(op.kind == "read_input" for op in fake.log) == polls + 2  # the step 1 reads
    assert hs.execute(p.read_accel_s(15)) == VALUES


def test_a_sequence_stops_where_the_robot_leaves_idle_and_says_the_controller_cancels_it() -> None:
    """Issue 19 item 4: the interlock before every command of an Rn sequence, not
    only the first (it was read once, and the other three went to a running robot)."""
    fake = controller()

    def answer(words: tuple[int, ...]) -> tuple[bool, tuple[int, ...]]:
        if len(fake.taken) == 2:
            fake.set_signal("Running", True)  # a task starts after the second command
        return False, (words[0], 0, 0)

    fake.answer = answer
    with pytest.raises(InterlockError) as caught:
        handshake(fake).execute_sequence(p.set_base(["1", "2", "3", "4"]))
    assert [w[:2] for w in fake.taken] == [(0x0352, c) for c in range(2)]
    text = one_line(caught.value)
    assert "Running 1 (a task is executing)" in text
    assert "Base stopped after 2 of its 4 commands" in text
    assert "the controller cancels an unfinished sequence" in text


def test_a_sequence_of_an_idle_robot_goes_out_whole() -> None:
    fake = controller()
    assert handshake(fake).execute_sequence(p.set_base(["1", "2", "3", "4"])) is None
    assert [w[:2] for w in fake.taken] == [(0x0352, c) for c in range(4)]


def test_ready_0_on_an_otherwise_idle_robot_refuses_a_write_and_not_a_read() -> None:
    """Issue 19 item 5: a status bit mapped to an unused address reads 0 and looked
    idle; Ready must read 1 before a write."""
    fake = controller(ready_follows=False)
    fake.set_signal("Ready", True)
    hs = handshake(fake)
    hs.start()
    fake.set_signal("Ready", False)  # e.g. Ready and Running mapped to unused bits
    with pytest.raises(InterlockError) as caught:
        hs.execute(p.select_tool(5).requests[0])
    assert "Ready 0 (the controller is not ready" in one_line(caught.value)
    assert fake.command_writes() == []
    assert hs.execute(p.read_accel_s(15)) == VALUES
    assert not hs.status().idle


def test_ready_and_running_both_1_is_a_map_that_is_wrong() -> None:
    fake = controller(ready_follows=False)
    fake.set_signal("Ready", True)
    hs = handshake(fake)
    hs.start()
    fake.set_signal("Running", True)
    status = hs.status()
    assert not status.idle
    assert status.describe().startswith("Ready 1 and Running 1 together")
    with pytest.raises(InterlockError, match="mapped to the wrong bit"):
        hs.execute(p.select_tool(5).requests[0])
    assert fake.command_writes() == []


def test_the_reset_is_raised_only_once_the_controller_shows_ready() -> None:
    """Manual §6.2: release the reset after the controller becomes operable."""
    fake = controller(ready_follows=False)
    polls = []

    def read_input(address: int, count: int) -> list[int]:
        polls.append(fake.input_signal("ExtCmdReset"))
        if len(polls) == 3:
            fake.set_signal("Ready", True)  # start-up completes
        return FakeController.read_input(fake, address, count)

    fake.read_input = read_input  # type: ignore[method-assign]
    handshake(fake).start()
    assert polls == [False, False, False]  # ExtCmdReset stayed 0 while Ready was 0
    assert fake.input_signal("ExtCmdReset")


def test_a_controller_that_never_shows_ready_is_not_started() -> None:
    fake = controller(ready_follows=False)
    with pytest.raises(HandshakeTimeout) as caught:
        handshake(fake).start()
    assert "ExtCmdReset not raised (§6.2)" in one_line(caught.value)
    assert not fake.input_signal("ExtCmdReset")


def test_a_robot_whose_map_lacks_paused_is_read_but_never_written() -> None:
    fake = controller(map=map_from_dict({"signals": {"Paused": None}}))
    hs = handshake(fake)
    assert hs.execute(p.read_accel_s(15)) == VALUES
    writes = len(fake.writes())
    with pytest.raises(InterlockError, match="no Paused signal"):
        hs.execute(p.select_tool(5).requests[0])
    assert len(fake.writes()) == writes
    status = hs.status()
    assert status["Paused"] is None
    assert not status.idle and "no Paused signal" in status.describe()


def test_an_error_response_is_returned_with_its_meaning_and_the_handshake_completes() -> None:
    fake = controller(answer=lambda words: (True, (words[0], 0x2006, 0x0000)))
    hs = handshake(fake)
    reply = hs.execute(p.read_accel_s(3))
    assert reply == ErrorReply(59, 0x2006, 0)
    assert isinstance(reply, ErrorReply) and reply.meaning.startswith("table registration")
    assert fake.state == "idle" and not fake.input_signal("ExtRespGet")


def test_a_split_write_goes_out_back_to_back_and_stops_at_an_error() -> None:
    small = map_from_dict({"command_words": 4, "response_words": 3})
    fake = controller(map=small)
    hs = handshake(fake)
    sequence = p.register_accel_s(15, VALUES, command_words=small.command_words)
    assert hs.execute_sequence(sequence) is None
    assert fake.taken == [(0x0036, 0x000F, 0x0001, 0x871B), (0x0037, 0x000F, 0x0003, 0x0D40)]
    failing = controller(map=small, answer=lambda words: (True, (words[0], 0x2004, 0)))
    reply = handshake(failing).execute_sequence(sequence)
    assert reply == ErrorReply(54, 0x2004, 0)
    assert len(failing.taken) == 1


def test_a_request_bigger_than_the_map_is_refused_before_anything_is_sent() -> None:
    fake = controller(map=map_from_dict({"response_words": 4, "command_words": 5}))
    with pytest.raises(ValueError, match="needs 6 response words, the register map has 4"):
        handshake(fake).execute(p.read_accel_s(15))
    with pytest.raises(ValueError, match="needs 6 command words, the register map has 5"):
        handshake(fake).execute(p.register_accel_s(1, VALUES).requests[0])
    assert fake.log == []


def test_a_response_that_does_not_echo_is_an_error_after_the_handshake_completes() -> None:
    fake = controller(answer=lambda words: (False, (0x0190, 3, 0, 0x278B, 0, 0x4E9B)))
    hs = handshake(fake)
    with pytest.raises(ReplyError, match="not the command number 0193H"):
        hs.execute(p.read_arch(3))
    assert fake.state == "idle" and hs.pending is None
    fake.answer = lambda words: (False, (0x01F5, 7))
    assert hs.execute(p.read_tool()) == 7


def test_the_handshake_works_wherever_the_site_put_the_signals() -> None:
    moved = map_from_dict(
        {
            "in_base": 40,
            "out_base": 60,
            "command_base": 10,
            "response_base": 20,
            "signals": {
                "ExtCmdReset": {"register": 41, "bit": 15},
                "ExtRespGet": 9,
                "Running": {"register": 70, "bit": 0},
                "ExtCmdResult": 14,
            },
        }
    )
    fake = controller(map=moved)
    hs = handshake(fake)
    assert hs.execute(p.read_accel_s(15)) == VALUES
    assert fake.holding[41] == 0x8000 and fake.holding[40] == 0
    assert [op.address for op in fake.writes()] == [41, 10, 40, 40, 40, 40]
    fake.set_signal("Running", True)
    assert hs.status().describe() == "Running 1 (a task is executing)"
