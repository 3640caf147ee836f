"""The Epson register map: the profile's default, the robot.yaml dict form, and
every way a map can be wrong, each said in one message."""

from __future__ import annotations

from dataclasses import replace

import pytest

from harlsync.families.epson import profile
from harlsync.families.epson.map_form import map_from_dict, map_to_dict
from harlsync.families.epson.profile import Bit, RegisterMap, RegisterMapInvalid


def test_the_default_map_is_the_profiles() -> None:
    m = map_from_dict(None)
    assert m == RegisterMap() == map_from_dict({})
    assert (m.ext_cmd_set, m.ext_resp_get, m.ext_cmd_reset) == (Bit(0, 0), Bit(0, 1), Bit(0, 2))
    assert (m.command_base, m.command_words) == (1, 8)
    assert [m.signal(n) for n in ("ExtCmdGet", "ExtRespSet", "ExtCmdResult", "ExtError")] == [
        Bit(0, 0),
        Bit(0, 1),
        Bit(0, 2),
        Bit(0, 3),
    ]
    assert [
        m.signal(n) for n in ("Ready", "Running", "Paused", "Error", "EStopOn", "SafeguardOn")
    ] == [Bit(0, b) for b in range(8, 14)]
    assert (m.response_base, m.response_words) == (1, 8)
    assert m.input_span == (0, 9)  # every output and response word in one read
    assert m.control_registers == (0,)
    assert m.unwritable is None
    assert (profile.DEFAULT_PORT, profile.DEFAULT_UNIT) == (502, 1)
    assert (profile.POLL_INTERVAL, profile.COMMAND_DEADLINE) == (0.005, 2.0)
    assert profile.FUNCTION_RESET_LOW == 0.030
    assert profile.DEFAULT_POINT_RANGE == (0, 99)


def test_the_bases_move_every_signal_and_word_with_them() -> None:
    m = map_from_dict({"in_base": 100, "out_base": 200})
    assert m.ext_cmd_reset == Bit(100, 2)
    assert m.command_base == 101
    assert m.running == Bit(200, 9)
    assert m.response_base == 201
    assert m.input_span == (200, 9)


def test_every_register_and_bit_can_be_given_and_the_dict_form_round_trips() -> None:
    data = {
        "command_base": 10,
        "command_words": 5,
        "response_base": 20,
        "response_words": 4,
        "signals": {
            "ExtCmdSet": 3,
            "ExtCmdReset": {"register": 7, "bit": 15},
            "Running": {"register": 30, "bit": 0},
            "SafeguardOn": None,
            "Ready": None,
        },
    }
    m = map_from_dict(data)
    assert m.ext_cmd_set == Bit(0, 3)
    assert m.ext_cmd_reset == Bit(7, 15)
    assert m.running == Bit(30, 0)
    assert m.safeguard_on is None and m.ready is None
    assert m.control_registers == (0, 7)
    assert m.input_span == (0, 31)
    assert map_from_dict(map_to_dict(m)) == m
    signals = map_to_dict(m)["signals"]
    assert isinstance(signals, dict) and signals["SafeguardOn"] is None


@pytest.mark.parametrize("missing", ["Running", "Paused", "EStopOn", "Error"])
def test_a_map_without_running_paused_or_estop_is_recognisably_unwritable(missing: str) -> None:
    m = map_from_dict({"signals": {missing: None}})
    assert m.unwritable is not None
    assert f"no {missing} signal" in m.unwritable
    assert "never writes" in m.unwritable


def test_issue_34_a_map_without_ready_or_safeguard_is_written_only_when_robot_yaml_accepts_it() -> (
    None
):
    m = map_from_dict({"signals": {"Ready": None, "SafeguardOn": None}})
    assert m.unwritable is not None and "no Ready or SafeguardOn signal" in m.unwritable
    assert "connection.write_without: [Ready, SafeguardOn]" in m.unwritable
    assert replace(m, write_without=frozenset({"Ready"})).unwritable is not None
    accepted = replace(m, write_without=frozenset({"Ready", "SafeguardOn"}))
    assert accepted.unwritable is None
    assert accepted.ready_note is not None and "accepts writing without it" in accepted.ready_note
    assert RegisterMap().ready_note is None and RegisterMap().unwritable is None


@pytest.mark.parametrize(
    ("data", "issue"),
    [
        ({"in_bse": 1}, "unknown key 'in_bse'"),
        ({"command_words": 9}, "command_words: 9 out of range (allowed: 3 to 8)"),
        ({"response_words": 2}, "response_words: 2 out of range (allowed: 3 to 8)"),
        ({"in_base": "0"}, "in_base: '0' is not a whole number"),
        ({"out_base": True}, "out_base: True is not a whole number"),
        ({"signals": {"Runing": 9}}, "unknown signal 'Runing'"),
        ({"signals": {"Running": 16}}, "Running at register 0 bit 16: out of range"),
        ({"signals": {"Running": {"register": 1, "bit": 1, "x": 2}}}, "Running: {"),
        ({"signals": {"Running": "9"}}, "Running: '9' is not a bit number"),
        ({"signals": {"ExtCmdSet": None}}, "ExtCmdSet must be mapped"),
        ({"signals": {"ExtError": None}}, "ExtError must be mapped"),
        ({"signals": {"Paused": 9}}, "Running and Paused are both at register 0 bit 9"),
        ({"signals": {"ExtRespGet": 0}}, "ExtCmdSet and ExtRespGet are both at register 0 bit 0"),
        ({"command_base": 0}, "ExtCmdSet at register 0 bit 0 lies in the command words"),
        (
            {"signals": {"Running": {"register": 3, "bit": 0}}},
            "Running at register 3 bit 0 lies in the response words (registers 1 to 8)",
        ),
        ({"signals": {"EStopOn": {"register": 500, "bit": 0}}}, "more than one Modbus read"),
        ({"command_base": 65530}, "command_base: 65530 out of range"),
        ({"signals": 5}, "signals: 5 is not a mapping"),
    ],
)
def test_every_problem_of_a_map_is_named(data: dict[str, object], issue: str) -> None:
    with pytest.raises(RegisterMapInvalid) as caught:
        map_from_dict(data)
    assert any(issue in line for line in caught.value.issues), caught.value.issues
    assert issue in str(caught.value)


def test_all_problems_are_named_at_once() -> None:
    with pytest.raises(RegisterMapInvalid) as caught:
        map_from_dict({"x": 1, "command_words": 1, "signals": {"ExtCmdSet": None}})
    assert len(caught.value.issues) == 3


def test_a_map_built_in_code_is_checked_too() -> None:
    with pytest.raises(RegisterMapInvalid, match="ExtCmdGet must be mapped"):
        RegisterMap(ext_cmd_get=None)  # type: ignore[arg-type]
