"""The HARL-U2 codec as the shared link drives it (:class:`harlsync.link.codec.Codec`).

Sans I/O like the rest of the protocol package: it names the decoder, the serial
defaults, the reply deadline and what to check when a station stays silent.
"""

from __future__ import annotations

from ....settings import SerialSettings
from . import profile
from .frame import FrameDecoder

__all__ = ["CODEC", "SETTINGS", "Codec"]

#: The profile's serial settings: 9600 8N1, no flow control, 1 s, 3 read retries.
SETTINGS = SerialSettings(
    baudrate=profile.BAUDRATE,
    bytesize=profile.BYTESIZE,
    parity=profile.PARITY,
    stopbits=profile.STOPBITS,
    rtscts=profile.RTSCTS,
    timeout=profile.REPLY_TIMEOUT,
    retries=3,
)


class Codec:
    """STX station SP payload ETX LRC frames; every reply has the same deadline."""

    settings = SETTINGS
    #: The controller takes the next command as soon as it has answered.
    reply_gap = 0.0

    def decoder(self) -> FrameDecoder:
        return FrameDecoder()

    def station_text(self, station: int) -> str:
        return str(station)

    def no_reply_hint(self, station: int) -> str:
        return (
            "check the station number (pendant: SYSTEM GENERATION > MAINTENANCE > STATION NO.), "
            "the cable, and the serial settings (baud, parity) in robot.yaml"
        )

    def reply_timeout(self, request: object, settings: SerialSettings) -> float:
        """``settings.timeout``: no HARL-U2 reply is long on the wire (under 200 bytes)."""
        return settings.timeout


CODEC = Codec()
