"""What a write must be for the wire to give it back, sans I/O: :func:`read_back`.

The request, and the reply to the read of the same item, each fit one frame to
any station, and that reply, which begins with the first written field when no
step number leads it (LNE: PULL LIMIT), does not begin with the error prefix
nor with a command harlsync never sends.  The project's checks use it, so that
no project holds a step or parameters a pull could not read again.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import profile
from .commands import Ack, Request
from .frame import MAX_STATION, off_allow_list, payload_room

__all__ = ["ReadBack", "read_back"]

#: Each write with a read of the same item: (that read's letters, how many of the
#: write's fields name the item, how many of those lead the reply).  The reply is
#: the written value, after the step number for a step.
_READ_BACK: dict[str, tuple[str, int, int]] = {
    "SNA": ("LNA", 1, 1), "SNM": ("LNM", 2, 1), "SNS": ("LNS", 2, 1), "SNH": ("LNH", 2, 1),
    "SNT": ("LNT", 1, 0), "SND": ("LND", 1, 0), "SNL": ("LNL", 1, 0), "SNE": ("LNE", 0, 0),
}  # fmt: skip


@dataclass(frozen=True)
class ReadBack:
    """What the read of the item a write writes gives back (:func:`read_back`)."""

    #: The read of the same item (``LNM 2 3`` for ``SNM 2 3 ...``).
    read: Request[object]
    #: The payload a controller answers it with once the write took.
    reply: str
    #: Characters the write, or that reply, holds beyond one frame (0: both fit).
    excess: int
    #: Why that reply would not give the value back, as a phrase (None: it would).
    misread: str | None


def read_back(write: Request[Ack], station: int = MAX_STATION) -> ReadBack:
    """How the item ``write`` writes would be read back, and what would keep it from it.

    Frames are measured for ``station``, by default the widest (a push may name
    another station than robot.yaml).  A reply that begins with the error prefix
    is read as ``E`` + status whatever follows (:meth:`Request.decode_payload`);
    any other reply to a read-back is the written fields, which the request
    builders have checked against what the reply parsers accept
    (tests/families/harl_u2/test_fuzz.py proves it through the simulator and both frames).

    Raises :class:`ValueError` for a write no read gives back (SNX, SNO, SNB).
    """
    entry = _READ_BACK.get(write.letters)
    if entry is None:
        raise ValueError(f"{write.letters} has no read that gives back what it writes")
    letters, naming, leading = entry
    reply = " ".join(write.args[naming - leading :])
    room = payload_room(station)
    misread = None
    if reply.startswith(profile.ERROR_PREFIX):
        misread = (
            f"would begin the {letters} reply with {profile.ERROR_PREFIX!r}, which "
            "reads as an error status"
        )
    elif (command := off_allow_list(reply)) is not None:
        misread = (
            f"would begin the {letters} reply with '{command}', which reads as a "
            "command harlsync never sends, so no frame carries it"
        )
    return ReadBack(
        read=Request(letters, write.args[:naming]),
        reply=reply,
        excess=max(0, len(write.payload) - room, len(reply) - room),
        misread=misread,
    )
