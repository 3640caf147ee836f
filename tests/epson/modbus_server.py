"""A real pymodbus TCP server on 127.0.0.1, on a free port, in a thread of its own:
a tiny datastore, or a :class:`~tests.epson.fakebank.FakeController` behind it so
that the handshake runs over a real socket.  And a server that never answers."""

from __future__ import annotations

import asyncio
import socket
import threading
from types import TracebackType
from typing import Any

from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from .fakebank import FakeController

#: Seconds the test waits for the server thread to listen, or to stop.
START_DEADLINE = 10.0


class ModbusServer:
    """``with ModbusServer(...) as server:`` serves unit ``unit`` until the block ends.

    Holding and input registers 0..``size``-1; input registers start as
    ``inputs``.  With ``bank``, every register access goes to it instead (the
    fake controller plays its part on each read and write).
    """

    def __init__(self, unit: int = 1, *, size: int = 64, inputs: list[int] | None = None,
                 bank: FakeController | None = None) -> None:
        initial = (inputs or []) + [0] * (size - len(inputs or []))
        blocks = (
            [SimData(0, count=16, values=False, datatype=DataType.BITS)],
            [SimData(0, count=16, values=False, datatype=DataType.BITS)],
            [SimData(0, count=size, values=0, datatype=DataType.REGISTERS)],
            [SimData(0, values=initial, datatype=DataType.REGISTERS)],
        )
        self.bank = bank
        self.device = SimDevice(unit, simdata=blocks, action=self._action if bank else None)
        self.port = 0
        self._loop = asyncio.new_event_loop()
        self._server: ModbusTcpServer | None = None
        self._ready = threading.Event()
        self._failed: Exception | None = None
        self._thread = threading.Thread(target=self._run, name="modbus-server", daemon=True)

    @property
    def url(self) -> str:
        return f"modbus://127.0.0.1:{self.port}"

    async def _action(self, function_code: int, start: int, address: int, count: int,
                      registers: list[int], values: Any) -> None:
        bank = self.bank
        assert bank is not None
        at = address - start
        if function_code == 4:
            registers[at : at + count] = bank.read_input(address, count)
        elif function_code == 3:
            registers[at : at + count] = bank.read_holding(address, count)
        elif values is not None:
            bank.write_holding(address, list(values))

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)

        async def listen() -> None:
            self._server = ModbusTcpServer(self.device, address=("127.0.0.1", 0))
            await self._server.serve_forever(background=True)
            listening: Any = self._server.transport  # an asyncio.Server once it listens
            self.port = listening.sockets[0].getsockname()[1]

        try:
            self._loop.run_until_complete(listen())
        except Exception as exc:  # noqa: BLE001  the test thread raises it
            self._failed = exc
            return
        finally:
            self._ready.set()
        self._loop.run_forever()

    def __enter__(self) -> ModbusServer:
        self._thread.start()
        assert self._ready.wait(START_DEADLINE), "the Modbus server did not start"
        if self._failed is not None:
            raise self._failed
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        server = self._server
        if server is not None and self._failed is None:
            stop: Any = server.shutdown  # unannotated in pymodbus
            asyncio.run_coroutine_threadsafe(stop(), self._loop).result(START_DEADLINE)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(START_DEADLINE)
        self._loop.close()


class SilentServer:
    """A TCP server that takes connections and never answers a byte."""

    def __init__(self) -> None:
        self._socket = socket.create_server(("127.0.0.1", 0))
        self.port = self._socket.getsockname()[1]
        self._held: list[socket.socket] = []
        self._thread = threading.Thread(target=self._accept, name="silent-server", daemon=True)

    @property
    def url(self) -> str:
        return f"modbus://127.0.0.1:{self.port}"

    def _accept(self) -> None:
        while True:
            try:
                connection, _ = self._socket.accept()
            except OSError:  # closed: the test is over
                return
            self._held.append(connection)

    def __enter__(self) -> SilentServer:
        self._thread.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        try:
            self._socket.shutdown(socket.SHUT_RDWR)  # wakes the accept() of the thread
        except OSError:
            pass
        self._socket.close()
        self._thread.join(START_DEADLINE)
        for connection in self._held:
            connection.close()


def free_port() -> int:
    """A port nothing listens on (it was free a moment ago)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port
