"""One read of an Epson controller's Remote outputs, and what it says: the
interlock's answer (may a write go now, and if not, why), and whether the Remote
Control function is idle."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from .profile import INTERLOCK_SIGNALS, READY
from .protocol import CONTROL_DEVICES, REMOTE_IO

__all__ = ["RemoteStatus"]

#: What each interlock signal at 1 means.
_BUSY_TEXT: Mapping[str, str] = MappingProxyType(
    {
        "Running": "a task is executing",
        "Paused": "a task is paused",
        "EStopOn": "emergency stop",
        "Error": "the controller is in error",
        "SafeguardOn": "the safeguard is open: a person may be in the cell",
    }
)
_FUNCTION_SIGNALS = (
    "ExtCmdReset",
    "ExtCmdSet",
    "ExtRespGet",
    "ExtCmdGet",
    "ExtRespSet",
    "ExtError",
)


@dataclass(frozen=True)
class RemoteStatus:
    """One read of the controller's outputs, with the handshake's own inputs.

    ``signals`` holds every signal by its manual name (None: not mapped);
    ``response`` the response words as read.  It is the interlock's answer too
    (:class:`~harlsync.families.base.Status`).
    """

    signals: Mapping[str, bool | None]
    response: tuple[int, ...]
    #: why the map never allows a write (:attr:`RegisterMap.unwritable`)
    unwritable: str | None = None
    #: what 2156 (the control device) and 2155 (the controller's error code)
    #: answered, read before a write when the signals allow one; None: not read
    control_device: int | None = None
    controller_error: int | None = None
    #: why they could not be read (then no write goes: fail closed)
    unreadable: str | None = None

    def __getitem__(self, name: str) -> bool | None:
        return self.signals[name]

    @property
    def busy(self) -> tuple[str, ...]:
        """The interlock signals at 1: Running, Paused, EStopOn, Error."""
        return tuple(name for name in INTERLOCK_SIGNALS if self.signals[name])

    @property
    def mismapped(self) -> str | None:
        """Why these outputs cannot be the controller's as mapped, or None: Ready
        and Running at 1 together (the controller's Ready means no task runs)."""
        if self.signals.get(READY) and self.signals.get("Running"):
            return (
                "Ready 1 and Running 1 together, which the controller never shows (Ready "
                "means no task runs): one of them is mapped to the wrong bit; check "
                "robot.yaml connection.map against RC+"
            )
        return None

    @property
    def not_ready(self) -> bool:
        """Ready is mapped and reads 0 (while no interlock signal says why)."""
        return self.signals.get(READY) is False

    @property
    def blocked(self) -> str | None:
        """Why a write may not go now, the function aside, or None."""
        if self.unwritable is not None:
            return self.unwritable
        if self.mismapped is not None:
            return self.mismapped
        if self.busy:
            return ", ".join(f"{name} 1 ({_BUSY_TEXT[name]})" for name in self.busy)
        if self.not_ready:
            return (
                "Ready 0 (the controller is not ready: still starting up, or Ready is "
                "mapped to a bit it does not drive)"
            )
        if self.unreadable is not None:
            return self.unreadable
        if self.control_device is not None and self.control_device != REMOTE_IO:
            device = CONTROL_DEVICES.get(self.control_device, "unknown")
            return (
                f"the control device is {self.control_device} ({device}), not 22 (Remote "
                "I/O): someone controls the robot from there (2156)"
            )
        if self.controller_error:
            return (
                f"the controller reports error {self.controller_error} (2155), though its "
                "Error signal reads 0: the controller is in error, or Error is mapped to a "
                "bit it does not drive"
            )
        return None

    @property
    def unsettled(self) -> str | None:
        """Why the robot is not plainly at rest, or None: what :attr:`blocked` says,
        or a map without Ready (then nothing shows the controller up with no task
        run).  A function reset no person asked for goes only to a robot at rest:
        dropping ExtCmdReset aborts a paused task too (§4.1.1)."""
        blocked = self.blocked
        if blocked is not None:
            return blocked
        if self.signals.get(READY) is None:
            return "the register map has no Ready signal (nothing shows that no task runs)"
        return None

    @property
    def function_off(self) -> tuple[str, ...]:
        """The signals that keep the function from taking a command (step 1):
        ExtCmdReset at 0, any other handshake signal at 1."""
        return tuple(
            name
            for name in _FUNCTION_SIGNALS
            if bool(self.signals[name]) != (name == "ExtCmdReset")
        )

    @property
    def function_idle(self) -> bool:
        return not self.function_off

    @property
    def operable(self) -> bool:
        """Whether the controller shows it is up (§6.2, "operable"): Ready, or a
        task, an error or an emergency stop at 1; True when Ready is not mapped."""
        if self.signals.get(READY) is None:
            return True
        return any(self.signals.get(name) for name in (READY, *INTERLOCK_SIGNALS))

    @property
    def idle(self) -> bool:
        """Whether a write may go now."""
        return self.blocked is None and self.function_idle

    def describe(self) -> str:
        """``"idle"``, or what forbids a write, naming the signal."""
        blocked = self.blocked
        if blocked is not None:
            return blocked
        if not self.function_idle:
            return f"the Remote Control function is not idle ({self.function_signals()})"
        return "idle"

    def function_signals(self) -> str:
        """The handshake signals that keep the function from taking a command:
        ``"ExtCmdReset 0, ExtRespSet 1"`` (empty when it is idle)."""
        return ", ".join(f"{name} {int(bool(self.signals[name]))}" for name in self.function_off)
