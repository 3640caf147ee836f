"""Modbus TCP to the controller's fieldbus slave: the handshake's register access.

``modbus://HOST[:PORT]`` (port 502 when it has none; an IPv6 host in brackets)
opens a pymodbus :class:`~pymodbus.client.ModbusTcpClient` to the controller,
whose unit id comes from the robot.  Holding registers are read with function
3 and written with 6 (one) or 16 (several); input registers are read with 4.

pymodbus never sends a request twice: its client is made with ``retries=0``.  A
read that gets no answer is sent again here, ``retries`` times (a read changes
nothing); a write that gets no answer is never sent again by the link (issue 34):
whether it took is for harlsync to find out, and a write it sends once more passes
the interlock again first (:mod:`harlsync.link.confirm`, docs/SAFETY.md).

Every pymodbus exception is translated here and never leaves this module:
no connection is :class:`~harlsync.errors.PortError`, no answer in time
:class:`~harlsync.errors.LinkTimeout`, a Modbus exception response
:class:`ModbusRefused`; each names the controller's host:port and unit in one
line.  While open, the link holds the line lock of the controller's host:port
(:mod:`harlsync.link.lock`): one harlsync per controller.  Every register
operation is logged at DEBUG, in hex.
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable, Sequence
from types import MappingProxyType, TracebackType
from typing import TypeVar
from urllib.parse import urlsplit

from pymodbus.client import ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.pdu import ModbusPDU
from typing_extensions import Self

from ...errors import LinkError, LinkTimeout, PortError
from ...link.lock import DEFAULT_LOCK_TIMEOUT, LineLock, lock_path
from ...link.readonly import refuse_write
from ...settings import seconds
from . import profile

__all__ = ["SCHEME", "ModbusLink", "ModbusRefused", "parse_url"]

log = logging.getLogger(__name__)

T = TypeVar("T")

SCHEME = "modbus"

#: Modbus exception codes, as the specification names them.
_EXCEPTIONS = MappingProxyType(
    {
        1: "illegal function",
        2: "illegal data address",
        3: "illegal data value",
        4: "server device failure",
        5: "acknowledge",
        6: "server device busy",
        8: "memory parity error",
        10: "gateway path unavailable",
        11: "gateway target device failed to respond",
    }
)


class ModbusRefused(LinkError):
    """The controller answered a Modbus exception: ``code`` (2: a register the map
    names does not exist; 10, 11: no device with that unit id behind a gateway)."""

    def __init__(self, message: str, *, port: str, code: int) -> None:
        self.code = code
        super().__init__(message, port=port)


def parse_url(url: str) -> tuple[str, int]:
    """(host, port) of ``modbus://HOST[:PORT]``.

    Raises :class:`PortError` for another scheme, no host, a bad port, or a path.
    """
    parts = urlsplit(url)
    try:
        port = parts.port
    except ValueError:
        port = -1
    if (
        parts.scheme.lower() != SCHEME
        or not parts.hostname
        or port == -1
        or parts.path not in ("", "/")
        or parts.query
        or parts.fragment
        or parts.username
    ):
        raise PortError(
            f"not a Modbus TCP address: {url!r} (expected modbus://HOST[:PORT], "
            f"port {profile.DEFAULT_PORT} when none is given)",
            port=url,
        )
    return parts.hostname, profile.DEFAULT_PORT if port is None else port


class ModbusLink:
    """The registers of one controller over Modbus TCP (a
    :class:`~harlsync.families.epson.remote_io.RegisterAccess`).

    Opening connects and takes the line lock; :meth:`close` (or the ``with``
    block) gives both back.  ``timeout`` is the seconds one transaction may
    take, ``retries`` how often a read is sent again after no answer.  A write is
    sent once: with no answer it raises :class:`~harlsync.errors.LinkTimeout` and
    the caller, which knows what the write was for, decides (a write sent again
    is a write, and passes the interlock again).
    """

    def __init__(
        self,
        url: str,
        unit: int = profile.DEFAULT_UNIT,
        *,
        timeout: float = profile.MODBUS_TIMEOUT,
        retries: int = profile.MODBUS_RETRIES,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | None = None,
    ) -> None:
        self.host, self.port = parse_url(url)
        shown = f"[{self.host}]" if ":" in self.host else self.host
        self.url = f"{SCHEME}://{shown}:{self.port}"
        if not 0 <= unit <= 255:
            raise PortError(f"unit id {unit} out of range (allowed: 0 to 255)", port=self.url)
        self.unit = unit
        self.timeout, self.retries = timeout, retries
        #: where the registers are, for messages
        self.label = f"{self.url} unit {unit}"
        # One lock per controller endpoint (lock_key: the socket:// line of host:port).
        self._lock = LineLock(self.url, lock_path(self.url, lock_dir))
        self._lock.acquire(lock_timeout)
        # retries=0: pymodbus itself never sends a request again, a write least of
        # all; reads are sent again by _read (issue 34)
        self._client = ModbusTcpClient(
            self.host, port=self.port, timeout=timeout, retries=0, reconnect_delay=0
        )
        try:
            self._connect(timeout)
        except BaseException:
            self._lock.release()
            raise

    def _connect(self, timeout: float) -> None:
        connect: Callable[[], bool] = self._client.connect  # pymodbus leaves it unannotated
        try:
            connected = connect()
        except Exception as exc:  # anything pymodbus raises here is a failed connect
            raise PortError(f"cannot connect: {_describe(exc)}", port=self.label) from exc
        if connected:
            return
        # pymodbus logs the reason and returns False: ask the socket for it.
        reason = "no connection"
        try:
            socket.create_connection((self.host, self.port), timeout=timeout).close()
        except OSError as exc:
            reason = _describe(exc)
        raise PortError(
            f"cannot connect: {reason}; check the controller is on, its Modbus TCP "
            "slave enabled and the port right",
            port=self.label,
        )

    # --- register access ----------------------------------------------------------------

    def read_holding(self, address: int, count: int) -> list[int]:
        return self._read("holding", address, count, self._client.read_holding_registers)

    def read_input(self, address: int, count: int) -> list[int]:
        return self._read("input", address, count, self._client.read_input_registers)

    def write_holding(self, address: int, values: Sequence[int]) -> None:
        words = [int(v) for v in values]
        if not words or any(not 0 <= w <= 0xFFFF for w in words):
            raise ValueError(f"{self.label}: {words} are not 1 or more 16-bit words")
        what = f"write holding registers {address}-{address + len(words) - 1}"
        refuse_write(what, port=self.url, station=self.unit)  # harlsync probe: reads only
        log.debug("%s: %s: %s", self.label, what, _hex(words))
        if len(words) == 1:
            self._call(
                what,
                lambda: self._client.write_register(address, words[0], device_id=self.unit),
                write=True,
            )
        else:
            self._call(
                what,
                lambda: self._client.write_registers(address, words, device_id=self.unit),
                write=True,
            )

    def _read(
        self, kind: str, address: int, count: int, read: Callable[..., ModbusPDU]
    ) -> list[int]:
        what = f"read {kind} registers {address}-{address + count - 1}"
        tries = 1 + max(0, self.retries)
        for attempt in range(1, tries + 1):
            try:
                reply = self._call(
                    what, lambda: read(address, count=count, device_id=self.unit), tries=tries
                )
                break
            except LinkTimeout:
                if attempt == tries:
                    raise
                log.debug(
                    "%s: %s: no answer, sent again (%d of %d)", self.label, what, attempt, tries
                )
        values = list(reply.registers)
        if len(values) < count:
            raise LinkError(f"{what}: {len(values)} registers in the answer", port=self.label)
        log.debug("%s: %s: %s", self.label, what, _hex(values[:count]))
        return values[:count]

    def _call(
        self, what: str, call: Callable[[], ModbusPDU], *, tries: int = 1, write: bool = False
    ) -> ModbusPDU:
        """One transaction, sent once; every pymodbus failure becomes a harlsync
        LinkError (``tries``: how many a read gets, for the message)."""
        try:
            reply = call()
        except ModbusIOException as exc:
            said = (
                "1 try: a write is never sent again by the link"
                if write
                else (f"{tries} tries" if tries > 1 else "1 try")
            )
            raise LinkTimeout(
                f"{what}: no answer within {seconds(self.timeout)} s ({said})", port=self.label
            ) from exc
        except ConnectionException as exc:
            raise PortError(
                f"{what}: the connection is gone ({_describe(exc)}); check the "
                "network and that no other Modbus master holds the controller",
                port=self.label,
            ) from exc
        except (ModbusException, OSError) as exc:
            raise LinkError(f"{what}: {_describe(exc)}", port=self.label) from exc
        if reply.isError():
            code = int(getattr(reply, "exception_code", 0) or 0)
            name = _EXCEPTIONS.get(code, "unknown exception")
            hint = {
                2: "; check the register map in robot.yaml",
                10: "; check the unit id",
                11: "; check the unit id",
            }.get(code, "")
            raise ModbusRefused(
                f"{what}: the controller answered Modbus exception {code} ({name}){hint}",
                port=self.label,
                code=code,
            )
        return reply

    # --- open and close -----------------------------------------------------------------

    def close(self) -> None:
        """Disconnect and give the line lock back (again: nothing)."""
        disconnect: Callable[[], None] = self._client.close  # unannotated in pymodbus
        try:
            disconnect()
        finally:
            self._lock.release()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _hex(words: Sequence[int]) -> str:
    return " ".join(f"{w:04X}" for w in words)


def _describe(exc: BaseException) -> str:
    """An exception's text on one line, without pymodbus's "Modbus Error: [...]" frame."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    for prefix in (
        "Modbus Error: [Input/Output] ",
        "Modbus Error: [Connection] ",
        "Modbus Error: ",
    ):
        if text.startswith(prefix):
            text = text[len(prefix) :]
            break
    return text
