"""The controller's side of the Remote Control command words, written from the
manual (§7, §8, §10) and the profile, not from the client's codec: a command
the client encodes wrongly gets the error a controller would give it.

How this works::

    command words (latched at the request)        response words (from word 0)
    number  param 1 .. param 7   ------------>    echo  data ...              read
            unused words 0 (profile)              echo  0000H 0000H           set/register
                                                  echo  code  detail          error (ExtCmdResult 1)

    number off the command set ........................ 1000 (recorded as off-list)
    more words than the map's command words ........... 2002
    a word after the command's own words not 0 ........ 2004 (the profile: unused words 0)
    a parameter out of range .......................... 2004; a table number over 15: 2005
    a table entry never registered .................... 2006; an undefined point: 2004
    a later step of a split or Rn write out of turn ... 1002 (command sequence error)
    a response longer than the map's response words ... 2003

Split writes (S1/S2, R1/R2: 54/55, 104/105, 204/205, 351/352, 401/402,
451/452, 601/602, 751/752, 801/802) and Rn sequences (600, 650, 700, 750,
850: one axis a command, in order X, Y, Z ...) take effect at their last
step.  Any other command in between cancels them silently (the profile); a
later step that does not follow its earlier ones is refused with 1002 and
cancels the sequence (§10.2 "an error response will be returned", §10.13
"values received at that point will be canceled and an error response will be
returned").

Only the two's complement word conversions are shared with the codec
(:func:`~harlsync.families.epson.protocol.int32_from_words`, ``int32_to_words``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import NamedTuple

from .. import profile
from ..protocol import int32_from_words, int32_to_words
from .state import MAX_POINT, RS, SIX_AXIS, Point, SimState

__all__ = [
    "COMMAND_SET",
    "COMMAND_WORDS",
    "EXECUTION",
    "FUNCTION_ERROR",
    "MESSAGE_FAILURE",
    "NORMAL",
    "PARAMETER",
    "PRINT_ERROR",
    "READS",
    "REQUEST_WHILE_EXECUTING",
    "RESPONSE_WORDS",
    "SEQUENCE",
    "UNSUPPORTED",
    "WRITES",
    "Outcome",
    "PointAnswers",
    "Session",
]

log = logging.getLogger(__name__)

# --- §7.1 Response 1 and §7.2.3 Response 2 codes -----------------------------------------

NORMAL = 0x0000
UNSUPPORTED = 0x1000
SEQUENCE = 0x1002
EXECUTION = 0x2000
COMMAND_WORDS = 0x2002
RESPONSE_WORDS = 0x2003
PARAMETER = 0x2004
FUNCTION_ERROR = 0x9999
#: Function error details: a request while a command executes (external, a
#: function reset clears it), and the two the controller causes (a controller
#: reset clears them).
REQUEST_WHILE_EXECUTING = 0x0001
MESSAGE_FAILURE = 0x9901
PRINT_ERROR = 0x9902

#: The fewest response words the controller sets (§7: an error response is 3).
_MIN_RESPONSE = 3
_WORD = 0xFFFF


class _Refused(Exception):
    """The command is answered with an error response carrying ``code`` (Response 1)
    and ``detail`` (Response 2)."""

    def __init__(self, code: int, detail: int = 0) -> None:
        super().__init__(f"{code:04X}/{detail:04X}")
        self.code = code
        self.detail = detail


class PointAnswers(NamedTuple):
    """How a controller answers for points where the manual is silent (the
    simulator's variants, :data:`~.device.SIM_FAMILY`): Response 1 and 2 of a point
    not defined, of a point number past its point table, and the table's last point."""

    undefined: tuple[int, int] = (profile.UNDEFINED_POINT, 0)
    past_table: tuple[int, int] = (PARAMETER, 0)
    last: int = MAX_POINT


@dataclass(frozen=True)
class Outcome:
    """What the controller made of one command."""

    number: int
    #: the response words from word 0 (the echo), as the controller sets them
    response: tuple[int, ...]
    #: ExtCmdResult: an error response (Response 1 is the code)
    error: bool
    #: a write command (everything off the command set counts as one)
    is_write: bool
    #: whether the number is in the command set (the backup reads and deploy writes)
    known: bool
    #: a write whose last step was carried out: the robot changed
    took_effect: bool = False
    #: a later step of a split or Rn write, taken as part of its sequence
    continuation: bool = False

    @property
    def code(self) -> int:
        """Response 1 of an error response; 0 for a normal one."""
        return self.response[1] if self.error else NORMAL


class _Params:
    """The parameters of one command (word 1 on), read as the manual lays them out."""

    def __init__(self, words: Sequence[int]) -> None:
        self.words = words

    def word(self, i: int) -> int:
        return self.words[i] if i < len(self.words) else 0

    def number(self, i: int, low: int, high: int) -> int:
        value = self.word(i)
        if not low <= value <= high:
            raise _Refused(PARAMETER)
        return value

    def table(self, i: int = 1) -> int:
        """A speed/accel table number: over 15 answers 2005 (the profile)."""
        value = self.word(i)
        if value > 15:
            raise _Refused(profile.TABLE_OUT_OF_RANGE)
        return value

    def int32(self, i: int) -> int:
        """Parameters ``i`` (high word) and ``i + 1`` as a 32-bit two's complement integer."""
        return int32_from_words(self.word(i), self.word(i + 1))

    def at_least(self, i: int, low: int) -> int:
        value = self.int32(i)
        if value < low:
            raise _Refused(PARAMETER)
        return value


def _w(value: int) -> tuple[int, int]:
    """A 32-bit value as its two response words, high first."""
    return int32_to_words(value)


def _ws(values: tuple[int, ...], which: slice = slice(None)) -> tuple[int, ...]:
    """Some of ``values`` (32-bit each) as their response words, two a value."""
    return tuple(w for value in values[which] for w in _w(value))


@dataclass
class _Sequence:
    """A split or Rn write under way: the steps it takes, the values so far."""

    key: tuple[object, ...]
    steps: tuple[tuple[int, int], ...]
    values: list[tuple[int, ...]]
    apply: Callable[[list[tuple[int, ...]]], None]


Handler = Callable[["Session", SimState, _Params], tuple[int, ...]]


class _Spec(NamedTuple):
    #: command words, word 0 included, for a robot of so many axes
    words: Callable[[int], int]
    handler: Handler


def _fixed(count: int) -> Callable[[int], int]:
    return lambda axes: count


class Session:
    """The command handling of one controller: what it keeps between commands
    (a split or Rn write under way, the model name read so far), not the
    robot's state, which each call is given."""

    def __init__(self) -> None:
        self.pending: _Sequence | None = None
        self._name_at: int | None = None
        #: how points not there are answered (set by the simulator before each command)
        self.points = PointAnswers()
        #: commands of the set this controller lacks (an older firmware): answered 1000
        self.lacks: frozenset[int] = frozenset()
        self._before: _Sequence | None = None
        self._took_effect = False
        self._continuation = False

    def reset(self) -> None:
        """As a controller comes up: no write under way, no name being read."""
        self.pending = None
        self._name_at = None

    def execute(
        self,
        state: SimState,
        words: Sequence[int],
        *,
        command_words: int = 8,
        response_words: int = 8,
    ) -> Outcome:
        """Carry out the command in ``words`` (word 0 its number) on ``state``;
        ``command_words`` and ``response_words`` are how many words the
        controller's map assigns (§5.3)."""
        number = words[0] if words else 0
        # Any command cancels a split or Rn write under way, unless it is its next step.
        self._before, self.pending = self.pending, None
        self._took_effect = self._continuation = False
        spec = _COMMANDS.get(number)
        is_write = number not in READS
        if spec is None:
            log.warning(
                "sim: command %d is off the command set: refused with %04X", number, UNSUPPORTED
            )
            return Outcome(number, (number, UNSUPPORTED, 0), True, True, False)
        if number in self.lacks:
            return Outcome(number, (number, UNSUPPORTED, 0), True, is_write, True)
        try:
            need = spec.words(state.axes)
            if need > command_words:
                raise _Refused(COMMAND_WORDS)
            if any(words[need:]):  # the profile: unused command words are 0
                raise _Refused(PARAMETER)
            data = spec.handler(self, state, _Params(words))
            response = (number, *data) if data else (number, NORMAL, 0)
            response += (0,) * (_MIN_RESPONSE - len(response))
            if len(response) > response_words:
                raise _Refused(RESPONSE_WORDS)
        except _Refused as refusal:
            self.pending = None
            return Outcome(number, (number, refusal.code, refusal.detail), True, is_write, True)
        return Outcome(
            number, response, False, is_write, True, self._took_effect, self._continuation
        )

    # --- split and Rn writes ---------------------------------------------------------------

    def _sequence(
        self,
        key: tuple[object, ...],
        steps: tuple[tuple[int, int], ...],
        step: tuple[int, int],
        values: tuple[int, ...],
        apply: Callable[[list[tuple[int, ...]]], None],
    ) -> tuple[int, ...]:
        """One step of a write that takes several commands; it takes effect at the last."""
        index = steps.index(step)
        if index == 0:
            sequence = _Sequence(key, steps, [values], apply)
        else:
            sequence_ = self._before
            if (
                sequence_ is None
                or sequence_.key != key
                or sequence_.steps != steps
                or len(sequence_.values) != index
            ):
                raise _Refused(SEQUENCE)
            sequence = sequence_
            sequence.values.append(values)
            self._continuation = True
        if len(sequence.values) == len(steps):
            sequence.apply(sequence.values)
            self._took_effect = True
        else:
            self.pending = sequence
        return ()

    def _split(
        self,
        key: tuple[object, ...],
        first: int,
        second: int,
        number: int,
        values: tuple[int, ...],
        apply: Callable[[tuple[int, ...], tuple[int, ...]], None],
    ) -> tuple[int, ...]:
        """S1/S2 or R1/R2: ``first`` then ``second``."""
        return self._sequence(
            key, ((first, 0), (second, 0)), (number, 0), values, lambda v: apply(v[0], v[1])
        )

    def _done(self) -> tuple[int, ...]:
        """A write carried out in one command."""
        self._took_effect = True
        return ()

    # --- the six tables (§10.1-10.6) -------------------------------------------------------

    def _accel(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t = p.table()
        entry = _registered(st.accel, t)
        return (t, *entry)

    def _register_accel(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t, accel, decel = p.table(), p.number(2, 1, _WORD), p.number(3, 1, _WORD)
        st.accel[t] = (accel, decel)
        return self._done()

    def _real_pair_read(
        self, table: dict[int, tuple[int, int]], p: _Params, which: slice
    ) -> tuple[int, ...]:
        t = p.table()
        entry = _registered(table, t)
        return (t, *_ws(entry, which))

    def _real_pair_write(self, table: dict[int, tuple[int, int]], p: _Params) -> tuple[int, ...]:
        t, accel, decel = p.table(), p.at_least(2, 1), p.at_least(4, 1)
        table[t] = (accel, decel)
        return self._done()

    def _real_pair_split(
        self, name: str, table: dict[int, tuple[int, int]], first: int, p: _Params
    ) -> tuple[int, ...]:
        number = p.word(0)
        t, value = p.table(), p.at_least(2, 1)

        def apply(accel: tuple[int, ...], decel: tuple[int, ...]) -> None:
            table[t] = (accel[0], decel[0])

        return self._split((name, t), first, first + 1, number, (value,), apply)

    def _speed(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t = p.table()
        return (t, *_registered(st.speed, t))

    def _register_speed(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t = p.table()
        st.speed[t] = (p.number(2, 1, 100), p.number(3, 1, 100), p.number(4, 1, 100))
        return self._done()

    def _speed_s(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        t = p.table()
        entry = _registered(st.speed_s, t)
        return (t, *_ws(entry, which))

    def _register_speed_s(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t = p.table()
        st.speed_s[t] = (p.at_least(2, 1), p.at_least(4, 1), p.at_least(6, 1))
        return self._done()

    def _register_speed_s_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        number, t = p.word(0), p.table()
        values = (p.at_least(2, 1), p.at_least(4, 1)) if number == 204 else (p.at_least(2, 1),)

        def apply(first: tuple[int, ...], second: tuple[int, ...]) -> None:
            st.speed_s[t] = (first[0], first[1], second[0])

        return self._split(("SpeedS", t), 204, 205, number, values, apply)

    def _speed_r(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t = p.table()
        return (t, *_ws(_registered(st.speed_r, t)))

    def _register_speed_r(self, st: SimState, p: _Params) -> tuple[int, ...]:
        t = p.table()
        st.speed_r[t] = p.at_least(2, 1)
        return self._done()

    # --- Weight, Inertia, Arch, Fine, Tool (§10.7-10.11) ----------------------------------

    def _weight(self, st: SimState, p: _Params) -> tuple[int, ...]:
        return _ws(st.weight)

    def _set_weight(self, st: SimState, p: _Params) -> tuple[int, ...]:
        weight = p.at_least(1, 0)
        # The arm length is a SCARA's (§10.7: "invalid for the models other than
        # the SCARA"): another robot keeps 0.
        arm = p.at_least(3, 0) if p.word(0) == 300 else st.weight[1]
        st.weight = (weight, arm if st.has_arm_length else 0)
        return self._done()

    def _inertia(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        return _ws(st.inertia, which)

    def _set_inertia(self, st: SimState, p: _Params) -> tuple[int, ...]:
        st.inertia = (p.at_least(1, 0), p.at_least(3, 0))
        return self._done()

    def _set_inertia_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        def apply(inertia: tuple[int, ...], eccentricity: tuple[int, ...]) -> None:
            st.inertia = (inertia[0], eccentricity[0])

        return self._split(("Inertia",), 351, 352, p.word(0), (p.at_least(1, 0),), apply)

    def _arch(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        a = p.number(1, 0, 6)
        return (a, *_ws(st.arch[a], which))

    def _set_arch(self, st: SimState, p: _Params) -> tuple[int, ...]:
        a = p.number(1, 0, 6)
        st.arch[a] = (p.at_least(2, 0), p.at_least(4, 0))
        return self._done()

    def _set_arch_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        a = p.number(1, 0, 6)

        def apply(depart: tuple[int, ...], approach: tuple[int, ...]) -> None:
            st.arch[a] = (depart[0], approach[0])

        return self._split(("Arch", a), 401, 402, p.word(0), (p.at_least(2, 0),), apply)

    def _fine(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        return st.fine[which]  # a 4-axis robot has no joints 5 and 6 to answer

    def _set_fine(self, st: SimState, p: _Params) -> tuple[int, ...]:
        st.fine = tuple(p.word(1 + j) for j in range(st.axes))
        return self._done()

    def _set_fine_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        number = p.word(0)
        count = 3 if number == 451 else st.axes - 3

        def apply(first: tuple[int, ...], second: tuple[int, ...]) -> None:
            st.fine = first + second

        return self._split(
            ("Fine",), 451, 452, number, tuple(p.word(1 + j) for j in range(count)), apply
        )

    def _tool(self, st: SimState, p: _Params) -> tuple[int, ...]:
        return (st.tool,)

    def _select_tool(self, st: SimState, p: _Params) -> tuple[int, ...]:
        st.tool = p.number(1, 0, 15)
        return self._done()

    # --- Box, Plane, Local, XYLim, JRange, Base (§10.13-10.18) ----------------------------

    def _box(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        area, axis = p.number(1, 1, 15), p.number(2, 0, 2)
        limits = st.boxes.get(area, ((0, 0), (0, 0), (0, 0)))[axis]
        return (area, axis, *_ws(limits, which))

    def _set_box(self, st: SimState, p: _Params) -> tuple[int, ...]:
        area, axis = p.number(1, 1, 15), p.number(2, 0, 2)

        def apply(values: list[tuple[int, ...]]) -> None:
            st.boxes[area] = (
                (values[0][0], values[0][1]),
                (values[1][0], values[1][1]),
                (values[2][0], values[2][1]),
            )

        return self._sequence(
            ("Box", area),
            ((600, 0), (600, 1), (600, 2)),
            (600, axis),
            (p.int32(3), p.int32(5)),
            apply,
        )

    def _set_box_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        number, area, axis = p.word(0), p.number(1, 1, 15), p.number(2, 0, 2)

        def apply(values: list[tuple[int, ...]]) -> None:
            st.boxes[area] = (
                (values[0][0], values[3][0]),
                (values[1][0], values[4][0]),
                (values[2][0], values[5][0]),
            )

        steps = tuple((n, a) for n in (601, 602) for a in range(3))
        return self._sequence(("Box", area), steps, (number, axis), (p.int32(3),), apply)

    def _frame(
        self, frames: dict[int, tuple[int, ...]], st: SimState, p: _Params
    ) -> tuple[int, ...]:
        n, coord = p.number(1, 1, 15), p.number(2, 0, st.axes - 1)
        return (n, coord, *_w(frames.get(n, (0,) * st.axes)[coord]))

    def _set_frame(
        self, name: str, frames: dict[int, tuple[int, ...]], st: SimState, p: _Params
    ) -> tuple[int, ...]:
        number, n, coord = p.word(0), p.number(1, 1, 15), p.number(2, 0, st.axes - 1)

        def apply(values: list[tuple[int, ...]]) -> None:
            frames[n] = tuple(v[0] for v in values)

        steps = tuple((number, c) for c in range(st.axes))
        return self._sequence((name, n), steps, (number, coord), (p.int32(3),), apply)

    def _xylim(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        axis = p.number(1, 0, 2)
        return (axis, *_ws(st.xylim[axis], which))

    def _set_xylim(self, st: SimState, p: _Params) -> tuple[int, ...]:
        axis = p.number(1, 0, 2)

        def apply(values: list[tuple[int, ...]]) -> None:
            st.xylim = (
                (values[0][0], values[0][1]),
                (values[1][0], values[1][1]),
                (values[2][0], values[2][1]),
            )

        return self._sequence(
            ("XYLim",), ((750, 0), (750, 1), (750, 2)), (750, axis), (p.int32(2), p.int32(4)), apply
        )

    def _set_xylim_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        number, axis = p.word(0), p.number(1, 0, 2)

        def apply(values: list[tuple[int, ...]]) -> None:
            st.xylim = (
                (values[0][0], values[3][0]),
                (values[1][0], values[4][0]),
                (values[2][0], values[5][0]),
            )

        steps = tuple((n, a) for n in (751, 752) for a in range(3))
        return self._sequence(("XYLim",), steps, (number, axis), (p.int32(2),), apply)

    def _jrange(self, st: SimState, p: _Params, which: slice) -> tuple[int, ...]:
        joint = p.number(1, 1, st.axes)
        return (joint, *_ws(st.jrange[joint - 1], which))

    def _set_jrange(self, st: SimState, p: _Params) -> tuple[int, ...]:
        joint = p.number(1, 1, st.axes)
        _set_joint(st, joint, (p.int32(2), p.int32(4)))
        return self._done()

    def _set_jrange_split(self, st: SimState, p: _Params) -> tuple[int, ...]:
        joint = p.number(1, 1, st.axes)

        def apply(lower: tuple[int, ...], upper: tuple[int, ...]) -> None:
            _set_joint(st, joint, (lower[0], upper[0]))

        return self._split(("JRange", joint), 801, 802, p.word(0), (p.int32(2),), apply)

    def _base(self, st: SimState, p: _Params) -> tuple[int, ...]:
        coord = p.number(1, 0, st.axes - 1)
        return (coord, *_w(st.base[coord]))

    def _set_base(self, st: SimState, p: _Params) -> tuple[int, ...]:
        coord = p.number(1, 0, st.axes - 1)

        def apply(values: list[tuple[int, ...]]) -> None:
            st.base = tuple(v[0] for v in values)

        steps = tuple((850, c) for c in range(st.axes))
        return self._sequence(("Base",), steps, (850, coord), (p.int32(2),), apply)

    # --- points (§10.25), LimZ (§10.26), the robot (§8.5) -----------------------------------

    def _point_number(self, p: _Params, i: int = 1) -> int:
        """The point number parameter ``i`` gives; one past the point table answers as
        :attr:`PointAnswers.past_table` (a variant: the manual does not say)."""
        number = p.word(i)
        if number > self.points.last:
            raise _Refused(*self.points.past_table)
        return number

    def _point(self, st: SimState, p: _Params, i: int = 1) -> Point:
        """The point parameter ``i`` names; an undefined one answers as
        :attr:`PointAnswers.undefined` (2004 by default, the profile's guess)."""
        point = st.points.get(self._point_number(p, i))
        if point is None:
            raise _Refused(*self.points.undefined)
        return point

    def _point_coord(self, st: SimState, p: _Params) -> tuple[int, ...]:
        point, axis = self._point(st, p), p.number(2, 0, st.axes - 1)
        return _w(point.coords[axis])  # neither the point nor the axis is echoed

    def _set_point_coord(self, st: SimState, p: _Params) -> tuple[int, ...]:
        number, selector = self._point_number(p), p.word(2)
        if selector & ~0x7 or selector >= st.axes:  # bits 15-3 reserved: 0
            raise _Refused(PARAMETER)
        value = p.int32(3)
        point = st.points.setdefault(number, Point((0,) * st.axes))  # the first defines it
        point.coords = tuple(value if i == selector else c for i, c in enumerate(point.coords))
        return self._done()

    def _set_point_local(self, st: SimState, p: _Params) -> tuple[int, ...]:
        point, word = self._point(st, p), p.word(2)
        if word & 0x8000:
            # "convert": the coordinates become the local's.  The simulator has no
            # kinematics to convert them with, and harlsync never asks for it.
            raise _Refused(EXECUTION)
        if word & 0x7FF0 or not 1 <= word & 0xF <= 15:
            raise _Refused(PARAMETER)
        point.local = word & 0xF
        return self._done()

    def _type_point(self, st: SimState, p: _Params, types: tuple[int, ...]) -> Point:
        """The point of a command "available for" only some manipulators (1223-1228:
        6-axis, RS); another type's controller cannot execute it (error 2000)."""
        if st.robot_type not in types:
            raise _Refused(EXECUTION)
        return self._point(st, p)

    def _j1angle(self, st: SimState, p: _Params) -> tuple[int, ...]:
        return _w(self._type_point(st, p, (RS,)).j1angle)

    def _set_j1angle(self, st: SimState, p: _Params) -> tuple[int, ...]:
        """1227: parameter 1 0 omits the value, 1 uses it; parameter 2 the point."""
        if st.robot_type != RS:
            raise _Refused(EXECUTION)
        option = p.number(1, 0, 1)
        point = self._point(st, p, 2)
        if option:
            point.j1angle = p.int32(3)
        return self._done()

    def _limz(self, st: SimState, p: _Params) -> tuple[int, ...]:
        return _w(st.limz)

    def _set_limz(self, st: SimState, p: _Params) -> tuple[int, ...]:
        st.limz = p.int32(1)
        return self._done()

    def _controller_error(self, st: SimState, p: _Params) -> tuple[int, ...]:
        """2155: the error code, 0000H in the normal state."""
        return (st.error_code,)

    def _control_device(self, st: SimState, p: _Params) -> tuple[int, ...]:
        """2156: the control device, 22 (Remote I/O) in the normal state."""
        return (st.control_device,)

    def _robot_type(self, st: SimState, p: _Params) -> tuple[int, ...]:
        return (st.robot_type,)

    def _model_name(self, st: SimState, p: _Params) -> tuple[int, ...]:
        """2154: one character a call; status 1 more follow, 0 the last, 2 done."""
        word = p.word(1)
        if word & ~1:  # bits 15-1 reserved: 0
            raise _Refused(PARAMETER)
        at = 0 if word & 1 else self._name_at
        if at is None or at >= len(st.model):
            self._name_at = len(st.model)
            return (2, 0)
        self._name_at = at + 1
        return (1 if at + 1 < len(st.model) else 0, ord(st.model[at]))


def _registered(
    table: Mapping[int, tuple[int, ...]] | Mapping[int, int], t: int
) -> tuple[int, ...]:
    entry = table.get(t)
    if entry is None:
        raise _Refused(profile.TABLE_NOT_REGISTERED)
    return entry if isinstance(entry, tuple) else (entry,)


def _set_joint(st: SimState, joint: int, limits: tuple[int, int]) -> None:
    st.jrange = tuple(limits if j == joint else old for j, old in enumerate(st.jrange, 1))


def _point_attribute(name: str) -> Handler:
    """1215-1220: one attribute of a point."""

    def read(session: Session, st: SimState, p: _Params) -> tuple[int, ...]:
        value: int = getattr(session._point(st, p), name)
        return (value,)

    return read


def _set_point_flag(name: str, value: int) -> Handler:
    """1206-1211: a command a value, the point its only parameter."""

    def write(session: Session, st: SimState, p: _Params) -> tuple[int, ...]:
        setattr(session._point(st, p), name, value)
        return session._done()

    return write


def _set_point_number(name: str, high: int, types: tuple[int, ...] = ()) -> Handler:
    """1212, 1213 (1223, 1225 on ``types`` only): the value in parameter 2."""

    def write(session: Session, st: SimState, p: _Params) -> tuple[int, ...]:
        point = session._type_point(st, p, types) if types else session._point(st, p)
        setattr(point, name, p.number(2, 0, high))
        return session._done()

    return write


def _type_attribute(name: str, types: tuple[int, ...]) -> Handler:
    """1224, 1226: an attribute only ``types`` of manipulator have."""

    def read(session: Session, st: SimState, p: _Params) -> tuple[int, ...]:
        value: int = getattr(session._type_point(st, p, types), name)
        return (value,)

    return read


Parted = Callable[[Session, SimState, _Params, slice], tuple[int, ...]]
#: An entry's two values, its first, its second.
_HALVES = (slice(0, 2), slice(0, 1), slice(1, 2))


def _parts(
    first: int, words: int, read: Parted, parts: tuple[slice, slice, slice] = _HALVES
) -> dict[int, tuple[int, Handler]]:
    """A read of a whole entry (``first``) and of its parts (``first + 1``, ``+ 2``:
    59 an AccelS entry, 60 its accel, 61 its decel), ``words`` command words each."""

    def part(which: slice) -> Handler:
        return lambda s, st, p: read(s, st, p, which)

    return {first + i: (words, part(which)) for i, which in enumerate(parts)}


#: Command words, word 0 included: a number, or one a robot's axes give.
WordCount = int | Callable[[int], int]


def _with_halves(
    first: int, words: tuple[WordCount, WordCount, WordCount], whole: Handler, half: Handler
) -> dict[int, tuple[WordCount, Handler]]:
    """A write in one command (``first``) and in two halves (``first + 1``, ``+ 2``:
    53 an AccelS entry, 54 its accel, 55 its decel)."""
    return {first: (words[0], whole), first + 1: (words[1], half), first + 2: (words[2], half)}


def _commands() -> dict[int, _Spec]:
    S = Session
    reads: dict[int, tuple[int, Handler]] = {
        3: (2, S._accel),
        **_parts(59, 2, lambda s, st, p, which: s._real_pair_read(st.accel_s, p, which)),
        **_parts(109, 2, lambda s, st, p, which: s._real_pair_read(st.accel_r, p, which)),
        153: (2, S._speed),
        **_parts(209, 2, S._speed_s, (slice(0, 3), slice(0, 2), slice(2, 3))),
        253: (2, S._speed_r),
        302: (1, S._weight),
        **_parts(353, 1, S._inertia),
        **_parts(403, 2, S._arch),
        **_parts(453, 1, S._fine, (slice(0, 6), slice(0, 3), slice(3, 6))),
        501: (1, S._tool),
        **_parts(603, 3, S._box),
        651: (3, lambda s, st, p: s._frame(st.planes, st, p)),
        701: (3, lambda s, st, p: s._frame(st.locals, st, p)),
        **_parts(753, 2, S._xylim),
        **_parts(803, 2, S._jrange),
        851: (2, S._base),
        **{
            1215 + i: (2, _point_attribute(name))  # 1215 hand ... 1220 local
            for i, name in enumerate(("hand", "elbow", "wrist", "j4flag", "j6flag", "local"))
        },
        1222: (3, S._point_coord),
        1224: (2, _type_attribute("j1flag", (SIX_AXIS,))),
        1226: (2, _type_attribute("j2flag", (SIX_AXIS,))),
        1228: (2, S._j1angle),
        1251: (1, S._limz),
        2153: (1, S._robot_type),
        2154: (2, S._model_name),
        2155: (1, S._controller_error),
        2156: (1, S._control_device),
    }
    writes: dict[int, tuple[WordCount, Handler]] = {
        1: (4, S._register_accel),
        **_with_halves(
            53,
            (6, 4, 4),
            lambda s, st, p: s._real_pair_write(st.accel_s, p),
            lambda s, st, p: s._real_pair_split("AccelS", st.accel_s, 54, p),
        ),
        **_with_halves(
            103,
            (6, 4, 4),
            lambda s, st, p: s._real_pair_write(st.accel_r, p),
            lambda s, st, p: s._real_pair_split("AccelR", st.accel_r, 104, p),
        ),
        151: (5, S._register_speed),
        **_with_halves(203, (8, 6, 4), S._register_speed_s, S._register_speed_s_split),
        251: (4, S._register_speed_r),
        300: (5, S._set_weight),
        301: (3, S._set_weight),
        # 350 and 400: their bodies' 5 and 6 words, not the 3 and 4 of the §8 list
        **_with_halves(350, (5, 3, 3), S._set_inertia, S._set_inertia_split),
        **_with_halves(400, (6, 4, 4), S._set_arch, S._set_arch_split),
        **_with_halves(
            450, (lambda axes: 1 + axes, 4, lambda axes: axes - 2), S._set_fine, S._set_fine_split
        ),
        500: (2, S._select_tool),
        **_with_halves(600, (7, 5, 5), S._set_box, S._set_box_split),
        650: (5, lambda s, st, p: s._set_frame("Plane", st.planes, st, p)),
        700: (5, lambda s, st, p: s._set_frame("Local", st.locals, st, p)),
        **_with_halves(750, (6, 4, 4), S._set_xylim, S._set_xylim_split),
        **_with_halves(800, (6, 4, 4), S._set_jrange, S._set_jrange_split),
        850: (4, S._set_base),
        1204: (5, S._set_point_coord),
        1206: (2, _set_point_flag("hand", 1)),  # Righty
        1207: (2, _set_point_flag("hand", 0)),  # Lefty
        1208: (2, _set_point_flag("elbow", 0)),  # Above
        1209: (2, _set_point_flag("elbow", 1)),  # Below
        1210: (2, _set_point_flag("wrist", 1)),  # Flip
        1211: (2, _set_point_flag("wrist", 0)),  # NoFlip
        1212: (3, _set_point_number("j4flag", 1)),
        1213: (3, _set_point_number("j6flag", 127)),
        1214: (3, S._set_point_local),
        1223: (3, _set_point_number("j1flag", 1, (SIX_AXIS,))),
        1225: (3, _set_point_number("j2flag", 1, (SIX_AXIS,))),
        1227: (5, S._set_j1angle),
        1250: (3, S._set_limz),
    }
    out = {n: _Spec(_fixed(count), handler) for n, (count, handler) in reads.items()}
    for n, (count, handler) in writes.items():
        out[n] = _Spec(count if callable(count) else _fixed(count), handler)
    return out


_COMMANDS: Mapping[int, _Spec] = MappingProxyType(_commands())
#: The commands the simulated controller carries out: the digest's backup reads
#: and deploy writes that harlsync sends.  Everything else is answered 1000.
COMMAND_SET = frozenset(_COMMANDS)
READS = frozenset(
    {
        3,
        59,
        60,
        61,
        109,
        110,
        111,
        153,
        209,
        210,
        211,
        253,
        302,
        353,
        354,
        355,
        403,
        404,
        405,
        453,
        454,
        455,
        501,
        603,
        604,
        605,
        651,
        701,
        753,
        754,
        755,
        803,
        804,
        805,
        851,
        1215,
        1216,
        1217,
        1218,
        1219,
        1220,
        1222,
        1224,
        1226,
        1228,
        1251,
        2153,
        2154,
        2155,
        2156,
    }
)
WRITES = COMMAND_SET - READS
