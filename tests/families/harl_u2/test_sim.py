"""The simulated HARL-U2: behaviour per the profile, faults, timing, serving."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
import serial
from simprocess import harlsync_sim

from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.protocol import FrameDecoder, encode_frame, lrc
from harlsync.families.harl_u2.sim import SIM_FAMILY, SimState, Simulator
from harlsync.families.harl_u2.sim.device import STATUS_RANGE
from harlsync.sim import Faults
from harlsync.sim.control import apply_command
from harlsync.sim.protocol_sim import register, simulator_from_url, unregister
from harlsync.sim.serve import PtyServer, TcpServer

if "harlsync.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("harlsync.sim")

SMALL = Config(ProgramArea(1, 8), ProgramArea(2, 8), ProgramArea(1, 4), ProgramArea(1, 4), 4, 16, 4)


def ask(sim: Simulator, payload: str, station: int = 1) -> str | None:
    """Send one request straight into the simulator; the reply payload or None."""
    dec = FrameDecoder()
    # Built by hand, not by encode_frame: the simulator must answer what harlsync
    # never sends (SNO, SNB) as the controller does.
    body = f"{station} {payload}".encode("ascii") + b"\x03"
    for _, chunk in sim.receive(b"\x02" + body + bytes([lrc(body)])):
        dec.feed(chunk)
    frame = dec.next_frame()
    return None if frame is None else frame.payload


def answer(sim: Simulator, payload: str, station: int = 1) -> str:
    """The reply payload of a request the simulator answers."""
    reply = ask(sim, payload, station)
    assert reply is not None, f"no reply to {payload}"
    return reply


@pytest.fixture
def sim() -> Simulator:
    return Simulator(SimState.generate(7, SMALL))


def test_lnx_reports_the_configuration_in_profile_order(sim: Simulator) -> None:
    assert ask(sim, "LNX") == "1 8 2 8 1 4 1 4 4 16 4"


@pytest.mark.parametrize(
    "payload",
    [
        "LNM 2 0",
        "LNM 0 8",
        "LNA 8",
        "LNS 1 0",
        "LNH 0 4",
        "LNT 4",
        "LND 4",
        "LNL 100",
        "LNBB 255",
        "LNBB 272",
        "LNBD 2",
        "LNIB 256",
        "LNOD 32",
    ],
)
def test_requests_outside_the_configuration_get_a_range_error(sim: Simulator, payload: str) -> None:
    assert ask(sim, payload) == "E" + STATUS_RANGE


def test_a_step_reply_echoes_the_step_and_an_empty_step_is_the_number_alone(sim: Simulator) -> None:
    state = sim.stations[1]
    state.data.programs[(ProgramType.MAIN, 1)] = {3: Step.parse("MOVE P010 S50")}
    assert ask(sim, "LNM 1 3") == "3 MOVE P010 S50"
    assert ask(sim, "LNM 1 4") == "4"


def test_sn_writes_are_answered_0_and_read_back(sim: Simulator) -> None:
    assert ask(sim, "SNM 1 2 MOVE P001 S20") == "0"
    assert ask(sim, "LNM 1 2") == "2 MOVE P001 S20"
    assert ask(sim, "SNM 1 2") == "0"  # no command clears the step
    assert ask(sim, "LNM 1 2") == "2"
    assert ask(sim, "SNT 1 1.50") == "0" and ask(sim, "LNT 1") == "1.50"
    assert ask(sim, "SND 1 0012") == "0" and ask(sim, "LND 1") == "0012"
    assert ask(sim, "SNL 7 1.00 -2.00 3.00 4.00 5.00 6.00 7 8") == "0"
    assert ask(sim, "LNL 7") == "1.00 -2.00 3.00 4.00 5.00 6.00 7 8"
    assert ask(sim, "SNE 1 2 3 4 5 6 7 8 9 10 11 12 13") == "0"
    assert ask(sim, "LNE") == "1 2 3 4 5 6 7 8 9 10 11 12 13"


def test_io_and_memory_bits_map_to_ports_as_the_manual_tables_say(sim: Simulator) -> None:
    assert ask(sim, "SNOB 9") == "E10"  # missing field
    assert ask(sim, "SNOB 9 1") == "0"
    assert ask(sim, "LNOD 1") == "2"  # DO 9 is bit 1 of port 1
    assert ask(sim, "SNBD 1 129") == "0"  # memory port 1 holds bits 264..271
    assert (
        ask(sim, "LNBB 264") == "1" and ask(sim, "LNBB 271") == "1" and ask(sim, "LNBB 265") == "0"
    )
    assert ask(sim, "LNIB 0") == "0" and ask(sim, "LNID 31") == "0"


@pytest.mark.parametrize(
    "payload",
    [
        "SNT 1 10.00",
        "SNT 1 1.5",
        "SND 1 12",
        "SNL 1 1.00 2.00 3.00 4.00 5.00 6.00 100 0",
        "SNOD 1 256",
        "SNBB 256 2",
        "SNM 0 0 A 1 2 3 4 5",
    ],
)
def test_out_of_range_writes_are_refused_with_an_error_status(sim: Simulator, payload: str) -> None:
    before = ask(sim, "LNT 1")
    assert answer(sim, payload).startswith("E")
    assert ask(sim, "LNT 1") == before


def test_snx_changes_the_configuration_and_wipes_every_program(sim: Simulator) -> None:
    assert ask(sim, "LNM 0 0") != "0"
    assert ask(sim, "SNX 1 8 3 16 1 4 1 4") == "0"
    assert ask(sim, "LNX") == "1 8 3 16 1 4 1 4 4 16 4"
    assert all(ask(sim, f"LNM {p} {s}") == str(s) for p in range(3) for s in range(16))
    assert ask(sim, "LNA 0") == "0"


def test_another_station_or_a_bad_lrc_gets_silence(sim: Simulator) -> None:
    assert sim.receive(encode_frame(2, "LNV")) == []
    bad = bytearray(encode_frame(1, "LNV"))
    bad[-1] ^= 0xFF
    assert sim.receive(bytes(bad)) == []
    assert sim.ignored == 2 and sim.received == []


def test_an_unknown_command_gets_an_error(sim: Simulator) -> None:
    assert answer(sim, "LNQ").startswith("E")
    assert answer(sim, "LNR 1").startswith("E")


def test_several_stations_share_one_line() -> None:
    sim = Simulator({1: SimState.generate(1, SMALL), 3: SimState.blank(SMALL, "4.10")})
    assert ask(sim, "LNV", 3) == "4.10"
    assert ask(sim, "LNV", 1) == "5.00"
    assert ask(sim, "LNV", 2) is None
    assert [(r.station, r.payload) for r in sim.received] == [(3, "LNV"), (1, "LNV")]


def test_lnr_shows_tasks_started_suspended_and_stopped(sim: Simulator) -> None:
    assert ask(sim, "LNR") == " ".join(["0 START 0 0"] * 5)
    assert apply_command(sim, "status").startswith("station 1: idle;")
    apply_command(sim, "auto 1 2")
    assert answer(sim, "LNR").split()[8:12] == ["1", "MAIN", "0", "0"]
    assert "station 1: task 2 in execution: MAIN program 0 step 0;" in apply_command(sim, "status")
    apply_command(sim, "suspend 1 2")
    assert answer(sim, "LNR").split()[8] == "2"
    # Issue 14: a suspended task is called suspended, as LNR says it, never "automatic".
    assert "station 1: task 2 suspended: MAIN program 0 step 0;" in apply_command(sim, "status")
    apply_command(sim, "stop")
    fields = answer(sim, "LNR").split()
    assert fields[0::4] == ["0"] * 5  # every task stopped
    assert fields[8:12] == ["0", "MAIN", "0", "0"]  # task 2 still shows its program


def test_a_schedule_switches_to_automatic_after_n_writes(sim: Simulator) -> None:
    apply_command(sim, "auto-after-writes 2")
    ask(sim, "SNT 0 1.00")
    assert not sim.stations[1].automatic
    ask(sim, "SNT 0 1.00")
    assert sim.stations[1].automatic
    ask(sim, "SNM 0 0 END")
    assert [r.payload for r in sim.unsafe_in_automatic()] == ["SNM 0 0 END"]
    assert [r.payload for r in sim.writes_received()] == ["SNT 0 1.00", "SNT 0 1.00", "SNM 0 0 END"]


def test_each_reply_is_delayed_by_its_time_on_the_wire() -> None:
    sim = Simulator(SimState.generate(1, SMALL), baudrate=9600, turnaround=0.005)
    request = encode_frame(1, "LNV")
    [(delay, reply)] = sim.receive(request)
    assert reply == encode_frame(1, "5.00")
    assert delay == pytest.approx(0.005 + (len(request) + len(reply)) * 10 / 9600)


def test_fault_drop_sends_nothing_but_records_the_request() -> None:
    sim = Simulator(SimState.generate(1, SMALL), faults=Faults(drop=1.0))
    assert sim.receive(encode_frame(1, "LNV")) == []
    assert [(r.payload, r.answered) for r in sim.received] == [("LNV", False)]


def test_fault_bad_lrc_corrupts_only_the_lrc() -> None:
    sim = Simulator(SimState.generate(1, SMALL), faults=Faults(bad_checksum=1.0))
    [(_, reply)] = sim.receive(encode_frame(1, "LNV"))
    assert reply[:-1] == encode_frame(1, "5.00")[:-1]
    assert reply[-1] != lrc(reply[1:-1])


def test_fault_noise_prefixes_bytes_the_decoder_drops() -> None:
    sim = Simulator(SimState.generate(1, SMALL), faults=Faults(noise=1.0, seed=4))
    [(_, reply)] = sim.receive(encode_frame(1, "LNV"))
    assert reply.endswith(encode_frame(1, "5.00")) and len(reply) > len(encode_frame(1, "5.00"))


def test_fault_fragment_splits_the_reply_into_timed_pieces() -> None:
    sim = Simulator(SimState.generate(1, SMALL), faults=Faults(fragment=1.0, seed=1))
    chunks = sim.receive(encode_frame(1, "LNV"))
    assert len(chunks) > 1
    assert b"".join(c for _, c in chunks) == encode_frame(1, "5.00")
    assert [d for d, _ in chunks] == sorted(d for d, _ in chunks)


def test_fault_slow_delays_the_reply() -> None:
    sim = Simulator(SimState.generate(1, SMALL), faults=Faults(slow=1.0, slow_delay=2.5))
    [(delay, _)] = sim.receive(encode_frame(1, "LNV"))
    assert delay == 2.5


def test_fault_rates_are_rates() -> None:
    sim = Simulator(SimState.generate(1, SMALL), faults=Faults(drop=0.3, seed=11))
    answered = sum(bool(sim.receive(encode_frame(1, "LNV"))) for _ in range(1000))
    assert 600 < answered < 800


def test_faults_parse_from_text_and_refuse_unknown_names() -> None:
    assert Faults.parse("noise=0.1,drop=0.2,seed=3") == Faults(noise=0.1, drop=0.2, seed=3)
    with pytest.raises(ValueError, match="unknown fault"):
        Faults.parse("lightning=1")


def test_generated_robots_are_realistic_and_reproducible() -> None:
    a, b = SimState.generate(5), SimState.generate(5)
    assert a.data == b.data
    start = a.data.programs[(ProgramType.START, 0)]
    assert any(step.command == "CALL" for step in start.values())
    assert all(prog and list(prog.values())[-1] == Step("END") for prog in a.data.programs.values())
    assert SimState.generate(6).data != a.data


# --- serving over real transports ---------------------------------------------------------


def exchange(port: serial.Serial, payload: str, station: int = 1, deadline: float = 3.0) -> str:
    port.write(encode_frame(station, payload))
    dec = FrameDecoder()
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        dec.feed(port.read(port.in_waiting or 1))
        frame = dec.next_frame()
        if frame:
            return frame.payload
    raise AssertionError(f"no reply to {payload}")


def read_program_step_by_step(port: serial.Serial, number: int, steps: int) -> list[str]:
    return [exchange(port, f"LNM {number} {s}") for s in range(steps)]


def expected_program(sim: Simulator, number: int, steps: int) -> list[str]:
    prog = sim.stations[1].data.programs[(ProgramType.MAIN, number)]
    return [" ".join((str(s), *prog.get(s, Step()).tokens)) for s in range(steps)]


def test_a_client_reads_a_program_step_by_step_over_a_pty(sim: Simulator) -> None:
    with PtyServer(sim) as server:
        assert os.path.exists(server.device)
        with serial.serial_for_url(server.device, baudrate=9600, timeout=0.05) as port:
            assert read_program_step_by_step(port, 1, 8) == expected_program(sim, 1, 8)


def test_a_client_reads_a_program_step_by_step_over_tcp(sim: Simulator) -> None:
    with TcpServer(sim) as server, serial.serial_for_url(server.url, timeout=0.05) as port:
        assert read_program_step_by_step(port, 0, 8) == expected_program(sim, 0, 8)


def test_fragments_and_noise_arrive_intact_over_tcp() -> None:
    sim = Simulator(SimState.generate(7, SMALL), faults=Faults(fragment=1.0, noise=1.0, seed=2))
    with TcpServer(sim) as server, serial.serial_for_url(server.url, timeout=0.05) as port:
        assert read_program_step_by_step(port, 1, 8) == expected_program(sim, 1, 8)


def test_sim_urls_serve_generated_and_registered_simulators(sim: Simulator) -> None:
    url = register(sim)
    try:
        with serial.serial_for_url(url, timeout=0.05) as port:
            assert read_program_step_by_step(port, 1, 8) == expected_program(sim, 1, 8)
        assert len(sim.received) == 8
    finally:
        unregister(url)
    generated = simulator_from_url("sim://?seed=7&stations=1,2&baud=19200&drop=0.5&fault_seed=1")
    assert sorted(generated.stations) == [1, 2] and generated.baudrate == 19200
    assert generated.faults.drop == 0.5
    with pytest.raises(serial.SerialException, match="unknown sim:// option"):
        simulator_from_url("sim://?sead=7")


def test_sim_url_with_baud_emulation_takes_wire_time() -> None:
    with serial.serial_for_url("sim://?seed=1&baud=1200", timeout=0.01) as port:
        start = time.monotonic()
        exchange(port, "LNV")
        # request 7 bytes + reply 8 bytes at 1200 baud, 10 bits a character
        assert time.monotonic() - start >= 15 * 10 / 1200


def test_harlsync_sim_serves_pty_and_tcp_and_takes_control_commands(tmp_path: Path) -> None:
    record = tmp_path / "requests.jsonl"
    with harlsync_sim(
        "--seed",
        "3",
        "--baud",
        "0",
        "--listen",
        "127.0.0.1:0",
        "--stations",
        "1,2",
        "--record",
        str(record),
    ) as (proc, lines):
        assert lines["stations"] == "1, 2"
        with serial.serial_for_url(lines["pty"], timeout=0.05) as port:
            assert exchange(port, "LNV", station=2) == "5.00"
        with serial.serial_for_url(lines["tcp"], timeout=0.05) as port:
            assert exchange(port, "LNR").startswith("0 START")
            assert proc.stdin is not None and proc.stdout is not None
            proc.stdin.write("auto 1 0\n")
            proc.stdin.flush()
            assert proc.stdout.readline().startswith(
                "station 1: task 0 in execution: MAIN program 0 step 0"
            )
            assert exchange(port, "LNR").startswith("1 MAIN 0 0")
    records = [json.loads(line) for line in record.read_text().splitlines()]
    assert [(r["station"], r["payload"], r["busy"]) for r in records] == [
        (2, "LNV", False),
        (1, "LNR", False),
        (1, "LNR", True),
    ]


def test_issue_29_a_variant_the_family_lacks_is_one_line_on_the_command_line_and_in_a_url(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from harlsync import cli

    assert cli.main(["sim", "--no-pty", "--listen", "127.0.0.1:0", "--variant", "nope=1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--variant" in err and "nope" in err and "\n" not in err
    assert cli.main(["sim", "--no-pty", "--listen", "127.0.0.1:0", "--variant", "nope"]) == 2
    assert "NAME=VALUE" in capsys.readouterr().err
    with pytest.raises(serial.SerialException, match="nope"):
        simulator_from_url("sim://?seed=1&nope=1")


@pytest.mark.parametrize("reply", ["E2", "E99"])
def test_issue_29_the_harl_u2_missing_table_variant_answers_every_number_it_lacks(
    sim: Simulator, reply: str
) -> None:
    sim.vary({"missing_table": reply})
    for payload in ("LNL 100", "SNL 100 0.00 0.00 0.00 0.00 0.00 0.00 0 0", "LNT 4", "LNM 9 0"):
        assert ask(sim, payload) == reply, payload
    assert ask(sim, "LNL 99") == "0.00 0.00 0.00 0.00 0.00 0.00 0 0"
    assert sim.writes == 0  # the refused SNL changed nothing


def test_issue_29_the_harl_u2_offset_tables_variant_sets_how_many_tables_it_has(
    sim: Simulator,
) -> None:
    sim.vary({"offset_tables": "64"})
    assert ask(sim, "LNL 63") == "0.00 0.00 0.00 0.00 0.00 0.00 0 0"
    assert ask(sim, "LNL 64") == "E" + STATUS_RANGE
    # a robot built with its own count (more tables, or from a project) keeps it
    sim.stations[1].offset_tables = 120
    sim.stations[1].__post_init__()
    assert ask(sim, "LNL 119") == "0.00 0.00 0.00 0.00 0.00 0.00 0 0"
    with pytest.raises(ValueError, match="128 is not one of 100, 64"):
        sim.vary(
            {"offset_tables": "128"}
        )  # more: tested apart (tests/families/harl_u2/test_offset_end.py)


def test_issue_29_a_harl_u2_simulator_of_a_project_has_the_tables_its_pull_found(
    tmp_path: Path,
) -> None:
    sim = Simulator(SimState.generate(1, SMALL))
    sim.vary({"offset_tables": "64"})
    url = register(sim)
    try:
        from harlsync.sync import engine

        engine.pull(tmp_path / "cell", port=url)
    finally:
        unregister(url)
    again = SIM_FAMILY.from_project(tmp_path / "cell", None)  # the profile's variants
    assert ask(again, "LNL 63") is not None and ask(again, "LNL 64") == "E" + STATUS_RANGE
