"""Reading one speed or acceleration table entry or one setting of an Epson
controller, by the commands that answer it within the map's words: a table entry
that is not registered (error 2006) or a Box area the controller calls undefined
is absent (None)."""

from __future__ import annotations

from collections.abc import Callable

from . import profile
from . import protocol as p
from .channel import CommandChannel
from .protocol import Limits, Request

__all__ = ["read_setting", "read_table"]

#: Error responses that mean "not there": a table entry never registered, a Box
#: area the controller calls undefined.  A point has no code for it in the manual:
#: what a point not there answers is learned from the controller (:class:`PointTable`).
_ABSENT = {
    "table": frozenset({profile.TABLE_NOT_REGISTERED}),
    "box": frozenset({0x2009}),
}


def read_table(channel: CommandChannel, kind: str, n: int) -> object:
    """One table entry, None when it is not registered."""
    absent = _ABSENT["table"]
    if kind == "accel":
        return channel.ask_if_there(p.read_accel(n), absent)
    if kind in ("accel_s", "accel_r"):
        s = kind == "accel_s"
        return channel.either(
            p.read_accel_s(n) if s else p.read_accel_r(n),
            p.read_accel_s_accel(n) if s else p.read_accel_r_accel(n),
            p.read_accel_s_decel(n) if s else p.read_accel_r_decel(n),
            p.AccelReal,
            absent,
        )
    if kind == "speed":
        return channel.ask_if_there(p.read_speed(n), absent)
    if kind == "speed_s":
        return channel.either(
            p.read_speed_s(n),
            p.read_speed_s_speed_depart(n),
            p.read_speed_s_approach(n),
            lambda sd, a: p.SpeedReal(*sd, a),
            absent,
        )
    return channel.ask_if_there(p.read_speed_r(n), absent)


def _limits(
    channel: CommandChannel,
    full: Callable[[int], Request[Limits]],
    lower: Callable[[int], Request[str]],
    upper: Callable[[int], Request[str]],
    absent: frozenset[int] = frozenset(),
) -> tuple[Limits, ...] | None:
    found = []
    for axis in range(3):
        limits = channel.either(full(axis), lower(axis), upper(axis), Limits, absent)
        if limits is None:
            return None
        found.append(limits)
    return tuple(found)


def read_setting(
    channel: CommandChannel, kind: str, n: int | None, axes: Callable[[], int]
) -> object:
    """One setting (``n`` for a numbered one); None for a Box the controller
    calls undefined."""
    if kind == "arch":
        assert n is not None
        return channel.either(
            p.read_arch(n), p.read_arch_depart(n), p.read_arch_approach(n), p.Distances
        )
    if kind == "fine":
        if channel.fits(p.read_fine(axes())):
            return channel.ask(p.read_fine(axes()))
        return channel.ask(p.read_fine_123()) + channel.ask(p.read_fine_456(axes()))
    if kind == "weight":
        return channel.ask(p.read_weight())
    if kind == "inertia":
        return channel.either(
            p.read_inertia(), p.read_inertia_load(), p.read_inertia_eccentricity(), p.Inertia
        )
    if kind == "tool":
        return channel.ask(p.read_tool())
    if kind == "box":
        assert n is not None
        area = n
        return _limits(
            channel,
            lambda a: p.read_box(area, a),
            lambda a: p.read_box_lower(area, a),
            lambda a: p.read_box_upper(area, a),
            _ABSENT["box"],
        )
    if kind in ("plane", "local"):
        assert n is not None
        read = p.read_plane if kind == "plane" else p.read_local
        return tuple(channel.ask(read(n, c)) for c in range(axes()))
    if kind == "xylim":
        return _limits(channel, p.read_xylim, p.read_xylim_lower, p.read_xylim_upper)
    if kind == "jrange":
        assert n is not None
        return channel.either(
            p.read_jrange(n), p.read_jrange_lower(n), p.read_jrange_upper(n), p.PulseLimits
        )
    if kind == "base":
        return tuple(channel.ask(p.read_base(c)) for c in range(axes()))
    if kind == "limz":
        return channel.ask(p.read_limz())
    raise KeyError(f"no setting {kind!r}")
