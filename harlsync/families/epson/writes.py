"""Writing one item to an Epson controller: the item's write sequence(s), each with
how to read back what it changes, and sending them confirmed.

A write is one command, or a split or Rn sequence whose commands go out back to
back (:meth:`.Handshake.execute_sequence` reads the interlock before the first).
A point is one 1204 per coordinate that changed, then one of 1206-1214 per
attribute.  Each sequence is confirmed
(:func:`~harlsync.link.confirm.confirmed_write`): a command taken but not answered
in time (the handshake's deadline, or Modbus silence) is a lost reply; what it was
meant to change is read back, and it is sent once more only when that still holds
the old value and the robot is idle.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

from ...errors import (
    HarlsyncError,
    LinkError,
    LinkTimeout,
    PartlyWritten,
    WriteUnconfirmed,
    partly_words,
)
from ...link.confirm import confirmed_write, refuse_unless_idle
from . import protocol as p
from .channel import CommandChannel
from .model import ATTRIBUTE_OF, Point, SettingKey, TableKey, coordinate_names
from .protocol import Request, WriteSequence
from .remote_status import RemoteStatus

__all__ = ["WriteStep", "command_text", "point_steps", "sequence_of", "whole", "write_confirmed"]


@dataclass(frozen=True)
class WriteStep:
    """One write sequence of an item, how to read back what it changes, and which
    part of the item's value that is."""

    sequence: WriteSequence
    readback: Callable[[], object]
    part: Callable[[Any], object]
    #: the part of the item it writes, as a diff names it (a point's ``x``, ``hand``)
    name: str = ""


def whole(value: object) -> object:
    """The part of an item one write sequence changes, when it changes all of it."""
    return value


def _coord_of(axis: int, point: Point) -> object:
    return point.coords[axis]


def _attribute_of(name: str, point: Point) -> object:
    return point.attribute(name)


def _extra_of(name: str, point: Point) -> object:
    return getattr(point, name)


def _words(request: Request[object]) -> str:
    return " ".join(f"{w:04X}" for w in request.command.words)


def sequence_of(key: TableKey | SettingKey, value: Any, command_words: int) -> WriteSequence:
    """The sequence that makes a table entry or setting hold ``value``, in as many
    commands as ``command_words`` (the map's) need.  Raises ValueError for a value
    the wire cannot carry."""
    cw = command_words
    n = key.number
    kind = key.kind
    if isinstance(key, TableKey):
        assert n is not None
        if kind == "accel":
            return p.register_accel(n, value.accel, value.decel)
        if kind == "accel_s":
            return p.register_accel_s(n, value, command_words=cw)
        if kind == "accel_r":
            return p.register_accel_r(n, value, command_words=cw)
        if kind == "speed":
            return p.register_speed(n, value)
        if kind == "speed_s":
            return p.register_speed_s(n, value, command_words=cw)
        return p.register_speed_r(n, value)
    numbered: dict[str, Callable[[int], WriteSequence]] = {
        "arch": lambda n: p.set_arch(n, value, command_words=cw),
        "box": lambda n: p.set_box(n, value, command_words=cw),
        "plane": lambda n: p.set_plane(n, value),
        "local": lambda n: p.set_local(n, value),
        "jrange": lambda n: p.set_jrange(n, value, command_words=cw),
    }
    if kind in numbered:
        assert n is not None
        return numbered[kind](n)
    single: dict[str, Callable[[], WriteSequence]] = {
        "fine": lambda: p.set_fine(value, command_words=cw),
        "weight": lambda: p.set_weight(value.weight, value.arm_length),
        "inertia": lambda: p.set_inertia(value, command_words=cw),
        "tool": lambda: p.select_tool(value),
        "xylim": lambda: p.set_xylim(value, command_words=cw),
        "base": lambda: p.set_base(value),
        "limz": lambda: p.set_limz(value),
    }
    return single[kind]()


def point_steps(
    channel: CommandChannel,
    number: int,
    point: Point,
    fields: tuple[str, ...],
    coord: Callable[[int, int], object],
) -> list[WriteStep]:
    """The steps that write ``fields`` of point ``number``: one command each, read
    back through ``channel``, a coordinate by ``coord(number, axis)``."""
    names = coordinate_names(len(point.coords))
    steps = []
    for name in fields:
        if name in names:
            axis = names.index(name)
            steps.append(
                WriteStep(
                    p.set_point_coord(number, axis, point.coords[axis]),
                    partial(coord, number, axis),
                    partial(_coord_of, axis),
                    name,
                )
            )
        elif name == "j1angle":
            value = point.j1angle
            assert value is not None
            steps.append(
                WriteStep(
                    p.set_point_j1angle(number, value),
                    partial(channel.ask, p.read_point_j1angle(number)),
                    partial(_extra_of, "j1angle"),
                    name,
                )
            )
        else:
            attribute = ATTRIBUTE_OF[name]
            steps.append(
                WriteStep(
                    p.set_point_attribute(attribute, number, point.attribute(attribute)),
                    partial(channel.ask, p.read_point_attribute(attribute, number)),
                    partial(_attribute_of, attribute),
                    name,
                )
            )
    return steps


def command_text(steps: list[WriteStep]) -> str:
    """The commands of ``steps`` as sent, in order: each run of one command number
    as the number, the manual's name and each command's words in hex split by
    ``|``; runs split by ``;``::

        53 register AccelS table entry: 0035 0003 0001 871B 0003 0D40
        600 set Box, one axis (Rn): 0258 0005 0000 ... | 0258 0005 0001 ... | ...
    """
    runs: list[list[Request[None]]] = []
    for request in (r for step in steps for r in step.sequence):
        if runs and runs[-1][0].number == request.number:
            runs[-1].append(request)
        else:
            runs.append([request])
    return "; ".join(
        f"{run[0].number} {p.COMMANDS[run[0].number].name}: " + " | ".join(_words(r) for r in run)
        for run in runs
    )


def write_confirmed(
    channel: CommandChannel,
    steps: list[WriteStep],
    value: object,
    old: object,
    status: Callable[[], RemoteStatus],
) -> None:
    """Send each step and confirm it; ``status`` is the interlock read before a
    command is sent again.

    Raises InterlockError (that step not sent, or cancelled) when the robot is
    not idle before a command, or before sending one again after a lost reply;
    WriteUnconfirmed when the read-back is neither the new nor the old value;
    ControllerError for an error response.  Any of them after the first step
    (a point's coordinates and attributes, one command each) comes as
    :class:`~harlsync.errors.PartlyWritten`: the item then holds neither its old
    value nor the new one, and the error names the parts that went out.
    """
    for i, step in enumerate(steps):
        try:
            _confirmed(
                channel, status, step, step.part(value), None if old is None else step.part(old)
            )
        except HarlsyncError as exc:
            if i == 0:
                raise
            raise _partly(channel.label, steps, i, exc) from exc


def _partly(label: str, steps: list[WriteStep], stopped: int, exc: HarlsyncError) -> PartlyWritten:
    """Steps before ``stopped`` went out and took; ``stopped`` did not take when
    the interlock or the controller refused it, and may have after a lost reply."""
    sent = [s.name for s in steps[:stopped]]
    unknown = steps[stopped].name if isinstance(exc, LinkError) else None
    left = [s.name for s in steps[stopped + (unknown is not None) :]]
    what = steps[0].sequence.what.split(" ")[0]
    return PartlyWritten(
        f"{label}: {what} partly written: {partly_words(sent, unknown, left)} ({exc})",
        sent=sent,
        left=left,
        unknown=unknown,
        cause=exc,
    )


def _confirmed(
    channel: CommandChannel,
    status: Callable[[], RemoteStatus],
    step: WriteStep,
    wanted: object,
    old: object,
) -> None:
    sequence = step.sequence

    def send() -> None:
        try:
            reply = channel.handshake.execute_sequence(sequence)
        except LinkTimeout as exc:  # the handshake's deadline, or Modbus silence
            raise WriteUnconfirmed(
                f"{sequence.what}: the write may or may not have taken ({exc.message})",
                port=channel.label,
                command=exc.command,
            ) from exc
        if reply is not None:
            request = next(r for r in sequence if r.number == reply.number)
            raise channel.error(request, reply)

    confirmed_write(
        send,
        step.readback,
        wanted,
        old,
        what=sequence.what,
        before_resend=partial(
            refuse_unless_idle,
            status,
            where=f"{channel.label}, {sequence.what}",
            reading="the status",
        ),
    )
