"""What an Epson controller can do for harlsync, as methods: the manipulator, every
setting, the points, status, and writing an item.

A :class:`Controller` sends Remote Control commands through the §6
:class:`~.handshake.Handshake` over the Modbus TCP :class:`~.transport.ModbusLink`,
one at a time, and only what the codec can encode (the allow-list).  Each read
asks for the most a command answers within the map's words: 59 (an AccelS entry,
6 response words), or its two halves 60 and 61 when RC+ assigned fewer.  A
table entry that is not registered (error 2006) or a point that is not defined
(2004) is absent; any other error response raises
:class:`~harlsync.errors.ControllerError` with its §7.1 meaning.

A write is the item's write sequence(s): one command, or a split or Rn
sequence whose commands go out back to back (:meth:`.Handshake.execute_sequence`
reads the interlock before the first).  A point is one 1204 per coordinate that
changed, then one of 1206-1214 per attribute.  Each sequence is confirmed
(:func:`~harlsync.link.confirm.confirmed_write`): a command taken but not
answered in time (the handshake's deadline, or Modbus silence) is a lost
reply; what it was meant to change is read back, and it is sent once more only
when that still holds the old value and the robot is idle.

The interlock (:meth:`Controller.status`) is one read of the controller's
outputs: Running, Paused, EStopOn and Error at 0, the function idle, and a map
that has Running, Paused and EStopOn at all.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from functools import partial
from typing import Any, TypeVar

from ...errors import (
    ControllerError,
    HarlsyncError,
    InterlockError,
    LinkError,
    LinkTimeout,
    PartlyWritten,
    ProjectError,
    ProtocolError,
    WriteUnconfirmed,
    partly_words,
)
from ...link.confirm import confirmed_write, refuse_unless_idle
from ..base import Progress
from . import profile
from . import protocol as p
from .handshake import Handshake
from .layout import Connection
from .model import (
    ATTRIBUTE_OF,
    ATTRIBUTES,
    KINDS,
    EpsonData,
    Key,
    NotThere,
    Point,
    PointKey,
    PointTable,
    SettingKey,
    TableKey,
    axes_of_type,
    coordinate_names,
    type_attributes,
)
from .protocol import ErrorReply, Limits, Request, WriteSequence
from .remote_status import RemoteStatus
from .steps import FunctionBusy
from .transport import ModbusLink

__all__ = ["Controller", "WriteStep", "item_keys"]

log = logging.getLogger(__name__)

T = TypeVar("T")
A = TypeVar("A")
B = TypeVar("B")

#: Error responses that mean "not there": a table entry never registered, a Box
#: area the controller calls undefined.  A point has no code for it in the manual:
#: what a point not there answers is learned from the controller (:class:`PointTable`).
_ABSENT = {
    "table": frozenset({profile.TABLE_NOT_REGISTERED}),
    "box": frozenset({0x2009}),
}
#: Response 1 codes that never say "no point here": the command was not understood,
#: the words are wrong, or the controller could not run it for a reason of its own
#: (§7.1).  Any other error response to a point's read may be one (asked twice).
_NEVER_ABSENT = frozenset({0x1000, 0x1002, 0x2001, 0x2002, 0x2003, 0x200B, 0x3000, 0x9999})


class _End:
    """A point number past the controller's point table (:meth:`Controller._first_coord`)."""


END = _End()
#: The longest model name read, in characters (2154 sends one a call).
MODEL_NAME_MAX = 64


@dataclass(frozen=True)
class WriteStep:
    """One write sequence of an item, how to read back what it changes, and which
    part of the item's value that is."""

    sequence: WriteSequence
    readback: Callable[[], object]
    part: Callable[[Any], object]
    #: the part of the item it writes, as a diff names it (a point's ``x``, ``hand``)
    name: str = ""


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


def _whole(value: Any) -> object:
    return value


def _coord_of(axis: int, point: Point) -> object:
    return point.coords[axis]


def _attribute_of(name: str, point: Point) -> object:
    return point.attribute(name)


def _extra_of(name: str, point: Point) -> object:
    return getattr(point, name)


def _numbers(points: list[int], most: int = 6) -> str:
    """``P100-P104, P120 and 3 more``: point numbers in runs, long lists folded."""
    runs: list[list[int]] = []
    for n in points:
        if runs and runs[-1][-1] == n - 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    texts = [f"P{r[0]}" if len(r) == 1 else f"P{r[0]}-P{r[-1]}" for r in runs]
    more = f" and {len(texts) - most} more" if len(texts) > most else ""
    return ", ".join(texts[:most]) + more


def _words(request: Request[object]) -> str:
    return " ".join(f"{w:04X}" for w in request.command.words)


class Controller:
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
        self.handshake = handshake
        self.map = handshake.map
        self.robot_type = robot_type
        self.configured_axes = axes
        self._axes: int | None = None
        self._type: int | None = None
        self.first, self.last = first, last
        self.table_end = profile.POINT_PROBE_END if table_end is None else table_end
        self.first_pull = first_pull
        #: what the point table showed this session (:meth:`point_table`)
        self._table: PointTable | None = None
        #: what the table's last point answered at its probe, and where the
        #: "not defined" answer was first met (for messages)
        self._last_answer: str | NotThere | None = None
        self._not_defined_at: int | None = None
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
        **options: Any,
    ) -> Controller:
        """Connect (taking the line lock) and make the Remote Control function
        usable (§6.2).  With ``reset_function``, a function found in use or halted
        is reset first (§6.5.2), and only while Running is 0.  ``unattended`` (a
        nightly backup) recovers on its own a function found in use, not halted, on
        a robot at rest (Running, Paused, EStopOn and Error 0, Ready 1, the map
        right): with the line lock held here, no harlsync is using it, so it was
        left by one that is gone; :attr:`notes` says so.  On a robot not at rest
        (a task paused, an emergency stop, an error) it is left alone.

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
            notes = []
            if reset_function:
                status = handshake.status()
                if status.function_idle and not status["ExtError"]:
                    log.info("%s: the function is idle: no reset needed", link.label)
                else:
                    handshake.reset_function()
            elif unattended:
                status = handshake.status()
                if not status.function_idle and not status["ExtError"]:
                    left = status.function_signals()
                    if (why := status.unsettled) is not None:
                        raise FunctionBusy(
                            f"the Remote Control function is in use ({left}) on a robot "
                            f"not at rest ({why}): a backup no person watches resets it "
                            "only with Running, Paused, EStopOn and Error 0 and Ready 1; "
                            "nothing sent. Look at the robot; once it is idle, "
                            "'harlsync pull --reset-function' clears it",
                            port=link.label,
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
                    notes.append(
                        f"the Remote Control function was found in use ({left}) with no "
                        "harlsync on the line and the robot at rest (Running, Paused, "
                        "EStopOn and Error 0, Ready 1): left by a harlsync that is gone; "
                        "reset (manual 6.5.2) before the backup"
                    )
                    log.warning("%s: %s", link.label, notes[-1])
            controller = cls(handshake, **options)
            controller.notes = notes
        except BaseException:
            link.close()
            raise
        controller._link = link
        return controller

    @property
    def label(self) -> str:
        return self.handshake.label

    def close(self) -> None:
        """Disconnect and give the line lock back, when :meth:`open` made the link."""
        if self._link is not None:
            try:
                self.handshake.finish()  # a command left unanswered: answered, if it can be
            finally:
                self._link.close()

    # --- the one place commands go through -------------------------------------------

    def _fits(self, request: Request[object]) -> bool:
        return (
            request.command_words <= self.map.command_words
            and request.response_words <= self.map.response_words
        )

    def _error(self, request: Request[object], reply: ErrorReply) -> ControllerError:
        return ControllerError(
            f"{reply.code:04X}",
            port=self.label,
            command=str(request),
            message=f"controller answered error {p.describe_code(reply.code, reply.detail)} "
            f"({reply.remedy})",
        )

    def _execute(self, request: Request[T]) -> T | ErrorReply:
        try:
            return self.handshake.execute(request)
        except ValueError as exc:  # more words than RC+ assigned: nothing was sent
            raise ProjectError(
                f"{exc}: assign more words in RC+ and in robot.yaml connection.map"
            ) from exc

    def ask(self, request: Request[T]) -> T:
        """Send one read and return its value; an error response raises ControllerError.

        Raises ProjectError for a read the register map has too few words for.
        """
        reply = self._execute(request)
        if isinstance(reply, ErrorReply):
            raise self._error(request, reply)
        return reply

    def ask_if_there(self, request: Request[T], absent: frozenset[int]) -> T | None:
        """As :meth:`ask`, but None for an error response whose code is in ``absent``."""
        reply = self._execute(request)
        if isinstance(reply, ErrorReply):
            if reply.code in absent:
                return None
            raise self._error(request, reply)
        return reply

    def _either(
        self,
        full: Request[T],
        first: Request[A],
        second: Request[B],
        join: Callable[[A, B], T],
        absent: frozenset[int] = frozenset(),
    ) -> T | None:
        """``full`` when the map has the words for it, else its two halves joined."""
        if self._fits(full):
            return self.ask_if_there(full, absent)
        a = self.ask_if_there(first, absent)
        return None if a is None else join(a, self.ask(second))

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

    def read_table(self, kind: str, n: int) -> Any:
        """One table entry, None when it is not registered."""
        absent = _ABSENT["table"]
        if kind == "accel":
            return self.ask_if_there(p.read_accel(n), absent)
        if kind in ("accel_s", "accel_r"):
            s = kind == "accel_s"
            return self._either(
                p.read_accel_s(n) if s else p.read_accel_r(n),
                p.read_accel_s_accel(n) if s else p.read_accel_r_accel(n),
                p.read_accel_s_decel(n) if s else p.read_accel_r_decel(n),
                p.AccelReal,
                absent,
            )
        if kind == "speed":
            return self.ask_if_there(p.read_speed(n), absent)
        if kind == "speed_s":
            return self._either(
                p.read_speed_s(n),
                p.read_speed_s_speed_depart(n),
                p.read_speed_s_approach(n),
                lambda sd, a: p.SpeedReal(*sd, a),
                absent,
            )
        return self.ask_if_there(p.read_speed_r(n), absent)

    def _limits(
        self,
        full: Callable[[int], Request[Limits]],
        lower: Callable[[int], Request[str]],
        upper: Callable[[int], Request[str]],
        absent: frozenset[int] = frozenset(),
    ) -> tuple[Limits, ...] | None:
        found = []
        for axis in range(3):
            limits = self._either(full(axis), lower(axis), upper(axis), Limits, absent)
            if limits is None:
                return None
            found.append(limits)
        return tuple(found)

    def read_setting(self, kind: str, n: int | None = None) -> Any:
        """One setting (``n`` for a numbered one); None for a Box the controller
        calls undefined."""
        if kind == "arch":
            assert n is not None
            return self._either(
                p.read_arch(n), p.read_arch_depart(n), p.read_arch_approach(n), p.Distances
            )
        if kind == "fine":
            if self._fits(p.read_fine(self.axes)):
                return self.ask(p.read_fine(self.axes))
            return self.ask(p.read_fine_123()) + self.ask(p.read_fine_456(self.axes))
        if kind == "weight":
            return self.ask(p.read_weight())
        if kind == "inertia":
            return self._either(
                p.read_inertia(), p.read_inertia_load(), p.read_inertia_eccentricity(), p.Inertia
            )
        if kind == "tool":
            return self.ask(p.read_tool())
        if kind == "box":
            assert n is not None
            area = n
            return self._limits(
                lambda a: p.read_box(area, a),
                lambda a: p.read_box_lower(area, a),
                lambda a: p.read_box_upper(area, a),
                _ABSENT["box"],
            )
        if kind in ("plane", "local"):
            assert n is not None
            read = p.read_plane if kind == "plane" else p.read_local
            return tuple(self.ask(read(n, c)) for c in range(self.axes))
        if kind == "xylim":
            return self._limits(p.read_xylim, p.read_xylim_lower, p.read_xylim_upper)
        if kind == "jrange":
            assert n is not None
            return self._either(
                p.read_jrange(n), p.read_jrange_lower(n), p.read_jrange_upper(n), p.PulseLimits
            )
        if kind == "base":
            return tuple(self.ask(p.read_base(c)) for c in range(self.axes))
        if kind == "limz":
            return self.ask(p.read_limz())
        raise KeyError(f"no setting {kind!r}")

    # --- points: where the table ends, what "no point" answers (issue 29) -----------

    def _point_answer(self, number: int, axis: int = 0) -> str | NotThere:
        """1222 of one coordinate: the coordinate, or the error response as a
        :class:`NotThere` when it may say "no point here".  Raises ControllerError
        for one that never does (:data:`_NEVER_ABSENT`)."""
        request = p.read_point_coord(number, axis)
        reply = self._execute(request)
        if isinstance(reply, ErrorReply):
            if reply.code in _NEVER_ABSENT:
                raise self._error(request, reply)
            return NotThere(reply.code, reply.detail)
        return reply

    def _unsteady(self, number: int, first: str | NotThere, again: str | NotThere) -> ProjectError:
        def said(answer: str | NotThere) -> str:
            return answer.describe() if isinstance(answer, NotThere) else f"a coordinate ({answer})"

        return ProjectError(
            f"{self.label}: P{number} answered {said(first)}, then {said(again)} when asked "
            "again: harlsync takes a point as not there only from an answer that repeats; "
            "look at the controller (RC+) and run again"
        )

    def point_table(self) -> PointTable:
        """Where the controller's point table ends, from its own behaviour, asked once
        a session: the point past :attr:`table_end` must answer the same error
        response twice (that answer is recorded in controller.yaml and is part of
        the robot's identity), and the last point's answer is kept.  A few
        exchanges: P(end+1) twice, P(end) once (twice when it answers otherwise
        than P(end+1): what a point not defined answers, learned at once).

        Raises ProjectError when the point past the table is defined (the table is
        larger than robot.yaml says), or answers two different things."""
        if self._table is not None:
            return self._table
        end = self.table_end
        past = self._point_answer(end + 1)
        if not isinstance(past, NotThere):
            raise ProjectError(
                f"{self.label}: P{end + 1} is defined: the controller's points go past "
                f"P{end}, where harlsync takes its point table to end; set "
                "controller.point_table_end in robot.yaml to the controller's last point "
                "number and pull again"
            )
        again = self._point_answer(end + 1)
        if again != past:
            raise self._unsteady(end + 1, past, again)
        table = PointTable(end, past)
        last = self._point_answer(end)
        if isinstance(last, NotThere) and last != past:
            again = self._point_answer(end)
            if again != last:
                raise self._unsteady(end, last, again)
            table.not_defined, self._not_defined_at = last, end
        self._last_answer = last
        self._table = table
        return table

    def _first_coord(self, number: int, axis: int = 0) -> str | None | _End:
        """A point's coordinate ``axis`` (a point's first read: X), None when the
        point is not defined, :data:`END` when ``number`` lies past the point table.

        An error response is taken as "not defined" when it is the one points not
        defined answered before, or, the first time one is met, when it answers
        the same when asked again.  The answer of the point past the table, asked
        twice, is the table's end only when the table's last point answered it too
        and points not defined answer otherwise (a table smaller than
        robot.yaml's).  Raises ProjectError for an answer that does not repeat, or
        that is neither."""
        table = self.point_table()
        answer = self._point_answer(number, axis)
        if not isinstance(answer, NotThere):
            return answer
        if answer == table.not_defined:
            return None
        again = self._point_answer(number, axis)
        if again != answer:
            raise self._unsteady(number, answer, again)
        if (
            axis == 0
            and answer == table.past_end
            and table.not_defined is not None
            and self._last_answer == table.past_end
        ):
            return END
        if table.not_defined is None:
            table.not_defined, self._not_defined_at = answer, number
            log.info("%s: P%d not defined: it answers %s", self.label, number, answer.describe())
            return None
        where = f"P{self._not_defined_at}" if self._not_defined_at is not None else "a point"
        raise ProjectError(
            f"{self.label}: P{number} answers {answer.describe()} twice, where {where}, not "
            f"defined, answered {table.not_defined.describe()}: one of them is not the "
            "controller's answer for a point not defined (an error of the controller?); "
            "look at the controller (RC+) and run again"
        )

    def read_point(self, number: int) -> Point | None:
        """One point: 1222 per axis, then 1215-1220; None when it is not defined (or
        past the point table)."""
        first = self._first_coord(number)
        if first is None or isinstance(first, _End):
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

    def read_item(self, key: Key) -> Any:
        """One item's value (None when it is absent)."""
        if isinstance(key, TableKey):
            return self.read_table(key.kind, key.number)
        if isinstance(key, PointKey):
            return self.read_point(key.number)
        return self.read_setting(key.kind, key.number)

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
        outside: list[int] = []
        taken: list[int] = []
        ended: int | None = None
        for done, n in enumerate(numbers, len(keys) + 2):
            found = self._first_coord(n)
            if isinstance(found, _End):
                ended = n
                break
            if found is not None:
                inside = first <= n <= last
                if inside or self.first_pull:
                    data.items[PointKey("point", n)] = self._rest_of_point(n, found)
                if not inside:
                    (taken if self.first_pull else outside).append(n)
            if progress is not None:
                progress(done, total)
        if progress is not None and ended is not None:
            progress(total, total)
        before = [n for n in outside if n < first]
        beyond = [n for n in outside if n > last]
        if before:
            raise ProjectError(
                f"{self.label}: {len(before)} point(s) defined before "
                f"controller.first_point {first}, which this backup would leave out: "
                f"{_numbers(before)}; set controller.first_point: {before[0]} (or less) in "
                "robot.yaml and pull again"
            )
        if beyond:
            raise ProjectError(
                f"{self.label}: {len(beyond)} point(s) defined past controller.last_point "
                f"{last}, which this backup would leave out: {_numbers(beyond)}; set "
                f"controller.last_point: {beyond[-1]} (or more) in robot.yaml and pull again"
            )
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
        data.covered = (first, last)
        if taken:
            data.taken_in = (taken[0], taken[-1])
            data.covered = (min(first, taken[0]), max(last, taken[-1]))
        data.probed_to = recorded.end if probe else None
        return data

    # --- writes ------------------------------------------------------------------------

    def write_steps(self, key: Key, value: Any, fields: tuple[str, ...] = ()) -> list[WriteStep]:
        """The write sequences that make ``key`` hold ``value`` (a point: its
        ``fields``, coordinates first), each with its read-back.

        Raises ValueError for a value the wire cannot carry.
        """
        if isinstance(key, PointKey):
            return self._point_steps(key.number, value, fields)
        return [WriteStep(self._sequence(key, value), partial(self.read_item, key), _whole)]

    def _sequence(self, key: TableKey | SettingKey, value: Any) -> WriteSequence:
        cw = self.map.command_words
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

    def _point_steps(self, number: int, point: Point, fields: tuple[str, ...]) -> list[WriteStep]:
        names = coordinate_names(len(point.coords))
        steps = []
        for name in fields:
            if name in names:
                axis = names.index(name)
                steps.append(
                    WriteStep(
                        p.set_point_coord(number, axis, point.coords[axis]),
                        partial(self._point_coord, number, axis),
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
                        partial(self.ask, p.read_point_j1angle(number)),
                        partial(_extra_of, "j1angle"),
                        name,
                    )
                )
            else:
                attribute = ATTRIBUTE_OF[name]
                steps.append(
                    WriteStep(
                        p.set_point_attribute(attribute, number, point.attribute(attribute)),
                        partial(self.ask, p.read_point_attribute(attribute, number)),
                        partial(_attribute_of, attribute),
                        name,
                    )
                )
        return steps

    def _point_coord(self, number: int, axis: int) -> str | None:
        found = self._first_coord(number, axis)
        return None if isinstance(found, _End) else found

    @staticmethod
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
            f"{run[0].number} {p.COMMANDS[run[0].number].name}: "
            + " | ".join(_words(r) for r in run)
            for run in runs
        )

    def write(self, steps: list[WriteStep], value: Any, old: Any) -> None:
        """Send each step and confirm it.

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
                self._confirmed(step, step.part(value), None if old is None else step.part(old))
            except HarlsyncError as exc:
                if i == 0:
                    raise
                raise self._partly(steps, i, exc) from exc

    def _partly(self, steps: list[WriteStep], stopped: int, exc: HarlsyncError) -> PartlyWritten:
        """Steps before ``stopped`` went out and took; ``stopped`` did not take when
        the interlock or the controller refused it, and may have after a lost reply."""
        sent = [s.name for s in steps[:stopped]]
        unknown = steps[stopped].name if isinstance(exc, LinkError) else None
        left = [s.name for s in steps[stopped + (unknown is not None) :]]
        what = steps[0].sequence.what.split(" ")[0]
        return PartlyWritten(
            f"{self.label}: {what} partly written: {partly_words(sent, unknown, left)} ({exc})",
            sent=sent,
            left=left,
            unknown=unknown,
            cause=exc,
        )

    def _confirmed(self, step: WriteStep, wanted: object, old: object) -> None:
        sequence = step.sequence

        def send() -> None:
            try:
                reply = self.handshake.execute_sequence(sequence)
            except LinkTimeout as exc:  # the handshake's deadline, or Modbus silence
                raise WriteUnconfirmed(
                    f"{sequence.what}: the write may or may not have taken ({exc.message})",
                    port=self.label,
                    command=exc.command,
                ) from exc
            if reply is not None:
                request = next(r for r in sequence if r.number == reply.number)
                raise self._error(request, reply)

        confirmed_write(
            send,
            step.readback,
            wanted,
            old,
            what=sequence.what,
            before_resend=partial(
                refuse_unless_idle,
                self.status,
                where=f"{self.label}, {sequence.what}",
                reading="the status",
            ),
        )
