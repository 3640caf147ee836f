"""What the interlock reads: the 215H system status and the 212H axis statuses,
every reason they give not to write now, and what a person does about each.

:class:`SystemStatus` names its refusals in the profile's order (p.27-31), one
constant per bit; :func:`axes_refusal` fails closed for an axis a 212H reply
leaves out; :class:`IaiStatus` is the two together, as
:meth:`~harlsync.families.iai.controller.Controller.status` reads them.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

__all__ = [
    "AXIS_IN_USE",
    "AXIS_SERVO_ON",
    "MODE_NAMES",
    "NO_CRITICAL_ERROR",
    "READ_AGAIN_ADVICE",
    "S1_EMERGENCY_STOP",
    "S1_SAFETY_GATE_OPEN",
    "S2_FLASH_ROM_WRITING",
    "S2_PROGRAM_RUNNING",
    "S2_SLAVE_PARAMETER_WRITING",
    "S3_DRIVE_CUT_OFF",
    "S3_OPERATING_IN_AUTO",
    "S3_POSITIONER_MODE",
    "S3_SYSTEM_READY",
    "AxisStatus",
    "IaiStatus",
    "SystemStatus",
    "axes_advice",
    "axes_refusal",
]

#: 215H system mode codes (p.30).
MODE_NAMES = {0: "indeterminable", 1: "AUTO", 2: "MANUAL", 3: "slave update", 4: "core update"}

# --- 215H and 212H bits the interlock reads (p.27-31), one constant each ----------------

#: 215H status byte 1 bit 3: the emergency stop switch is pressed.
S1_EMERGENCY_STOP = 0x08
#: 215H status byte 1 bit 2: safety gate open (0 CLOSE, 1 OPEN).  On X-SEL
#: P/Q/.../SXD, SSEL/ASEL/PSEL and TTA the same bit is the enable (deadman) switch.
S1_SAFETY_GATE_OPEN = 0x04
#: 215H status byte 2 bit 5: a program is running.
S2_PROGRAM_RUNNING = 0x20
#: 215H status byte 2 bit 1: slave parameters are being written.
S2_SLAVE_PARAMETER_WRITING = 0x02
#: 215H status byte 2 bit 0: application data is being written to (or erased from) flash ROM.
S2_FLASH_ROM_WRITING = 0x01
#: 215H status byte 3 bit 4: positioner mode (0 program mode): a PLC can move the
#: robot to a position number with no program running.
S3_POSITIONER_MODE = 0x10
#: 215H status byte 3 bit 2: the system is ready.
S3_SYSTEM_READY = 0x04
#: 215H status byte 3 bit 1: operating in AUTO mode.
S3_OPERATING_IN_AUTO = 0x02
#: 215H status byte 3 bit 0: the drive source is cut off.
S3_DRIVE_CUT_OFF = 0x01
#: 215H critical-level system error number when there is none.
NO_CRITICAL_ERROR = "000"
#: 212H axis status bit 0: a task holds the axis (moving, servo starting or
#: stopping, paused).
AXIS_IN_USE = 0x01
#: 212H axis status bit 3: servo on.
AXIS_SERVO_ON = 0x08


#: A 215H status bit the interlock reads: (status byte 1-3, its mask, whether the
#: bit set (True) or clear (False) forbids a write, the reason, the advice's key).
_Bit = tuple[int, int, bool, str, str]

#: The bits checked before the critical error number, in the interlock's order.
_BITS_BEFORE_ERROR: tuple[_Bit, ...] = (
    (2, S2_PROGRAM_RUNNING, True, "program running (215H status byte 2 bit 5)", "program"),
    (
        2,
        S2_FLASH_ROM_WRITING,
        True,
        "flash ROM write in progress (215H status byte 2 bit 0)",
        "flash",
    ),
    (
        2,
        S2_SLAVE_PARAMETER_WRITING,
        True,
        "slave parameter writing (215H status byte 2 bit 1)",
        "slave",
    ),
    (3, S3_OPERATING_IN_AUTO, True, "operating in AUTO mode (215H status byte 3 bit 1)", "auto"),
    (3, S3_SYSTEM_READY, False, "system not ready (215H status byte 3 bit 2)", "ready"),
    (1, S1_EMERGENCY_STOP, True, "emergency stop (215H status byte 1 bit 3)", "estop"),
)
#: The bits checked after it.
_BITS_AFTER_ERROR: tuple[_Bit, ...] = (
    (3, S3_DRIVE_CUT_OFF, True, "drive source cut off (215H status byte 3 bit 0)", "cutoff"),
    (
        3,
        S3_POSITIONER_MODE,
        True,
        (
            "positioner mode: a PLC can move the robot to a position number with no "
            "program running (215H status byte 3 bit 4)"
        ),
        "positioner",
    ),
    (
        1,
        S1_SAFETY_GATE_OPEN,
        True,
        (
            "safety gate open, or the enable switch on a TTA, X-SEL P/Q/R/S or "
            "SSEL/ASEL/PSEL (215H status byte 1 bit 2)"
        ),
        "gate",
    ),
)


@dataclass(frozen=True)
class SystemStatus:
    """215H: system mode, the two error numbers (hex text) and status bytes 1-4."""

    mode: int
    critical_error: str
    latest_error: str
    status1: int
    status2: int
    status3: int
    status4: int

    def _refused(self) -> list[tuple[str, str]]:
        """Every reason the profile's interlock forbids a write now, in its order, each
        with what a person does about it."""
        out: list[tuple[str, str]] = []
        if self.mode != 1:
            name = MODE_NAMES.get(self.mode)
            out.append(
                (f"{name} mode (215H mode {self.mode})", _ADVICE["mode"])
                if name
                else (f"unknown system mode {self.mode} (215H)", _ADVICE["unknown mode"])
            )
        out += self._bits_refused(_BITS_BEFORE_ERROR)
        if self.critical_error.upper() != NO_CRITICAL_ERROR:
            reason = (
                f"critical error {self.critical_error.upper()} on the controller "
                "(215H critical-level system error number)"
            )
            out.append((reason, _ADVICE["error"]))
        out += self._bits_refused(_BITS_AFTER_ERROR)
        return out

    def _bits_refused(self, bits: tuple[_Bit, ...]) -> list[tuple[str, str]]:
        """The reasons among ``bits`` that forbid a write now, with their advice."""
        out = []
        for byte, mask, when_set, reason, cause in bits:
            value = (self.status1, self.status2, self.status3)[byte - 1]
            if bool(value & mask) == when_set:
                out.append((reason, _ADVICE[cause]))
        return out

    @property
    def refusals(self) -> tuple[str, ...]:
        """Every reason the profile's interlock forbids a write now, in its order."""
        return tuple(reason for reason, _ in self._refused())

    @property
    def refusal(self) -> str | None:
        """The first reason a write is forbidden, or None when the system is idle."""
        refusals = self.refusals
        return refusals[0] if refusals else None

    @property
    def advice(self) -> str | None:
        """What a person does about :attr:`refusal` (one sentence), or None when idle."""
        refused = self._refused()
        return refused[0][1] if refused else None


#: What a person does about each reason the interlock refuses a write, in IAI's words.
_ADVICE = MappingProxyType(
    {
        "mode": (
            "Set the controller's mode switch to AUTO (protocol B writes only in AUTO mode, "
            "with no program running) and run again"
        ),
        "unknown mode": (
            "Check the controller's mode on its display or the teaching pendant, set it to "
            "AUTO and run again"
        ),
        "program": "Stop the program (or wait for it to end) and run again",
        "flash": (
            "Wait for the flash ROM write to finish (do not switch the controller off "
            "meanwhile), then run again"
        ),
        "slave": "Wait for the slave parameter write to finish, then run again",
        "auto": "Stop the automatic operation (the program or a PLC's start) and run again",
        "ready": "Wait for the controller to be ready (see its display), then run again",
        "estop": (
            "Find why the emergency stop is on; when it is safe, release it and reset the "
            "controller's alarm, then run again"
        ),
        "error": (
            "Look the code up in the controller's error list, remove its cause and clear "
            "the error on the controller, then run again"
        ),
        "cutoff": "Restore the drive source (the motor power) and run again",
        "positioner": (
            "Take the controller out of positioner mode (in it a PLC can move the robot "
            "at any time) and run again"
        ),
        "gate": (
            "Close the safety gate (a TTA, X-SEL P/Q/R/S or SSEL/ASEL/PSEL: release the "
            "enable switch) and run again"
        ),
        "axis in use": (
            "Wait for the axis to stop (a program, the teaching pendant or a PLC holds it) "
            "and run again"
        ),
        "axis unseen": (
            "Check that the axis's driver is connected and that robot.yaml's axes are the "
            "robot's, then run again"
        ),
        "read again": (
            "Check the line (cable, noise: the status had to be asked for again) and run again"
        ),
    }
)


@dataclass(frozen=True)
class AxisStatus:
    """212H, one axis: status bits, sensors, error number (hex text), encoder
    status and the current position as coordinate text."""

    axis: int
    status: int
    sensors: int
    error: str
    encoder: int
    position: str

    @property
    def in_use(self) -> bool:
        """Bit 0: a task holds the axis (moving, servo starting or stopping, paused)."""
        return bool(self.status & AXIS_IN_USE)

    @property
    def servo_on(self) -> bool:
        return bool(self.status & AXIS_SERVO_ON)

    @property
    def home(self) -> int:
        """Bits 1-2: 0 not yet returned, 1 returning, 2 completed."""
        return self.status >> 1 & 3

    @property
    def refusal(self) -> str | None:
        if self.in_use:
            return f"axis {self.axis} servo axis in use (212H axis status bit 0)"
        return None


def axes_refusal(axes: tuple[int, ...], statuses: tuple[AxisStatus, ...]) -> str | None:
    """The first reason 212H forbids a write for the robot's ``axes``, or None.

    Fails closed: an axis of the robot the reply leaves out (driver not
    connected, or a reply that lists fewer axes than asked for) cannot be seen
    to be idle, so it refuses; so does a reply that reports no axis at all.
    """
    refused = _axes_refused(axes, statuses)
    return None if refused is None else refused[0]


def axes_advice(axes: tuple[int, ...], statuses: tuple[AxisStatus, ...]) -> str | None:
    """What a person does about :func:`axes_refusal`'s reason, or None."""
    refused = _axes_refused(axes, statuses)
    return None if refused is None else refused[1]


#: What a person does when 212H and 215H could not be read back to back.
READ_AGAIN_ADVICE = _ADVICE["read again"]


def _axes_refused(
    axes: tuple[int, ...], statuses: tuple[AxisStatus, ...]
) -> tuple[str, str] | None:
    by_axis = {s.axis: s for s in statuses}
    for axis in axes:
        status = by_axis.get(axis)
        if status is None:
            reason = (
                f"axis {axis} not reported by 212H (its reply lists "
                f"{_axes_listed(statuses)}): an axis it does not report cannot be seen to be idle"
            )
            return reason, _ADVICE["axis unseen"]
        if status.refusal is not None:
            return status.refusal, _ADVICE["axis in use"]
    if not statuses:
        return (
            "212H reports no axis: an axis it does not report cannot be seen to be idle",
            _ADVICE["axis unseen"],
        )
    return None


def _axes_listed(statuses: tuple[AxisStatus, ...]) -> str:
    if not statuses:
        return "no axis"
    return "axis " + ", ".join(str(s.axis) for s in statuses)


@dataclass(frozen=True)
class IaiStatus:
    """The interlock's answer: 212H and 215H, and the first reason not to write."""

    system: SystemStatus
    axes: tuple[AxisStatus, ...]
    refusal: str | None
    #: what a person does about :attr:`refusal`, in IAI's words (None when idle)
    advice: str | None = None

    @property
    def idle(self) -> bool:
        return self.refusal is None

    def describe(self) -> str:
        return "idle" if self.refusal is None else self.refusal
