"""A real pymodbus TCP server on 127.0.0.1, on a free port, in a thread of its own
(the simulator's, :class:`harlsync.families.epson.sim.ModbusServer`): a tiny
datastore, or a :class:`~families.epson.fakebank.FakeController` behind it so that
the handshake runs over a real socket.  And a server that never answers."""

from __future__ import annotations

import socket
import threading
from collections.abc import Sequence
from types import TracebackType

from harlsync.families.epson.sim import server

from .fakebank import FakeController

#: Seconds the test waits for the server thread to listen, or to stop.
START_DEADLINE = server.START_DEADLINE


class Datastore:
    """Holding and input registers 0..``size``-1, the input registers preset."""

    def __init__(self, size: int, inputs: Sequence[int]) -> None:
        self.holding = [0] * size
        self.inputs = [*inputs, *[0] * (size - len(inputs))]
        #: every request the server handed over, in order: (kind, address, words
        #: written or the count read), the server's own record
        self.log: list[tuple[str, int, tuple[int, ...] | int]] = []

    def read_holding(self, address: int, count: int) -> list[int]:
        self.log.append(("read_holding", address, count))
        return self.holding[address : address + count]

    def read_input(self, address: int, count: int) -> list[int]:
        self.log.append(("read_input", address, count))
        return self.inputs[address : address + count]

    def write_holding(self, address: int, values: list[int]) -> None:
        self.log.append(("write", address, tuple(values)))
        self.holding[address : address + len(values)] = values


class ModbusServer(server.ModbusServer):
    """``with ModbusServer(...) as server:`` serves unit ``unit`` until the block ends.

    Holding and input registers 0..``size``-1; input registers start as
    ``inputs``.  With ``bank``, every register access goes to it instead (the
    fake controller plays its part on each read and write).
    """

    def __init__(
        self,
        unit: int = 1,
        *,
        size: int = 64,
        inputs: list[int] | None = None,
        bank: FakeController | None = None,
    ) -> None:
        self.store = Datastore(size, inputs or [])
        super().__init__({unit: bank if bank is not None else self.store}, size=size)
        self.bank = bank

    def __enter__(self) -> ModbusServer:
        super().__enter__()  # the simulator's server, started
        return self

    def lose_replies(self, count: int) -> None:
        """Send no reply to the next ``count`` requests (each is still carried out)."""
        left = [count]

        def drop() -> bool:
            if left[0]:
                left[0] -= 1
                return True
            return False

        self.drop = drop


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

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
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
