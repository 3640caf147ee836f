"""Property test of the Epson push interlock (issue 13, "the interlock property test
extended to Epson").

Over 1,000 random pushes (100 in every run, the rest in ``pytest -m slow``), each
case drawn from one seed, it proves,
from the simulated controller's own record (``Simulator.commands()``, and for each
command the client's last status read before its command words,
:attr:`Operator.arrival`), never from what harlsync believed:

1. every write command (a lone command, and each command of a split or Rn
   sequence, issue 19 item 4) arrived after a status read that found Running,
   Paused, EStopOn and Error at 0 and the function idle (ExtCmdReset 1, every
   other handshake signal 0), as the simulator's own map places them, whatever
   map the client was given;
2. hence no such write arrived while the robot was not idle, except in the window
   no client can close: the operator acting after that status read was answered
   and before the command was taken (counted, ``race``, only when the operator's
   own log shows a change in that window);
3. nothing off the two lists arrived, and the simulator raised no function error;
4. a push that returns has made the robot equal the project (converged), and read
   the status once more after its last write;
5. a push that raises PushFailed says why in one line; its result and its audit
   record cover the plan; every write command the controller received belongs to
   a write the result names as written or unknown, and every write reported
   written arrived whole;
6. the snapshot taken before the first write is what the robot held;
7. once the operator stops and the line is clean, the same push converges (or is
   refused again, writing nothing, when the project lacks an item the robot has:
   no Remote Control command unregisters a table entry or deletes a point);
8. a point stopped part way (issue 19 item 3) is named partly written, in the
   result and the audit record, with the fields the simulator holds new; a split
   or Rn sequence stopped part way left its item as it was (the controller
   cancels it); an item is never left holding part of a sequence.

Most cases (the rest are below) are: a generated robot (SCARA or six-axis,
``SimState.generate``); a project made from it by a random diff (table entries, settings and points taken
from another generated robot of the same type, new table entries and points,
rarely one left out); and, at random moments (after the k-th Modbus request,
most of them while the push writes), an operator who runs, pauses, presses the
emergency stop, puts the controller in error or stops it (idle again); Modbus
replies dropped (the write or read still takes effect; the link sends a read
again, never a write: harlsync reads the item back and the status first);
and slow execution (a command that runs past the handshake's deadline).

The others aim at what issue 19 found: a point of several fields with the
operator starting a task part way through it; an Rn or split write (Box, Plane,
Local, Base, XYLim) likewise; and a register map with Running (a status bit the
controller does not drive there, reading 0) or Ready mapped to an unused bit:
Ready 0 must stop every write, the first push refused writing nothing.

The push runs in memory: the engine and the Epson driver, controller and
handshake as they are, over the simulator's register bank (its Remote I/O and
command set) instead of Modbus TCP, on a fake clock shared by the handshake and
the simulator; tests/families/epson/test_e2e.py covers the same promises over TCP.

To replay or explore: ``HARLSYNC_PROPERTY_SEEDS=7,8,9`` runs only those seeds (a
failure names its seed); ``HARLSYNC_PROPERTY_BASE=N`` moves every chunk.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import pytest
from pushproperty import (
    CHUNKS,
    ONLY,
    Change,
    Outcome,
    Tally,
    base,
    check_failure,
    check_rerun,
    check_wrote_nothing,
    count_failure,
    explain,
    off_the_disk,
    seeds,
)

from harlsync import families
from harlsync.errors import LinkTimeout, PolicyError
from harlsync.families.epson import controller as controller_module
from harlsync.families.epson.catalogue import CATALOGUE, PointWrite
from harlsync.families.epson.catalogue import Key as PlanKey
from harlsync.families.epson.controller import Controller
from harlsync.families.epson.handshake import Handshake
from harlsync.families.epson.model import (
    EpsonData,
    Key,
    Point,
    PointKey,
    SettingKey,
    TableKey,
)
from harlsync.families.epson.profile import INTERLOCK_SIGNALS, RegisterMap
from harlsync.families.epson.protocol import (
    AccelPercent,
    AccelReal,
    Distances,
    Inertia,
    Limits,
    PulseLimits,
    SpeedPercent,
    SpeedReal,
    Weight,
    real_text,
)
from harlsync.families.epson.sim import CommandReceived, SimState, Simulator
from harlsync.families.epson.sim.commands import WRITES
from harlsync.project import Project
from harlsync.sim import Faults
from harlsync.sync import PushFailed, PushOptions, engine
from harlsync.sync import audit as audit_log
from harlsync.sync import items as sync_items
from harlsync.sync.plan import PlannedWrite

BASE = base(900000)
#: The points a case's robot.yaml backs up.
FIRST, LAST = 0, 15
#: The handshake's deadline for one command and the link's per-request timeout,
#: on the fake clock: short, so a lost reply costs little (and no real time).
DEADLINE = 0.2
TIMEOUT = 0.05
RETRIES = 2
#: The simulator's execution time for a command, on the fake clock.
EXECUTION = 0.0
POLL = 0.005


# --- the fake clock and the line ------------------------------------------------------------


class FakeClock:
    """Time shared by the handshake (its polls and deadlines) and the simulator (a
    command's execution): sleeping moves it, nothing waits."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += max(seconds, 0.0)


@dataclass
class Seen:
    """One status read as the client got it: its index among the requests, the
    interlock signals at 1 and whether the function was idle."""

    index: int
    busy: tuple[str, ...]
    function_idle: bool


class Operator(Simulator):
    """A simulated Epson controller with an operator: after the k-th Modbus
    request, a change (run, pause, estop, error, stop, or the line's faults).

    :attr:`arrival` holds, for each command in the record, the client's last
    status read before it wrote that command's words (None: no read before).
    """

    def __init__(self, state: SimState, clock: FakeClock, *, seed: int) -> None:
        super().__init__(state, execution_time=EXECUTION, clock=clock)
        self.fake_clock = clock
        self.schedule: list[tuple[int, Change]] = []
        self.done: list[str] = []
        self.requests = 0
        #: the request that wrote the first write's command words
        self.writing_from: int | None = None
        #: Modbus requests after which the operator changed what the robot does
        self.acted: set[int] = set()
        self.arrival: list[Seen | None] = []
        self.last_read: Seen | None = None
        self._words_seen: Seen | None = None
        #: the rate of Modbus replies lost (the request still takes effect)
        self.drop = 0.0
        self.dropped = 0
        self._rng = random.Random(seed)

    @property
    def state(self) -> SimState:
        return self.stations[1]

    def calm(self) -> None:
        """The operator stops the robot and leaves it alone; the line is mended."""
        self.schedule, self.drop, self.faults = [], 0.0, Faults()
        self.writing_from = None
        self.state.stop()

    def _seen(self, index: int, values: list[int]) -> Seen:
        """What a status read found: the interlock signals at 1, the function idle."""
        m = self.register_map
        if not hasattr(self, "_bits"):
            first, _ = m.input_span
            self._bits = {
                name: (bit.register - first, bit.bit)
                for name, bit in m.signals()
                if bit is not None and name not in ("ExtCmdSet", "ExtRespGet", "ExtCmdReset")
            }
        holding = self._controllers[1].read_holding(m.ext_cmd_set.register, 1)[0]

        def on(name: str) -> bool:
            if name in ("ExtCmdSet", "ExtRespGet", "ExtCmdReset"):
                b = m.signal(name)
                assert b is not None
                return bool(holding >> b.bit & 1)
            if name not in self._bits:
                return False
            at, bit = self._bits[name]
            return bool(values[at] >> bit & 1)

        idle = on("ExtCmdReset") and not any(
            on(n) for n in ("ExtCmdSet", "ExtRespGet", "ExtCmdGet", "ExtRespSet", "ExtError")
        )
        return Seen(index, tuple(n for n in INTERLOCK_SIGNALS if on(n)), idle)

    def record_command(self, station: int, words: Any, at: float, busy: bool, outcome: Any) -> None:
        self.arrival.append(self._words_seen)
        super().record_command(station, words, at, busy, outcome)

    # --- the register bank, as the link reaches it --------------------------------------

    def request(self, kind: str, address: int, values: Sequence[int] | int) -> list[int]:
        """One Modbus request: carried out, then the operator's changes due after it."""
        station = self._controllers[1]
        m = self.register_map
        index = self.requests
        self.requests += 1
        result: list[int] = []
        if kind == "input":
            assert isinstance(values, int)
            result = station.read_input(address, values)
            self.last_read = self._seen(index, result)
        elif kind == "holding":
            assert isinstance(values, int)
            result = station.read_holding(address, values)
        else:
            assert not isinstance(values, int)
            at = m.command_base - address  # the words, alone or after ExtCmdSet's register
            if 0 <= at < len(values):
                self._words_seen = self.last_read
                if self.writing_from is None and values[at] in WRITES:
                    self.writing_from = index
            station.write_holding(address, list(values))
        for entry in list(self.schedule):
            at, change = entry
            if at < 0:  # -k: k requests after the first write's command words
                if self.writing_from is None or index < self.writing_from - at - 1:
                    continue
            elif index < at:
                continue
            self.schedule.remove(entry)
            before = self.state.not_idle()
            said = change(self, self.state)
            if self.state.not_idle() != before:
                self.acted.add(index)
            self.done.append(f"after request {index} ({kind} {address}): {said}")
        return result


class MemoryLink:
    """The Epson transport's place (a RegisterAccess) over an :class:`Operator`'s
    register bank: a lost reply costs the link's timeout on the fake clock; a read
    is sent again, ``retries`` times, a write never (issue 34), as ModbusLink does."""

    def __init__(self, sim: Operator, *, timeout: float, retries: int) -> None:
        self.sim, self.timeout, self.retries = sim, timeout, retries
        self.label = "memory unit 1"

    def _call(self, kind: str, address: int, values: Sequence[int] | int) -> list[int]:
        for _ in range(1 if kind == "write" else self.retries + 1):
            result = self.sim.request(kind, address, values)
            if not (self.sim.drop and self.sim._rng.random() < self.sim.drop):
                return result
            self.sim.dropped += 1
            self.sim.fake_clock.sleep(self.timeout)
        raise LinkTimeout(f"{kind} {address}: no answer within {self.timeout:g} s", port=self.label)

    def read_holding(self, address: int, count: int) -> list[int]:
        return self._call("holding", address, count)

    def read_input(self, address: int, count: int) -> list[int]:
        return self._call("input", address, count)

    def write_holding(self, address: int, values: Sequence[int]) -> None:
        self._call("write", address, list(values))

    def close(self) -> None:
        pass


# --- the robot as a pull reads it -----------------------------------------------------------


def data_of(state: SimState, first: int = FIRST, last: int = LAST) -> EpsonData:
    """What a pull of ``state`` reads (points ``first``-``last``)."""
    t, axes = real_text, state.axes
    data = EpsonData(state.robot_type, axes, state.model)
    items = data.items
    for n, (a, d) in state.accel.items():
        items[TableKey("accel", n)] = AccelPercent(a, d)
    for kind in ("accel_s", "accel_r"):
        for n, (a, d) in getattr(state, kind).items():
            items[TableKey(kind, n)] = AccelReal(t(a), t(d))
    for n, (s, dp, ap) in state.speed.items():
        items[TableKey("speed", n)] = SpeedPercent(s, dp, ap)
    for n, (s, dp, ap) in state.speed_s.items():
        items[TableKey("speed_s", n)] = SpeedReal(t(s), t(dp), t(ap))
    for n, s in state.speed_r.items():
        items[TableKey("speed_r", n)] = t(s)
    for n, (d, a) in state.arch.items():
        items[SettingKey("arch", n)] = Distances(t(d), t(a))
    items[SettingKey("fine")] = tuple(state.fine)
    items[SettingKey("weight")] = Weight(t(state.weight[0]), t(state.weight[1]))
    items[SettingKey("inertia")] = Inertia(t(state.inertia[0]), t(state.inertia[1]))
    items[SettingKey("tool")] = state.tool
    off = ((0, 0),) * 3
    zeros = (0,) * axes
    for n in range(1, 16):
        items[SettingKey("box", n)] = tuple(
            Limits(t(lo), t(hi)) for lo, hi in state.boxes.get(n, off)
        )
        items[SettingKey("plane", n)] = tuple(t(c) for c in state.planes.get(n, zeros))
        items[SettingKey("local", n)] = tuple(t(c) for c in state.locals.get(n, zeros))
    items[SettingKey("xylim")] = tuple(Limits(t(lo), t(hi)) for lo, hi in state.xylim)
    for joint, (lo, hi) in enumerate(state.jrange, 1):
        items[SettingKey("jrange", joint)] = PulseLimits(lo, hi)
    items[SettingKey("base")] = tuple(t(c) for c in state.base)
    items[SettingKey("limz")] = t(state.limz)
    six, rs = state.robot_type == 5, state.robot_type == 6
    for n, p in state.points.items():
        if first <= n <= last:
            items[PointKey("point", n)] = Point(
                tuple(t(c) for c in p.coords),
                p.hand,
                p.elbow,
                p.wrist,
                p.j4flag,
                p.j6flag,
                p.local,
                p.j1flag if six else None,
                p.j2flag if six else None,
                t(p.j1angle) if rs else None,
            )
    return data


# --- one random case -------------------------------------------------------------------------


def verb(name: str) -> Change:
    def change(sim: Simulator, state: SimState) -> str:
        sim.control(name, state, ())
        return name

    return change


def faults(drop: float, slow: float, seed: int) -> Change:
    def change(sim: Operator, state: SimState) -> str:
        sim.drop = drop
        sim.faults = Faults(slow=slow, slow_delay=DEADLINE * 1.5, seed=seed)
        return f"replies dropped {drop}, slow execution {slow}"

    return change


@dataclass
class Case:
    seed: int
    before: EpsonData
    target: EpsonData
    sim: Operator
    clock: FakeClock
    story: list[str] = field(default_factory=list)
    #: the register map the client is given (robot.yaml's), None: the profile's
    client_map: dict[str, Any] | None = None
    #: what the case aims at: "random", "point", "sequence", "running mis-mapped",
    #: "ready mis-mapped"
    kind: str = "random"

    def why(self, message: str) -> str:
        return explain(self.seed, self.story + self.sim.done, message)


def random_target(rng: random.Random, state: SimState, story: list[str]) -> EpsonData:
    """The robot's data with a random diff: items taken from another robot of the
    same type, new table entries and points; rarely one left out."""
    before = data_of(state)
    other = data_of(
        SimState.generate(
            rng.randrange(2**31), robot_type=state.robot_type, point_range=(FIRST, LAST)
        )
    )
    target = EpsonData(before.robot_type, before.axes, before.model, dict(before.items))
    if rng.random() < 0.05:
        story.append("no change")
        return target
    rate = rng.choice([0.02, 0.05, 0.15])
    changed: list[str] = []
    for key, value in other.items.items():
        if rng.random() >= rate or target.items.get(key) == value:
            continue
        if isinstance(key, PointKey):
            old = target.items.get(key)
            # no command sets a point back to no Local, nor may it name an undefined one
            value = replace(value, local=old.local if isinstance(old, Point) else 0)
        elif key.kind == "local" and any(
            isinstance(k, PointKey) and v.local == key.number for k, v in target.items.items()
        ):
            continue  # a Local a point uses: kept (only to keep the case simple)
        target.items[key] = value
        changed.append(CATALOGUE.describe(key))
    if rng.random() < 0.04:
        gone = rng.choice([k for k in target.items if isinstance(k, (PointKey, TableKey))])
        del target.items[gone]
        changed.append(f"{CATALOGUE.describe(gone)} left out")
    story.append(f"changed: {', '.join(changed) or 'nothing'}")
    return target


#: Bits of out_base the simulator does not drive: a signal mapped there reads 0.
UNUSED = {"register": 0, "bit": 14}
#: Kinds whose operator acts after this many requests of the first write (about
#: one command each 7 requests: step 1, words, set, 4 polls ...)
AIMED = ("point", "sequence")
#: The Rn and split settings an aimed sequence case changes.
SEQUENCES = ("box", "plane", "local", "base", "xylim")


def aimed_target(rng: random.Random, state: SimState, kind: str, story: list[str]) -> EpsonData:
    """The robot's data with one item changed: a point in several fields (or a new
    one), or an Rn/split setting."""
    before = data_of(state)
    other = data_of(
        SimState.generate(
            rng.randrange(2**31), robot_type=state.robot_type, point_range=(FIRST, LAST)
        )
    )
    target = EpsonData(before.robot_type, before.axes, before.model, dict(before.items))
    if kind == "point":
        points = [k for k, v in other.items.items() if isinstance(k, PointKey)]
        key: Key = rng.choice(points)
        new = other.items[key]
        old = before.items.get(key)
        local = old.local if isinstance(old, Point) else 0
        target.items[key] = replace(new, local=local)
    else:
        name = rng.choice(SEQUENCES)
        keys = [
            k
            for k in other.items
            if k.kind == name and other.items[k] != before.items.get(k) and k.number != 0
        ]
        if name == "local":  # a Local a point uses is kept (only to keep the case simple)
            used = {v.local for k, v in before.items.items() if isinstance(k, PointKey)}
            keys = [k for k in keys if k.number not in used]
        if not keys:
            story.append(f"{kind}: no {name} to change")
            return target
        key = rng.choice(keys)
        target.items[key] = other.items[key]
    story.append(f"{kind}: {CATALOGUE.describe(key)} changed")
    return target


def make_case(seed: int) -> Case:
    rng = random.Random(seed)
    story: list[str] = []
    draw = rng.random()
    kind = (
        "point"
        if draw < 0.08
        else "sequence"
        if draw < 0.16
        else "running mis-mapped"
        if draw < 0.19
        else "ready mis-mapped"
        if draw < 0.22
        else "random"
    )
    if kind != "random":
        return make_aimed_case(seed, rng, kind, story)
    state = SimState.generate(rng.randrange(2**31), point_range=(FIRST, LAST))
    story.append(f"robot: type {state.robot_type}, {len(state.points)} points")
    before = data_of(state)
    target = random_target(rng, state, story)
    clock = FakeClock()
    sim = Operator(state, clock, seed=rng.randrange(2**32))
    writes = max(1, len(sync_items.diff(CATALOGUE, before, target)))

    def moment() -> int:
        """After request k of the push (>= 0: while it reads, rarely), or -k: k requests
        after the first write's command words (most: while it writes)."""
        if rng.random() < 0.1:
            return rng.randrange(3000)
        return -1 - rng.randrange(25 * writes + 10)

    schedule: list[tuple[int, Change]] = []
    for _ in range(rng.choice([0, 1, 1, 2, 3])):
        name = rng.choice(["run", "pause", "estop", "error", "stop", "run", "pause"])
        schedule.append((moment(), verb(name)))
        if rng.random() < 0.5:
            schedule.append((moment(), verb("stop")))
    if rng.random() < 0.6:
        schedule.append(
            (
                moment(),
                faults(
                    rng.choice([0.01, 0.03, 0.1]),
                    rng.choice([0.0, 0.02, 0.1]),
                    rng.randrange(2**32),
                ),
            )
        )
    sim.schedule = schedule
    return Case(seed, before, target, sim, clock, story)


def make_aimed_case(seed: int, rng: random.Random, kind: str, story: list[str]) -> Case:
    """A case aimed at one of issue 19's holes (see the module's docstring)."""
    state = SimState.generate(rng.randrange(2**31), point_range=(FIRST, LAST))
    story.append(f"robot: type {state.robot_type}, {len(state.points)} points")
    before = data_of(state)
    clock = FakeClock()
    sim = Operator(state, clock, seed=rng.randrange(2**32))
    client_map: dict[str, Any] | None = None
    if kind in AIMED:
        target = aimed_target(rng, state, kind, story)
        # after the first command of the write, before its last
        sim.schedule = [(-1 - rng.randrange(5, 30), verb(rng.choice(["run", "pause", "estop"])))]
    else:
        target = random_target(rng, state, story)
        signal = "Running" if kind == "running mis-mapped" else "Ready"
        client_map = {"signals": {signal: dict(UNUSED)}}
        # the robot is already running, or is started while the push reads
        sim.schedule = [(rng.choice([0, rng.randrange(200)]), verb("run"))]
        if kind == "ready mis-mapped":
            sim.schedule = [] if rng.random() < 0.5 else sim.schedule
    story.append(f"case: {kind}")
    return Case(seed, before, target, sim, clock, story, client_map, kind)


# --- pushing a case --------------------------------------------------------------------------

Deploy = Callable[[Case, float], Outcome]


@pytest.fixture
def in_memory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Deploy:
    """Push a case through the engine's deploy with the Epson driver over the
    simulator's register bank (:class:`MemoryLink`), on the case's fake clock."""
    taken = off_the_disk(monkeypatch)
    current: list[Case] = []

    def link(
        url: str, unit: int, *, timeout: float, retries: int, lock_timeout: float
    ) -> MemoryLink:
        return MemoryLink(current[0].sim, timeout=timeout, retries=retries)

    def handshake(registers: Any, register_map: RegisterMap | None = None, **kw: Any) -> Handshake:
        return Handshake(registers, register_map, **kw, clock=current[0].clock)

    monkeypatch.setattr(controller_module, "ModbusLink", link)
    monkeypatch.setattr(controller_module, "Handshake", handshake)

    def deploy(case: Case, deadline: float) -> Outcome:
        current[:] = [case]
        monkeypatch.setenv("HARLSYNC_AUDIT_LOG", str(tmp_path / f"audit-{case.seed}.jsonl"))
        robot = families.get("epson").new_robot("cell", f"modbus://10.9.{case.seed % 250}.1", None)
        robot.options.update(
            first=FIRST,
            last=LAST,
            timeout=TIMEOUT,
            retries=RETRIES,
            poll_interval=POLL,
            deadline=deadline,
        )
        if case.client_map is not None:
            robot.options["map"] = case.client_map
        project = Project(tmp_path / f"case-{case.seed}", robot, case.target)
        opts = PushOptions(yes=True, allow_dirty=True)
        first, before = len(case.sim.commands()), len(taken)
        reads = case.sim.requests
        try:
            result = engine._deploy("push", project, case.target, opts, None, None)
            failed = None
        except PushFailed as exc:
            result, failed = exc.result, exc
        snapshot = taken[before] if len(taken) > before else None
        got = Outcome(result, failed, list(case.sim.commands()[first:]), snapshot, first)
        got.requests_from = reads  # type: ignore[attr-defined]
        return got

    return deploy


# --- the checks ------------------------------------------------------------------------------


@dataclass
class EpsonTally(Tally):
    sequences: int = 0
    points_written: int = 0
    dropped: int = 0
    #: points recorded partly written; sequences stopped part way; pushes refused
    #: for Ready 0 (a mis-mapped map)
    partly: int = 0
    sequences_stopped: int = 0
    not_ready: int = 0


_PAYLOADS = Controller(Handshake(None, RegisterMap()))  # type: ignore[arg-type]


def payloads(write: PlannedWrite[PlanKey]) -> list[str]:
    """The command words of every command a planned write sends, as the simulator
    records them (the map's 8 command words, in hex)."""
    key, value = write.key, write.new
    if isinstance(key, PointWrite):
        steps = _PAYLOADS.write_steps(PointKey("point", key.number), value, key.fields)
    else:
        steps = _PAYLOADS.write_steps(key, value)
    out = []
    for step in steps:
        for request in step.sequence:
            words = tuple(request.encode(8))
            out.append(" ".join(f"{w:04X}" for w in (*words, *(0,) * (8 - len(words)))))
    return out


def check_interlock(case: Case, got: Outcome, tally: EpsonTally) -> None:
    sim = case.sim
    assert not sim.off_list(), case.why(f"off the lists: {sim.off_list()}")
    assert not sim.function_errors, case.why(f"function error: {sim.function_errors}")
    assert not sim.stale_requests, case.why(f"ExtCmdSet over stale words: {sim.stale_requests}")
    commands = sim.commands()
    for i in range(got.first, len(commands)):
        r: CommandReceived = commands[i]
        if not r.is_write:
            continue
        seen = sim.arrival[i]
        name = f"command {r.number} ({r.payload}, #{i})"
        assert seen is not None, case.why(f"{name} arrived with no status read before it")
        assert not seen.busy, case.why(f"{name} followed a status read that found {seen.busy}")
        assert seen.function_idle, case.why(
            f"{name} followed a status read that found the function not idle"
        )
        if r.busy:
            # Started after that status read was answered: see the docstring.
            assert any(a >= seen.index for a in sim.acted), case.why(
                f"{name} arrived while the robot was busy with no change by the operator "
                "after its status read"
            )
            tally.race += 1
    if got.failed is None and got.result.written:
        # the status once more after the last write: an input read after its command
        last = max(i for i in range(got.first, len(commands)) if commands[i].is_write)
        assert last < len(commands) and sim.last_read is not None, case.why("no read after")


def commands_of(got: Outcome) -> list[CommandReceived]:
    """What the simulated controller received: every request an Epson command."""
    return [r for r in got.received if isinstance(r, CommandReceived)]


def check_sent(case: Case, got: Outcome) -> None:
    """Every write command received belongs to a write the result names written or
    unknown; every write named written arrived whole."""
    result = got.result
    sent = [r.payload for r in commands_of(got) if r.is_write and r.number in WRITES]
    maybe: set[str] = set()
    for w in [*result.written, *([result.failed] if result.failed else [])]:
        maybe.update(payloads(w))
    for payload in sent:
        assert payload in maybe, case.why(
            f"the controller received {payload!r}, which the "
            "result does not name as written or unknown"
        )
    for w in result.written:
        for payload in payloads(w):
            assert payload in sent, case.why(
                f"{w.name} reported written but {payload!r} never arrived"
            )


def check_stopped_item(case: Case, got: Outcome, tally: EpsonTally) -> None:
    """Where a push stopped inside an item: a point is named partly written with
    exactly the fields the simulator holds new; any other item holds its old value
    or its new one, never part of a sequence, and its old one when the sequence
    was stopped part way (the controller cancels it)."""
    result, w = got.result, got.result.failed
    partly = result.partly_written
    if w is None:
        assert partly is None, case.why("partly written, yet no item stopped")
        return
    now = data_of(case.sim.state).items.get(PointKey("point", w.key.number))
    record = audit_log.read()[-1]
    if not isinstance(w.key, PointWrite):
        assert partly is None, case.why(f"{w.name} partly written: it is one sequence")
        held = data_of(case.sim.state).items.get(w.key)
        assert held in (w.old, w.new), case.why(f"{w.name} holds part of its sequence: {held}")
        if "stopped after" in (result.error or ""):
            tally.sequences_stopped += 1
            assert held == w.old, case.why(f"{w.name} took effect though its sequence stopped")
        return
    fields = list(w.key.fields)
    # A point's write: its values are Points (the plan holds them as objects).
    new_fields = dict(cast(Point, w.new).fields())
    old_fields = dict(cast(Point, w.old).fields()) if w.old is not None else {}
    held_fields = dict(now.fields()) if now is not None else {}
    took = [f for f in fields if held_fields.get(f) == new_fields[f] != old_fields.get(f)]
    changed = [f for f in fields if new_fields[f] != old_fields.get(f)]
    if partly is None:
        # nothing of it went out, or (a lost reply) its first field may have, or all
        # of it did and what failed came after (its read-back)
        assert took in ([], changed[:1], changed), case.why(
            f"{w.name}: fields {took} took, yet the push does not say partly written"
        )
        assert record.partly_written is None, case.why("audit record says partly written")
        return
    tally.partly += 1
    assert partly.sent == fields[: len(partly.sent)] and partly.sent, case.why(
        f"{w.name}: partly written {partly.sent}, not its first fields {fields}"
    )
    assert set(partly.sent) <= set(took) | {f for f in partly.sent if f not in old_fields}, (
        case.why(f"{w.name}: {partly.sent} said to have gone out, the robot holds {held_fields}")
    )
    for f in partly.left:
        if f in old_fields:
            assert held_fields.get(f) == old_fields[f], case.why(
                f"{w.name} {f}: said not sent, yet the robot holds {held_fields.get(f)}"
            )
    assert "nothing written" not in (result.error or ""), case.why(result.error or "")
    recorded = record.partly_written
    assert recorded is not None and list(recorded.sent) == partly.sent, case.why(
        f"audit record: {recorded}"
    )


def check_not_ready(case: Case, got: Outcome, tally: EpsonTally) -> None:
    """Ready mapped where the controller does not drive it reads 0: no write goes
    out, and the push says Ready."""
    assert got.failed is not None, case.why("a push with Ready always 0 returned")
    assert not [r for r in got.received if r.is_write], case.why("Ready 0, yet it wrote")
    assert got.result.written == [] and got.result.failed is None, case.why("recorded a write")
    assert "Ready" in str(got.failed) or got.result.plan is None or got.result.plan.empty, case.why(
        f"refused without naming Ready: {got.failed}"
    )


def check_converged(case: Case) -> None:
    left = sync_items.diff(CATALOGUE, data_of(case.sim.state), case.target)
    assert not left, case.why(f"push returned but the robot still differs: {left[:3]}")


def check_case(case: Case, deploy: Deploy, tally: EpsonTally) -> None:
    got = deploy(case, DEADLINE)
    tally.cases += 1
    tally.dropped += case.sim.dropped
    tally.sequences += any(r.continuation for r in commands_of(got))
    tally.points_written += any(r.is_write and 1204 <= r.number <= 1214 for r in commands_of(got))
    check_interlock(case, got, tally)
    check_sent(case, got)
    tally.not_ready += got.failed is not None and "Ready" in str(got.failed)
    if case.kind == "ready mis-mapped":
        if got.failed is None:  # nothing to write: the push never needed Ready
            assert got.result.plan is not None and got.result.plan.empty, case.why("wrote")
            return
        check_not_ready(case, got, tally)
        return
    check_stopped_item(case, got, tally)
    if got.snapshot is not None:
        assert not sync_items.diff(CATALOGUE, got.snapshot, case.before), case.why(
            "the snapshot is not what the robot held before the push"
        )
    if got.failed is None:
        tally.ok += 1
        check_converged(case)
        return
    count_failure(tally, got)
    check_failure(case.why, got)
    if isinstance(got.failed.cause, PolicyError):
        check_wrote_nothing(case.why, got)
        return
    # The operator stops the robot and the line is mended: the same push finishes.
    case.sim.calm()
    case.before = data_of(case.sim.state)
    again = deploy(case, 2.0)
    check_interlock(case, again, tally)
    check_sent(case, again)
    check_stopped_item(case, again, tally)
    refused = any(
        isinstance(k, PointKey | TableKey) and k not in case.target.items for k in case.before.items
    )
    check_rerun(case.why, again, refused=refused)
    if not refused:
        check_converged(case)


@pytest.mark.parametrize("chunk", CHUNKS)
def test_no_write_reaches_an_epson_robot_that_is_not_idle_and_every_push_converges(
    chunk: int, in_memory: Deploy
) -> None:
    tally = EpsonTally()
    for seed in seeds(chunk, BASE):
        check_case(make_case(seed), in_memory, tally)
    print(json.dumps(tally.__dict__))
    if not ONLY:  # the cases still reach what they are meant to (a generator can rot)
        assert tally.ok >= 25 and tally.failed - tally.refused_before_writing >= 5, tally
        assert tally.sequences >= 10 and tally.points_written >= 10, tally
        assert tally.dropped >= 5, tally
        assert tally.partly >= 1 and tally.sequences_stopped >= 1 and tally.not_ready >= 1, tally
