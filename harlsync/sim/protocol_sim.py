"""The ``sim://`` port: an in-process simulated controller behind pyserial's API.

pyserial finds this module because :mod:`harlsync.link` adds ``harlsync.sim`` to
``serial.protocol_handler_packages``.  URL forms::

    sim://projects/pick-and-place          the robot of that project directory (of the
                                           family its robot.yaml names)
    sim:///abs/path/to/project?baud=9600   absolute path, wire-time emulation at 9600
    sim://?seed=7&stations=1,2             generated robots on stations 1 and 2 (default family)
    sim://?seed=7&family=iai&stations=99   a generated controller of the family ``iai``, station 99
    sim://@name                            a Simulator registered with register()

Query options: ``family``, ``seed``, ``stations`` (as the family writes them),
``baud``, ``turnaround``, the family's schedule (``auto_after_writes``,
``run_after_writes``: its busy verb's), and the faults ``noise``, ``drop``,
``bad_checksum``, ``fragment``, ``slow``, ``slow_delay``,
``fault_seed`` (rates 0-1), and the family's variants by name
(``?missing_table=E2``, :mod:`harlsync.sim.variants`).
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar
from urllib.parse import parse_qs

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from .. import families
from ..errors import ProjectError
from .device import Decoder, Device, Faults, Simulator
from .family import line_family, project_family, sim_family

__all__ = [
    "Peer",
    "Serial",
    "build_simulator",
    "register",
    "simulator_from_url",
    "unregister",
]

T = TypeVar("T")


class Peer(Protocol):
    """What answers a ``sim://`` or ``replay://`` port: a Simulator or a Replay."""

    def receive(
        self, data: bytes, decoder: Decoder[Any] | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]: ...


class Registry(Generic[T]):
    """In-process peers reachable as ``SCHEME://@name`` (for tests and embedding)."""

    def __init__(self, scheme: str) -> None:
        self.scheme = scheme
        self._peers: dict[str, T] = {}
        self._names = itertools.count(1)

    def register(self, peer: T, name: str | None = None) -> str:
        """Make ``peer`` reachable as ``SCHEME://@name``; return that URL."""
        name = name or f"{self.scheme}{next(self._names)}"
        self._peers[name] = peer
        return f"{self.scheme}://@{name}"

    def unregister(self, url_or_name: str) -> None:
        self._peers.pop(url_or_name.removeprefix(f"{self.scheme}://@"), None)

    def get(self, path: str) -> T:
        """The peer a URL path ``@name`` names.  Raises SerialException."""
        try:
            return self._peers[path[1:]]
        except KeyError:
            raise SerialException(f"no {self.scheme} peer registered as {path!r}") from None


_simulators: Registry[Simulator[Any, Any]] = Registry("sim")
register = _simulators.register
unregister = _simulators.unregister


def build_simulator(
    *,
    family: str | None = None,
    project: str | None = None,
    seed: int | None = None,
    stations: list[int] | None = None,
    baudrate: int | None = None,
    turnaround: float = 0.0,
    faults: Faults | None = None,
    busy_after_writes: int = 0,
    variant: Mapping[str, str] | None = None,
) -> Device[Any]:
    """A simulated controller: the robot of a project directory, or generated robots.

    ``family`` defaults to the one the project's robot.yaml names, or to the
    default family.  ``baudrate`` and ``turnaround`` are a serial line's (a
    :class:`Simulator`'s); other families have no wire time.  Raises
    :class:`~harlsync.errors.ProjectError` for an unreadable project, an
    unknown family, or a project of another family; ValueError for an unknown
    ``variant`` (name -> value, :mod:`harlsync.sim.variants`).
    """
    if project:
        named = project_family(project)
        if family is not None and family != named:
            raise ProjectError(f"{project}: a {named} project, not {family}")
        family = named
    sim_side = sim_family(family)
    if project:
        sim = sim_side.from_project(Path(project), stations)
    else:
        sim = sim_side.generate(seed or 0, stations or [sim_side.default_station])
    if isinstance(sim, Simulator):
        sim.baudrate = baudrate
        sim.turnaround = turnaround
    sim.faults = faults or Faults()
    sim.busy_after_writes = busy_after_writes
    sim.vary(variant or {})
    return sim


#: sim:// options that set faults: every fault setting and spelling, the seed spelt fault_seed.
_FAULT_KEYS = {("fault_seed" if n == "seed" else n): n for n in Faults.names()}


def simulator_from_url(url: str) -> Simulator[Any, Any]:
    """The simulator a ``sim://`` URL names (a new one, unless ``@name``).

    Raises SerialException for a bad option, ProjectError for a bad project.
    """
    rest = url.split("://", 1)[1]
    path, _, query = rest.partition("?")
    if path.startswith("@"):
        return _simulators.get(path)
    opts = {k: v[-1] for k, v in parse_qs(query, keep_blank_values=True).items()}
    family = opts.get("family") or (project_family(path) if path else None)
    try:
        sim_side = line_family(family)
    except ProjectError as exc:
        raise SerialException(f"{url}: {exc}") from exc
    after_writes = f"{sim_side.busy_verb}_after_writes"
    known = {"family", "seed", "stations", "baud", "turnaround", after_writes}
    declared = {v.name for v in sim_side.variants}
    unknown = set(opts) - known - set(_FAULT_KEYS) - declared
    if unknown:
        raise SerialException(f"{url}: unknown sim:// option(s) {', '.join(sorted(unknown))}")
    try:
        faults = Faults.from_settings(
            {name: opts[key] for key, name in _FAULT_KEYS.items() if key in opts}
        )
        stations = opts.get("stations")
        notation = families.get(sim_side.name)
        try:
            numbers = [notation.parse_station(s) for s in stations.split(",")] if stations else None
        except ValueError as exc:
            raise ValueError(f"stations: {exc}") from None
        sim = build_simulator(
            family=sim_side.name,
            project=path or None,
            seed=int(opts.get("seed", 0)),
            stations=numbers,
            baudrate=int(opts["baud"]) if "baud" in opts else None,
            turnaround=float(opts.get("turnaround", 0)),
            faults=faults,
            busy_after_writes=int(opts.get(after_writes, 0)),
            variant={name: opts[name] for name in declared if name in opts},
        )
    except ValueError as exc:
        raise SerialException(f"{url}: bad sim:// option: {exc}") from exc
    assert isinstance(sim, Simulator)  # a line family's simulator is a line
    return sim


class Serial(SerialBase):
    """pyserial port class for ``sim://`` URLs."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.sim: Peer | None = None
        self._decoder: Decoder[Any] | None = None
        self._pending: list[tuple[float, bytes]] = []
        self._cond = threading.Condition()
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self.port is None:
            raise SerialException("Port must be configured before it can be used.")
        try:
            sim = simulator_from_url(self.port)
        except SerialException:
            raise
        except Exception as exc:  # a bad project must not look like "unknown protocol"
            raise SerialException(f"cannot start simulator for {self.port}: {exc}") from exc
        self.sim = sim
        self._decoder = sim.new_decoder()
        self._pending = []
        self.is_open = True

    def close(self) -> None:
        self.is_open = False
        with self._cond:
            self._cond.notify_all()
        super().close()

    def _reconfigure_port(self) -> None:
        pass

    def write(self, data: bytes) -> int:  # type: ignore[override]
        if not self.is_open or self.sim is None:
            raise PortNotOpenError()
        chunks = self.sim.receive(bytes(data), self._decoder)
        now = time.monotonic()
        with self._cond:
            last = self._pending[-1][0] if self._pending else now
            for delay, chunk in chunks:
                last = max(last, now + delay)
                self._pending.append((last, chunk))
            self._cond.notify_all()
        return len(data)

    def _take_due(self, size: int) -> bytes:
        now = time.monotonic()
        out = bytearray()
        while self._pending and self._pending[0][0] <= now and len(out) < size:
            due, chunk = self._pending.pop(0)
            take = size - len(out)
            out += chunk[:take]
            if len(chunk) > take:
                self._pending.insert(0, (due, chunk[take:]))
        return bytes(out)

    def read(self, size: int = 1) -> bytes:
        if not self.is_open:
            raise PortNotOpenError()
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        out = bytearray()
        with self._cond:
            while self.is_open:
                out += self._take_due(size - len(out))
                if len(out) >= size:
                    break
                now = time.monotonic()
                if deadline is not None and now >= deadline:
                    break
                waits = [d for d in (deadline,) if d is not None]
                if self._pending:
                    waits.append(self._pending[0][0])
                self._cond.wait(min(waits) - now if waits else None)
        return bytes(out)

    @property
    def in_waiting(self) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        now = time.monotonic()
        with self._cond:
            return sum(len(c) for due, c in self._pending if due <= now)

    def reset_input_buffer(self) -> None:
        with self._cond:
            now = time.monotonic()
            self._pending = [(d, c) for d, c in self._pending if d > now]

    def reset_output_buffer(self) -> None:
        pass

    def cancel_read(self) -> None:
        with self._cond:
            self._cond.notify_all()

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    def _update_break_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
