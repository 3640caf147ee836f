"""The IAI protocol B codec as the shared link drives it (:class:`harlsync.link.codec.Codec`).

Sans I/O: it names the decoder, the profile's serial defaults, the reply deadline
of each request and what to check when a controller stays silent.  The deadline
is the profile's: the robot's ``timeout`` (default 0.5 s) plus 1.5 times the
wire time of the longest reply the request can get, so a 22DH reading 2 KiB at
9600 baud gets 3.7 s and a 215H 0.54 s.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ...settings import SerialSettings
from . import profile
from .protocol import Frame, FrameDecoder, Request

if TYPE_CHECKING:
    from ...link.codec import Codec as LinkCodec

__all__ = ["CODEC", "SETTINGS", "Codec"]

#: The profile's serial settings: 9600 8N1, no flow control, 0.5 s plus wire time.
SETTINGS = SerialSettings(
    baudrate=profile.BAUDRATE,
    bytesize=profile.BYTESIZE,
    parity=profile.PARITY,
    stopbits=profile.STOPBITS,
    rtscts=profile.RTSCTS,
    timeout=profile.REPLY_DEADLINE_BASE,
    retries=3,
)

#: A reply as long as the largest send buffer of any model: for a request we do not know.
_LONGEST_REPLY = max(b.send for b in profile.BUFFERS.values())


class Codec:
    """``!`` station id data SC CR LF frames; a reply's deadline grows with its length."""

    settings = SETTINGS
    #: The controller wants at least 1 ms after a reply before the next command (p.9).
    reply_gap = profile.INTER_COMMAND_GAP

    def decoder(self) -> FrameDecoder:
        return FrameDecoder()

    def station_text(self, station: int) -> str:
        return f"{station:02X}"

    def no_reply_hint(self, station: int) -> str:
        return (
            "check that the controller speaks protocol B (I/O parameter No. 90 = 2), that its "
            f"station is {station:02X} (hex, as --station and robot.yaml give it), that it is "
            "in AUTO mode (it answers nothing in MANUAL), the cable, and the baud rate in "
            "robot.yaml"
        )

    def reply_timeout(self, request: object, settings: SerialSettings) -> float:
        """``settings.timeout`` plus 1.5 x the wire time of the longest reply ``request``
        can get (the largest send buffer when it is not an IAI request)."""
        reply_bytes = request.reply_bytes if isinstance(request, Request) else _LONGEST_REPLY
        char_bits = profile.bits_per_char(
            settings.bytesize, settings.parity, math.ceil(settings.stopbits)
        )
        wire = reply_bytes * char_bits / settings.baudrate
        return settings.timeout + profile.REPLY_DEADLINE_FACTOR * wire


CODEC = Codec()

if TYPE_CHECKING:  # mypy proves the shared link can drive this codec: Link(url, codec=CODEC)
    _drivable: LinkCodec[Frame] = CODEC
