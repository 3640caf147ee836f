"""What one simulated Epson controller holds: the robot's settings and points, as
the Remote Control commands read and write them, and what the robot is doing.

Values are kept as the controller carries them on the wire, not as text:
real values in thousandths (``100.123`` is ``100123``), JRange limits in
encoder pulses, percentages and attributes as integers.  The state is a plain
dataclass: a test builds one field by field, :meth:`SimState.generate` draws a
realistic robot from a seed (:mod:`.random_robot`), :meth:`SimState.from_data`
takes a backup's, and :mod:`.memory` keeps what survives a power cycle.  A point
is a :class:`~.point.Point`.

Volatility, as the manual says (digest §2): the six speed/accel tables
(§9.1) and LimZ (§10.26) are cleared when the controller is turned off or
reset (:meth:`SimState.power_cycle`); everything else here is kept (the
memory card, or nothing stated).  What the robot is doing (Running, Paused
...) is not kept: a controller comes up idle.
"""

from __future__ import annotations

import random
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from .. import profile
from ..model import EpsonData
from ..protocol import real_units
from .point import Point, fits_int32
from .random_robot import Draw

__all__ = [
    "DEFAULT_ARCH",
    "MAX_POINT",
    "SCARA",
    "SIX_AXIS",
    "Limits",
    "SimState",
    "three_axes",
]

#: 2153 manipulator types the simulator builds robots of (the manual's codes).
SCARA = 3
SIX_AXIS = 5
RS = 6
#: Types whose Weight has an arm length (§10.7: SCARA robots, the RS series too).
_ARM_LENGTH_TYPES = (3, 6)
#: The highest point number a robot holds **(simulator)**: P0-P999.
MAX_POINT = 999
#: Arch 0-6 as a new controller has them, depart and approach distance in
#: thousandths of a mm **(simulator)**: the SPEL defaults, 30 mm to 90 mm.
DEFAULT_ARCH: Mapping[int, tuple[int, int]] = {n: (30_000 + 10_000 * n,) * 2 for n in range(7)}
_DEFAULT_FINE = 10
_DEFAULT_WEIGHT = (2_000, 0)  # 2 kg, no arm length
_DEFAULT_INERTIA = (5, 0)  # 0.005 kg m², no eccentricity
_TABLES = ("accel", "accel_s", "accel_r", "speed", "speed_s", "speed_r")

_SCARA_MODELS = ("G6-551S", "G3-301S", "LS6-B602S", "T6-B602S", "GX8-A652S", "LS3-B401S")
_SIX_AXIS_MODELS = ("C4-A601S", "C8-A1401S", "VT6-A901S", "C12-A1401S", "C4-A901S")

#: (lower, upper) of one axis: a Box area's or XYLim's in thousandths, a JRange
#: joint's in pulses.
Limits = tuple[int, int]


@dataclass
class SimState:
    """One simulated Epson controller and its robot.

    Tables hold only their registered entries (an entry never registered answers
    2006); Box, Plane and Local hold the numbers that are not all 0, the rest
    read as 0 (off, as a new controller has them).  Raises :class:`ValueError`
    naming every problem for a robot the controller could not hold.
    """

    robot_type: int = SCARA
    model: str = _SCARA_MODELS[0]
    # --- volatile: cleared by a power cycle ------------------------------------------
    #: table 0-15 -> (accel %, decel %)
    accel: dict[int, tuple[int, int]] = field(default_factory=dict)
    #: table -> (accel, decel) in thousandths of mm/s² (AccelS) or deg/s² (AccelR)
    accel_s: dict[int, tuple[int, int]] = field(default_factory=dict)
    accel_r: dict[int, tuple[int, int]] = field(default_factory=dict)
    #: table -> (speed, depart speed, approach speed) %
    speed: dict[int, tuple[int, int, int]] = field(default_factory=dict)
    #: table -> (speed, depart speed, approach speed) in thousandths of mm/s
    speed_s: dict[int, tuple[int, int, int]] = field(default_factory=dict)
    #: table -> speed in thousandths of deg/s
    speed_r: dict[int, int] = field(default_factory=dict)
    limz: int = 0
    # --- kept ------------------------------------------------------------------------
    #: arch 0-6 -> (depart, approach) in thousandths of a mm
    arch: dict[int, tuple[int, int]] = field(default_factory=lambda: dict(DEFAULT_ARCH))
    #: one word a joint; empty: the default for every joint
    fine: tuple[int, ...] = ()
    #: (hand weight, arm length), thousandths
    weight: tuple[int, int] = _DEFAULT_WEIGHT
    #: (load inertia, eccentricity), thousandths
    inertia: tuple[int, int] = _DEFAULT_INERTIA
    tool: int = 0
    #: area 1-15 -> (X, Y, Z) limits
    boxes: dict[int, tuple[Limits, Limits, Limits]] = field(default_factory=dict)
    #: plane 1-15 -> a coordinate an axis
    planes: dict[int, tuple[int, ...]] = field(default_factory=dict)
    locals: dict[int, tuple[int, ...]] = field(default_factory=dict)
    #: X, Y, Z limits; all 0: off
    xylim: tuple[Limits, Limits, Limits] = ((0, 0), (0, 0), (0, 0))
    #: one (lower, upper) pulse pair a joint; empty: the default range
    jrange: tuple[Limits, ...] = ()
    #: a coordinate an axis; empty: all 0
    base: tuple[int, ...] = ()
    points: dict[int, Point] = field(default_factory=dict)
    # --- what the robot is doing: a controller comes up idle ---------------------------
    running: bool = False
    paused: bool = False
    estop: bool = False
    error: bool = False
    safeguard: bool = False
    #: what 2155 answers: the controller's error code, 0 in the normal state
    error_code: int = 0
    #: what 2156 answers: the control device (22 Remote I/O, the manual's normal state)
    control_device: int = 22

    def __post_init__(self) -> None:
        if self.robot_type not in profile.ROBOT_AXES:
            raise ValueError(
                f"manipulator type {self.robot_type}: the simulator builds "
                f"types {sorted(profile.ROBOT_AXES)} (3 SCARA, 5 6-AXIS, 6 RS)"
            )
        axes = self.axes
        self.fine = self.fine or (_DEFAULT_FINE,) * axes
        self.jrange = self.jrange or _default_jrange(axes)
        self.base = self.base or (0,) * axes
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(problems))

    @property
    def axes(self) -> int:
        """4 (SCARA, RS) or 6: coordinates of a point, Plane, Local, Base; joints."""
        return profile.ROBOT_AXES[self.robot_type]

    @property
    def has_arm_length(self) -> bool:
        return self.robot_type in _ARM_LENGTH_TYPES

    def problems(self) -> list[str]:
        """Why the controller could not hold this robot, one line each; empty if it can."""
        axes, out = self.axes, []
        if not self.model or not all(0x20 <= ord(c) <= 0x7E for c in self.model):
            out.append(f"model name {self.model!r}: printable ASCII, at least one character")
        for name in _TABLES:
            table: dict[int, object] = getattr(self, name)
            out += [f"{name} table {t}: not 0 to 15" for t in table if not 0 <= t <= 15]
        out += [
            f"accel table {t}: {v} (each 1 or more)" for t, v in self.accel.items() if min(v) < 1
        ]
        out += [
            f"speed table {t}: {v} (each 1 to 100)"
            for t, v in self.speed.items()
            if not all(1 <= s <= 100 for s in v)
        ]
        for name in ("accel_s", "accel_r", "speed_s"):
            table2: dict[int, tuple[int, ...]] = getattr(self, name)
            out += [
                f"{name} table {t}: {v} (each more than 0)"
                for t, v in table2.items()
                if min(v) <= 0 or not all(fits_int32(x) for x in v)
            ]
        out += [
            f"speed_r table {t}: {v} (more than 0)"
            for t, v in self.speed_r.items()
            if not 0 < v < 2**31
        ]
        if sorted(self.arch) != list(range(7)):
            out.append(f"arch {sorted(self.arch)}: 0 to 6, each once")
        if len(self.fine) != axes or not all(0 <= f <= 0xFFFF for f in self.fine):
            out.append(f"fine {self.fine}: {axes} words")
        if not 0 <= self.tool <= 15:
            out.append(f"tool {self.tool}: 0 to 15")
        out += [f"box {n}: not 1 to 15" for n in self.boxes if not 1 <= n <= 15]
        for name in ("planes", "locals"):
            frames: dict[int, tuple[int, ...]] = getattr(self, name)
            out += [f"{name} {n}: not 1 to 15" for n in frames if not 1 <= n <= 15]
            out += [
                f"{name} {n}: {len(c)} coordinates on a {axes}-axis robot"
                for n, c in frames.items()
                if len(c) != axes
            ]
        if len(self.jrange) != axes:
            out.append(f"jrange: {len(self.jrange)} joints on a {axes}-axis robot")
        if len(self.base) != axes:
            out.append(f"base: {len(self.base)} coordinates on a {axes}-axis robot")
        for number, point in sorted(self.points.items()):
            if not 0 <= number <= MAX_POINT:
                out.append(f"point {number}: not 0 to {MAX_POINT}")
            out += [f"point {number}: {p}" for p in point.problems(axes)]
        return out

    # --- what the robot is doing ----------------------------------------------------------

    def not_idle(self) -> list[str]:
        """The profile's interlock signals at 1, by their names; empty when idle."""
        return [
            name
            for name, on in (
                ("Running", self.running),
                ("Paused", self.paused),
                ("EStopOn", self.estop),
                ("Error", self.error),
                ("SafeguardOn", self.safeguard),
            )
            if on
        ] + ([f"control device {self.control_device}"] if self.control_device != 22 else [])

    @property
    def idle(self) -> bool:
        return not self.not_idle()

    def signals(self) -> dict[str, bool]:
        """The controller's standard Remote outputs: Ready (started up, no task
        running or paused, no error, no emergency stop) and the five states."""
        return {
            "Ready": not (self.running or self.paused or self.error or self.estop),
            "Running": self.running,
            "Paused": self.paused,
            "Error": self.error,
            "EStopOn": self.estop,
            "SafeguardOn": self.safeguard,
        }

    def stop(self) -> None:
        """Idle: no task running or paused, no emergency stop, error or open safeguard,
        Remote I/O the control device."""
        self.running = self.paused = self.estop = self.error = self.safeguard = False
        self.error_code, self.control_device = 0, 22

    def power_cycle(self) -> None:
        """The controller turned off and on: the six tables and LimZ cleared
        (§9.1, §10.26), the robot idle; everything else kept."""
        for name in _TABLES:
            getattr(self, name).clear()
        self.limz = 0
        self.stop()

    @classmethod
    def from_data(cls, data: EpsonData) -> SimState:
        """The controller a backup describes (a project's settings and points, or a
        pull's data), on the wire as the controller holds it: what the backup lacks
        is as a new controller has it (a table entry, Box, Plane or Local absent
        is not registered or off).  Raises ValueError for a robot the simulator
        cannot hold or a value that is not exact decimal text."""
        u = real_units
        state = cls(robot_type=data.robot_type, model=data.model)
        jrange: dict[int, Limits] = {}
        for key, value in data.items.items():
            kind, number = key.kind, key.number or 0
            if kind == "point":
                state.points[number] = Point.from_data(value)
            elif kind == "accel":
                state.accel[number] = (int(value.accel), int(value.decel))
            elif kind in ("accel_s", "accel_r"):
                getattr(state, kind)[number] = (u(value.accel), u(value.decel))
            elif kind == "speed":
                state.speed[number] = (int(value.speed), int(value.depart), int(value.approach))
            elif kind == "speed_s":
                state.speed_s[number] = (u(value.speed), u(value.depart), u(value.approach))
            elif kind == "speed_r":
                state.speed_r[number] = u(value)
            elif kind == "limz":
                state.limz = u(value)
            elif kind == "arch":
                state.arch[number] = (u(value.depart), u(value.approach))
            elif kind == "fine":
                state.fine = tuple(int(v) for v in value)
            elif kind == "weight":
                state.weight = (u(value.weight), u(value.arm_length))
            elif kind == "inertia":
                state.inertia = (u(value.inertia), u(value.eccentricity))
            elif kind == "tool":
                state.tool = int(value)
            elif kind in ("box", "xylim"):
                limits = three_axes(tuple((u(a.lower), u(a.upper)) for a in value))
                if kind == "xylim":
                    state.xylim = limits
                elif any(v for axis in limits for v in axis):
                    state.boxes[number] = limits
            elif kind in ("plane", "local"):
                coords = tuple(u(c) for c in value)
                if any(coords):
                    (state.planes if kind == "plane" else state.locals)[number] = coords
            elif kind == "base":
                state.base = tuple(u(c) for c in value)
            elif kind == "jrange":
                jrange[number] = (int(value.lower), int(value.upper))
            else:  # pragma: no cover - every kind is above
                raise ValueError(f"{kind}: not a setting the simulator holds")
        if jrange:
            default = _default_jrange(state.axes)
            state.jrange = tuple(jrange.get(j, default[j - 1]) for j in range(1, state.axes + 1))
        problems = state.problems()
        if problems:
            raise ValueError("; ".join(problems))
        return state

    def copy(self) -> SimState:
        """An independent copy (the tables and points are not shared)."""
        return replace(
            self,
            accel=dict(self.accel),
            accel_s=dict(self.accel_s),
            accel_r=dict(self.accel_r),
            speed=dict(self.speed),
            speed_s=dict(self.speed_s),
            speed_r=dict(self.speed_r),
            arch=dict(self.arch),
            boxes=dict(self.boxes),
            planes=dict(self.planes),
            locals=dict(self.locals),
            points={n: replace(p) for n, p in self.points.items()},
        )

    # --- a realistic robot -----------------------------------------------------------------

    @classmethod
    def generate(
        cls, seed: int, *, robot_type: int | None = None, point_range: tuple[int, int] = (0, 119)
    ) -> SimState:
        """A robot drawn from ``seed``: a SCARA (4 axes) or a six-axis arm unless
        ``robot_type`` says which, some entries of each table registered, the
        settings a plant leaves (arches, Fine, Weight, boxes, planes, locals,
        limits), and points in runs with gaps over ``point_range`` (by default
        beyond the P0-P99 a project backs up)."""
        rng = random.Random(seed)
        kind = robot_type if robot_type is not None else rng.choice((SCARA, SIX_AXIS))
        axes = profile.ROBOT_AXES[kind]
        draw = Draw(rng)  # each setting drawn in turn, in this order
        state = cls(
            robot_type=kind,
            model=rng.choice(_SCARA_MODELS if axes == 4 else _SIX_AXIS_MODELS),
            accel=draw.percent_pairs((2, 8)),
            accel_s=draw.real_pairs((1, 6), 100, 25000),
            accel_r=draw.real_pairs((0, 4), 100, 5000),
            speed=draw.percent_triples((2, 8)),
            speed_s=draw.real_triples((1, 6), 10, 2000),
            speed_r=draw.reals((0, 4), 10, 1000),
            limz=draw.limz(),
            arch={**DEFAULT_ARCH, **draw.arches()},
            fine=draw.fine(axes),
            weight=draw.weight(axes == 4),
            inertia=draw.inertia(),
            tool=rng.choice((0, 0, 1, 2, 3)),
            boxes={n: draw.box() for n in draw.some((0, 3), range(1, 16))},
            planes=draw.frames((0, 2), axes),
            locals=draw.frames((0, 4), axes),
            xylim=draw.xylim(),
            jrange=draw.jrange(axes),
            base=draw.base(axes),
        )
        state.points = draw.points(axes, point_range, sorted(state.locals))
        # the type's own attributes from a stream of their own (the rest stays as
        # each seed always drew it)
        extra = random.Random(seed ^ 0x1223)
        for point in state.points.values():
            if kind == SIX_AXIS:
                point.j1flag = extra.choice((0, 0, 0, 1))
                point.j2flag = extra.choice((0, 0, 0, 1))
            elif kind == RS:
                point.j1angle = extra.choice((0, 0, extra.randint(-180_000, 180_000)))
        return state


def three_axes(values: tuple[Limits, ...]) -> tuple[Limits, Limits, Limits]:
    """X, Y and Z limits (a Box area's, XYLim's).  Raises ValueError for another count."""
    if len(values) != 3:
        raise ValueError(f"{len(values)} axes, X, Y and Z needed")
    return values[0], values[1], values[2]


def _default_jrange(axes: int) -> tuple[Limits, ...]:
    return tuple((-2_000_000, 2_000_000) for _ in range(axes))
