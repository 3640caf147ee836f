"""One serial line to a HARL-U2 controller (placeholder: being written)."""

from __future__ import annotations

from dataclasses import dataclass

from .protocol import profile

__all__ = ["SerialSettings"]


@dataclass(frozen=True)
class SerialSettings:
    """Per-robot serial settings and reply deadline; defaults are the profile's."""

    baudrate: int = profile.BAUDRATE
    bytesize: int = profile.BYTESIZE
    parity: str = profile.PARITY
    stopbits: float = profile.STOPBITS
    rtscts: bool = profile.RTSCTS
    timeout: float = profile.REPLY_TIMEOUT
    retries: int = 3
