"""Property test of the IAI push interlock (issue 12, "the interlock property test
extended to IAI").

Over 1,000 random pushes (100 in every run, the rest in ``pytest -m slow``; plus 20
more through ``harlsync push``
on a project on disk), each case drawn from one seed, it proves, from the
simulated controller's own record of what arrived and of what the controller was
doing when it arrived (``Simulator.received``, and :attr:`Operator.arrival`, the
reasons it was not idle), never from what harlsync believed:

1. every write (291H positions and, with ``--registers``, 24BH a flag, 24CH
   integer and 24DH real variables; 24EH a row of string variable columns, issue
   34 item 18) arrived straight after a 212H (for the
   robot's axes) and a 215H, in that order (issue 19: 215H last), with nothing
   between the three; the 215H found the controller idle (AUTO mode, no program
   running, no flash write, no emergency stop, ready, no critical error, drive
   source on, program mode, safety gate closed), and the 212H found every axis
   the client can know of reported and none of the robot's axes in use.  That
   holds for a re-send after a lost reply too: it follows a fresh 212H and 215H;
2. hence no write arrived while the controller was not idle (a program running,
   MANUAL mode, a flash write, an emergency stop, not ready, a critical error,
   the drive source cut off, positioner mode, the gate open, an axis in use or
   left out of 212H's reply), except in the one window no client can close
   (below);
3. no message off the profile's allow-list arrived, in any case;
4. a push that returns has made the robot equal the project (converged), and read
   212H and 215H once more after its last write (or says why it could not);
5. a push that raises PushFailed says why in one line; its result, its audit
   record and (on disk) what ``harlsync push`` prints name exactly the writes the
   controller received; each position, flag and variable holds its old or its
   new value (the new one for every write reported written); nothing outside the
   plan changed; no write was sent twice without reading back in between all it
   wrote;
6. the snapshot taken before the first write is what the robot held;
7. once the operator stops and the line is clean, the same push converges (or is
   refused again, writing nothing, when the project lacks a position the robot
   has: no message of protocol B clears one).

A case is: a random IAI robot (its model, a small-buffer one like the TT among
them so that runs split; its axes; its position range; ``SimState.generate`` or a
table of its own; in about a third of the cases global flags and variables that
robot.yaml keeps, and in about a quarter string variable columns it keeps); a
project made from it by a random diff (positions changed and
added, scattered and in runs, sometimes a run long enough for several 291H,
rarely one left out; flags set and cleared, integer and real variables changed,
pushed with ``--registers``; rows of string variable columns edited); and, at
random moments (after the controller has
answered the k-th request, most of them while the push writes), an operator who
starts a program, switches MANUAL, presses the emergency stop, starts a flash
write, holds an axis, takes the system out of ready, switches positioner mode,
raises a critical error, cuts the drive source, opens the safety gate, makes 212H
leave axes out of its reply (sometimes all, sometimes one in use), or stops (idle
again); and a
line that goes bad: faults on the replies (noise, drops, bad SC, fragments, late
replies), requests lost on their way in, one write lost, a short burst of faults.
The reply to the request after which the operator acts is often late, lost or
garbled: the operator acts while it is on the wire.

The window no client can close: the operator acting after the 212H and 215H that
found the controller idle were answered and before the write they cleared
arrives (an axis taken between 212H and 215H is not in 215H's reply).  Such a
write is counted (``race``) only when the operator's own log shows a change in
that window; checks 3-7 still hold for its case.  (The simulated controller
refuses it, as the profile's interlock says; a real one may not.)

To replay or explore: ``HARLSYNC_PROPERTY_SEEDS=7,8,9`` runs only those seeds
(a failure names its seed); ``HARLSYNC_PROPERTY_BASE=N`` moves every chunk.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import pytest
from conftest import git
from pushproperty import (
    CHUNKS,
    ONLY,
    Change,
    Outcome,
    Scheduled,
    Tally,
    base,
    check_failure,
    check_rerun,
    check_sent,
    check_wrote_nothing,
    count_failure,
    explain,
    line_changes,
    off_the_disk,
    push_command,
    seeds,
    spy_on_push,
)

from harlsync import cli, families
from harlsync.errors import PolicyError
from harlsync.families.iai import profile
from harlsync.families.iai.catalogue import (
    CATALOGUE,
    Key,
    PositionKey,
    RecordKey,
    Run,
    VariableKey,
)
from harlsync.families.iai.codec import CODEC
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position, real_text, real_value
from harlsync.families.iai.protocol import (
    Frame,
    max_flags_per_read,
    max_positions_per_read,
    max_string_columns_per_read,
    max_variables_per_read,
    system_status,
    write_flag,
    write_integers,
    write_positions,
    write_reals,
    write_strings,
)
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import Project, Robot, load_project, save_project
from harlsync.settings import SerialSettings
from harlsync.sim import Received
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import PushFailed, PushOptions, engine
from harlsync.sync import items as sync_items
from harlsync.sync.plan import PlannedWrite

BASE = base(700000)

#: The reply deadline while faults are on: short, so a lost reply costs little.  The
#: baud rate only sets how much wire time the codec adds to it (nothing is paced:
#: the simulator emulates no wire time), so in memory it is set high enough that
#: a long 22DH reply's deadline stays short too.
FAST = SerialSettings(baudrate=10_000_000, timeout=0.02, retries=2)
#: The same on disk, where robot.yaml takes only the controller's baud rates.
FAST_ON_DISK = SerialSettings(baudrate=115200, timeout=0.02, retries=2)
#: The deadline for the re-run on a clean line: long, so a busy CI machine is no fault.
CALM = SerialSettings(baudrate=115200, timeout=1.0, retries=3)
#: Controller models: mostly the small-buffer TT (a 291H takes 12 positions, a 22DH
#: asks for 12) and the TTA (25 and 24); the others have the same two buffer sizes.
MODELS = ["TT", "TT", "TTA", "TTA", "XSEL-JK", "PSEL"]


#: The writes (291H positions; 24BH a flag, 24CH integer and 24DH real variables; 24EH
#: string variable columns) and,
#: for each, the read that reads it back, and where start and count sit in both.
READ_BACK = {
    "291": ("22D", slice(5, 9), slice(9, 13)),
    "24C": ("20E", slice(5, 8), slice(8, 10)),
    "24D": ("20F", slice(5, 8), slice(8, 10)),
    "24B": ("20D", slice(5, 9), slice(9, 13)),  # one flag: no count in the write
    "24E": ("210", slice(5, 8), slice(8, 10)),  # issue 34 item 18: a row of string columns
}
WRITES = {command.encode() for command in READ_BACK}
#: Every message a push of positions, flags and variables sends.
PUSHED = {"201", "215", "212", *READ_BACK, *(read for read, _, _ in READ_BACK.values())}


def deadline(settings: SerialSettings) -> float:
    """The reply deadline of 215H: what a late reply is measured against."""
    return CODEC.reply_timeout(system_status(), settings)


# --- the operator at the controller ----------------------------------------------------


class Operator(Scheduled, Simulator):
    """A simulated IAI controller with a schedule (:class:`pushproperty.Scheduled`):
    after answering the k-th request, make a change.

    A change puts the controller out of idle (or back), or changes the line's
    faults.  The record says whether the controller was idle when each request
    arrived (``received[i].busy``); :attr:`arrival` says why not, and :attr:`acted`
    after which requests the operator changed what the controller does, so a
    change made after request k shows from request k+1 on.
    """

    def __init__(
        self,
        state: SimState,
        schedule: list[tuple[int, Change]],
        *,
        seed: int,
        deadline: float,
        lose_writes: set[int] | None = None,
    ) -> None:
        super().__init__(state)
        self.start_schedule(schedule, seed=seed, deadline=deadline, lose_writes=lose_writes)
        #: The index in :attr:`received` of each request after which the operator
        #: changed what the controller does.
        self.acted: set[int] = set()
        #: For each request in :attr:`received`: why the controller was not idle
        #: when it arrived (``SimState.not_idle``), empty when it was.
        self.arrival: list[tuple[str, ...]] = []
        self._arriving: tuple[str, ...] = ()
        self.listeners.append(lambda record: self.arrival.append(self._arriving))
        self._handling = 0

    @property
    def state(self) -> SimState:
        return self.stations[profile.DEFAULT_STATION]

    def calm(self) -> None:
        """The operator stops the controller and leaves it alone; the line is mended."""
        self.mend()
        self.state.stop()

    def busy(self, state: SimState) -> bool:
        # Called as each request arrives, before it is carried out: keep why.
        self._arriving = tuple(state.not_idle())
        return super().busy(state)

    def receive(
        self, data: bytes, decoder: Any = None, client: str = ""
    ) -> list[tuple[float, bytes]]:
        write = data[:1] == b"!" and data[3:6] in WRITES  # the link sends a frame a write
        # A bad SC: the controller drops it.
        return super().receive(self.on_the_way_in(data, write), decoder, client)

    def handle(self, state: SimState, frame: Frame) -> str:
        self.before_request()
        self._handling = len(self.received)  # this request's index in the record
        try:
            return super().handle(state, frame)  # a refusal raises: it is answered too
        finally:
            self.act(state, self._handling, f"{frame.payload[:3]}H")

    def make(self, change: Change, state: SimState) -> str:
        before = state.not_idle()
        said = super().make(change, state)
        if state.not_idle() != before:
            self.acted.add(self._handling)
        return said


def verb(name: str, *args: str) -> Change:
    """One of the simulator's control verbs (``harlsync sim``'s run, manual, estop ...)."""

    def change(sim: Simulator, state: SimState) -> str:
        sim.control(name, state, args)
        return " ".join([name, *args])

    return change


def not_ready(sim: Simulator, state: SimState) -> str:
    state.ready = False
    return "system not ready"


# --- one random case ----------------------------------------------------------------------


@dataclass
class Case:
    seed: int
    model: str
    axes: tuple[int, ...]
    #: the robot's axes as robot.yaml gives them; None: every axis 212H reports
    robot_axes: tuple[int, ...] | None
    position_range: tuple[int, int]
    before: IaiData
    target: IaiData
    sim: Operator
    #: the flags' and variables' ranges when robot.yaml keeps them (keep_registers)
    keeps: dict[str, tuple[int, int]] | None = None
    #: whether the push writes them too (--registers)
    registers: bool = False
    story: list[str] = field(default_factory=list)
    #: the string variable columns robot.yaml keeps (records.yaml), if any
    strings: tuple[int, int] | None = None

    def why(self, message: str) -> str:
        return explain(self.seed, self.story + self.sim.done, message)

    @property
    def checked_axes(self) -> tuple[int, ...]:
        """The axes whose use the client checks: robot.yaml's, else every one 212H reports."""
        return self.axes if self.robot_axes is None else self.robot_axes

    @property
    def known_axes(self) -> tuple[int, ...]:
        """The axes the client can know the robot has: robot.yaml's, else those the
        positions it reads or writes use."""
        if self.robot_axes is not None:
            return self.robot_axes
        tables = (self.before.positions, self.target.positions)
        return tuple(sorted({a for table in tables for p in table.values() for a in p.axes}))

    @property
    def pattern(self) -> int:
        """The axis pattern the interlock's 212H asks for."""
        if self.robot_axes is None:
            return 0xFF
        return sum(1 << (a - 1) for a in self.robot_axes)


def coordinate(rng: random.Random) -> str:
    units = rng.choice(
        [
            rng.randint(-300_000, 600_000),
            rng.randint(-300_000, 600_000),
            rng.randint(-999, 999),
            rng.choice([-(2**31), 2**31 - 1, 0, -1]),  # the wire's ends: two's complement
        ]
    )
    sign = "-" if units < 0 else ""
    return f"{sign}{abs(units) // 1000}.{abs(units) % 1000:03d}"


def g(rng: random.Random) -> str:
    hundredths = rng.choice([0, rng.randint(1, 150), rng.randint(0, 0xFFFF)])
    return f"{hundredths // 100}.{hundredths % 100:02d}"


def random_position(rng: random.Random, number: int, axes: tuple[int, ...]) -> Position:
    used = (
        axes if rng.random() < 0.6 else tuple(sorted(rng.sample(axes, rng.randint(1, len(axes)))))
    )
    return Position(
        number,
        used,
        g(rng),
        g(rng),
        rng.choice([0, 100, rng.randint(0, 0xFFFF)]),
        tuple(coordinate(rng) for _ in used),
        rng.choice([0, 0, 1, 2]),
        rng.choice([0, 0, 1, 2]),
    )


def edited(rng: random.Random, p: Position, axes: tuple[int, ...]) -> Position:
    """``p`` with one to three of its fields changed."""
    for _ in range(rng.randint(1, 3)):
        what = rng.randrange(6)
        if what == 0:
            new = random_position(rng, p.number, axes)
            p = Position(p.number, new.axes, p.acc, p.dec, p.speed, new.coords, p.arm1, p.arm2)
        elif what == 1:
            i = rng.randrange(len(p.coords))
            coords = list(p.coords)
            coords[i] = coordinate(rng)
            p = Position(p.number, p.axes, p.acc, p.dec, p.speed, tuple(coords), p.arm1, p.arm2)
        elif what == 2:
            p = Position(p.number, p.axes, g(rng), p.dec, p.speed, p.coords, p.arm1, p.arm2)
        elif what == 3:
            p = Position(p.number, p.axes, p.acc, g(rng), p.speed, p.coords, p.arm1, p.arm2)
        elif what == 4:
            p = Position(
                p.number, p.axes, p.acc, p.dec, rng.randint(0, 0xFFFF), p.coords, p.arm1, p.arm2
            )
        else:
            p = Position(
                p.number,
                p.axes,
                p.acc,
                p.dec,
                p.speed,
                p.coords,
                rng.choice([0, 1, 2]),
                rng.choice([0, 1, 2]),
            )
    return p


def random_robot(rng: random.Random, story: list[str]) -> SimState:
    model = rng.choice(MODELS)
    first = rng.randint(1, 40)
    last = first + rng.randint(20, 220)
    if rng.random() < 0.6:
        state = SimState.generate(rng.randrange(2**31), model=model, position_range=(first, last))
    else:  # a table of its own: any axes, 1 to 8 of them, denser or sparser
        axes = tuple(sorted(rng.sample(range(1, 9), rng.choice([1, 2, 3, 4, 6, 8]))))
        density = rng.choice([0.1, 0.4, 0.8])
        positions = [
            random_position(rng, n, axes) for n in range(first, last + 1) if rng.random() < density
        ]
        state = SimState.from_positions(
            positions, axes=axes, model=model, position_range=(first, last)
        )
    story.append(
        f"robot: {model}, axes {list(state.axes)}, positions {first}-{last}, "
        f"{len(state.positions)} defined"
    )
    return state


def random_target(rng: random.Random, state: SimState, story: list[str]) -> dict[int, Position]:
    """The robot's table with a random diff applied."""
    table = dict(state.positions)
    first, last = state.position_range
    numbers = range(first, last + 1)
    axes = state.axes
    if rng.random() < 0.05:
        story.append("no change")
        return table
    if table and rng.random() < 0.7:
        picked = rng.sample(sorted(table), k=min(len(table), rng.randint(1, 8)))
        for n in picked:
            table[n] = edited(rng, table[n], axes)
        story.append(f"positions edited, scattered: {sorted(picked)}")
    if rng.random() < 0.5:
        free = [n for n in numbers if n not in table]
        added = rng.sample(free, k=min(len(free), rng.randint(1, 5)))
        for n in added:
            table[n] = random_position(rng, n, axes)
        story.append(f"positions added, scattered: {sorted(added)}")
    if rng.random() < 0.5:
        # A run: changed and new positions side by side, sometimes longer than one
        # 291H can carry (TT: 12, TTA: 25), so it takes several.
        size = rng.choice([rng.randint(2, 10), rng.randint(10, 40), rng.randint(30, 70)])
        start = rng.randint(first, max(first, last - size + 1))
        run = range(start, min(last, start + size - 1) + 1)
        for n in run:
            table[n] = edited(rng, table[n], axes) if n in table else random_position(rng, n, axes)
        story.append(f"positions changed in a run: {run.start}-{run.stop - 1}")
    if table and rng.random() < 0.04:
        gone = rng.choice(sorted(table))
        del table[gone]
        story.append(f"position {gone} left out of the project (no write can clear it)")
    return table


def random_change(rng: random.Random, axes: tuple[int, ...], known: tuple[int, ...] = ()) -> Change:
    """One of the operator's changes.  ``known`` are the axes the client can know of
    (an axis it cannot know of, unplugged, is one it never checks); none: the robot's."""
    known = known or axes
    return rng.choices(
        [
            verb("run"),
            verb("manual"),
            verb("estop"),
            verb("flash"),
            verb("hold", str(rng.choice(axes))),
            not_ready,
            # issue 19: what only the manual's 215H bits and a short 212H reply show
            verb("positioner"),
            verb("error", rng.choice(["0E1", "A05", "C8F"])),
            verb("cutoff"),
            verb("gate"),
            unplugged(rng.sample(known, rng.randint(1, len(known)))),
            verb("stop"),
        ],
        weights=[4, 3, 1, 1, 2, 1, 1, 1, 1, 1, 2, 4],
    )[0]


def unplugged(axes: list[int]) -> Change:
    """212H leaves ``axes`` out of its reply (all of them: a reply that lists none),
    and now and then one of them is in use too: the write it hides must not go."""

    def change(sim: Simulator, state: SimState) -> str:
        for axis in axes:
            sim.control("unplug", state, [str(axis)])
        if len(axes) % 2:
            state.axes_in_use.add(axes[0])
        return f"unplug {axes}" + (f", axis {axes[0]} in use" if len(axes) % 2 else "")

    return change


def random_schedule(
    rng: random.Random,
    reads: int,
    horizon: int,
    axes: tuple[int, ...],
    known: tuple[int, ...],
    deadline: float,
) -> list[tuple[int, Change]]:
    """Changes and line faults at random moments: most of them while the push
    writes (request ``reads`` on), the rest at any time."""

    def moment() -> int:
        return rng.randrange(horizon) if rng.random() < 0.15 else rng.randrange(reads, horizon)

    out = [
        (moment(), random_change(rng, axes, known))
        for _ in range(rng.choice([0, 1, 1, 2, 2, 3, 5]))
    ]
    return out + line_changes(rng, moment, deadline)


def real(rng: random.Random) -> float:
    return rng.choice(
        [
            round(rng.uniform(-500, 500), rng.randint(0, 6)),
            0.0,
            rng.choice([1e300, -2.5e-300, 0.1, 2.0**53 + 2]),
        ]
    )


def random_variables(
    rng: random.Random, state: SimState, story: list[str]
) -> dict[str, tuple[int, int]]:
    """Flags and variables on the controller, in small ranges robot.yaml keeps (a
    first flag off the 20DH alignment of 8 among them)."""
    keeps = {
        "flags": (600 + rng.randrange(20), 0),
        "integers": (200 + rng.randrange(10), 0),
        "reals": (300 + rng.randrange(10), 0),
    }
    keeps = {section: (first, first + rng.randint(2, 30)) for section, (first, _) in keeps.items()}
    flags, integers, reals = (range(a, b + 1) for a, b in keeps.values())
    state.flags = {n for n in flags if rng.random() < 0.3}
    state.integers = {n: rng.randint(-5000, 5000) for n in integers if rng.random() < 0.5}
    state.reals = {n: real(rng) for n in reals if rng.random() < 0.5}
    story.append(f"flags and variables kept: {keeps}")
    return keeps


def variable_reads(model: str, section: str, first: int, last: int) -> int:
    """The queries a read of ``section`` ``first``-``last`` and its probes past ``last``
    (up to the last number the message names) and below ``first`` (down to the
    lowest) take, when no query is refused."""
    step = (
        max_flags_per_read(model) if section == "flags" else max_variables_per_read(model, section)
    )
    align = profile.FLAG_QUERY_ALIGNMENT if section == "flags" else 1
    end = profile.VARIABLE_NUMBER_END[section]
    read = -(-(last + 1 - (first - first % align)) // step)
    head = (last + 1) - (last + 1) % align
    lowest = profile.NUMBER_FIRST[section]
    below = -(-(first - lowest) // step)  # issue 29: down to the lowest number too
    return read + -(-(end + 1 - head) // step) + below


def held(
    state: SimState,
    keeps: dict[str, tuple[int, int]] | None,
    strings: tuple[int, int] | None = None,
) -> IaiData:
    """What the controller holds: its table, the flags and variables robot.yaml
    keeps (every number of their ranges: an unset one is off, or 0), and the string
    variable columns it keeps, as rows of records.yaml."""
    data = IaiData(state.versions[(0, 0)], dict(state.positions), state.model)
    if strings is not None:
        first, last = strings
        row = profile.STRING_ROW
        data.strings = {
            start: "".join(
                f"{state.strings.get(n, 0):02X}"
                for n in range(start, min(last, start + row - 1) + 1)
            )
            for start in range(first, last + 1, row)
        }
    if keeps is not None:
        flags, integers, reals = (range(a, b + 1) for a, b in keeps.values())
        data.flags = {n: n in state.flags for n in flags}
        data.integers = {n: state.integers.get(n, 0) for n in integers}
        data.reals = {n: real_text(state.reals.get(n, 0.0)) for n in reals}
    return data


def random_variable_edits(
    rng: random.Random, data: IaiData, keeps: dict[str, tuple[int, int]], story: list[str]
) -> None:
    """Flags set and cleared, integer and real variables changed, scattered and in runs."""
    assert data.flags is not None and data.integers is not None and data.reals is not None
    changed: list[str] = []
    if rng.random() < 0.6:
        for n in rng.sample(sorted(data.flags), k=rng.randint(1, 4)):
            data.flags[n] = not data.flags[n]
        changed.append("flags")
    if rng.random() < 0.6:
        first, last = keeps["integers"]
        start = rng.randint(first, last)
        for n in range(start, min(last, start + rng.randint(0, 8)) + 1):
            data.integers[n] = rng.choice([rng.randint(-9999, 9999), -(2**31), 2**31 - 1])
        changed.append("integers")
    if rng.random() < 0.6:
        for n in rng.sample(sorted(data.reals), k=rng.randint(1, 5)):
            data.reals[n] = real_text(real(rng))
        changed.append("reals")
    story.append(f"variables edited: {', '.join(changed) or 'none'}")


def random_strings(
    rng: random.Random, state: SimState, target: IaiData, story: list[str]
) -> tuple[int, int]:
    """String variable columns on the controller in a range robot.yaml keeps, and
    rows of them edited in the project (issue 34 item 18: written back with 24EH)."""
    first = 1 + rng.randrange(40)
    last = first + rng.randint(10, 100)
    state.strings = {
        n: rng.randrange(0x20, 0x7F) for n in range(first, last + 1) if rng.random() < 0.3
    }
    target.strings = held(state, None, (first, last)).strings
    assert target.strings is not None
    for start in rng.sample(sorted(target.strings), k=rng.randint(1, len(target.strings))):
        row = target.strings[start]
        target.strings[start] = "".join(
            f"{rng.randrange(0x20, 0x7F):02X}" if rng.random() < 0.3 else row[i : i + 2]
            for i in range(0, len(row), 2)
        )
    story.append(f"string variable columns kept: {first}-{last}, rows edited")
    return first, last


def make_case(seed: int, settings: SerialSettings) -> Case:
    rng = random.Random(seed)
    story: list[str] = []
    state = random_robot(rng, story)
    target = IaiData(
        version=state.versions[(0, 0)],
        positions=random_target(rng, state, story),
        model=state.model,
    )
    # Flags and variables from a generator of their own: the table and the rest of
    # a case stay what they were before variables were in the test.
    vrng = random.Random(f"variables {seed}")
    keeps = random_variables(vrng, state, story) if vrng.random() < 0.3 else None
    registers = keeps is not None and vrng.random() < 0.85
    # String variables from a generator of their own too, in a quarter of the cases.
    srng = random.Random(f"strings {seed}")
    strings = random_strings(srng, state, target, story) if srng.random() < 0.25 else None
    before = held(state, keeps, strings)
    if keeps is not None:
        variables = held(state, keeps)
        target.flags, target.integers, target.reals = (
            variables.flags,
            variables.integers,
            variables.reals,
        )
        if registers:
            random_variable_edits(vrng, target, keeps, story)
        else:
            story.append("pushed without --registers: the flags and variables stay")
    robot_axes = state.axes if rng.random() < 0.7 else None
    if robot_axes is None:
        story.append("robot.yaml names no axes: the interlock checks every axis 212H reports")
    busy = random_change(rng, state.axes) if rng.random() < 0.08 else None
    first, last = state.position_range
    step = max_positions_per_read(state.model)
    reads = 3 + -(-(last - first + 1) // step)  # 212H, 215H, 201H, the 22DH pages
    if registers and keeps is not None:  # each section's read, then its probe to the wire's end
        reads += sum(variable_reads(state.model, s, *keeps[s]) for s in keeps)
    if strings is not None:  # their range's reads (no probe outside it)
        reads += -(-(strings[1] - strings[0] + 1) // max_string_columns_per_read(state.model))
    changes = sync_items.diff(CATALOGUE, before, target, registers=registers)
    horizon = reads + 6 * len(changes) + 8
    wait = deadline(settings)
    plan = CATALOGUE.plan(
        before, target, [(c.key, c.old, c.new) for c in changes], registers=registers
    )
    writes = len(plan.wanted)
    lose_writes = {rng.randrange(writes)} if writes and rng.random() < 0.3 else set()
    if lose_writes:
        story.append(f"write requests lost on the way in: {sorted(lose_writes)}")
    tables = (before.positions, target.positions)
    known = robot_axes or tuple(sorted({a for t in tables for p in t.values() for a in p.axes}))
    schedule = random_schedule(rng, reads, horizon, state.axes, known, wait)
    sim = Operator(
        state, schedule, seed=rng.randrange(2**32), deadline=wait, lose_writes=lose_writes
    )
    if busy is not None:
        story.append(f"when the push starts: {busy(sim, state)}")
    return Case(
        seed,
        state.model,
        state.axes,
        robot_axes,
        state.position_range,
        before,
        target,
        sim,
        keeps,
        registers,
        story,
        strings,
    )


def robot_for(case: Case, url: str, settings: SerialSettings) -> Robot:
    robot = families.get("iai").new_robot(f"case-{case.seed}", url, None)
    robot.serial = settings
    robot.options.update(
        model=case.model, first=case.position_range[0], last=case.position_range[1]
    )
    if case.robot_axes is not None:
        robot.options["axes"] = case.robot_axes
    if case.keeps is not None:
        robot.keep_registers = True
        robot.options.update(case.keeps)
        # The real variables' word order is the simulator's (issue 29: read from the
        # values when robot.yaml gives none, and a push of reals refused while none
        # tells; tests/families/iai/test_real_order.py): this test is about the interlock.
        robot.options["real_word_order"] = case.sim.state.real_word_order
    if case.strings is not None:
        robot.options["strings"] = case.strings
    return robot


# --- running it -------------------------------------------------------------------------


Deploy = Callable[[Case, SerialSettings], Outcome]


@pytest.fixture
def in_memory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Deploy:
    """Push a case with its project held in memory and its snapshot kept in memory:
    the engine's deploy, which ``engine.push`` runs once it has read and checked the
    project on disk.

    Saving the project, loading it and saving the snapshot cost three times the
    rest of a case; :func:`test_the_cli_on_a_project_on_disk_keeps_the_same_promises`
    shows that they change nothing the checks look at.  So do, at a quarter of a
    case, what only the disk has: the audit log's fsync (each case keeps its own
    log, which the checks read back), asking git for the commit of a project that
    is not in a repository, and the controller's 1 ms pause after each reply, which
    the simulator does not ask for.
    """
    taken = off_the_disk(monkeypatch)
    monkeypatch.setattr(CODEC, "reply_gap", 0.0)

    def deploy(case: Case, settings: SerialSettings) -> Outcome:
        url = register(case.sim)
        monkeypatch.setenv("HARLSYNC_AUDIT_LOG", str(tmp_path / f"audit-{case.seed}.jsonl"))
        try:
            path = tmp_path / f"case-{case.seed}"
            project = Project(path, robot_for(case, url, settings), case.target)
            opts = PushOptions(yes=True, allow_dirty=True, registers=case.registers)
            first, before = len(case.sim.received), len(taken)
            try:
                result = engine._deploy("push", project, case.target, opts, None, None)
                failed = None
            except PushFailed as exc:
                result, failed = exc.result, exc
            snapshot = taken[before] if len(taken) > before else None
            return Outcome(result, failed, case.sim.received[first:], snapshot, first)
        finally:
            unregister(url)

    return deploy


@pytest.fixture
def on_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> Deploy:
    """Push a case as a person does: the project on disk and committed to git,
    ``harlsync push DIR --yes``, the snapshot written and read back; the exit status
    and what the command printed are checked here (the result is taken from
    ``engine.push`` on its way out)."""
    seen = spy_on_push(monkeypatch)

    def deploy(case: Case, settings: SerialSettings) -> Outcome:
        url = register(case.sim)
        try:
            path = tmp_path / f"case-{case.seed}"
            save_project(
                path, Project(path, robot_for(case, url, settings), case.target), rewrite_robot=True
            )
            if not (path / ".git").exists():
                git(path, "init", "-q")
            git(path, "add", "-A")
            git(path, "commit", "-q", "--allow-empty", "-m", "the project")
            first = len(case.sim.received)
            argv = ["push", str(path), "--yes", *["--registers"] * case.registers]
            result, failed = push_command(case.why, argv, seen, capsys)
            snapshot = load_project(result.snapshot).data if result.snapshot else None
            return Outcome(result, failed, case.sim.received[first:], snapshot, first)
        finally:
            unregister(url)

    return deploy


@dataclass
class IaiTally(Tally):
    several_runs: int = 0
    #: pushes that wrote a flag or a variable
    variables_written: int = 0
    #: pushes that wrote a row of string variable columns (24EH)
    strings_written: int = 0
    #: pushes refused for a condition issue 19 added, by condition
    issue_19: dict[str, int] = field(default_factory=dict)


#: What the refusal names for each condition issue 19 added to the interlock.
ISSUE_19 = {
    "positioner": "positioner mode",
    "critical error": "critical error",
    "drive cut off": "drive source cut off",
    "safety gate": "safety gate open",
    "axes missing from 212H": "not reported by 212H",
}


def wire(write: PlannedWrite[Key]) -> str:
    """The payload of the write a planned write sends, as the controller records it.
    (``write.new`` is an object to the plan; what it holds the key's kind says.)"""
    key = write.key
    if isinstance(key, RecordKey):  # a row of string variable columns
        row = cast(str, write.new)
        codes = [int(row[i : i + 2], 16) for i in range(0, len(row), 2)]
        return write_strings(key.number, codes).payload
    if not isinstance(key, Run):
        return write_flag(key.number, cast(bool, write.new)).payload
    if key.kind == "positions":
        return write_positions(key.start, cast(list[Position], write.new)).payload
    if key.kind == "integers":
        return write_integers(key.start, cast(list[int], write.new)).payload
    return write_reals(key.start, [real_value(v) for v in cast(list[str], write.new)]).payload


def reads_back(payload: str, between: list[Received]) -> bool:
    """Whether the reads among ``between`` read every item the write wrote (a run
    longer than one query asks for is read in two)."""
    read, start_at, count_at = READ_BACK[payload[:3]]
    start = int(payload[start_at], 16)
    count = 1 if read == "20D" else int(payload[count_at], 16)
    pages = [
        range(
            int(r.payload[start_at], 16),
            int(r.payload[start_at], 16) + int(r.payload[count_at], 16),
        )
        for r in between
        if r.command == read
    ]
    return all(any(n in page for page in pages) for n in range(start, start + count))


def axis_reason(why: str) -> bool:
    """Whether a reason the controller was not idle is 212H's to show: an axis in
    use, or one its reply leaves out."""
    return why.endswith((" in use", " not reported"))


def check_interlock(case: Case, got: Outcome, tally: IaiTally) -> None:
    received, arrival = got.received, case.sim.arrival[got.first :]
    assert not case.sim.off_list(), case.why(f"off the allow-list: {case.sim.off_list()}")
    for i, r in enumerate(received):
        assert r.command in PUSHED, case.why(
            f"{r.payload[:12]!r} (request {i}) is no message a push sends"
        )
        if not r.is_write:
            continue
        name = f"{r.command}H (request {i})"
        # issue 19: 212H first, 215H last, so that MANUAL mode and an emergency stop
        # are the freshest read.
        axes, status = (received[i - 2], received[i - 1]) if i >= 2 else (None, None)
        assert (
            status is not None
            and axes is not None
            and axes.command == "212"
            and (status.command == "215")
        ), case.why(
            f"{name} did not follow a 212H and a 215H straight "
            f"(before it: {received[max(0, i - 2) : i]})"
        )
        assert axes.payload == f"212{case.pattern:02X}", case.why(
            f"{name} was cleared by {axes.payload}, not by the robot's axes"
        )
        # Each read answers for its part: 215H for the mode and the status bytes,
        # 212H for the axes (an axis held at the 215H and let go before the 212H is
        # no reason to refuse), in use or left out of its reply.
        shown = [why for why in arrival[i - 1] if not axis_reason(why)]
        assert not shown, case.why(
            f"{name} followed a 215H that found the controller not idle: {shown}"
        )
        in_use = [
            why
            for why in arrival[i - 2]
            if axis_reason(why)
            and int(why.split()[1])
            in (case.known_axes if why.endswith(" not reported") else case.checked_axes)
        ]
        assert not in_use, case.why(f"{name} followed a 212H that found {in_use}")
        window = {got.first + i - 2, got.first + i - 1} & case.sim.acted
        if axes.busy or r.busy:
            # Started (or switched) after that 215H was answered: see the docstring.
            assert window, case.why(
                f"{name} or its 212H found the controller not idle "
                f"({arrival[i - 1] or arrival[i]}) with no change by the operator after the 215H"
            )
            tally.race += 1
    if got.failed is None and got.result.written:
        last = max(i for i, r in enumerate(received) if r.is_write)
        after = [r.command for r in received[last:]]
        unread = any(
            w.startswith("cannot read the task states after the last write")
            for w in got.result.warnings
        )
        assert ("212" in after and "215" in after) or unread, case.why(
            "neither a 212H and a 215H after the last write, nor a warning that says why not"
        )


#: A run's kind -> the kind of the items it writes.
ITEM_OF_RUN = {"positions": "position", "integers": "integer", "reals": "real"}


def items(write: PlannedWrite[Key]) -> dict[Key, Any]:
    """The items a planned write writes, each with its new value."""
    key = write.key
    if not isinstance(key, Run):
        return {key: write.new}  # a flag
    kind = ITEM_OF_RUN[key.kind]
    make = PositionKey if kind == "position" else VariableKey
    return {make(kind, n): new for n, new in zip(key.numbers, cast(list[object], write.new))}


def check_writes(case: Case, got: Outcome, final: IaiData) -> None:
    """The result names exactly what the controller received; each position, flag and
    variable holds its old or its new value."""
    result = got.result
    # A write the controller refused (an & reply: the simulated controller refuses
    # a write that arrives while it is not idle) is not written (issue 22).
    sent = check_sent(case.why, got, wire, reads_back, refused=lambda arrivals: arrivals[-1].busy)
    plan = result.plan
    if plan is None:
        assert not sent, case.why("writes without a plan")
        return
    old = CATALOGUE.items(case.before, registers=True)
    now = CATALOGUE.items(final, registers=True)
    planned = {key: new for w in plan.writes for key, new in items(w).items()}
    done = {key for w in result.written for key in items(w)}
    failed = set(items(result.failed)) if result.failed else set()
    for key in old.keys() | now.keys() | planned.keys():
        was, holds = old.get(key), now.get(key)
        if key in done:
            assert holds == planned[key], case.why(f"{key} was reported written but holds {holds}")
        elif key in failed:
            assert holds in (was, planned[key]), case.why(
                f"{key}, whose write failed, holds {holds}: neither old nor new"
            )
        else:
            assert holds == was, case.why(f"{key} was not written but changed: {was} -> {holds}")


def check_converged(case: Case, final: IaiData) -> None:
    left = sync_items.diff(CATALOGUE, final, case.target, registers=case.registers)
    assert not left, case.why(f"push returned but the robot still differs: {left[:3]}")


def check_case(case: Case, deploy: Deploy, tally: IaiTally, settings: SerialSettings) -> None:
    got = deploy(case, settings)
    final = held(case.sim.state, case.keeps, case.strings)
    tally.cases += 1
    tally.lost_writes += case.sim.lost_writes
    if got.result.plan is not None and len(got.result.plan.writes) > 1:
        tally.several_runs += 1
    tally.variables_written += any(r.is_write and r.command != "291" for r in got.received)
    tally.strings_written += any(r.is_write and r.command == "24E" for r in got.received)
    check_interlock(case, got, tally)
    check_writes(case, got, final)
    if got.snapshot is not None:
        assert not sync_items.diff(
            CATALOGUE, got.snapshot, case.before, registers=case.registers
        ), case.why("the snapshot is not what the robot held before the push")
    if got.failed is None:
        tally.ok += 1
        check_converged(case, final)
        return
    count_failure(tally, got)
    for name, text in ISSUE_19.items():
        if text in str(got.failed):
            tally.issue_19[name] = tally.issue_19.get(name, 0) + 1
    check_failure(case.why, got)
    if isinstance(got.failed.cause, PolicyError):
        check_wrote_nothing(case.why, got)
        return
    # The operator stops the controller and the line is mended: the same push finishes.
    case.sim.calm()
    case.before = final
    again = deploy(case, CALM)
    final = held(case.sim.state, case.keeps, case.strings)
    check_interlock(case, again, tally)
    check_writes(case, again, final)
    # No message clears a position: a project that lacks one is refused every time.
    refused = any(n not in case.target.positions for n in case.before.positions)
    check_rerun(case.why, again, refused=refused)
    if not refused:
        check_converged(case, final)


@pytest.mark.parametrize("chunk", CHUNKS)
def test_no_write_reaches_a_controller_that_is_not_idle_and_every_push_converges_or_names_its_writes(
    chunk: int, in_memory: Deploy
) -> None:
    tally = IaiTally()
    for seed in seeds(chunk, BASE):
        check_case(make_case(seed, FAST), in_memory, tally, FAST)
    print(json.dumps(tally.__dict__))
    if not ONLY:  # the cases still reach what they are meant to (a generator can rot)
        assert tally.ok >= 25 and tally.failed - tally.refused_before_writing >= 10, tally
        assert tally.lost_writes >= 5 and tally.several_runs >= 25, tally
        assert tally.variables_written >= 8 and tally.strings_written >= 5, tally
        assert sum(tally.issue_19.values()) >= 3, tally  # issue 19's conditions are drawn


#: Seeds for the on-disk run: enough to meet every kind of outcome, few enough to be quick.
ON_DISK = range(BASE - 20, BASE)


def test_the_cli_on_a_project_on_disk_keeps_the_same_promises(on_disk: Deploy) -> None:
    tally = IaiTally()
    for seed in ONLY or ON_DISK:
        check_case(make_case(seed, FAST_ON_DISK), on_disk, tally, FAST_ON_DISK)
    print(json.dumps(tally.__dict__))


# --- a refusal, through the command, names the bit ------------------------------------------


class Pendant(Simulator):
    """A controller whose operator does ``change`` once ``after_writes`` writes are
    carried out (0: before the push)."""

    def __init__(self, state: SimState, change: Change, after_writes: int) -> None:
        super().__init__(state)
        self.change, self.after_writes = change, after_writes
        if not after_writes:
            change(self, state)

    def wrote(self, state: SimState) -> None:
        super().wrote(state)
        if self.writes == self.after_writes:
            self.change(self, state)


@pytest.mark.parametrize("after_writes", [0, 1], ids=["before the push", "after a write"])
@pytest.mark.parametrize(
    ("change", "bit"),
    [
        (verb("run"), "program running (215H status byte 2 bit 5)"),
        (verb("manual"), "MANUAL mode (215H mode 2)"),
        (verb("estop"), "emergency stop (215H status byte 1 bit 3)"),
        (verb("flash"), "flash ROM write in progress (215H status byte 2 bit 0)"),
        (verb("hold", "2"), "axis 2 servo axis in use (212H axis status bit 0)"),
        (not_ready, "system not ready (215H status byte 3 bit 2)"),
        # issue 19
        (verb("positioner"), "positioner mode: a PLC can move the robot to a position number"),
        (verb("error", "C8F"), "critical error C8F on the controller"),
        (verb("cutoff"), "drive source cut off (215H status byte 3 bit 0)"),
        (verb("gate"), "safety gate open"),
        (verb("unplug", "2"), "axis 2 not reported by 212H (its reply lists axis 1, 3)"),
    ],
    ids=[
        "run",
        "manual",
        "estop",
        "flash",
        "hold 2",
        "not ready",
        "positioner",
        "critical error",
        "drive cut off",
        "safety gate",
        "212H without axis 2",
    ],
)
def test_a_refusal_exits_3_naming_the_bit_and_writes_nothing_more(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: Change,
    bit: str,
    after_writes: int,
) -> None:
    axes = (1, 2, 3)
    table = {n: random_position(random.Random(n), n, axes) for n in range(1, 13)}
    state = SimState.from_positions(table, axes=axes, model="TT", position_range=(1, 40))
    sim = Pendant(state, change, after_writes)
    url = register(sim)
    try:
        robot = families.get("iai").new_robot("cell", url, None)
        robot.serial = CALM
        robot.options.update(model="TT", axes=axes, first=1, last=40)
        target = dict(table)
        for n in (3, 20):  # two 291H: one run each
            target[n] = random_position(random.Random(1000 + n), n, axes)
        path = tmp_path / "cell"
        save_project(path, Project(path, robot, IaiData(state.versions[(0, 0)], target, "TT")))
        git(path, "init", "-q")
        git(path, "add", "-A")
        git(path, "commit", "-q", "-m", "two positions changed")
        capsys.readouterr()

        code = cli.main(["push", str(path), "--yes"])
    finally:
        unregister(url)

    err = capsys.readouterr().err
    refusal = [line for line in err.splitlines() if line.startswith("harlsync: refused: ")]
    assert code == 3, err
    assert len(refusal) == 1 and bit in refusal[0], err
    assert not sim.off_list()
    assert not sim.writes_while_busy()
    assert len(sim.writes_received()) == after_writes
    assert state.positions == {**table, **{n: target[n] for n in (3,) if after_writes}}
    if after_writes:
        assert "harlsync: push stopped: wrote 1 of 2 item(s)" in err
