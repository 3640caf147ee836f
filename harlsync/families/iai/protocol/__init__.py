"""IAI protocol B, sans I/O: frames, SC, typed requests and the decoding of replies.

How this works::

    command  '!'  station  id     data           SC    CR LF
              21  '99'     '212'  '01'           '89'  0D 0A
    reply    '#'  station  id     data           SC    CR LF
              23  '99'     '212'  '021C000...'   'AF'  0D 0A
    error    '&'  station  code                  SC    CR LF     always 10 bytes, no id
              26  '99'     '0A1'                 '3A'  0D 0A

    SC = (sum of the bytes from the header through the last data byte) mod 256,
         two hex digits; SC, CR and LF are not summed.

Every field is fixed-width hex ASCII.  :func:`encode_frame` writes upper case and
a real SC, and refuses any message id off the profile's allow-list.

A :class:`FrameDecoder` is fed whatever bytes arrive, whole, one at a time or
after line noise, and hands back complete frames: header (``!``, ``#`` or ``&``)
through LF.  Bytes before a header are noise: dropped and counted, and so is a
frame cut short by a new header (no field of a valid frame can hold one).  A bad
frame raises a :class:`~harlsync.errors.ProtocolError` subclass after the frame
is consumed, so the next call goes on after it; a frame with no LF within the
length limit is dropped the same way.  ``!`` frames are decoded too: a line that
echoes commands shows them, and the link recognises its own.

A :class:`Request` is a message id and its data, and knows how to decode its reply
into a typed value: :class:`~harlsync.families.iai.model.Version`,
:class:`~harlsync.families.iai.interlock.SystemStatus`, axis statuses, positions,
counts.  An ``&`` reply decodes to an :class:`ErrorReply` value; a reply that
does not answer the request raises :class:`~harlsync.errors.ReplyError`.

Request builders, one per message of the allow-list::

    201H version          215H system_status     212H axis_status
    22DH read_positions   291H write_positions
    opt-in:  20DH read_flags      20EH read_integers      20FH read_reals
             24BH write_flag      24CH write_integers     24DH write_reals
    records: 2A0H read_coordinate_systems                 210H read_strings
             24EH write_strings

The package, a module a job: :mod:`.frame` (frames and SC), :mod:`.request`
(requests and the decoding of replies), and the requests by what they read or
write: :mod:`.status`, :mod:`.positions`, :mod:`.variables`, :mod:`.records`.
"""

from ....errors import ChecksumError
from .frame import Frame, FrameDecoder, FrameKind, encode_frame, sc
from .positions import (
    max_flags_per_read,
    max_positions_per_read,
    max_positions_per_write,
    max_variables_per_read,
    max_variables_per_write,
    parse_write_positions,
    position_fields,
    position_record,
    read_positions,
    write_positions,
)
from .records import (
    max_coordinate_systems_per_read,
    max_string_columns_per_read,
    read_coordinate_systems,
    read_strings,
    write_strings,
)
from .request import ErrorReply, Request
from .status import axis_status, system_status, version
from .variables import (
    read_flags,
    read_integers,
    read_real_words,
    read_reals,
    real_from_wire,
    real_to_wire,
    write_flag,
    write_integers,
    write_reals,
)

__all__ = [
    "ChecksumError",
    "ErrorReply",
    "Frame",
    "FrameDecoder",
    "FrameKind",
    "Request",
    "axis_status",
    "encode_frame",
    "max_coordinate_systems_per_read",
    "max_flags_per_read",
    "max_positions_per_read",
    "max_positions_per_write",
    "max_string_columns_per_read",
    "max_variables_per_read",
    "max_variables_per_write",
    "parse_write_positions",
    "position_fields",
    "position_record",
    "read_coordinate_systems",
    "read_flags",
    "read_integers",
    "read_positions",
    "read_real_words",
    "read_reals",
    "read_strings",
    "real_from_wire",
    "real_to_wire",
    "sc",
    "system_status",
    "version",
    "write_flag",
    "write_integers",
    "write_positions",
    "write_reals",
    "write_strings",
]
