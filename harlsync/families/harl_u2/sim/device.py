"""The simulated HARL-U2: one serial line, one or several stations, played with
the project's own codec from the device's side.

How this works::

    bytes in --> FrameDecoder --> frame for a station we have? --no--> silence
                                      |yes
                                  handle(request)  --> reply payload ("E"+status on error)
                                      |
                  Faults.shape(reply frame) --> [(delay, bytes), ...] --> the wire

:meth:`Simulator.receive` is sans-I/O like the codec: it takes the bytes the
client sent and returns the chunks to send back, each with the delay after which
it is due.  The pty, TCP and ``sim://`` servers only move those bytes and honour
the delays.  Every valid request is recorded in :attr:`Simulator.received`, so a
test can assert exactly what was and was not sent.
"""

from __future__ import annotations

import logging
import random
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields

from ....errors import ProtocolError
from ..model import (
    MAX_STEP_DATA,
    OFFSET_TABLE_COUNT,
    REGISTER_RE,
    TIMER_RE,
    TOKEN_RE,
    Config,
    OffsetTable,
    Parameters,
    ProgramType,
    Step,
)
from ..protocol import FrameDecoder, Request, encode_frame, parse_request, profile
from .state import IO_BITS, MEM_BIT_BASE, SimState

__all__ = ["STATUS_COMMAND", "STATUS_DATA", "STATUS_RANGE", "Faults", "Received", "Simulator"]

log = logging.getLogger(__name__)

#: Error statuses the simulator answers with (the real codes are in the HRCS-R3
#: manual, which we do not have; harlsync only shows them raw).
STATUS_RANGE = "21"  # number outside the configuration
STATUS_COMMAND = "10"  # unknown command or wrong number of fields
STATUS_DATA = "22"  # value out of range for a write


class _Refuse(Exception):
    def __init__(self, status: str) -> None:
        self.status = status


@dataclass(frozen=True)
class Received:
    """One valid request the simulator received."""

    station: int
    payload: str
    at: float
    answered: bool
    automatic: bool  # some task of that station was in execution or suspended
    client: str = ""  # who sent it: "pty", a TCP peer "host:port", ... ("" when unknown)

    @property
    def letters(self) -> str:
        return self.payload.split(" ", 1)[0]

    @property
    def is_write(self) -> bool:
        return self.letters.startswith("SN")


@dataclass
class Faults:
    """Fault injection on replies: each rate is a probability per reply (0-1).

    ``noise`` prefixes random bytes, ``drop`` sends nothing, ``bad_lrc`` flips the
    LRC, ``fragment`` splits the reply into pieces sent with gaps, ``slow`` delays
    it by ``slow_delay`` seconds (longer than the client's deadline by default).
    """

    noise: float = 0.0
    drop: float = 0.0
    bad_lrc: float = 0.0
    fragment: float = 0.0
    slow: float = 0.0
    slow_delay: float = 1.5
    fragment_gap: float = 0.002
    seed: int | None = None
    _rng: random.Random = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The settings a user can give: the rates, the timings and the seed."""
        return tuple(f.name for f in fields(cls) if f.init)

    @classmethod
    def from_settings(cls, settings: dict[str, str]) -> Faults:
        """From name -> text (``{"noise": "0.1", "seed": "3"}``).  Raises ValueError."""
        unknown = set(settings) - set(cls.names())
        if unknown:
            raise ValueError(
                f"unknown fault {', '.join(sorted(unknown))} (known: {', '.join(cls.names())})"
            )
        return cls(**{  # type: ignore[arg-type]
            name: int(value) if name == "seed" else float(value)
            for name, value in settings.items()
        })

    @classmethod
    def parse(cls, text: str) -> Faults:
        """From ``"noise=0.1,drop=0.05,seed=3"`` (the CLI form).  Raises ValueError."""
        pairs = (item.partition("=") for item in filter(None, text.split(",")))
        return cls.from_settings({k.strip().replace("-", "_"): v for k, _, v in pairs})

    def shape(self, frame: bytes) -> list[tuple[float, bytes]]:
        """The reply as chunks ``(extra delay, bytes)``; empty when dropped."""
        rng = self._rng
        if self.drop and rng.random() < self.drop:
            return []
        data = bytearray(frame)
        if self.bad_lrc and rng.random() < self.bad_lrc:
            data[-1] ^= 0x5A
        if self.noise and rng.random() < self.noise:
            junk = bytes(rng.choice(b"\x00\x7f\xff#*?!ZQ\x03 ") for _ in range(rng.randrange(1, 8)))
            data[:0] = junk
        delay = self.slow_delay if self.slow and rng.random() < self.slow else 0.0
        if self.fragment and rng.random() < self.fragment and len(data) > 2:
            cuts = sorted(rng.sample(range(1, len(data)), k=min(3, len(data) - 1)))
            pieces = [bytes(data[a:b]) for a, b in zip([0, *cuts], [*cuts, len(data)])]
            return [(delay + i * self.fragment_gap, p) for i, p in enumerate(pieces)]
        return [(delay, bytes(data))]




class Simulator:
    """A simulated HNC controller: one serial line and the robots (stations) on it.

    ``baudrate`` turns on wire-time emulation: each reply's last byte is due after
    the time the request and the reply take on the wire at that speed, plus
    ``turnaround`` (the servers pace the bytes before it, see
    :class:`~harlsync.sim.serve.ReplyScheduler`).
    ``auto_after_writes`` puts task 0 of the written station into automatic
    operation once that many SN writes have been answered (0 = never), so that
    interlocks can be tested mid-push.
    """

    def __init__(
        self,
        stations: dict[int, SimState] | SimState,
        *,
        baudrate: int | None = None,
        bits_per_char: int = 10,
        turnaround: float = 0.0,
        faults: Faults | None = None,
        auto_after_writes: int = 0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.stations = stations if isinstance(stations, dict) else {1: stations}
        self.baudrate = baudrate
        self.bits_per_char = bits_per_char
        self.turnaround = turnaround
        self.faults = faults or Faults()
        self.auto_after_writes = auto_after_writes
        self.received: list[Received] = []
        #: Called with each :class:`Received` as it is recorded (``harlsync sim --record``).
        self.listeners: list[Callable[[Received], None]] = []
        self.ignored = 0  # frames with a bad LRC, for another station, or malformed
        self.writes = 0
        #: bytes received from the client, and reply bytes sent (before the server
        #: writes them): what crossed the line each way
        self.bytes_in = 0
        self.bytes_out = 0
        self._clock = clock
        self._decoder = FrameDecoder()
        self.lock = threading.RLock()

    # --- the wire ---------------------------------------------------------------------

    def receive(
        self, data: bytes, decoder: FrameDecoder | None = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        """Take bytes from the client; return the reply chunks as (delay, bytes).

        ``decoder`` keeps the framing state of one connection (one TCP client);
        by default the line's own decoder is used.  ``client`` names the sender
        in :attr:`received`.
        """
        out: list[tuple[float, bytes]] = []
        decoder = decoder or self._decoder
        with self.lock:
            self.bytes_in += len(data)
            decoder.feed(data)
            while True:
                try:
                    frame = decoder.next_frame()
                except ProtocolError as exc:
                    self.ignored += 1
                    log.debug("sim: ignored bad request: %s", exc)
                    continue
                if frame is None:
                    return out
                state = self.stations.get(frame.station)
                if state is None:
                    self.ignored += 1
                    log.debug("sim: no robot with station %d: silence", frame.station)
                    continue
                automatic = state.automatic
                reply = self.handle(state, frame.payload)
                raw = encode_frame(frame.station, reply)
                wire = self._wire_time(len(frame.encode()) + len(raw))
                chunks = self.faults.shape(raw)
                record = Received(
                    frame.station, frame.payload, self._clock(), bool(chunks), automatic, client
                )
                self.received.append(record)
                for listener in self.listeners:
                    listener(record)
                for extra, chunk in chunks:
                    out.append((wire + extra, chunk))
                    self.bytes_out += len(chunk)

    @property
    def char_time(self) -> float:
        """Seconds one character takes on the emulated line (0: no emulation)."""
        return self.bits_per_char / self.baudrate if self.baudrate else 0.0

    def _wire_time(self, nbytes: int) -> float:
        if not self.baudrate:
            return self.turnaround
        return self.turnaround + nbytes * self.bits_per_char / self.baudrate

    # --- the controller -----------------------------------------------------------

    def handle(self, state: SimState, payload: str) -> str:
        """The reply payload to one request payload for one robot."""
        try:
            request = parse_request(payload)
        except ProtocolError:
            return profile.ERROR_PREFIX + STATUS_COMMAND
        try:
            if request.is_write:
                reply = self._write(state, request)
                self.writes += 1
                due = self.auto_after_writes and self.writes >= self.auto_after_writes
                if due and not state.automatic:
                    log.info("sim: scheduled switch to automatic operation")
                    state.start_task(0)
                return reply
            return self._read(state, request)
        except _Refuse as refusal:
            return profile.ERROR_PREFIX + refusal.status
        except ValueError:
            return profile.ERROR_PREFIX + STATUS_COMMAND

    def _read(self, state: SimState, req: Request) -> str:
        data, cfg, a = state.data, state.data.config, req.args
        letters = req.letters
        if letters in ("LNA", "LNM", "LNS", "LNH"):
            key, step = _program_step(cfg, letters, a)
            found = data.programs[key].get(step, Step())
            return " ".join((str(step), *found.tokens))
        if letters == "LNT":
            return data.timers[_index(a[0], cfg.timers)]
        if letters == "LND":
            assert data.registers is not None
            return data.registers[_index(a[0], cfg.registers)]
        if letters == "LNL":
            return " ".join(data.offsets[_index(a[0], OFFSET_TABLE_COUNT)].values)
        if letters in ("LNIB", "LNOB"):
            bits = state.di if letters == "LNIB" else state.do
            return str(bits[_index(a[0], IO_BITS)])
        if letters in ("LNID", "LNOD"):
            bits = state.di if letters == "LNID" else state.do
            return str(_port_value(bits, _index(a[0], IO_BITS // 8)))
        if letters == "LNBB":
            return str(state.mem[_index(a[0], cfg.memory_bits, MEM_BIT_BASE)])
        if letters == "LNBD":
            return str(_port_value(state.mem, _index(a[0], cfg.memory_bits // 8)))
        if letters == "LNE":
            return " ".join(data.parameters.values)
        if letters == "LNR":
            return " ".join(
                f"{t.status} {t.program_type} {t.program} {t.step}" for t in state.tasks
            )
        if letters == "LNV":
            return data.version
        if letters == "LNX":
            return " ".join(str(n) for n in cfg.numbers())
        raise _Refuse(STATUS_COMMAND)

    def _write(self, state: SimState, req: Request) -> str:
        data, cfg, a = state.data, state.data.config, req.args
        letters = req.letters
        if letters in ("SNA", "SNM", "SNS", "SNH"):
            numbered = letters != "SNA"
            key, step = _program_step(cfg, "LN" + letters[2], a[: 2 if numbered else 1])
            tokens = a[2 if numbered else 1 :]
            if len(tokens) > 1 + MAX_STEP_DATA:
                raise _Refuse(STATUS_DATA)
            if tokens:
                data.programs[key][step] = Step.from_tokens(tokens)
            else:
                data.programs[key].pop(step, None)
        elif letters == "SNT":
            data.timers[_index(a[0], cfg.timers)] = _valid(TIMER_RE, a[1])
        elif letters == "SND":
            assert data.registers is not None
            data.registers[_index(a[0], cfg.registers)] = _valid(REGISTER_RE, a[1])
        elif letters == "SNL":
            table = OffsetTable.from_values(a[1:])
            if table.problems():
                raise _Refuse(STATUS_DATA)
            data.offsets[_index(a[0], OFFSET_TABLE_COUNT)] = table
        elif letters in ("SNOB", "SNBB"):
            bits = state.do if letters == "SNOB" else state.mem
            base, size = (0, IO_BITS) if letters == "SNOB" else (MEM_BIT_BASE, cfg.memory_bits)
            bits[_index(a[0], size, base)] = int(_valid_bit(a[1]))
        elif letters in ("SNOD", "SNBD"):
            bits = state.do if letters == "SNOD" else state.mem
            port = _index(a[0], len(bits) // 8)
            value = int(a[1])
            if not 0 <= value <= 255:
                raise _Refuse(STATUS_DATA)
            for i in range(8):
                bits[port * 8 + i] = (value >> i) & 1
        elif letters == "SNE":
            if not all(TOKEN_RE.fullmatch(v) for v in a):
                raise _Refuse(STATUS_DATA)
            data.parameters = Parameters.from_values(a)
        elif letters == "SNX":
            data.config = Config.from_numbers(
                [*(int(v) for v in a), cfg.timers, cfg.memory_bits, cfg.registers]
            )
            # The manual: changing the configuration breaks the programs made.
            data.programs = {key: {} for key in data.config.programs()}
        else:
            raise _Refuse(STATUS_COMMAND)
        return profile.SN_OK

    # --- for tests and the CLI --------------------------------------------------------

    def writes_received(self, station: int | None = None) -> list[Received]:
        with self.lock:
            return [
                r
                for r in self.received
                if r.is_write and (station is None or r.station == station)
            ]

    def unsafe_in_automatic(self) -> list[Received]:
        """Unsafe SN commands (SNA/SNM/SNS/SNH/SNE/SNX) received during automatic operation."""
        with self.lock:
            return [
                r
                for r in self.received
                if r.automatic and Request(r.letters).unsafe
            ]


def _index(text: str, size: int, base: int = 0) -> int:
    """A number field within [base, base+size), else a range error."""
    if not text.isdigit():
        raise _Refuse(STATUS_COMMAND)
    n = int(text) - base
    if not 0 <= n < size:
        raise _Refuse(STATUS_RANGE)
    return n


def _program_step(
    cfg: Config, letters: str, args: tuple[str, ...]
) -> tuple[tuple[ProgramType, int], int]:
    ptype = next(t for t in ProgramType if t.letter == letters[2])
    area = cfg.area(ptype)
    if ptype is ProgramType.START:
        number, step_text = 0, args[0]
        if area.count < 1:
            raise _Refuse(STATUS_RANGE)
    else:
        number, step_text = _index(args[0], area.count), args[1]
    return (ptype, number), _index(step_text, area.steps)


def _port_value(bits: list[int], port: int) -> int:
    return sum(bits[port * 8 + i] << i for i in range(8))


def _valid(pattern: re.Pattern[str], text: str) -> str:
    if not pattern.fullmatch(text):
        raise _Refuse(STATUS_DATA)
    return text


def _valid_bit(text: str) -> str:
    if text not in ("0", "1"):
        raise _Refuse(STATUS_DATA)
    return text
