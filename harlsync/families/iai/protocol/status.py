"""Requests for the version and the system and axis statuses (201H, 215H, 212H)."""

from ..interlock import AxisStatus, SystemStatus
from ..model import (
    Version,
    axes_from_pattern,
    coord_from_wire,
)
from .frame import _FRAME_OVERHEAD
from .request import Request, _check, _Fields

# --- 201H, 215H, 212H: version and status -------------------------------------------

_TIME_FIELDS = ("month", "day", "hour", "minute", "second")


def version(unit_type: int = 0, device: int = 0) -> Request[Version]:
    """201H: the version of unit ``unit_type`` (0 main CPU application), device 0."""
    _check(unit_type, 0, 0xFF, "unit type")
    _check(device, 0, 0xF, "device number")

    def parse(data: str) -> Version:
        f = _Fields(data)
        f.expect(2, unit_type, "unit type")
        f.expect(1, device, "device number")
        model_code, unit_code = f.code(2, "model code"), f.code(2, "unit code")
        number = f.code(4, "version")
        year = f.hex(4, "year")
        month, day, hour, minute, second = (f.hex(2, name) for name in _TIME_FIELDS)
        f.end()
        built = f"{year:04d}-{month:02d}-{day:02d} {hour:02d}:{minute:02d}:{second:02d}"
        return Version(unit_type, device, model_code, unit_code, number, built)

    return Request(0x201, f"{unit_type:02X}{device:X}", False, False, parse, 35)


def system_status() -> Request[SystemStatus]:
    """215H: mode, error numbers and status bytes; the interlock reads it."""

    def parse(data: str) -> SystemStatus:
        f = _Fields(data)
        mode = f.hex(1, "system mode")
        critical, latest = f.code(3, "critical error"), f.code(3, "latest error")
        s1, s2, s3, s4 = (f.hex(2, f"status byte {n}") for n in range(1, 5))
        f.end()
        return SystemStatus(mode, critical, latest, s1, s2, s3, s4)

    return Request(0x215, "", False, True, parse, 25)


def axis_status(pattern: int) -> Request[tuple[AxisStatus, ...]]:
    """212H: the status of the axes in ``pattern`` (bit n = axis n+1).

    The reply lists the axes it reports, lowest first; an axis left out is not
    connected (see :func:`~harlsync.families.iai.interlock.axes_refusal`).
    """
    _check(pattern, 1, 0xFF, "axis pattern")

    def parse(data: str) -> tuple[AxisStatus, ...]:
        f = _Fields(data)
        got = f.hex(2, "axis pattern")
        if got & ~pattern:
            raise ValueError(f"reports axis pattern {got:02X}h, asked for {pattern:02X}h")
        out = []
        for axis in axes_from_pattern(got):
            what = f"axis {axis}"
            status, sensors = f.hex(2, f"{what} status"), f.hex(1, f"{what} sensors")
            error, encoder = f.code(3, f"{what} error"), f.hex(2, f"{what} encoder")
            position = coord_from_wire(f.take(8, f"{what} position"))
            out.append(AxisStatus(axis, status, sensors, error, encoder, position))
        f.end()
        return tuple(out)

    reply = _FRAME_OVERHEAD + 2 + 16 * len(axes_from_pattern(pattern))
    return Request(0x212, f"{pattern:02X}", False, True, parse, reply)
