"""One point as a simulated Epson controller holds it: a coordinate an axis in
thousandths and its attributes as integers, as the point commands (§10.25) read
and write them; what the controller could not hold (:meth:`Point.problems`), and
a backup's point on the wire (:meth:`Point.from_data`)."""

from __future__ import annotations

from dataclasses import dataclass

from .. import model
from ..protocol import real_units

__all__ = ["Point", "fits_int32"]


def fits_int32(value: int) -> bool:
    """Whether ``value`` is a 32-bit two's complement integer (two words on the wire)."""
    return -(2**31) <= value < 2**31


@dataclass
class Point:
    """One point: a coordinate a robot axis (thousandths; X, Y, Z, U, then V, W on
    a six-axis robot) and its attributes as 1215-1220 read them."""

    coords: tuple[int, ...]
    hand: int = 1  # 0 Lefty, 1 Righty
    elbow: int = 0  # 0 Above, 1 Below
    wrist: int = 0  # 0 NoFlip, 1 Flip
    j4flag: int = 0
    j6flag: int = 0
    local: int = 0  # 0: none
    #: 6-axis robots (1223-1226): Joint 1 and 2 ranges, 0 or 1
    j1flag: int = 0
    j2flag: int = 0
    #: RS robots (1227/1228): Joint 1's angle at the singularity, thousandths of a degree
    j1angle: int = 0

    @classmethod
    def from_data(cls, value: model.Point) -> Point:
        """A backup's point, on the wire: its coordinates (and J1Angle) in
        thousandths, an attribute its robot lacks 0.  Raises ValueError for a
        value that is not exact decimal text."""
        u = real_units
        return cls(
            tuple(u(c) for c in value.coords),
            value.hand,
            value.elbow,
            value.wrist,
            value.j4flag,
            value.j6flag,
            value.local,
            value.j1flag or 0,
            value.j2flag or 0,
            0 if value.j1angle is None else u(value.j1angle),
        )

    def problems(self, axes: int) -> list[str]:
        out = []
        if len(self.coords) != axes:
            out.append(f"{len(self.coords)} coordinates on a {axes}-axis robot")
        for name, value, high in (
            ("hand", self.hand, 1),
            ("elbow", self.elbow, 1),
            ("wrist", self.wrist, 1),
            ("j4flag", self.j4flag, 1),
            ("j6flag", self.j6flag, 127),
            ("local", self.local, 15),
            ("j1flag", self.j1flag, 1),
            ("j2flag", self.j2flag, 1),
        ):
            if not 0 <= value <= high:
                out.append(f"{name} {value} out of range (0 to {high})")
        out += [f"coordinate {c} does not fit 32 bits" for c in self.coords if not fits_int32(c)]
        if not fits_int32(self.j1angle):
            out.append(f"j1angle {self.j1angle} does not fit 32 bits")
        return out
