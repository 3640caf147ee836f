"""A fake Epson robot behind the fake register bank: it answers the Remote Control
commands the family sends, from a state of its own, until the real simulator lands.

The words are made here by hand arithmetic, never by the codec under test: a real
value is ``round(x * 1000)`` as a 32-bit two's complement pair, high word first.
Split (S1/S2, R1/R2) and Rn writes take effect at their last command; any other
command in between cancels them silently, as the manual says.  A write that
arrives while Running, Paused, EStopOn or Error is 1 is recorded in
``busy_writes``; ``run_after_writes`` sets Running after that many writes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from .fakebank import FakeController

Words = tuple[int, ...]

NOT_REGISTERED = 0x2006
OUT_OF_RANGE = 0x2005
PARAMETER = 0x2004
UNSUPPORTED = 0x1000


def pair(units: int) -> tuple[int, int]:
    raw = units & 0xFFFFFFFF
    return raw >> 16, raw & 0xFFFF


def unpair(high: int, low: int) -> int:
    raw = high << 16 | low
    return raw - (1 << 32) if raw & 0x80000000 else raw


def mm(text: str) -> int:
    """``"-1.5"`` -> -1500 (test data only)."""
    sign = -1 if text.startswith("-") else 1
    whole, _, frac = text.lstrip("-").partition(".")
    return sign * (int(whole) * 1000 + int(frac.ljust(3, "0")[:3] or 0))


@dataclass
class RobotState:
    """What the controller holds; reals in thousandths, JRange in pulses."""

    robot_type: int = 3
    model: str = "LS6-B602S"
    axes: int = 4
    accel: dict[int, list[int]] = field(default_factory=dict)
    accel_s: dict[int, list[int]] = field(default_factory=dict)
    accel_r: dict[int, list[int]] = field(default_factory=dict)
    speed: dict[int, list[int]] = field(default_factory=dict)
    speed_s: dict[int, list[int]] = field(default_factory=dict)
    speed_r: dict[int, list[int]] = field(default_factory=dict)
    arch: dict[int, list[int]] = field(
        default_factory=lambda: {n: [30000, 30000] for n in range(7)}
    )
    fine: list[int] = field(default_factory=lambda: [10000] * 6)
    weight: list[int] = field(default_factory=lambda: [2000, 0])
    inertia: list[int] = field(default_factory=lambda: [5, 0])
    tool: int = 0
    box: dict[int, list[int]] = field(default_factory=lambda: {n: [0] * 6 for n in range(1, 16)})
    plane: dict[int, list[int]] = field(default_factory=lambda: {n: [0] * 6 for n in range(1, 16)})
    local: dict[int, list[int]] = field(default_factory=lambda: {n: [0] * 6 for n in range(1, 16)})
    xylim: list[int] = field(default_factory=lambda: [0] * 6)
    jrange: dict[int, list[int]] = field(
        default_factory=lambda: {j: [-100000, 100000] for j in range(1, 7)}
    )
    base: list[int] = field(default_factory=lambda: [0] * 6)
    limz: int = 0
    #: point -> its 6 coordinates, then hand, elbow, wrist, j4flag, j6flag, local
    points: dict[int, list[int]] = field(default_factory=dict)

    @classmethod
    def sample(cls, axes: int = 4) -> RobotState:
        """A robot with some of everything."""
        state = cls(
            robot_type=3 if axes == 4 else 5,
            model="LS6-B602S" if axes == 4 else "C4-A601S",
            axes=axes,
        )
        state.accel = {0: [100, 100], 1: [50, 40]}
        state.accel_s = {3: [mm("100.123"), mm("200")]}
        state.accel_r = {0: [mm("1000"), mm("1000")]}
        state.speed = {0: [100, 80, 80]}
        state.speed_s = {2: [mm("2000"), mm("1500.5"), mm("1000")]}
        state.speed_r = {0: [mm("720")]}
        state.box[5] = [mm("-10"), mm("10"), mm("-20"), mm("20"), mm("0"), mm("50")]
        state.plane[2] = [mm("100"), mm("200"), mm("-3.25"), mm("90"), 0, 0]
        state.local[1] = [mm("300"), mm("0"), mm("0"), mm("0"), 0, 0]
        state.xylim = [mm("-400"), mm("400"), mm("-400"), mm("400"), mm("-200"), mm("0")]
        state.limz = mm("-10")
        state.points = {
            0: [0, mm("400"), 0, 0, 0, 0, 1, 0, 0, 0, 0, 0],
            12: [mm("1"), mm("400"), mm("-10.5"), mm("90"), 0, 0, 0, 1, 0, 0, 0, 0],
            13: [mm("-1"), mm("300"), mm("-20"), 0, 0, 0, 1, 0, 1, 1, 5, 1],
        }
        return state

    def power_cycle(self) -> None:
        """Power off and on: the six tables cleared, LimZ 0, Fine its defaults."""
        for table in (
            self.accel,
            self.accel_s,
            self.accel_r,
            self.speed,
            self.speed_s,
            self.speed_r,
        ):
            table.clear()
        self.limz = 0
        self.fine = [10000] * 6


#: Write commands (they change the state), by number.
WRITES = frozenset(
    {
        1,
        53,
        54,
        55,
        103,
        104,
        105,
        151,
        203,
        204,
        205,
        251,
        300,
        301,
        350,
        351,
        352,
        400,
        401,
        402,
        450,
        451,
        452,
        500,
        600,
        601,
        602,
        650,
        700,
        750,
        751,
        752,
        800,
        801,
        802,
        850,
        1204,
        1206,
        1207,
        1208,
        1209,
        1210,
        1211,
        1212,
        1213,
        1214,
        1250,
    }
)
_BUSY = ("Running", "Paused", "EStopOn", "Error")


class FakeRobot:
    """The robot's command interpreter, on its own :class:`FakeController` (``bank``)."""

    def __init__(self, state: RobotState | None = None, **bank: object) -> None:
        self.state = state if state is not None else RobotState.sample()
        self.bank = FakeController(answer=self.answer, **bank)  # type: ignore[arg-type]
        #: every command answered, as its words (unused words dropped)
        self.commands: list[Words] = []
        self.busy_writes: list[Words] = []
        self.writes = 0
        self.run_after_writes: int | None = None
        self._pending: list[Words] = []
        self._name_at = 0

    def signal(self, name: str, on: bool = True) -> None:
        self.bank.set_signal(name, on)

    def written(self) -> list[Words]:
        return [w for w in self.commands if w[0] in WRITES]

    # --- the interpreter ------------------------------------------------------------------

    def answer(self, words: Words) -> tuple[bool, Words]:
        number = words[0]
        self.commands.append(words)
        if number in WRITES:
            if any(
                self.bank.inputs[bit.register] >> bit.bit & 1
                for name in _BUSY
                if (bit := self.bank.map.signal(name)) is not None
            ):
                self.busy_writes.append(words)
            self.writes += 1
            if self.run_after_writes is not None and self.writes >= self.run_after_writes:
                self.signal("Running")
            reply = self._write(words)
        else:
            self._pending = []
            reply = self._read(words)
        if isinstance(reply, int):
            return True, (number, reply, 0)
        return False, (number, *reply)

    def _read(self, w: Words) -> Words | int:
        s = self.state
        n, a, b = w[0], w[1], w[2]
        tables: dict[int, tuple[dict[int, list[int]], str]] = {
            3: (s.accel, "ints"),
            59: (s.accel_s, "reals"),
            60: (s.accel_s, "first"),
            61: (s.accel_s, "second"),
            109: (s.accel_r, "reals"),
            110: (s.accel_r, "first"),
            111: (s.accel_r, "second"),
            153: (s.speed, "ints"),
            209: (s.speed_s, "reals"),
            210: (s.speed_s, "first two"),
            211: (s.speed_s, "third"),
            253: (s.speed_r, "reals"),
        }
        if n in tables:
            table, how = tables[n]
            if a > 15:
                return OUT_OF_RANGE
            if a not in table:
                return NOT_REGISTERED
            v = table[a]
            picked = {
                "ints": v,
                "reals": v,
                "first": v[:1],
                "second": v[1:2],
                "first two": v[:2],
                "third": v[2:],
            }[how]
            if how == "ints":
                return (a, *picked)
            return (a, *_reals(picked))
        singles: dict[int, Callable[[], Words]] = {
            302: lambda: _reals(s.weight),
            353: lambda: _reals(s.inertia),
            354: lambda: _reals(s.inertia[:1]),
            355: lambda: _reals(s.inertia[1:]),
            453: lambda: tuple(s.fine[: s.axes]),
            454: lambda: tuple(s.fine[:3]),
            455: lambda: tuple(s.fine[3 : s.axes]),
            501: lambda: (s.tool,),
            1251: lambda: _reals([s.limz]),
            2153: lambda: (s.robot_type,),
            2155: lambda: (0,),  # no controller error
            2156: lambda: (22,),  # Remote I/O, the control device
        }
        if n in singles:
            return singles[n]()
        if n in (403, 404, 405):
            if a not in s.arch:
                return PARAMETER
            v = s.arch[a]
            return (a, *_reals({403: v, 404: v[:1], 405: v[1:]}[n]))
        if n in (603, 604, 605):
            if a not in s.box or b > 2:
                return PARAMETER
            lo, hi = s.box[a][2 * b], s.box[a][2 * b + 1]
            return (a, b, *_reals({603: [lo, hi], 604: [lo], 605: [hi]}[n]))
        if n in (651, 701):
            frames = s.plane if n == 651 else s.local
            if a not in frames or b >= s.axes:
                return PARAMETER
            return (a, b, *_reals([frames[a][b]]))
        if n in (753, 754, 755):
            if a > 2:
                return PARAMETER
            lo, hi = s.xylim[2 * a], s.xylim[2 * a + 1]
            return (a, *_reals({753: [lo, hi], 754: [lo], 755: [hi]}[n]))
        if n in (803, 804, 805):
            if not 1 <= a <= s.axes:
                return PARAMETER
            lo, hi = s.jrange[a]
            return (a, *_reals({803: [lo, hi], 804: [lo], 805: [hi]}[n]))
        if n == 851:
            return PARAMETER if a >= s.axes else (a, *_reals([s.base[a]]))
        if 1215 <= n <= 1220:
            if a not in s.points:
                return PARAMETER
            return (s.points[a][6 + n - 1215],)
        if n == 1222:
            if a not in s.points or b >= s.axes:
                return PARAMETER
            return _reals([s.points[a][b]])
        if n == 2154:
            if a:
                self._name_at = 0
            if self._name_at >= len(s.model):
                return (2, 0)
            char = ord(s.model[self._name_at])
            self._name_at += 1
            return (0 if self._name_at == len(s.model) else 1, char)
        return UNSUPPORTED

    # --- writes -----------------------------------------------------------------------------

    def _write(self, w: Words) -> Words | int:
        """A write: applied now, or at the last command of its sequence."""
        step = _sequence_step(w, self.state.axes)
        if step is None:
            self._pending = []
            return self._apply([w])
        group, index, length = step
        if index == 0 or not (
            self._pending
            and _sequence_step(self._pending[0], self.state.axes)[0] == group  # type: ignore[index]
            and len(self._pending) == index
        ):
            self._pending = []
            if index != 0:
                return (0, 0)  # an orphan second half: cancelled, silently
        self._pending.append(w)
        if len(self._pending) < length:
            return (0, 0)
        done, self._pending = self._pending, []
        return self._apply(done)

    def _apply(self, ws: list[Words]) -> Words | int:
        s = self.state
        w = ws[0]
        n, a = w[0], w[1]
        if n in (1, 151):
            if a > 15:
                return OUT_OF_RANGE
            count = 2 if n == 1 else 3
            (s.accel if n == 1 else s.speed)[a] = list(w[2 : 2 + count])
        elif n in (53, 103, 203):
            table = {53: s.accel_s, 103: s.accel_r, 203: s.speed_s}[n]
            table[a] = _units(w[2 : 2 + (4 if n != 203 else 6)])
        elif n in (54, 104, 204):
            table = {54: s.accel_s, 104: s.accel_r, 204: s.speed_s}[n]
            table[a] = _units(w[2 : 2 + (2 if n != 204 else 4)]) + _units(ws[1][2:4])
        elif n == 251:
            s.speed_r[a] = _units(w[2:4])
        elif n == 300:
            s.weight = _units(w[1:5])
        elif n == 301:
            s.weight = [*_units(w[1:3]), s.weight[1]]
        elif n == 350:
            s.inertia = _units(w[1:5])
        elif n == 351:
            s.inertia = _units(w[1:3]) + _units(ws[1][1:3])
        elif n == 400:
            s.arch[a] = _units(w[2:6])
        elif n == 401:
            s.arch[a] = _units(w[2:4]) + _units(ws[1][2:4])
        elif n == 450:
            s.fine[: s.axes] = list(w[1 : 1 + s.axes])
        elif n == 451:
            s.fine[: s.axes] = [*w[1:4], *ws[1][1 : s.axes - 2]]
        elif n == 500:
            s.tool = a
        elif n == 600:
            s.box[a] = [v for c in ws for v in _units(c[3:7])]
        elif n == 601:
            lows, highs = ws[:3], ws[3:]
            s.box[a] = [v for lo, hi in zip(lows, highs) for v in _units(lo[3:5]) + _units(hi[3:5])]
        elif n in (650, 700):
            frames = s.plane if n == 650 else s.local
            frames[a][: s.axes] = [_units(c[3:5])[0] for c in ws]
        elif n == 750:
            s.xylim = [v for c in ws for v in _units(c[2:6])]
        elif n == 751:
            lows, highs = ws[:3], ws[3:]
            s.xylim = [v for lo, hi in zip(lows, highs) for v in _units(lo[2:4]) + _units(hi[2:4])]
        elif n == 800:
            s.jrange[a] = _units(w[2:6])
        elif n == 801:
            s.jrange[a] = _units(w[2:4]) + _units(ws[1][2:4])
        elif n == 850:
            s.base[: s.axes] = [_units(c[2:4])[0] for c in ws]
        elif n == 1204:
            axis = w[2] & 0x7
            point = s.points.setdefault(a, [0] * 12)
            point[axis] = _units(w[3:5])[0]
        elif 1206 <= n <= 1214:
            if a not in s.points:
                return PARAMETER
            fixed = {
                1206: (6, 1),
                1207: (6, 0),
                1208: (7, 0),
                1209: (7, 1),
                1210: (8, 1),
                1211: (8, 0),
            }
            if n in fixed:
                at, value = fixed[n]
                s.points[a][at] = value
            else:
                at = {1212: 9, 1213: 10, 1214: 11}[n]
                s.points[a][at] = w[2] & (0xF if n == 1214 else 0xFFFF)
        elif n == 1250:
            s.limz = _units(w[1:3])[0]
        else:
            return UNSUPPORTED
        return (0, 0)


def _reals(units: list[int]) -> Words:
    return tuple(word for u in units for word in pair(u))


def _units(words: Words) -> list[int]:
    return [unpair(words[i], words[i + 1]) for i in range(0, len(words), 2)]


def _sequence_step(w: Words, axes: int) -> tuple[tuple[int, ...], int, int] | None:
    """(group, index, length) of a command that is part of a multi-command write."""
    n, a, b = w[0], w[1], w[2]
    halves = {54: 55, 104: 105, 204: 205, 351: 352, 401: 402, 451: 452, 801: 802}
    for first, second in halves.items():
        if n in (first, second):
            same = a if n not in (351, 352, 451, 452) else 0
            return (first, same), int(n == second), 2
    if n == 600:
        return (600, a), b, 3
    if n in (601, 602):
        return (601, a), b + 3 * (n == 602), 6
    if n in (650, 700):
        return (n, a), b, axes
    if n == 750:
        return (750,), a, 3
    if n in (751, 752):
        return (751,), a + 3 * (n == 752), 6
    if n == 850:
        return (850,), a, axes
    return None
