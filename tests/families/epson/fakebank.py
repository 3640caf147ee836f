"""An in-memory register bank that plays the controller's side of the handshake (§6).

The controller moves one step each time its outputs are read (a poll), after
``delays`` polls of its own, so a slow controller, one that never takes a
command or never answers, costs no real time: the handshake runs on a
:class:`FakeClock` whose sleep only moves its hands.

It does what the manual says the controller does, including the §6.5 function
error when a client misbehaves: a new request (ExtCmdSet rising) while a
command is unanswered halts the function with 9999/0001, recorded in
``function_errors``.  Every register access is in ``log``.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from harlsync.families.epson.profile import Bit, RegisterMap

#: A command's words -> (ExtCmdResult, the response words from word 0).
Answer = Callable[[tuple[int, ...]], tuple[bool, tuple[int, ...]]]

#: What unused response words hold: stale data the decoder must never read.
STALE = 0xEEEE


class FakeClock:
    """A clock whose sleep moves time on at once."""

    def __init__(self) -> None:
        self.now = 0.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds >= 0
        self.now += seconds


def acknowledge(words: tuple[int, ...]) -> tuple[bool, tuple[int, ...]]:
    """Every command answered normally: a set command's [echo, 0000H, 0000H]."""
    return False, (words[0], 0, 0)


@dataclass
class Delays:
    """Polls the controller lets pass before each of its steps."""

    acquire: int = 0
    execute: int = 0
    release: int = 0


@dataclass
class Op:
    """One register access: ``kind`` read_holding, read_input or write."""

    kind: str
    address: int
    values: tuple[int, ...]
    time: float


@dataclass
class FakeController:
    """The controller's Remote I/O as Modbus registers, and its §6 state machine."""

    map: RegisterMap = field(default_factory=RegisterMap)
    answer: Answer = acknowledge
    clock: FakeClock = field(default_factory=FakeClock)
    delays: Delays = field(default_factory=Delays)
    never_acquire: bool = False
    never_answer: bool = False
    #: a function error the controller raises on the next command (9901, 9902)
    fail_next: int | None = None
    label: str = "fake controller"
    holding: dict[int, int] = field(default_factory=lambda: defaultdict(int))
    inputs: dict[int, int] = field(default_factory=lambda: defaultdict(int))
    log: list[Op] = field(default_factory=list)
    #: the command words the controller took, in order
    taken: list[tuple[int, ...]] = field(default_factory=list)
    #: the function errors it raised (Response 2)
    function_errors: list[int] = field(default_factory=list)
    state: str = "idle"
    _wait: int = 0
    _latched: tuple[int, ...] = ()
    _seen: tuple[bool, bool, bool] = (False, False, False)
    #: Ready follows the state signals, as the controller's does (Ready 1 when no
    #: task runs or pauses, no error, no emergency stop); False: set by hand only
    ready_follows: bool = True
    #: whether a write reaches the controller whole (the profile's assumption,
    #: BLOCK_WRITE_WHOLE); False: a register at a time, in address order, the
    #: controller reacting after each (a slave that hands them over so)
    whole_writes: bool = True
    #: the requests whose command words were not all written since the request
    #: before (ExtCmdSet rose over stale words): never, from harlsync
    stale_requests: list[tuple[int, ...]] = field(default_factory=list)
    _fresh: set[int] = field(default_factory=set)

    def __post_init__(self) -> None:
        self._follow()

    def _follow(self) -> None:
        ready = self.map.ready
        if self.ready_follows and ready is not None:
            busy = ("Running", "Paused", "Error", "EStopOn")
            on = any(
                self.inputs[b.register] >> b.bit & 1
                for name in busy
                if (b := self.map.signal(name)) is not None
            )
            self._put(ready, not on)

    # --- the register access the handshake uses ---------------------------------------

    def read_holding(self, address: int, count: int) -> list[int]:
        values = [self.holding[address + i] for i in range(count)]
        self.log.append(Op("read_holding", address, tuple(values), self.clock.now))
        return values

    def read_input(self, address: int, count: int) -> list[int]:
        self._tick()
        values = [self.inputs[address + i] for i in range(count)]
        self.log.append(Op("read_input", address, tuple(values), self.clock.now))
        return values

    def write_holding(self, address: int, values: Sequence[int]) -> None:
        self.log.append(Op("write", address, tuple(values), self.clock.now))
        for i, value in enumerate(values):
            self.holding[address + i] = value
            self._fresh.add(address + i)
            if not self.whole_writes:
                self._react()
        if self.whole_writes:
            self._react()

    # --- what the tests set and look at -----------------------------------------------

    def set_signal(self, name: str, on: bool) -> None:
        """Set one of the controller's outputs (Running, Paused ...)."""
        bit = self.map.signal(name)
        assert bit is not None, name
        self._put(bit, on)
        if name != "Ready":
            self._follow()

    def preset(self, name: str, on: bool) -> None:
        """Set one of the controller's inputs as an earlier client left it (no edge)."""
        bit = self.map.signal(name)
        assert bit is not None, name
        value = self.holding[bit.register]
        self.holding[bit.register] = value | 1 << bit.bit if on else value & ~(1 << bit.bit)
        m = self.map
        self._seen = (
            self._get(m.ext_cmd_set),
            self._get(m.ext_resp_get),
            self._get(m.ext_cmd_reset),
        )
        self.state = "idle" if self._seen[2] else "off"

    def input_signal(self, name: str) -> bool:
        """One of the controller's inputs, as harlsync left it."""
        bit = self.map.signal(name)
        assert bit is not None
        return bool(self.holding[bit.register] >> bit.bit & 1)

    def writes(self) -> list[Op]:
        return [op for op in self.log if op.kind == "write"]

    def command_writes(self) -> list[tuple[int, ...]]:
        """The command words harlsync wrote, in order (alone, or in one write with
        ExtCmdSet's register)."""
        base, count = self.map.command_base, self.map.command_words
        return [
            op.values[base - op.address : base - op.address + count]
            for op in self.writes()
            if op.address <= base and op.address + len(op.values) >= base + count
        ]

    # --- the controller ---------------------------------------------------------------

    def _get(self, bit: Bit) -> bool:
        return bool(self.holding[bit.register] >> bit.bit & 1)

    def _put(self, bit: Bit, on: bool) -> None:
        value = self.inputs[bit.register]
        self.inputs[bit.register] = value | 1 << bit.bit if on else value & ~(1 << bit.bit)

    def _respond(self, error: bool, words: Sequence[int]) -> None:
        base = self.map.response_base
        for i in range(self.map.response_words):
            self.inputs[base + i] = words[i] if i < len(words) else STALE
        self._put(self.map.ext_cmd_result, error)

    def _function_error(self, detail: int) -> None:
        """§6.5: the command is aborted, ExtError 1, the code in the response words."""
        self.function_errors.append(detail)
        self._respond(False, (self._latched[0] if self._latched else 0, 0x9999, detail))
        for bit in (self.map.ext_cmd_get, self.map.ext_resp_set):
            self._put(bit, False)
        self._put(self.map.ext_error, True)
        self.state = "halted"

    def _react(self) -> None:
        """Edges of harlsync's signals, as the controller sees them on a write."""
        m = self.map
        now = (self._get(m.ext_cmd_set), self._get(m.ext_resp_get), self._get(m.ext_cmd_reset))
        (was_set, was_get, was_reset), self._seen = self._seen, now
        cmd_set, resp_get, reset = now
        if was_reset and not reset:  # §6.5.2: the function is reset
            for bit in (m.ext_cmd_get, m.ext_resp_set, m.ext_cmd_result, m.ext_error):
                self._put(bit, False)
            self.state = "off"
            return
        if not reset:
            self.state = "off"
            return
        if self.state == "off":
            self.state = "idle"
        if cmd_set and not was_set:
            if self.state == "halted":
                return
            if self.state != "idle":  # a second request while one is unanswered
                self._function_error(0x0001)
                return
            words = range(m.command_base, m.command_base + m.command_words)
            self._latched = tuple(self.holding[r] for r in words)
            if not self._fresh.issuperset(words):
                self.stale_requests.append(self._latched)
            self._fresh.clear()
            if self.fail_next is not None:
                detail, self.fail_next = self.fail_next, None
                self._function_error(detail)
                return
            self.state, self._wait = "requested", self.delays.acquire
        elif was_set and not cmd_set:
            if self.state == "requested":  # withdrawn before it was taken
                self.state = "idle"
            elif self.state == "acquired":
                self._put(m.ext_cmd_get, False)
                self.state, self._wait = "executing", self.delays.execute
        if resp_get and not was_get and self.state == "responded":
            self.state, self._wait = "releasing", self.delays.release
        elif was_get and not resp_get and self.state == "released":
            self.state = "idle"

    def _tick(self) -> None:
        """One poll: the controller moves one step when its delay has passed."""
        if self._wait > 0:
            self._wait -= 1
            return
        m = self.map
        if self.state == "requested" and not self.never_acquire:
            self.taken.append(self._latched)
            self._put(m.ext_cmd_get, True)
            self.state = "acquired"
        elif self.state == "executing" and not self.never_answer:
            error, words = self.answer(self._latched)
            self._respond(error, words)
            self._put(m.ext_resp_set, True)
            self.state = "responded"
        elif self.state == "releasing":
            self._put(m.ext_resp_set, False)
            self.state = "released"
