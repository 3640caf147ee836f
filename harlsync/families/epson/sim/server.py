"""A Modbus TCP server for register banks: pymodbus's asyncio server on a thread
of its own, each unit id's holding and input registers handed to a bank.

pymodbus does the Modbus (framing, function codes 3, 4, 6 and 16, exception
responses); every register access of a unit goes to its :class:`RegisterBank`
through the device's ``action`` hook, so the bank's state is the only copy.  A
unit id that is not served is answered with exception 11 (gateway target
device failed to respond), as a gateway does; an address outside the bank's
registers with exception 2.  ``drop`` decides, reply by reply, whether the
server leaves a request unanswered (the reply bytes are not sent).
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable, Mapping, Sequence
from types import TracebackType
from typing import Any, Protocol

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

__all__ = ["ModbusServer", "RegisterBank"]

log = logging.getLogger(__name__)

#: Seconds to wait for the server thread to listen, or to stop.
START_DEADLINE = 10.0
_READ_HOLDING, _READ_INPUT = 3, 4


class RegisterBank(Protocol):
    """One unit's registers, as a Modbus slave holds them."""

    def read_holding(self, address: int, count: int) -> Sequence[int]: ...

    def read_input(self, address: int, count: int) -> Sequence[int]: ...

    def write_holding(self, address: int, values: list[int]) -> None: ...


class ModbusServer:
    """``with ModbusServer({1: bank}) as server:`` serves until the block ends.

    ``size`` is how many holding and input registers each unit has, from 0;
    ``drop`` is asked before each reply is sent (True: the reply is dropped).
    ``port`` 0 takes a free one; :attr:`url` says which once started.
    """

    def __init__(
        self,
        banks: Mapping[int, RegisterBank],
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        size: int = 64,
        drop: Callable[[], bool] | None = None,
    ) -> None:
        self.banks = dict(banks)
        self.host, self.port = host, port
        self.size = size
        self.drop = drop
        #: requests answered and replies dropped, over all units
        self.replies = 0
        self.dropped = 0
        self._loop = asyncio.new_event_loop()
        self._server: ModbusTcpServer | None = None
        self._ready = threading.Event()
        self._failed: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="sim-modbus", daemon=True)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"modbus://{host}:{self.port}"

    def _device(self, unit: int, bank: RegisterBank | None) -> SimDevice:
        def block() -> list[SimData]:
            return [SimData(0, count=self.size, values=0, datatype=DataType.REGISTERS)]

        def bits() -> list[SimData]:
            return [SimData(0, count=16, values=False, datatype=DataType.BITS)]

        async def action(
            function_code: int,
            start: int,
            address: int,
            count: int,
            registers: list[int],
            values: list[int] | list[bool] | None,
        ) -> ExcCodes | None:
            if bank is None:
                return ExcCodes.GATEWAY_NO_RESPONSE
            at = address - start
            if function_code == _READ_INPUT:
                registers[at : at + count] = bank.read_input(address, count)
            elif function_code == _READ_HOLDING:
                registers[at : at + count] = bank.read_holding(address, count)
            elif values is not None:
                bank.write_holding(address, [int(v) for v in values])
            return None

        return SimDevice(unit, simdata=(bits(), bits(), block(), block()), action=action)

    def _trace(self, sending: bool, data: bytes) -> bytes:
        if not sending:
            return data
        if self.drop is not None and self.drop():
            self.dropped += 1
            log.debug("sim: Modbus reply dropped: %s", data.hex(" "))
            return b""  # nothing is sent: the client waits in vain
        self.replies += 1
        return data

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        # Unit 0 answers for every unit id that is not served (pymodbus's catch-all).
        devices = [self._device(unit, bank) for unit, bank in sorted(self.banks.items())]
        if 0 not in self.banks:
            devices.append(self._device(0, None))

        async def listen() -> None:
            self._server = ModbusTcpServer(
                devices, address=(self.host, self.port), trace_packet=self._trace
            )
            await self._server.serve_forever(background=True)
            listening: Any = self._server.transport  # an asyncio.Server once it listens
            self.port = listening.sockets[0].getsockname()[1]

        try:
            self._loop.run_until_complete(listen())
        except BaseException as exc:  # noqa: BLE001  the starting thread raises it
            self._failed = exc
            return
        finally:
            self._ready.set()
        self._loop.run_forever()

    def start(self) -> str:
        """Listen in the background; return the ``modbus://`` URL.  Raises OSError
        when the address cannot be listened on."""
        self._thread.start()
        if not self._ready.wait(START_DEADLINE):
            raise OSError(f"the Modbus server on {self.url} did not start")
        if self._failed is not None:
            self._loop.close()
            raise OSError(
                f"cannot listen on {self.host}:{self.port}: {self._failed}"
            ) from self._failed
        log.info(
            "sim: Modbus TCP on %s, units %s",
            self.url,
            ", ".join(str(u) for u in sorted(self.banks)),
        )
        return self.url

    def stop(self) -> None:
        """Stop serving and close every connection (again: nothing)."""
        server, self._server = self._server, None
        if server is None or self._loop.is_closed():
            return
        shutdown: Any = server.shutdown  # unannotated in pymodbus
        asyncio.run_coroutine_threadsafe(shutdown(), self._loop).result(START_DEADLINE)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(START_DEADLINE)
        self._loop.close()

    def __enter__(self) -> ModbusServer:
        if not self._ready.is_set():
            self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()
