"""The HARL-U2 wire protocol, sans I/O: frames, LRC, typed commands and replies.

Nothing here touches a port, a clock or a thread.
"""

from . import profile
from .commands import (
    READ_LETTERS,
    UNSAFE_LETTERS,
    WRITE_LETTERS,
    Ack,
    ErrorReply,
    Request,
    decode_reply,
    parse_request,
)
from .frame import Frame, FrameDecoder, encode_frame, lrc

__all__ = [
    "READ_LETTERS",
    "UNSAFE_LETTERS",
    "WRITE_LETTERS",
    "Ack",
    "ErrorReply",
    "Frame",
    "FrameDecoder",
    "Request",
    "decode_reply",
    "encode_frame",
    "lrc",
    "parse_request",
    "profile",
]
