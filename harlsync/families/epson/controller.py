"""What an Epson controller can do for harlsync, as methods: the manipulator, every
setting, the points, status, and writing an item.

A :class:`Controller` sends Remote Control commands through the §6
:class:`~.handshake.Handshake` over the Modbus TCP :class:`~.transport.ModbusLink`,
one at a time, and only what the codec can encode (the allow-list), as a
:class:`~.channel.CommandChannel`.  A table entry that is not registered (error
2006) or a point that is not defined is absent (:mod:`.setting_reads`,
:mod:`.points`); any other error response raises
:class:`~harlsync.errors.ControllerError` with its §7.1 meaning.  A write is the
item's write sequence(s), each confirmed (:mod:`.writes`).

The interlock (:meth:`Controller.status`) is one read of the controller's
outputs: Running, Paused, EStopOn and Error at 0, the function idle, and a map
that has Running, Paused and EStopOn at all.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import replace
from functools import partial
from typing import Any

from ...errors import ControllerError, HarlsyncError, InterlockError, ProjectError, ProtocolError
from ..base import Progress
from . import profile
from . import protocol as p
from .channel import CommandChannel
from .handshake import Handshake
from .layout import Connection
from .model import (
    ATTRIBUTE_OF,
    ATTRIBUTES,
    KINDS,
    EpsonData,
    Key,
    Point,
    PointKey,
    PointTable,
    SettingKey,
    TableKey,
    axes_of_type,
    type_attributes,
)
from .points import End, PointProbe, refuse_left_out
from .remote_status import RemoteStatus
from .setting_reads import read_setting, read_table
from .steps import FunctionBusy
from .transport import ModbusLink
from .writes import WriteStep, point_steps, sequence_of, whole, write_confirmed

__all__ = ["Controller", "item_keys"]

log = logging.getLogger(__name__)

#: The longest model name read, in characters (2154 sends one a call).
MODEL_NAME_MAX = 64


def item_keys(axes: int) -> Iterator[TableKey | SettingKey]:
    """Every setting of a robot with ``axes`` axes, in settings.yaml's order."""
    for kind in KINDS.values():
        if kind.numbers is None:
            yield SettingKey(kind.key)
            continue
        first, last = kind.numbers
        if kind.key == "jrange":
            last = axes
        for n in range(first, last + 1):
            yield TableKey(kind.key, n) if kind.table else SettingKey(kind.key, n)


class Controller(CommandChannel):
    """One Epson controller behind a handshake.

    ``robot_type`` (a 2153 type name) is what robot.yaml says the robot is, checked
    before anything is read; ``axes`` its axes when robot.yaml gives them.
    ``first``/``last`` bound the points read; ``table_end`` is the last point of the
    controller's point table (robot.yaml ``controller.point_table_end``, the
    profile's P999 when None); ``first_pull``: the range is the default, not
    robot.yaml's, and points found past it are taken in (a first pull).
    """

    def __init__(
        self,
        handshake: Handshake,
        *,
        robot_type: str | None = None,
        axes: int | None = None,
        first: int = profile.DEFAULT_POINT_RANGE[0],
        last: int = profile.DEFAULT_POINT_RANGE[1],
        table_end: int | None = None,
        first_pull: bool = False,
    ) -> None:
        super().__init__(handshake)
        self.robot_type = robot_type
        self.configured_axes = axes
        self._axes: int | None = None
        self._type: int | None = None
        self.first, self.last = first, last
        self.first_pull = first_pull
        #: the point table: where it ends, what a point not defined answers
        self._points = PointProbe(self, profile.POINT_PROBE_END if table_end is None else table_end)
        self._link: ModbusLink | None = None
        #: what :meth:`open` recovered on its own, for the backup's report and audit log
        self.notes: list[str] = []

    @classmethod
    def open(
        cls,
        url: str,
        unit: int,
        line: Connection,
        *,
        lock_timeout: float,
        reset_function: bool = False,
        unattended: bool = False,
        robot_type: str | None = None,
        axes: int | None = None,
        first: int = profile.DEFAULT_POINT_RANGE[0],
        last: int = profile.DEFAULT_POINT_RANGE[1],
        table_end: int | None = None,
        first_pull: bool = False,
    ) -> Controller:
        """Connect (taking the line lock) and make the Remote Control function
        usable (§6.2).  With ``reset_function``, a function found in use or halted
        is reset first (§6.5.2), and only while Running is 0.  ``unattended`` (a
        nightly backup) recovers on its own a function found in use, not halted, on
        a robot at rest (Running, Paused, EStopOn and Error 0, Ready 1, the map
        right): with the line lock held here, no harlsync is using it, so it was
        left by one that is gone; :attr:`notes` says so.  On a robot not at rest
        (a task paused, an emergency stop, an error) it is left alone.  The other
        options are the controller's (see the class).

        Raises :class:`~harlsync.errors.PortError`, PortBusyError (FunctionBusy: a
        function in use that ``unattended`` does not reset), LinkTimeout, and
        InterlockError for a reset asked of a robot that runs.
        """
        link = ModbusLink(
            url, unit, timeout=line.timeout, retries=line.retries, lock_timeout=lock_timeout
        )
        try:
            handshake = Handshake(
                link,
                line.register_map,
                poll_interval=line.poll_interval,
                deadline=line.deadline,
                block_write_whole=line.writes_whole,
            )
            handshake.start()
            notes = _take_function(handshake, reset=reset_function, unattended=unattended)
            controller = cls(
                handshake,
                robot_type=robot_type,
                axes=axes,
                first=first,
                last=last,
                table_end=table_end,
                first_pull=first_pull,
            )
            controller.notes = notes
        except BaseException:
            link.close()
            raise
        controller._link = link
        return controller

    def close(self) -> None:
        """Disconnect and give the line lock back, when :meth:`open` made the link."""
        if self._link is not None:
            try:
                self.handshake.finish()  # a command left unanswered: answered, if it can be
            finally:
                self._link.close()

    # --- the robot ---------------------------------------------------------------------

    def status(self) -> RemoteStatus:
        """The interlock: one read of the controller's outputs; when they allow a
        write, the control device (2156: Remote I/O, not a pendant or PC) and the
        controller's error code (2155: 0) too.  Either that cannot be read (an
        error response) makes the status refuse a write: fail closed (issue 34 item
        16).  A line that does not answer raises, as the read of the outputs does."""
        status = self.handshake.status()
        if not status.idle:
            return status
        found: list[int] = []
        for request in (p.read_control_device(), p.read_controller_error()):
            try:
                found.append(self.ask(request))
            except (ControllerError, ProtocolError) as exc:
                return replace(
                    status,
                    unreadable=(
                        f"the {request.what} ({request.number}) cannot be read "
                        f"({getattr(exc, 'message', exc)}): harlsync writes only when it has "
                        "read it, so nothing is written"
                    ),
                )
        device, error = found
        return replace(status, control_device=device, controller_error=error)

    def read_model_name(self) -> str:
        """2154, one character a call, until the status says it was the last."""
        chars: list[str] = []
        start = True
        while len(chars) < MODEL_NAME_MAX:
            answer = self.ask(p.read_model_name_char(start))
            start = False
            if answer.status == 2:
                break
            chars.append(answer.char)
            if answer.status == 0:
                break
        return "".join(chars)

    def identify(self) -> tuple[int, int, str]:
        """(manipulator type, axes, model name).  Raises ProjectError when the type
        is not robot.yaml's, or says no axis count and robot.yaml gives none."""
        code = self.ask(p.read_robot_type())
        name = p.ROBOT_TYPES[code]
        if self.robot_type is not None and self.robot_type != name:
            raise ProjectError(
                f"{self.label}: the controller reports a {name} robot (2153), robot.yaml "
                f"controller.type says {self.robot_type}: the wrong controller, or robot.yaml "
                "is wrong"
            )
        axes = axes_of_type(code)
        if axes is None:
            if self.configured_axes is None:
                raise ProjectError(
                    f"{self.label}: the controller reports a {name} robot (2153), which says "
                    "nothing of its axes: give them in robot.yaml controller.axes (4 or 6)"
                )
            axes = self.configured_axes
        elif self.configured_axes is not None and self.configured_axes != axes:
            raise ProjectError(
                f"{self.label}: the controller reports a {name} robot ({axes} axes), "
                f"robot.yaml controller.axes says {self.configured_axes}"
            )
        self._axes, self._type = axes, code
        return code, axes, self.read_model_name()

    @property
    def axes(self) -> int:
        if self._axes is None:
            self.identify()
        assert self._axes is not None
        return self._axes

    # --- reads -------------------------------------------------------------------------

    def point_table(self) -> PointTable:
        """Where the controller's point table ends, from its own behaviour, asked once
        a session (:meth:`.PointProbe.table`).  Raises ProjectError when the point
        past the table is defined, or answers two different things."""
        return self._points.table()

    def read_point(self, number: int) -> Point | None:
        """One point: 1222 per axis, then 1215-1220; None when it is not defined (or
        past the point table)."""
        first = self._points.first_coord(number)
        if first is None or isinstance(first, End):
            return None
        return self._rest_of_point(number, first)

    def _rest_of_point(self, number: int, first: str) -> Point:
        """A defined point, its X read: the other coordinates and its attributes."""
        coords = (
            first,
            *(self.ask(p.read_point_coord(number, axis)) for axis in range(1, self.axes)),
        )
        attributes: dict[str, Any] = {
            name: self.ask(p.read_point_attribute(name, number)) for name in ATTRIBUTES
        }
        for name in type_attributes(self.robot_code):
            attributes[name] = self._read_extra(name, number)
        return Point(coords, **attributes)

    @property
    def robot_code(self) -> int:
        """The manipulator type 2153 reports (read once)."""
        if self._type is None:
            self.identify()
        assert self._type is not None
        return self._type

    def _read_extra(self, name: str, number: int) -> object:
        """A type's own attribute of a point: J1Flag, J2Flag (6-axis), J1Angle (RS)."""
        if name == "j1angle":
            return self.ask(p.read_point_j1angle(number))
        return self.ask(p.read_point_attribute(ATTRIBUTE_OF[name], number))

    def read_item(self, key: Key) -> object:
        """One item's value (None when it is absent)."""
        if isinstance(key, TableKey):
            return read_table(self, key.kind, key.number)
        if isinstance(key, PointKey):
            return self.read_point(key.number)
        return read_setting(self, key.kind, key.number, lambda: self.axes)

    def read_all(
        self,
        progress: Progress | None = None,
        *,
        probe: bool = False,
        identity: tuple[int, int, str] | None = None,
    ) -> EpsonData:
        """The manipulator, every setting and every defined point of the range.

        The point table's end is the controller's own (:meth:`point_table`); the
        points are read in order, and a number found past the table ends the read
        there (a table smaller than the range: recorded, not failed).  With
        ``probe`` (a pull), every point outside the range, from P0 to the table's
        end, is looked for too with one read each (the manual has no command that
        says how many there are): raises ProjectError naming those defined and the
        robot.yaml setting that takes them in, except on a first pull, which takes
        them in (:attr:`EpsonData.taken_in`).  The data records the range covered
        and the point table.  ``progress(done, total)`` after each item.
        ``identity`` is what :meth:`identify` just returned: not asked for again.
        """
        code, axes, model = self.identify() if identity is None else identity
        table = self.point_table()
        data = EpsonData(
            code, axes, model, unwritable=self.map.unwritable, map_note=self.map.ready_note
        )
        keys: list[Key] = [*item_keys(axes)]
        first, last = self.first, self.last
        below = range(min(first, table.end + 1)) if probe else range(0)
        past = range(last + 1, table.end + 1) if probe else range(0)
        numbers = [*below, *range(first, last + 1), *past]
        total = len(keys) + 1 + len(numbers)
        if progress is not None:
            progress(1, total)
        for done, key in enumerate(keys, 2):
            value = self.read_item(key)
            if value is not None:
                data.items[key] = value
            if progress is not None:
                progress(done, total)
        outside, taken, ended = self._read_points(data, numbers, len(keys) + 2, total, progress)
        refuse_left_out(self.label, outside, first, last)
        self._record(data, table, ended, taken, probe=probe)
        return data

    def _read_points(
        self,
        data: EpsonData,
        numbers: list[int],
        start: int,
        total: int,
        progress: Progress | None,
    ) -> tuple[list[int], list[int], int | None]:
        """Read each point of ``numbers`` into ``data`` (those outside the range only
        on a first pull), until one lies past the point table.  Returns the points
        found outside the range and left out, those taken in, and where the table
        ended (None: it did not)."""
        outside: list[int] = []
        taken: list[int] = []
        ended: int | None = None
        for done, n in enumerate(numbers, start):
            found = self._points.first_coord(n)
            if isinstance(found, End):
                ended = n
                break
            if found is not None:
                inside = self.first <= n <= self.last
                if inside or self.first_pull:
                    data.items[PointKey("point", n)] = self._rest_of_point(n, found)
                if not inside:
                    (taken if self.first_pull else outside).append(n)
            if progress is not None:
                progress(done, total)
        if progress is not None and ended is not None:
            progress(total, total)
        return outside, taken, ended

    def _record(
        self,
        data: EpsonData,
        table: PointTable,
        ended: int | None,
        taken: list[int],
        *,
        probe: bool,
    ) -> None:
        """What the read covered, and the point table as it showed (cut where a
        point past it was found)."""
        recorded = PointTable(table.end, table.past_end, table.not_defined)
        if ended is not None:
            recorded.end = ended - 1
            data.cut_at = ended
            log.info(
                "%s: the point table ends at P%d: P%d answers %s twice",
                self.label,
                ended - 1,
                ended,
                table.past_end.describe(),
            )
        data.table = recorded
        first, last = self.first, self.last
        data.covered = (first, last)
        if taken:
            data.taken_in = (taken[0], taken[-1])
            data.covered = (min(first, taken[0]), max(last, taken[-1]))
        data.probed_to = recorded.end if probe else None

    # --- writes ------------------------------------------------------------------------

    def write_steps(self, key: Key, value: Any, fields: tuple[str, ...] = ()) -> list[WriteStep]:
        """The write sequences that make ``key`` hold ``value`` (a point: its
        ``fields``, coordinates first), each with its read-back.

        Raises ValueError for a value the wire cannot carry.
        """
        if isinstance(key, PointKey):
            return point_steps(self, key.number, value, fields, self._point_coord)
        sequence = sequence_of(key, value, self.map.command_words)
        return [WriteStep(sequence, partial(self.read_item, key), whole)]

    def _point_coord(self, number: int, axis: int) -> str | None:
        found = self._points.first_coord(number, axis)
        return None if isinstance(found, End) else found

    def write(self, steps: list[WriteStep], value: object, old: object) -> None:
        """Send each step and confirm it (:func:`~.writes.write_confirmed`, the
        interlock read again before a command is sent once more)."""
        write_confirmed(self, steps, value, old, self.status)


def _take_function(handshake: Handshake, *, reset: bool, unattended: bool) -> list[str]:
    """The function as :meth:`Controller.open` takes it: reset when asked (and not
    idle), recovered when ``unattended``; what was recovered on its own, as notes."""
    if reset:
        status = handshake.status()
        if status.function_idle and not status["ExtError"]:
            log.info("%s: the function is idle: no reset needed", handshake.label)
        else:
            handshake.reset_function()
        return []
    if unattended:
        return _recover_unattended(handshake)
    return []


def _recover_unattended(handshake: Handshake) -> list[str]:
    """A backup no person watches: reset a function found in use, not halted, on a
    robot at rest, and say so (the notes); a robot not at rest raises FunctionBusy,
    nothing sent."""
    status = handshake.status()
    if status.function_idle or status["ExtError"]:
        return []
    label = handshake.label
    left = status.function_signals()
    if (why := status.unsettled) is not None:
        raise FunctionBusy(
            f"the Remote Control function is in use ({left}) on a robot "
            f"not at rest ({why}): a backup no person watches resets it "
            "only with Running, Paused, EStopOn and Error 0 and Ready 1; "
            "nothing sent. Look at the robot; once it is idle, "
            "'harlsync pull --reset-function' clears it",
            port=label,
            command="function reset",
        )
    try:
        handshake.reset_function(at_rest=True)  # the same check, its own read
    except InterlockError:
        raise  # refused on that read: nothing was sent
    except HarlsyncError as exc:
        exc.notes = (
            *exc.notes,
            (
                f"the Remote Control function was found in use ({left}) with "
                "no harlsync on the line and the robot at rest: a reset "
                f"(manual 6.5.2) was begun and did not finish ({exc})"
            ),
        )
        raise
    note = (
        f"the Remote Control function was found in use ({left}) with no "
        "harlsync on the line and the robot at rest (Running, Paused, "
        "EStopOn and Error 0, Ready 1): left by a harlsync that is gone; "
        "reset (manual 6.5.2) before the backup"
    )
    log.warning("%s: %s", label, note)
    return [note]
