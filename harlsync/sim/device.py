"""The simulated line, for every family: stations, wire time, faults and the record.

How this works::

    bytes in --> family decoder --> frame for a station we have? --no--> silence
                                          |yes
                      family: respond(station, state, frame) --> reply bytes (None: silence)
                                          |
                  Faults.shape(reply) --> [(delay, bytes), ...] --> the wire

:meth:`Simulator.receive` is sans-I/O like the codecs: it takes the bytes the
client sent and returns the chunks to send back, each with the delay after which
it is due.  The pty, TCP and ``sim://`` servers (:mod:`harlsync.sim.serve`,
:mod:`harlsync.sim.protocol_sim`) only move those bytes and honour the delays.
Every request a station answers is recorded in :attr:`Simulator.received`, with
whether that station was busy (not idle) when it arrived, so a test can assert
exactly what was and was not sent, and when.

A family subclasses :class:`Simulator` with what only it knows: its decoder
(through its :class:`~harlsync.sim.family.LineFamily`), how one request is
carried out on one station's state and its reply encoded (:meth:`respond`),
which requests are writes, when a station is busy, its control verbs, where its
checksum sits, and how a station is kept in battery-backed memory.

What is not about bytes on a line is :class:`Device`, the base of every
family's simulator: the stations, the record of what was asked of them, the
faults, the busy-after-writes schedule, the control verbs and the
battery-backed memory.  A family whose controllers are reached another way
(registers over a network protocol, say, served by its own server through a
:class:`~harlsync.sim.family.ServedFamily`) subclasses :class:`Device` alone.
"""

from __future__ import annotations

import logging
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Generic, Protocol, TypeVar, cast, runtime_checkable

from .. import families
from ..errors import ProtocolError
from . import variants
from .faults import Faults
from .variants import Variant

__all__ = [
    "Decoder",
    "Device",
    "Faults",
    "LineFamily",
    "Received",
    "Refused",
    "RequestFrame",
    "SimFamily",
    "Simulator",
    "Verb",
]

log = logging.getLogger(__name__)


class RequestFrame(Protocol):
    """What the framework reads of a family's decoded frame."""

    @property
    def station(self) -> int: ...

    @property
    def payload(self) -> str:
        """The frame's text between station and checksum, as the record keeps it."""
        ...


F_co = TypeVar("F_co", bound=RequestFrame, covariant=True)
S = TypeVar("S")
F = TypeVar("F", bound=RequestFrame)


class Decoder(Protocol[F_co]):
    """A family's sans-I/O frame decoder: ``feed(bytes)``, then ``next_frame()``
    until None; a bad frame raises :class:`~harlsync.errors.ProtocolError` after
    its bytes are consumed."""

    def feed(self, data: bytes) -> None: ...

    def next_frame(self) -> F_co | None: ...

    @property
    def pending(self) -> int:
        """Bytes held that are not yet part of a returned or failed frame."""
        ...

    @property
    def dropped(self) -> int:
        """Bytes discarded as noise so far."""
        ...


@dataclass(frozen=True)
class Verb:
    """One control command of a family's simulator, as ``harlsync sim`` help lists it."""

    name: str
    #: the words after the verb, ``[STATION [TASK]]``
    usage: str
    #: what it does, in a few words
    does: str

    def __str__(self) -> str:
        return f"{self.name} {self.usage}".strip()


class SimFamily(Protocol):
    """What the framework needs of a family's simulated controller."""

    @property
    def name(self) -> str:
        """The family's name, as ``robot.yaml`` and ``--family`` say it."""
        ...

    @property
    def verbs(self) -> tuple[Verb, ...]:
        """The control verbs its stations take (``status`` and ``BUSY-after-writes
        N`` are the framework's, for every family)."""
        ...

    @property
    def busy_verb(self) -> str:
        """The verb that makes a station busy with no more arguments (``auto``,
        ``run``); it also names the schedule, ``auto-after-writes N``."""
        ...

    @property
    def variants(self) -> tuple[Variant, ...]:
        """Each choice its profile makes where the manual is silent, with the other
        ways a controller may answer (:mod:`harlsync.sim.variants`)."""
        ...

    @property
    def default_station(self) -> int:
        """Where a generated robot sits.  (How stations are written is the family's
        :class:`~harlsync.families.base.Family`'s, not repeated here.)"""
        ...

    def generate(self, seed: int, stations: Sequence[int]) -> Device[Any]:
        """Realistic robots drawn from seeds ``seed``, ``seed + 1`` ..., one a station."""
        ...

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Device[Any]:
        """The robot of a project directory, on its own station or on each of
        ``stations``.  Raises :class:`~harlsync.errors.ProjectError`."""
        ...


@runtime_checkable
class LineFamily(SimFamily, Protocol):
    """A family whose controllers sit on a serial line: the framework serves its
    :class:`~harlsync.sim.device.Simulator` (pty, TCP, ``sim://``)."""

    def decoder(self) -> Decoder[RequestFrame]:
        """A new decoder for the requests a client sends this family's controllers."""
        ...


class Refused(Exception):
    """A well-formed request a simulated station does not carry out: the family
    answers it with its error reply, carrying ``code`` (the family's error code)."""

    def __init__(self, code: str) -> None:
        super().__init__(code)
        self.code = code


@dataclass(frozen=True)
class Received:
    """One request a simulated station answered (or would have: see ``answered``)."""

    station: int
    payload: str
    #: the request's name as the family's protocol names it: letters, a message id
    command: str
    #: whether the request is a write (whether or not the station carried it out)
    is_write: bool
    at: float
    #: False when a fault dropped the reply
    answered: bool
    #: the station was not idle when the request arrived (the family's
    #: :attr:`~SimFamily.busy_verb`: its interlock refuses writes)
    busy: bool
    #: who sent it: "pty", a TCP peer "host:port", ... ("" when unknown)
    client: str = ""


class Device(ABC, Generic[S]):
    """Simulated controllers of one family, each a station holding a family state
    ``S``, whatever carries the requests to them.

    ``busy_after_writes`` makes the written station busy (the family's
    :attr:`~SimFamily.busy_verb`: what the family's interlock refuses, a program
    running, say) once that many writes have been carried out (0 = never),
    so that interlocks can be tested mid-push.  Every request a station takes
    is recorded in :attr:`received` (:meth:`record`), with whether that station
    was busy (not idle) when it arrived.
    """

    #: The family this simulator belongs to: its stations and verbs.
    family: ClassVar[SimFamily]

    def __init__(
        self,
        stations: Mapping[int, S] | S,
        *,
        faults: Faults | None = None,
        busy_after_writes: int = 0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if isinstance(stations, Mapping):
            self.stations: dict[int, S] = dict(stations)
        else:
            self.stations = {self.family.default_station: stations}
        self.faults = faults or Faults()
        self.busy_after_writes = busy_after_writes
        self.received: list[Received] = []
        #: Called with each :class:`Received` as it is recorded (``harlsync sim --record``).
        self.listeners: list[Callable[[Received], None]] = []
        #: writes carried out (a refused write is received, not carried out)
        self.writes = 0
        #: The clock the device's times come from (tests give it one they move).
        self.clock = clock
        self.lock = threading.RLock()
        #: How this controller fills each silence of its manual (name -> value, every
        #: variant of :attr:`family` present): :meth:`vary` changes it.
        self.variant: dict[str, str] = variants.defaults(self.family.variants)

    def vary(self, chosen: Mapping[str, str]) -> None:
        """Answer as ``chosen`` says where the manual is silent (the rest at the
        profile's choice).  Raises ValueError for an unknown variant or value."""
        self.variant = variants.choose(self.family.variants, chosen)

    def record(self, request: Received) -> None:
        """Keep ``request`` in :attr:`received` and tell the listeners."""
        self.received.append(request)
        for listener in self.listeners:
            listener(request)

    def parse_station(self, text: str) -> int:
        """A station as the family's people write it (``99`` is 99h for a family that
        writes stations in hex).  Raises ValueError."""
        return families.get(self.family.name).parse_station(text)

    def show_station(self, number: int) -> str:
        return families.get(self.family.name).format_station(number)

    # --- what the family plugs in -----------------------------------------------------

    @abstractmethod
    def busy(self, state: S) -> bool:
        """Whether the station is not idle: a write now is one the interlock forbids."""

    @abstractmethod
    def control(self, verb: str, state: S, args: Sequence[str]) -> None:
        """Carry out one of the family's :attr:`~SimFamily.verbs` on a station.

        ``args`` are the words after the station.  Raises ValueError for bad ones.
        """

    @abstractmethod
    def describe(self, state: S) -> str:
        """The station's mode in a few words (``idle``, ``automatic``, ``MANUAL``)."""

    @abstractmethod
    def save_station(self, station: int, directory: Path) -> None:
        """Keep the station's battery-backed memory in ``directory``."""

    @abstractmethod
    def load_station(self, station: int, directory: Path) -> bool:
        """Restore the station from ``directory``; False when nothing is kept there.

        Raises :class:`~harlsync.errors.ProjectError` for an unreadable memory.
        """

    # --- for the family and for tests --------------------------------------------------

    def wrote(self, state: S) -> None:
        """Count one write carried out on ``state``, and make the station busy when
        :attr:`busy_after_writes` is reached; the schedule then goes (it fires once:
        a station stopped afterwards stays idle).  A family calls it after each write."""
        self.writes += 1
        due = self.busy_after_writes and self.writes >= self.busy_after_writes
        if not due:
            return
        self.busy_after_writes = 0
        if not self.busy(state):
            log.info(
                "sim: scheduled switch after %d writes: %s", self.writes, self.family.busy_verb
            )
            self.control(self.family.busy_verb, state, ())

    @property
    def armed(self) -> int | None:
        """How many more writes until the scheduled switch to busy, or None when
        none is scheduled."""
        if not self.busy_after_writes:
            return None
        return max(0, self.busy_after_writes - self.writes)

    def writes_received(self, station: int | None = None) -> list[Received]:
        with self.lock:
            return [
                r for r in self.received if r.is_write and (station is None or r.station == station)
            ]


class Simulator(Device[S], Generic[S, F]):
    """A simulated serial line and the stations (robots) on it, each holding a
    family state ``S``; requests arrive as the family's frames ``F``.

    ``baudrate`` turns on wire-time emulation: each reply's last byte is due after
    the time the request and the reply take on the wire at that speed, plus
    ``turnaround`` (the servers pace the bytes before it, see
    :class:`~harlsync.sim.serve.ReplyScheduler`).
    """

    #: The family this simulator belongs to: its decoder, stations and verbs.
    family: ClassVar[LineFamily]

    def __init__(
        self,
        stations: Mapping[int, S] | S,
        *,
        baudrate: int | None = None,
        bits_per_char: int = 10,
        turnaround: float = 0.0,
        faults: Faults | None = None,
        busy_after_writes: int = 0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__(stations, faults=faults, busy_after_writes=busy_after_writes, clock=clock)
        self.baudrate = baudrate
        self.bits_per_char = bits_per_char
        self.turnaround = turnaround
        self.ignored = 0  # frames with a bad checksum, for another station, or malformed
        #: bytes received from the client, and reply bytes sent (before the server
        #: writes them): what crossed the line each way
        self.bytes_in = 0
        self.bytes_out = 0
        self._decoder = self.new_decoder()

    # --- the wire ---------------------------------------------------------------------

    def new_decoder(self) -> Decoder[F]:
        """A decoder for one connection's bytes (each TCP client has its own)."""
        return cast("Decoder[F]", self.family.decoder())

    def receive(
        self, data: bytes, decoder: Decoder[F] | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        """Take bytes from the client; return the reply chunks as (delay, bytes).

        ``decoder`` keeps the framing state of one connection (one TCP client);
        by default the line's own decoder is used.  ``client`` names the sender
        in :attr:`received`.
        """
        out: list[tuple[float, bytes]] = []
        decoder = self._decoder if decoder is None else decoder
        with self.lock:
            self.bytes_in += len(data)
            decoder.feed(data)
            while True:
                held, dropped = decoder.pending, decoder.dropped
                try:
                    frame = decoder.next_frame()
                except ProtocolError as exc:
                    self.ignored += 1
                    log.debug("sim: ignored bad request: %s", exc)
                    continue
                if frame is None:
                    return out
                size = held - decoder.pending - (decoder.dropped - dropped)
                out += self._answer(frame, size, client)

    def _answer(self, frame: F, size: int, client: str) -> list[tuple[float, bytes]]:
        """The chunks answering one frame of ``size`` bytes; recorded when answered."""
        state = self.stations.get(frame.station)
        if state is None:
            self.ignored += 1
            log.debug("sim: no robot with station %s: silence", self.show_station(frame.station))
            return []
        busy = self.busy(state)
        reply = self.respond(frame.station, state, frame)
        if reply is None:
            self.ignored += 1
            log.debug("sim: %r is not a request: silence", frame)
            return []
        wire = self._wire_time(size + len(reply))
        chunks = self.faults.shape(reply, self.corrupt_checksum)
        record = Received(
            frame.station,
            frame.payload,
            self.command(frame),
            self.is_write(frame),
            self.clock(),
            bool(chunks),
            busy,
            client,
        )
        self.record(record)
        self.bytes_out += sum(len(chunk) for _, chunk in chunks)
        return [(wire + extra, chunk) for extra, chunk in chunks]

    @property
    def char_time(self) -> float:
        """Seconds one character takes on the emulated line (0: no emulation)."""
        return self.bits_per_char / self.baudrate if self.baudrate else 0.0

    def _wire_time(self, nbytes: int) -> float:
        return self.turnaround + nbytes * self.char_time

    # --- what the family plugs in -----------------------------------------------------

    @abstractmethod
    def respond(self, station: int, state: S, frame: F) -> bytes | None:
        """Carry out one request on one station's state; the reply frame's bytes,
        or None for silence (a frame that is no request)."""

    @abstractmethod
    def is_write(self, frame: F) -> bool:
        """Whether the request is a write (for the record, carried out or not)."""

    @abstractmethod
    def command(self, frame: F) -> str:
        """The request's name in the record."""

    @abstractmethod
    def corrupt_checksum(self, frame: bytes) -> bytes:
        """``frame`` with a wrong checksum and every other byte as it was."""
