"""A robot's serial settings: plain data, no pyserial and no family.

The project store reads and writes these, the link opens a port with them, and
each family supplies its own defaults (its codec's ``settings``).  The defaults
here are the ones every existing robot.yaml was written against (the first
family's profile: 9600 8N1, no flow control, a 1 s reply deadline, 3 read retries), so a
file that leaves a setting out means what it always meant.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal

__all__ = ["SerialSettings", "seconds"]


def seconds(value: float) -> str:
    """A duration as robot.yaml writes it and a person configured it: the shortest
    text that reads back as the same number (``0.5``, ``1.0``, ``0.1234567``), never
    rounded to fewer digits (``:g`` makes ``0.1234567`` ``0.123457``) nor in
    exponent form (``1e-05`` is ``0.00001``)."""
    text = repr(float(value))
    return format(Decimal(text), "f") if "e" in text else text


@dataclass(frozen=True)
class SerialSettings:
    """Per-robot serial settings and reply deadline.

    ``timeout`` is the seconds a reply may take (a family's codec may stretch it
    per request, for replies that take long on the wire); ``retries`` how many
    times a read (never a write) is re-sent after a lost or garbled reply.
    """

    baudrate: int = 9600
    bytesize: int = 8
    parity: str = "N"
    stopbits: float = 1
    rtscts: bool = False
    timeout: float = 1.0
    retries: int = 3

    def __str__(self) -> str:
        """As robot.yaml's reader would say it: ``9600 8N1, no flow control, reply
        timeout 1.0 s, 3 retries``."""
        stop = f"{self.stopbits:g}"
        flow = "RTS/CTS" if self.rtscts else "no flow control"
        return (
            f"{self.baudrate} {self.bytesize}{self.parity}{stop}, {flow}, "
            f"reply timeout {seconds(self.timeout)} s, {self.retries} retries"
        )
