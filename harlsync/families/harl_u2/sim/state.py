"""What a simulated HARL-U2 robot holds: its memory, its I/O and its tasks.

:class:`SimState` wraps the shared :class:`~harlsync.model.RobotData` (programs,
parameters, offsets, timers, registers) and adds what only a live controller has:
DI/DO and memory bits and the five tasks LNR reports.  It can be built from a
robot project, blank for a configuration, or generated from a seed as realistic
pick-and-place programs.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field, replace

from ..model import (
    OFFSET_TABLE_COUNT,
    Config,
    OffsetTable,
    Parameters,
    ProgramArea,
    ProgramType,
    RobotData,
    Step,
    TaskState,
)
from ..protocol import profile

__all__ = ["DEFAULT_CONFIG", "DEFAULT_PARAMETERS", "DEFAULT_VERSION", "SimState"]

#: The configuration of a generated or blank robot: small enough that a full
#: pull takes seconds, shaped like a real cell.
DEFAULT_CONFIG = Config(
    start=ProgramArea(1, 64),
    main=ProgramArea(4, 128),
    sub=ProgramArea(4, 64),
    hand=ProgramArea(4, 32),
    timers=16,
    memory_bits=128,
    registers=16,
)
DEFAULT_VERSION = "5.00"
DEFAULT_PARAMETERS = Parameters.from_values(
    ["100", "1", "0", "20.00", "20.00", "30.00", "30.00", "40.00", "40.00", "50", "0", "0.00", "0"]
)

#: DI and DO bits 0-255 (ports 0-31); memory bits start at 256.
IO_BITS = 256
MEM_BIT_BASE = 256


def _idle_tasks() -> list[TaskState]:
    return [TaskState(i, 0, "START", 0, 0) for i in range(profile.TASK_COUNT)]


@dataclass
class SimState:
    """One simulated robot (one station)."""

    data: RobotData
    di: list[int] = field(default_factory=lambda: [0] * IO_BITS)
    do: list[int] = field(default_factory=lambda: [0] * IO_BITS)
    mem: list[int] = field(default_factory=list)
    tasks: list[TaskState] = field(default_factory=_idle_tasks)
    #: How many offset tables the controller has (the manual's 0-99 "(variable)");
    #: None: as the simulator's ``offset_tables`` variant says (100 by default).
    offset_tables: int | None = None
    #: Requests this robot answers with ``E`` + status instead of carrying them
    #: out (request payload -> status): the manual's robot "under abnormal
    #: conditions" that "is unable to return data normally", e.g.
    #: ``{"LNL 100": STATUS_BUSY}``.  Not kept in battery-backed memory.
    errors: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        cfg = self.data.config
        if not self.mem:
            self.mem = [0] * cfg.memory_bits
        if self.data.registers is None:
            self.data.registers = {}
        for key in cfg.programs():
            self.data.programs.setdefault(key, {})
        held = len(self.data.offsets)
        if held > max(OFFSET_TABLE_COUNT, self.offset_tables or 0):
            self.offset_tables = held  # a robot built with more tables has them all
        for n in range(max(OFFSET_TABLE_COUNT, self.offset_tables or 0)):
            self.data.offsets.setdefault(n, OffsetTable())
        for n in range(cfg.timers):
            self.data.timers.setdefault(n, "0.00")
        for n in range(cfg.registers):
            self.data.registers.setdefault(n, "0000")

    @classmethod
    def blank(cls, config: Config = DEFAULT_CONFIG, version: str = DEFAULT_VERSION) -> SimState:
        """A robot with this configuration and nothing written yet."""
        return cls(RobotData(version=version, config=config, parameters=DEFAULT_PARAMETERS))

    @classmethod
    def from_robot_data(cls, data: RobotData) -> SimState:
        """A robot that holds ``data`` (deep-copied: the caller's data is not shared),
        with as many offset tables as a pull of it found."""
        copy = RobotData(
            version=data.version,
            config=data.config,
            parameters=data.parameters,
            programs={k: dict(v) for k, v in data.programs.items()},
            offsets=dict(data.offsets),
            timers=dict(data.timers),
            registers=dict(data.registers) if data.registers is not None else None,
        )
        end = data.offset_end
        return cls(copy, offset_tables=None if end is None else end.count)

    @classmethod
    def generate(cls, seed: int, config: Config = DEFAULT_CONFIG) -> SimState:
        """A robot with realistic programs, offsets and timers drawn from ``seed``."""
        rng = random.Random(seed)
        state = cls.blank(config)
        data = state.data
        for key in config.programs():
            data.programs[key] = _generate_program(rng, key, config)
        for n in rng.sample(range(OFFSET_TABLE_COUNT), k=min(12, OFFSET_TABLE_COUNT)):
            data.offsets[n] = OffsetTable.from_values(
                [f"{rng.uniform(-500, 500):.2f}" for _ in range(6)]
                + [str(rng.randrange(100)), str(rng.randrange(100))]
            )
        for n in range(config.timers):
            if rng.random() < 0.6:
                data.timers[n] = f"{rng.randrange(1000) / 100:.2f}"
        assert data.registers is not None
        for n in range(config.registers):
            data.registers[n] = f"{rng.randrange(10000):04d}"
        data.parameters = replace(DEFAULT_PARAMETERS, pull_limit=str(rng.randrange(50, 150)))
        return state

    # --- mode control -------------------------------------------------------------

    def start_task(
        self, task: int = 0, ptype: str = "MAIN", program: int = 0, step: int = 0
    ) -> None:
        """Put a task into automatic operation (LNR status 1, in execution)."""
        self.tasks[task] = TaskState(task, 1, ptype, program, step)

    def suspend_task(self, task: int = 0) -> None:
        self.tasks[task] = replace(self.tasks[task], status=2)

    def stop_all(self) -> None:
        """Stop every task (status 0): the robot is idle."""
        self.tasks = [replace(t, status=0) for t in self.tasks]

    @property
    def automatic(self) -> bool:
        return any(t.active for t in self.tasks)


def _generate_program(
    rng: random.Random, key: tuple[ProgramType, int], config: Config
) -> dict[int, Step]:
    ptype = key[0]
    steps = config.area(ptype).steps
    length = min(steps, rng.randrange(4, 24))
    out: dict[int, Step] = {}
    for i in range(length - 1):
        out[i] = _generate_step(rng, ptype, config)
    out[length - 1] = Step("END")
    return out


def _generate_step(rng: random.Random, ptype: ProgramType, config: Config) -> Step:
    if ptype is ProgramType.START and config.main.count and rng.random() < 0.5:
        return Step("CALL", (f"M{rng.randrange(config.main.count):02d}",))
    if ptype is ProgramType.HAND:
        verb = rng.choice(["OUT", "WAIT"])
        return Step(verb, (f"DO{rng.randrange(32)}", rng.choice(["ON", "OFF"])))
    choice = rng.random()
    if choice < 0.45:
        return Step("MOVE", (f"P{rng.randrange(1000):03d}", f"S{rng.choice([20, 50, 80, 100])}"))
    if choice < 0.6 and config.sub.count:
        return Step("CALLS", (f"S{rng.randrange(config.sub.count):02d}",))
    if choice < 0.7 and config.hand.count:
        return Step("HAND", (f"H{rng.randrange(config.hand.count):02d}",))
    if choice < 0.8 and config.timers:
        return Step("TIMER", (f"T{rng.randrange(config.timers):02d}",))
    if choice < 0.9:
        return Step("OFFSET", (f"L{rng.randrange(OFFSET_TABLE_COUNT):02d}",))
    return Step("WAIT", (f"DI{rng.randrange(64)}", rng.choice(["ON", "OFF"])))
