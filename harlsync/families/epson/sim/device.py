"""The simulated Epson controller: a Modbus TCP server whose registers are the
controller's Remote I/O, on the shared simulator framework (:mod:`harlsync.sim`).

How this works::

    client --Modbus TCP--> pymodbus server (server.py) --a unit's registers-->
        RemoteIO (remote.py): the §6 handshake, the controller's side
            a command taken --> commands.py: carried out on the SimState (state.py)
                                in the station's Session, the response words back
        every command taken is recorded (Simulator.received): a CommandReceived

One :class:`Simulator` holds one or more controllers (stations: Modbus unit
ids), each a :class:`~.state.SimState`.  What the robot is doing (Running,
Paused, EStopOn, Error, SafeguardOn) is set by the control verbs
(``harlsync sim`` reads them on its standard input), by the framework's
``run-after-writes N`` schedule, or by a test.

**(simulator)** The manual names no interlock in the controller: a setting
command is carried out whatever the robot is doing.  The record says whether
the robot was busy when each command arrived, so a test can assert that
harlsync never wrote then (:meth:`Simulator.writes_while_busy`).

Faults: the framework's ``drop`` is the rate of Modbus replies the server
does not send, ``slow`` the rate of commands that run for ``slow_delay``
seconds instead of the execution time; :meth:`Simulator.drop_replies` drops the
next N replies, the ``function-error`` verb halts the function.  ``noise``,
``bad_checksum`` and ``fragment`` are a serial line's: TCP carries Modbus
whole and Modbus TCP has no checksum.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ....errors import ProjectError, ProjectFormatError
from ....sim import device
from ....sim.device import Faults, Received
from .. import profile
from ..profile import RegisterMap
from . import memory
from . import state as _state
from . import variants as _variants
from .codes import Outcome, PointAnswers
from .commands import COMMAND_SET, READS, execute
from .remote import FunctionFault, RemoteIO, Words
from .server import ModbusServer
from .session import Session
from .state import SimState
from .verbs import VERBS, act, function_error_detail

__all__ = [
    "DEFAULT_EXECUTION_TIME",
    "SIM_FAMILY",
    "CommandReceived",
    "EpsonSimFamily",
    "Simulator",
]

log = logging.getLogger(__name__)

#: Seconds a command runs, from ExtCmdGet to ExtRespSet **(simulator)**: the
#: manual gives no time; a controller carries a setting command out in a few ms.
DEFAULT_EXECUTION_TIME = 0.002


class EpsonSimFamily:
    """The Epson side of the simulator framework (a
    :class:`~harlsync.sim.ServedFamily`: it serves its controllers over Modbus TCP)."""

    name = "epson"
    verbs = VERBS
    busy_verb = "run"
    default_station = profile.DEFAULT_UNIT
    #: how it may fill its manual's silences (harlsync.sim.variants); the profile's first
    variants = _variants.VARIANTS

    def generate(self, seed: int, stations: Sequence[int]) -> Simulator:
        return Simulator({n: SimState.generate(seed + i) for i, n in enumerate(stations)})

    def from_project(self, project: Path, stations: Sequence[int] | None) -> Simulator:
        """The robot of an Epson project: its manipulator type and model, settings
        and points, on the unit robot.yaml names (or each of ``stations``), with
        robot.yaml's register map."""
        from ....project import load_project
        from ..layout import connection
        from ..model import EpsonData

        loaded = load_project(project)
        robot, data = loaded.robot, loaded.data
        if not isinstance(data, EpsonData):
            raise ProjectError(f"{project}: not an Epson project (family {robot.family})")
        try:
            register_map = connection(robot).register_map
            state = SimState.from_data(data)
        except ValueError as exc:
            raise ProjectError(f"{project}: the simulator cannot hold this robot: {exc}") from exc
        return Simulator(
            {n: state.copy() for n in stations or [robot.station]}, register_map=register_map
        )

    def serve(self, sim: device.Device[SimState], host: str, port: int) -> ModbusServer:
        """Serve ``sim`` (an Epson :class:`Simulator`) over Modbus TCP.  Raises
        ValueError for faults Modbus TCP cannot have, OSError when it cannot listen."""
        if not isinstance(sim, Simulator):
            raise TypeError(f"not an Epson simulator: {sim!r}")
        return sim.serve(host, port)


SIM_FAMILY = EpsonSimFamily()


@dataclass(frozen=True)
class CommandReceived(Received):
    """One command a simulated Epson controller took (or that halted its function).

    ``payload`` is the command words as latched, in hex; ``command`` the
    command number in decimal; ``answered`` False for a command aborted (a
    function error, ExtCmdReset dropped, a power cycle) or the request that
    halted the function.
    """

    number: int = 0
    #: Response 1 of the answer: 0 normal, else the error code; None: not answered
    code: int | None = None
    #: a later step of a split or Rn write, taken as part of its sequence (the
    #: interlock is read before the first step only, the profile)
    continuation: bool = False
    #: whether the number is in the simulator's command set (the two lists)
    known: bool = True


class _Station:
    """One controller: its Remote I/O and command session, over the simulator's
    state, lock, faults and record (the :class:`~.remote.Robot` the Remote I/O
    asks, and the register bank the Modbus server reaches)."""

    def __init__(self, sim: Simulator, number: int) -> None:
        self.sim = sim
        self.number = number
        self.session = Session()
        self.remote = RemoteIO(
            self,
            sim.register_map,
            clock=sim.clock,
            acquire_time=sim.acquire_time,
            reset_low=sim.reset_low,
            whole_writes=sim.whole_writes,
        )
        self._taken: tuple[float, bool] = (0.0, False)  # when, and whether busy

    @property
    def state(self) -> SimState:
        return self.sim.stations[self.number]

    # --- the register bank ----------------------------------------------------------------

    def read_holding(self, address: int, count: int) -> list[int]:
        with self.sim.lock:
            return self.remote.read_holding(address, count)

    def read_input(self, address: int, count: int) -> list[int]:
        with self.sim.lock:
            return self.remote.read_input(address, count)

    def write_holding(self, address: int, values: list[int]) -> None:
        with self.sim.lock:
            self.remote.write_holding(address, values)

    # --- what the Remote I/O asks ----------------------------------------------------------

    def signals(self) -> Mapping[str, bool]:
        return self.state.signals()

    def take(self, words: Words) -> float:
        self._taken = (self.sim.clock(), self.sim.busy(self.state))
        faults = self.sim.faults
        if faults.chance(faults.slow):
            log.info("sim: slow execution fault: command %d runs %g s", words[0], faults.slow_delay)
            return faults.slow_delay
        card = _variants.card_write_time(self.sim.variant, words[0]) if words[:1] else None
        if card is not None:
            return card
        return self.sim.execution_time

    def carry_out(self, words: Words) -> tuple[bool, Words]:
        m = self.sim.register_map
        self.session.points = self.sim.point_answers()
        self.session.lacks = self.sim.lacks
        outcome = execute(
            self.session,
            self.state,
            words,
            command_words=m.command_words,
            response_words=m.response_words,
        )
        at, busy = self._taken
        self.sim.record_command(self.number, words, at, busy, outcome)
        if outcome.took_effect:
            self.sim.wrote(self.state)
        return outcome.error, outcome.response

    def abort(self, words: Words, why: str) -> None:
        log.info("sim: command %d aborted: %s", words[0], why)
        at, busy = self._taken
        self.sim.record_command(self.number, words, at, busy, None)

    def halted(self, fault: FunctionFault, request: Words | None) -> None:
        self.session.pending = None  # a split or Rn write under way is lost
        if request is not None:
            self.sim.record_command(self.number, request, fault.at, self.sim.busy(self.state), None)

    def power_cycle(self) -> None:
        self.state.power_cycle()
        self.session.reset()
        self.remote.power_cycle()


class Simulator(device.Device[SimState]):
    """Simulated Epson controllers, one a station (Modbus unit id), each holding a
    :class:`~.state.SimState`: ``Simulator(SimState(...))`` puts one on the
    default unit 1, ``Simulator({1: a, 2: b})`` several.

    ``register_map`` is where the Remote I/O sits (the profile's by default);
    ``execution_time`` the seconds a command runs; ``acquire_time`` the seconds
    before a request is taken; ``reset_low`` how long ExtCmdReset must be 0 for a
    function reset.  ``busy_after_writes`` starts a task once that many writes
    have taken effect (a split or Rn write counts once, at its last step).
    ``whole_writes`` False: its Modbus slave hands a write to the controller a
    register at a time (:class:`~.remote.RemoteIO`), not whole (the ``modbus_writes``
    variant says the same).  ``point_end`` is the last point of its point table
    (P999, the last of an RC+ point file): a number past it answers as the
    ``past_points`` variant says.
    """

    family = SIM_FAMILY

    def __init__(
        self,
        stations: Mapping[int, SimState] | SimState,
        *,
        register_map: RegisterMap | None = None,
        execution_time: float = DEFAULT_EXECUTION_TIME,
        acquire_time: float = 0.0,
        reset_low: float = profile.FUNCTION_RESET_LOW,
        faults: Faults | None = None,
        busy_after_writes: int = 0,
        clock: Callable[[], float] = time.monotonic,
        whole_writes: bool = True,
        point_end: int | None = None,
    ) -> None:
        super().__init__(stations, faults=faults, busy_after_writes=busy_after_writes, clock=clock)
        self.register_map = register_map if register_map is not None else RegisterMap()
        self.execution_time = execution_time
        self.acquire_time = acquire_time
        self.reset_low = reset_low
        self._whole_writes = whole_writes
        self.point_end = _state.MAX_POINT if point_end is None else point_end
        #: commands of the set it lacks, as an older firmware might: answered 1000
        self.lacks: frozenset[int] = frozenset()
        self.server: ModbusServer | None = None
        self._drop_next = 0
        self._controllers = {n: _Station(self, n) for n in self.stations}

    # --- its variants ------------------------------------------------------------------------

    @property
    def whole_writes(self) -> bool:
        """Whether its Modbus slave hands a write of several registers over whole."""
        return self._whole_writes and _variants.whole_writes(self.variant)

    def vary(self, chosen: Mapping[str, str]) -> None:
        super().vary(chosen)
        for controller in getattr(self, "_controllers", {}).values():
            controller.remote.whole_writes = self.whole_writes

    def point_answers(self) -> PointAnswers:
        """How its points not there are answered, as its variants say."""
        return _variants.point_answers(self.variant, self.point_end)

    # --- serving ---------------------------------------------------------------------------

    def serve(self, host: str = "127.0.0.1", port: int = 0) -> ModbusServer:
        """Serve every station over Modbus TCP in the background, listening when
        this returns; ``server.url`` says where, ``server.stop()`` ends it (use it
        as a context manager).  Raises ValueError for a fault Modbus TCP cannot
        have, OSError when it cannot listen."""
        unusable = [
            name for name in ("noise", "bad_checksum", "fragment") if getattr(self.faults, name)
        ]
        if unusable:
            raise ValueError(
                f"fault {', '.join(unusable)}: not on Modbus TCP (TCP carries "
                "it whole, without a checksum); the Epson simulator takes drop, "
                "slow, slow_delay and seed"
            )
        m = self.register_map
        first, count = m.input_span
        size = max(first + count, m.command_base + m.command_words, *m.control_registers) + 1
        server = ModbusServer(
            self._controllers, host=host, port=port, size=size, drop=self._drop_reply
        )
        server.start()
        self.server = server
        return server

    def drop_replies(self, count: int) -> None:
        """Leave the next ``count`` Modbus requests unanswered (their writes still
        take effect: the reply is what is lost)."""
        with self.lock:
            self._drop_next += count

    def _drop_reply(self) -> bool:
        with self.lock:
            if self._drop_next:
                self._drop_next -= 1
                return True
            return self.faults.chance(self.faults.drop)

    # --- the record ------------------------------------------------------------------------

    def record_command(
        self, station: int, words: Words, at: float, busy: bool, outcome: Outcome | None
    ) -> None:
        """Record one command taken: answered with ``outcome``, or not (None)."""
        number = words[0] if words else 0
        self.record(
            CommandReceived(
                station,
                " ".join(f"{w:04X}" for w in words),
                str(number),
                outcome.is_write if outcome else number not in READS,
                at,
                outcome is not None,
                busy,
                number=number,
                code=None if outcome is None else outcome.code,
                continuation=outcome is not None and outcome.continuation,
                known=number in COMMAND_SET,
            )
        )

    def commands(self, station: int | None = None) -> list[CommandReceived]:
        """Every command recorded, in order (of ``station``, or of all)."""
        with self.lock:
            return [
                r
                for r in self.received
                if isinstance(r, CommandReceived) and (station is None or r.station == station)
            ]

    def off_list(self) -> list[CommandReceived]:
        """Every command received that is off the command set (the backup reads and
        deploy writes): each was refused with 1000, and none should ever be sent."""
        return [r for r in self.commands() if not r.known]

    def writes_while_busy(self) -> list[CommandReceived]:
        """Every write that arrived while the robot was not idle (Running, Paused,
        EStopOn or Error), except the later steps of a split or Rn write, which the
        profile sends without looking again."""
        return [r for r in self.commands() if r.is_write and r.busy and not r.continuation]

    @property
    def function_errors(self) -> list[FunctionFault]:
        """Every §6.5 function error any station raised, in order."""
        with self.lock:
            faults = [f for c in self._controllers.values() for f in c.remote.faults]
        return sorted(faults, key=lambda f: f.at)

    @property
    def stale_requests(self) -> list[str]:
        """Every request any station took with command words not written since the
        request before (ExtCmdSet raised before the words were all there)."""
        with self.lock:
            return [
                e.detail
                for c in self._controllers.values()
                for e in c.remote.events
                if e.kind == "stale words"
            ]

    def accesses(self) -> dict[str, int]:
        """Register accesses answered over all stations, by kind (read_holding,
        read_input, write): the round trips as the controller counts them."""
        with self.lock:
            total = dict.fromkeys(("read_holding", "read_input", "write"), 0)
            for c in self._controllers.values():
                for kind, n in c.remote.accesses.items():
                    total[kind] += n
            return total

    def remote(self, station: int | None = None) -> RemoteIO:
        """A station's Remote I/O (default: the lowest station), for tests."""
        return self._controllers[min(self.stations) if station is None else station].remote

    # --- the controller --------------------------------------------------------------------

    def power_cycle(self, station: int | None = None) -> None:
        """Turn a station (default: every one) off and on: the six tables and LimZ
        cleared, the robot idle, every register 0, the function off and its
        error gone; the rest kept."""
        with self.lock:
            for number in [station] if station is not None else sorted(self.stations):
                log.info("sim: unit %d power cycle", number)
                self._controllers[number].power_cycle()

    def _controller(self, state: SimState) -> _Station:
        for number, held in self.stations.items():
            if held is state:
                return self._controllers[number]
        raise ValueError("not a station of this simulator")

    # --- the framework's hooks -------------------------------------------------------------

    def parse_station(self, text: str) -> int:
        """A Modbus unit id, decimal 0-255.  Raises ValueError."""
        unit = int(text, 10)
        if not 0 <= unit <= 255:
            raise ValueError(f"unit id {text!r} out of range (allowed: 0 to 255)")
        return unit

    def show_station(self, number: int) -> str:
        return str(number)

    def busy(self, state: SimState) -> bool:
        return not state.idle

    def control(self, verb: str, state: SimState, args: Sequence[str]) -> None:
        controller = self._controller(state)
        if verb == "function-error":
            controller.remote.halt(function_error_detail(args), "on demand")
        elif verb == "power-cycle" and not args:
            self.power_cycle(controller.number)
        else:
            act(verb, state, args)

    def describe(self, state: SimState) -> str:
        remote = self._controller(state).remote
        remote.advance()
        return f"{', '.join(state.not_idle()) or 'idle'}, {remote.describe()}"

    def save_station(self, station: int, directory: Path) -> None:
        """Write what the station keeps over a power cycle to ``directory/memory.json``
        (a new file renamed over the old one: a kill never leaves half of it)."""
        memory.save(self.stations[station], directory)

    def load_station(self, station: int, directory: Path) -> bool:
        """The station as it comes up after a power cycle with ``directory``'s memory:
        its tables and LimZ cleared, as a restarted controller has them."""
        path = directory / memory.MEMORY_FILE
        if not path.exists():
            return False
        try:
            state = memory.load(path)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ProjectFormatError(f"{path}: not a simulator memory: {exc}") from exc
        with self.lock:
            self.stations[station] = state
            self._controllers[station].session.reset()
        return True
