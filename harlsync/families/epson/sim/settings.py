"""The controller's side of the setting commands: the six speed/accel tables
(§10.1-10.6), Weight, Inertia, Arch, Fine, Tool (§10.7-10.11), Box, Plane,
Local, XYLim, JRange, Base (§10.13-10.18) and LimZ (§10.26), read and written
on a :class:`~.state.SimState`, and the table of their command numbers
(:data:`READ_COMMANDS`, :data:`WRITE_COMMANDS`) that :mod:`.commands` carries out.

Split writes (S1/S2, R1/R2) and Rn sequences take effect at their last step
(:meth:`.session.Session.sequence`).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from .. import profile
from .codes import Refused
from .params import Params, words_of, words_of_all
from .session import Handler, Session, WordCount, parts, with_halves
from .state import SimState

__all__ = ["READ_COMMANDS", "WRITE_COMMANDS"]

_WORD = 0xFFFF

# --- the six tables (§10.1-10.6) -------------------------------------------------------------


def _registered(
    table: Mapping[int, tuple[int, ...]] | Mapping[int, int], t: int
) -> tuple[int, ...]:
    entry = table.get(t)
    if entry is None:
        raise Refused(profile.TABLE_NOT_REGISTERED)
    return entry if isinstance(entry, tuple) else (entry,)


def _accel(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t = p.table()
    entry = _registered(st.accel, t)
    return (t, *entry)


def _register_accel(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t, accel, decel = p.table(), p.number(2, 1, _WORD), p.number(3, 1, _WORD)
    st.accel[t] = (accel, decel)
    return s.done()


def _real_pair_read(table: dict[int, tuple[int, int]], p: Params, which: slice) -> tuple[int, ...]:
    t = p.table()
    entry = _registered(table, t)
    return (t, *words_of_all(entry, which))


def _real_pair_write(s: Session, table: dict[int, tuple[int, int]], p: Params) -> tuple[int, ...]:
    t, accel, decel = p.table(), p.at_least(2, 1), p.at_least(4, 1)
    table[t] = (accel, decel)
    return s.done()


def _real_pair_split(
    s: Session, name: str, table: dict[int, tuple[int, int]], first: int, p: Params
) -> tuple[int, ...]:
    number = p.word(0)
    t, value = p.table(), p.at_least(2, 1)

    def apply(accel: tuple[int, ...], decel: tuple[int, ...]) -> None:
        table[t] = (accel[0], decel[0])

    return s.split((name, t), first, first + 1, number, (value,), apply)


def _speed(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t = p.table()
    return (t, *_registered(st.speed, t))


def _register_speed(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t = p.table()
    st.speed[t] = (p.number(2, 1, 100), p.number(3, 1, 100), p.number(4, 1, 100))
    return s.done()


def _speed_s(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    t = p.table()
    entry = _registered(st.speed_s, t)
    return (t, *words_of_all(entry, which))


def _register_speed_s(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t = p.table()
    st.speed_s[t] = (p.at_least(2, 1), p.at_least(4, 1), p.at_least(6, 1))
    return s.done()


def _register_speed_s_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    number, t = p.word(0), p.table()
    values = (p.at_least(2, 1), p.at_least(4, 1)) if number == 204 else (p.at_least(2, 1),)

    def apply(first: tuple[int, ...], second: tuple[int, ...]) -> None:
        st.speed_s[t] = (first[0], first[1], second[0])

    return s.split(("SpeedS", t), 204, 205, number, values, apply)


def _speed_r(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t = p.table()
    return (t, *words_of_all(_registered(st.speed_r, t)))


def _register_speed_r(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    t = p.table()
    st.speed_r[t] = p.at_least(2, 1)
    return s.done()


# --- Weight, Inertia, Arch, Fine, Tool (§10.7-10.11) -----------------------------------------


def _weight(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    return words_of_all(st.weight)


def _set_weight(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    weight = p.at_least(1, 0)
    # The arm length is a SCARA's (§10.7: "invalid for the models other than
    # the SCARA"): another robot keeps 0.
    arm = p.at_least(3, 0) if p.word(0) == 300 else st.weight[1]
    st.weight = (weight, arm if st.has_arm_length else 0)
    return s.done()


def _inertia(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    return words_of_all(st.inertia, which)


def _set_inertia(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    st.inertia = (p.at_least(1, 0), p.at_least(3, 0))
    return s.done()


def _set_inertia_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    def apply(inertia: tuple[int, ...], eccentricity: tuple[int, ...]) -> None:
        st.inertia = (inertia[0], eccentricity[0])

    return s.split(("Inertia",), 351, 352, p.word(0), (p.at_least(1, 0),), apply)


def _arch(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    a = p.number(1, 0, 6)
    return (a, *words_of_all(st.arch[a], which))


def _set_arch(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    a = p.number(1, 0, 6)
    st.arch[a] = (p.at_least(2, 0), p.at_least(4, 0))
    return s.done()


def _set_arch_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    a = p.number(1, 0, 6)

    def apply(depart: tuple[int, ...], approach: tuple[int, ...]) -> None:
        st.arch[a] = (depart[0], approach[0])

    return s.split(("Arch", a), 401, 402, p.word(0), (p.at_least(2, 0),), apply)


def _fine(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    return st.fine[which]  # a 4-axis robot has no joints 5 and 6 to answer


def _set_fine(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    st.fine = tuple(p.word(1 + j) for j in range(st.axes))
    return s.done()


def _set_fine_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    number = p.word(0)
    count = 3 if number == 451 else st.axes - 3

    def apply(first: tuple[int, ...], second: tuple[int, ...]) -> None:
        st.fine = first + second

    return s.split(("Fine",), 451, 452, number, tuple(p.word(1 + j) for j in range(count)), apply)


def _tool(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    return (st.tool,)


def _select_tool(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    st.tool = p.number(1, 0, 15)
    return s.done()


# --- Box, Plane, Local, XYLim, JRange, Base (§10.13-10.18) -----------------------------------


def _box(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    area, axis = p.number(1, 1, 15), p.number(2, 0, 2)
    limits = st.boxes.get(area, ((0, 0), (0, 0), (0, 0)))[axis]
    return (area, axis, *words_of_all(limits, which))


def _set_box(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    area, axis = p.number(1, 1, 15), p.number(2, 0, 2)

    def apply(values: list[tuple[int, ...]]) -> None:
        st.boxes[area] = (
            (values[0][0], values[0][1]),
            (values[1][0], values[1][1]),
            (values[2][0], values[2][1]),
        )

    return s.sequence(
        ("Box", area),
        ((600, 0), (600, 1), (600, 2)),
        (600, axis),
        (p.int32(3), p.int32(5)),
        apply,
    )


def _set_box_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    number, area, axis = p.word(0), p.number(1, 1, 15), p.number(2, 0, 2)

    def apply(values: list[tuple[int, ...]]) -> None:
        st.boxes[area] = (
            (values[0][0], values[3][0]),
            (values[1][0], values[4][0]),
            (values[2][0], values[5][0]),
        )

    steps = tuple((n, a) for n in (601, 602) for a in range(3))
    return s.sequence(("Box", area), steps, (number, axis), (p.int32(3),), apply)


def _frame(frames: dict[int, tuple[int, ...]], st: SimState, p: Params) -> tuple[int, ...]:
    n, coord = p.number(1, 1, 15), p.number(2, 0, st.axes - 1)
    return (n, coord, *words_of(frames.get(n, (0,) * st.axes)[coord]))


def _set_frame(
    s: Session, name: str, frames: dict[int, tuple[int, ...]], st: SimState, p: Params
) -> tuple[int, ...]:
    number, n, coord = p.word(0), p.number(1, 1, 15), p.number(2, 0, st.axes - 1)

    def apply(values: list[tuple[int, ...]]) -> None:
        frames[n] = tuple(v[0] for v in values)

    steps = tuple((number, c) for c in range(st.axes))
    return s.sequence((name, n), steps, (number, coord), (p.int32(3),), apply)


def _xylim(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    axis = p.number(1, 0, 2)
    return (axis, *words_of_all(st.xylim[axis], which))


def _set_xylim(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    axis = p.number(1, 0, 2)

    def apply(values: list[tuple[int, ...]]) -> None:
        st.xylim = (
            (values[0][0], values[0][1]),
            (values[1][0], values[1][1]),
            (values[2][0], values[2][1]),
        )

    return s.sequence(
        ("XYLim",), ((750, 0), (750, 1), (750, 2)), (750, axis), (p.int32(2), p.int32(4)), apply
    )


def _set_xylim_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    number, axis = p.word(0), p.number(1, 0, 2)

    def apply(values: list[tuple[int, ...]]) -> None:
        st.xylim = (
            (values[0][0], values[3][0]),
            (values[1][0], values[4][0]),
            (values[2][0], values[5][0]),
        )

    steps = tuple((n, a) for n in (751, 752) for a in range(3))
    return s.sequence(("XYLim",), steps, (number, axis), (p.int32(2),), apply)


def _set_joint(st: SimState, joint: int, limits: tuple[int, int]) -> None:
    st.jrange = tuple(limits if j == joint else old for j, old in enumerate(st.jrange, 1))


def _jrange(s: Session, st: SimState, p: Params, which: slice) -> tuple[int, ...]:
    joint = p.number(1, 1, st.axes)
    return (joint, *words_of_all(st.jrange[joint - 1], which))


def _set_jrange(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    joint = p.number(1, 1, st.axes)
    _set_joint(st, joint, (p.int32(2), p.int32(4)))
    return s.done()


def _set_jrange_split(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    joint = p.number(1, 1, st.axes)

    def apply(lower: tuple[int, ...], upper: tuple[int, ...]) -> None:
        _set_joint(st, joint, (lower[0], upper[0]))

    return s.split(("JRange", joint), 801, 802, p.word(0), (p.int32(2),), apply)


def _base(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    coord = p.number(1, 0, st.axes - 1)
    return (coord, *words_of(st.base[coord]))


def _set_base(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    coord = p.number(1, 0, st.axes - 1)

    def apply(values: list[tuple[int, ...]]) -> None:
        st.base = tuple(v[0] for v in values)

    steps = tuple((850, c) for c in range(st.axes))
    return s.sequence(("Base",), steps, (850, coord), (p.int32(2),), apply)


# --- LimZ (§10.26) ---------------------------------------------------------------------------


def _limz(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    return words_of(st.limz)


def _set_limz(s: Session, st: SimState, p: Params) -> tuple[int, ...]:
    st.limz = p.int32(1)
    return s.done()


# --- the table: number -> (command words, word 0 included; handler) -------------------------

READ_COMMANDS: Mapping[int, tuple[WordCount, Handler]] = MappingProxyType(
    {
        3: (2, _accel),
        **parts(59, 2, lambda s, st, p, which: _real_pair_read(st.accel_s, p, which)),
        **parts(109, 2, lambda s, st, p, which: _real_pair_read(st.accel_r, p, which)),
        153: (2, _speed),
        **parts(209, 2, _speed_s, (slice(0, 3), slice(0, 2), slice(2, 3))),
        253: (2, _speed_r),
        302: (1, _weight),
        **parts(353, 1, _inertia),
        **parts(403, 2, _arch),
        **parts(453, 1, _fine, (slice(0, 6), slice(0, 3), slice(3, 6))),
        501: (1, _tool),
        **parts(603, 3, _box),
        651: (3, lambda s, st, p: _frame(st.planes, st, p)),
        701: (3, lambda s, st, p: _frame(st.locals, st, p)),
        **parts(753, 2, _xylim),
        **parts(803, 2, _jrange),
        851: (2, _base),
        1251: (1, _limz),
    }
)
WRITE_COMMANDS: Mapping[int, tuple[WordCount, Handler]] = MappingProxyType(
    {
        1: (4, _register_accel),
        **with_halves(
            53,
            (6, 4, 4),
            lambda s, st, p: _real_pair_write(s, st.accel_s, p),
            lambda s, st, p: _real_pair_split(s, "AccelS", st.accel_s, 54, p),
        ),
        **with_halves(
            103,
            (6, 4, 4),
            lambda s, st, p: _real_pair_write(s, st.accel_r, p),
            lambda s, st, p: _real_pair_split(s, "AccelR", st.accel_r, 104, p),
        ),
        151: (5, _register_speed),
        **with_halves(203, (8, 6, 4), _register_speed_s, _register_speed_s_split),
        251: (4, _register_speed_r),
        300: (5, _set_weight),
        301: (3, _set_weight),
        # 350 and 400: their bodies' 5 and 6 words, not the 3 and 4 of the §8 list
        **with_halves(350, (5, 3, 3), _set_inertia, _set_inertia_split),
        **with_halves(400, (6, 4, 4), _set_arch, _set_arch_split),
        **with_halves(
            450, (lambda axes: 1 + axes, 4, lambda axes: axes - 2), _set_fine, _set_fine_split
        ),
        500: (2, _select_tool),
        **with_halves(600, (7, 5, 5), _set_box, _set_box_split),
        650: (5, lambda s, st, p: _set_frame(s, "Plane", st.planes, st, p)),
        700: (5, lambda s, st, p: _set_frame(s, "Local", st.locals, st, p)),
        **with_halves(750, (6, 4, 4), _set_xylim, _set_xylim_split),
        **with_halves(800, (6, 4, 4), _set_jrange, _set_jrange_split),
        850: (4, _set_base),
        1250: (3, _set_limz),
    }
)
