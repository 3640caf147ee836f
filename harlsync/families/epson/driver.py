"""An Epson controller as the engine's :class:`~harlsync.families.base.Driver`: read
everything, read or write one item (a table entry, a setting, the fields of a
point a plan writes), and the interlock (the handshake's :class:`RemoteStatus`)."""

from __future__ import annotations

from typing import Any

from ...errors import ProjectError
from ..base import Driver, Progress, Status
from .catalogue import CATALOGUE, Key, PointWrite
from .controller import Controller
from .model import EpsonData, PointKey
from .protocol import REMOTE_IO
from .remote_status import RemoteStatus
from .writes import WriteStep, command_text

__all__ = ["EpsonDriver"]

#: What a person does about each interlock signal at 1, the gravest first.
_ADVICE = {
    "EStopOn": (
        "Find why the emergency stop is on; when it is safe, release it and reset the "
        "controller (Reset in RC+ or the Reset input), then run again"
    ),
    "SafeguardOn": (
        "Make sure no one is in the cell, close the safeguard (safety door) and reset the "
        "controller if it asks, then run again"
    ),
    "Error": (
        "Read the error in RC+ (its number says what it is), remove its cause and reset "
        "the controller (Reset in RC+ or the Reset input), then run again"
    ),
    "Paused": (
        "A paused task goes on where it stopped: stop it from RC+ or the operator's "
        "controls (a push never resumes or aborts a task), then run again"
    ),
    "Running": (
        "Stop the task from RC+ or the operator's controls (or wait for it to end) and run again"
    ),
}


class EpsonDriver(Driver[Key, EpsonData]):
    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.label = controller.label
        self._identity: tuple[int, int, str] | None = None
        self._command = ""

    @property
    def serves(self) -> str:
        """The harlsync command this connection serves; setting it makes every message
        that asks for a function reset name that command (issue 34 item 5: a push
        refused for a function left in use advised a pull, which saves the robot's
        half-written point over the committed edit)."""
        return self._command

    @serves.setter
    def serves(self, command: str) -> None:
        self._command = command
        self.controller.handshake.reset_advice = self.reset_advice

    @property
    def reset_advice(self) -> str:
        """``'harlsync push DIR --reset-function'``: the command being run, again,
        with the option; without a command known, the option alone."""
        if not self._command:
            return "--reset-function"
        return f"'harlsync {self._command} DIR --reset-function'"

    def identity(self) -> dict[str, str]:
        """2153 and 2154 (the manipulator), the first commands of a read, kept for
        :meth:`read_all`; and what the point past the point table answers (asked
        twice): a controller that answers otherwise than the backup records is
        refused at its first exchanges (issue 29)."""
        self._identity = code, axes, model = self.controller.identify()
        table = self.controller.point_table()
        return CATALOGUE.robot_identity(EpsonData(code, axes, model, table=table))

    def read_all(
        self, *, registers: bool, progress: Progress | None = None, whole: bool = False
    ) -> EpsonData:
        """Every setting and point (an Epson robot has no runtime data to add);
        ``whole``: probe past the point range too (see :meth:`Controller.read_all`)."""
        identity, self._identity = self._identity, None
        return self.controller.read_all(progress, probe=whole, identity=identity)

    @property
    def notes(self) -> list[str]:
        """What the connection recovered on its own (see :meth:`Controller.open`)."""
        return list(self.controller.notes)

    def status(self) -> RemoteStatus:
        return self.controller.status()

    def advice(self, status: Status) -> str:
        """By the signal that refuses, the gravest first: EStopOn, SafeguardOn, Error,
        Paused, Running; then Ready 0, 2156 and 2155 (unreadable, another control
        device, an error code) and a function in use.  A map that can never allow a
        write says what to do itself."""
        if not isinstance(status, RemoteStatus):
            return super().advice(status)
        if status.unwritable is not None or status.mismapped is not None:
            return ""
        for signal, advice in _ADVICE.items():
            if signal in status.busy:
                return advice
        if status.not_ready:
            return (
                "Wait for the controller to finish starting up (Ready 1); if Ready stays "
                "0, check robot.yaml connection.map against RC+"
            )
        if status.unreadable is not None:
            return "Check the controller and the line, then run again"
        if status.control_device is not None and status.control_device != REMOTE_IO:
            return (
                "Whoever controls the robot from there ends and gives control back to "
                "Remote I/O (RC+ [Setup]-[System Configuration]-[Controller]-"
                "[Configuration]), then run again"
            )
        if status.controller_error:
            return (
                _ADVICE["Error"] + "; if Error stays 0 meanwhile, check robot.yaml connection.map"
            )
        if not status.function_idle:
            how = (
                self.reset_advice
                if self._command
                else "running the same command again with --reset-function"
            )
            return (
                "Wait for the command of the other Remote Control client to end; a "
                f"function an earlier harlsync left in use is reset by {how} (on an idle "
                "robot)"
            )
        return super().advice(status)

    def read(self, key: Key) -> Any:
        if isinstance(key, PointWrite):
            return self.controller.read_point(key.number)
        return self.controller.read_item(key)

    def _steps(self, key: Key, value: Any) -> list[WriteStep]:
        """Raises ProjectError for a value the wire cannot carry, or a write the
        register map has too few command words for."""
        try:
            if isinstance(key, PointWrite):
                return self.controller.write_steps(PointKey("point", key.number), value, key.fields)
            return self.controller.write_steps(key, value)
        except ValueError as exc:
            raise ProjectError(f"{CATALOGUE.describe(key)}: cannot be written: {exc}") from exc

    def write(self, key: Key, value: Any, old: Any = None, *, needs_idle: bool = True) -> None:
        """Write one item; every Epson write needs an idle robot, so ``needs_idle``
        changes nothing."""
        if old is None:
            old = self.read(key)
        self.controller.write(self._steps(key, value), value, old)

    def command(self, key: Key, value: Any) -> str:
        """The commands a write sends, by number and name, with each one's words in
        hex: ``53 register AccelS table entry: 0035 0003 0001 871B 0003 0D40``
        (see :func:`~.writes.command_text`)."""
        return command_text(self._steps(key, value))

    def unsafe(self, key: Key) -> bool:
        return True  # every Epson write needs an idle robot

    def close(self) -> None:
        self.controller.close()
