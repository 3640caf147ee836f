"""Modbus TCP against a real pymodbus server on 127.0.0.1: registers read and
written, the handshake over a real socket, and every failure as one line that
names the controller's host:port and unit."""

from __future__ import annotations

import pytest

from harlsync.errors import LinkTimeout, PortBusyError, PortError
from harlsync.families.epson import protocol as p
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.profile import RegisterMap
from harlsync.families.epson.protocol import AccelReal
from harlsync.families.epson.transport import ModbusLink, ModbusRefused, parse_url
from harlsync.link.lock import lock_key

from .fakebank import FakeController
from .modbus_server import ModbusServer, SilentServer, free_port


def one_line(exc: BaseException) -> str:
    text = str(exc)
    assert "\n" not in text
    return text


def test_registers_are_read_and_written_over_tcp() -> None:
    with ModbusServer(inputs=list(range(100, 109))) as server, ModbusLink(server.url) as link:
        assert link.label == f"modbus://127.0.0.1:{server.port} unit 1"
        assert link.read_input(0, 9) == list(range(100, 109))
        link.write_holding(1, [0x003B, 0x000F, 0, 0, 0, 0, 0, 0])  # function 16
        link.write_holding(0, [0b101])  # function 6
        assert link.read_holding(0, 3) == [0b101, 0x003B, 0x000F]


def test_the_handshake_runs_over_a_real_socket() -> None:
    def answer(words: tuple[int, ...]) -> tuple[bool, tuple[int, ...]]:
        if words[0] == 0x003B:
            return False, (0x003B, 0x000F, 0x0001, 0x871B, 0x0003, 0x0D40)
        return False, (words[0], 0, 0)

    bank = FakeController(answer=answer)
    with ModbusServer(bank=bank) as server, ModbusLink(server.url) as link:
        handshake = Handshake(link, RegisterMap())
        assert handshake.execute(p.read_accel_s(15)) == AccelReal("100.123", "200.000")
        sequence = p.register_accel_s(15, AccelReal("1", "2"), command_words=4)
        assert handshake.execute_sequence(sequence) is None
    assert [w[0] for w in bank.taken] == [59, 54, 55]
    assert bank.function_errors == []


def test_a_refused_connection_is_one_line_naming_the_controller() -> None:
    port = free_port()
    with pytest.raises(PortError) as caught:
        ModbusLink(f"modbus://127.0.0.1:{port}", 3, timeout=1.0)
    text = one_line(caught.value)
    assert text.startswith(f"port modbus://127.0.0.1:{port} unit 3: cannot connect: ")
    assert "refused" in text.lower()
    # the line lock went back with the failed connection
    with pytest.raises(PortError, match="cannot connect"):
        ModbusLink(f"modbus://127.0.0.1:{port}", lock_timeout=0)


def test_a_silent_server_is_one_line_link_timeout_naming_the_controller() -> None:
    with (
        SilentServer() as server,
        ModbusLink(server.url, 2, timeout=0.2, retries=0) as link,
        pytest.raises(LinkTimeout) as caught,
    ):
        link.read_input(0, 9)
    text = one_line(caught.value)
    assert text == (
        f"port modbus://127.0.0.1:{server.port} unit 2: read input registers 0-8: "
        "no answer within 0.2 s (1 try)"
    )
    assert isinstance(caught.value, TimeoutError)


def test_issue_34_a_write_without_an_answer_is_never_sent_again_by_the_link() -> None:
    """Issue 34 item 0: pymodbus's own retries sent a write that got no answer again,
    with no status read between, to a robot that may have started meanwhile.  From
    the server's own record: the write arrived once; a read without an answer is
    sent again (it changes nothing)."""
    with ModbusServer() as server, ModbusLink(server.url, timeout=0.2, retries=2) as link:
        server.lose_replies(1)
        with pytest.raises(LinkTimeout) as caught:
            link.write_holding(1, [0x01F4, 0x0003, 0, 0, 0, 0, 0, 0])
        assert one_line(caught.value).endswith(
            "write holding registers 1-8: no answer within 0.2 s (1 try: a write is never "
            "sent again by the link)"
        )
        server.lose_replies(1)
        with pytest.raises(LinkTimeout):
            link.write_holding(0, [0b100])  # function 6 likewise
        server.lose_replies(1)
        assert link.read_holding(1, 2) == [0x01F4, 0x0003]
    assert server.store.log == [
        ("write", 1, (0x01F4, 0x0003, 0, 0, 0, 0, 0, 0)),
        ("write", 0, (0b100,)),
        ("read_holding", 1, 2),
        ("read_holding", 1, 2),
    ]


def test_a_register_the_controller_lacks_is_a_modbus_exception_with_a_hint() -> None:
    with (
        ModbusServer(size=16) as server,
        ModbusLink(server.url) as link,
        pytest.raises(ModbusRefused) as caught,
    ):
        link.read_input(10, 9)
    assert caught.value.code == 2
    assert one_line(caught.value).endswith(
        "read input registers 10-18: the controller answered Modbus exception 2 (illegal data "
        "address); check the register map in robot.yaml"
    )


def test_one_harlsync_per_controller_whatever_its_host_is_called() -> None:
    with ModbusServer() as server, ModbusLink(server.url):
        with pytest.raises(PortBusyError) as caught:
            ModbusLink(f"modbus://localhost:{server.port}", 2, lock_timeout=0)
        assert "in use by another Link of this process" in one_line(caught.value)
    with ModbusServer() as server, ModbusLink(server.url):
        pass  # closed links give the lock back
    with ModbusServer() as server:
        ModbusLink(server.url).close()
        ModbusLink(server.url, lock_timeout=0).close()


@pytest.mark.parametrize(
    ("url", "host", "port"),
    [
        ("modbus://10.0.0.5", "10.0.0.5", 502),
        ("modbus://10.0.0.5:1502", "10.0.0.5", 1502),
        ("MODBUS://cell-7.plant:502/", "cell-7.plant", 502),
        ("modbus://[::1]:1502", "::1", 1502),
    ],
)
def test_a_modbus_url_names_host_and_port(url: str, host: str, port: int) -> None:
    assert parse_url(url) == (host, port)


@pytest.mark.parametrize(
    "url",
    [
        "modbus://",
        "modbus://:502",
        "socket://10.0.0.5:502",
        "10.0.0.5:502",
        "modbus://h:99999",
        "modbus://h:x",
        "modbus://h/unit/1",
        "modbus://h?unit=1",
        "modbus://u@h",
    ],
)
def test_a_url_that_is_no_modbus_address_is_one_line(url: str) -> None:
    with pytest.raises(PortError) as caught:
        parse_url(url)
    assert "expected modbus://HOST[:PORT], port 502 when none is given" in one_line(caught.value)


def test_a_unit_id_out_of_range_is_refused_before_connecting() -> None:
    with pytest.raises(PortError, match=r"unit id 256 out of range \(allowed: 0 to 255\)"):
        ModbusLink(f"modbus://127.0.0.1:{free_port()}", 256)


def test_every_name_of_one_controllers_host_and_port_is_one_line_lock() -> None:
    same = [
        "modbus://127.0.0.1:502",
        "modbus://localhost",
        "modbus://LOCALHOST:502",
        "socket://127.0.0.1:502",
        "modbus://[::1]:502",
    ]
    assert {lock_key(url) for url in same} == {"socket://loopback:502"}
    assert lock_key("modbus://127.0.0.1:5020") != lock_key("modbus://127.0.0.1:502")
