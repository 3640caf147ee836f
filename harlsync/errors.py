"""The exceptions harlsync raises, one tree under :class:`HarlsyncError`.

::

    HarlsyncError
    ├── ProtocolError            bytes that are not a valid frame or reply of the family
    │   ├── FrameError           malformed frame: bad station, control byte, too long
    │   │   └── ChecksumError    the frame's checksum does not match its bytes
    │   └── ReplyError           a well-formed frame that does not answer the request
    ├── LinkError                the serial line (names the port and station)
    │   ├── PortError            cannot open the port, or it went away
    │   ├── PortBusyError        another harlsync holds the port or the line
    │   ├── LinkTimeout          no valid reply in time (also a TimeoutError)
    │   └── WriteUnconfirmed     a write's reply was lost: it may or may not have taken
    ├── ControllerError          an error reply where the operation cannot go on
    │   └── WriteRefused         it refused a write (also a NotWritten): nothing of it was applied
    ├── ProjectError             the robot project on disk
    │   ├── ProjectFormatError   unreadable YAML, a newer format version, a missing file
    │   └── ProjectInvalid       schema or range errors (carries every issue found)
    └── SyncError                pull / diff / plan / push
        ├── InterlockError       the robot is not idle: nothing may be written
        ├── PolicyError          dirty tree, outside the maintenance window, reconfigure not allowed
        ├── StalePlanError       the controller changed since the plan was made
        ├── VerifyError          a written item does not read back as written
        └── PartlyWritten        one item's write stopped part way (carries what went out)

    NotWritten                   mixin: a driver's write that raises it applied nothing

Library code raises these; only the CLI turns them into a one-line message and
an exit code.  pyserial's own exceptions never leave the link layer.
"""

from __future__ import annotations

__all__ = [
    "ChecksumError",
    "ControllerError",
    "FrameError",
    "HarlsyncError",
    "InterlockError",
    "LinkError",
    "LinkTimeout",
    "NotWritten",
    "PartlyWritten",
    "PolicyError",
    "PortBusyError",
    "PortError",
    "ProjectError",
    "ProjectFormatError",
    "ProjectInvalid",
    "ProtocolError",
    "ReplyError",
    "StalePlanError",
    "SyncError",
    "VerifyError",
    "WriteRefused",
    "WriteUnconfirmed",
    "partly_words",
]


class HarlsyncError(Exception):
    """Root of every error harlsync raises on purpose.

    ``notes`` are what harlsync did to the robot on its own before the error (a
    reset the driver began and did not finish), one sentence each: whoever
    records a failure records them too, so a record never denies an action.
    """

    notes: tuple[str, ...] = ()


class ProtocolError(HarlsyncError):
    """Bytes that are not a valid frame, or a frame that is not a valid reply."""


class FrameError(ProtocolError):
    """A frame that is malformed: bad station, control byte in the body, too long."""


class ChecksumError(FrameError):
    """A frame whose checksum (the family's own) does not match its bytes."""


class ReplyError(ProtocolError):
    """A well-formed frame that does not answer the request that was sent."""


class _Located(HarlsyncError):
    """An error that happened talking to one robot (port and station)."""

    def __init__(
        self,
        message: str,
        *,
        port: str | None = None,
        station: int | None = None,
        command: str | None = None,
        station_text: str | None = None,
    ) -> None:
        self.message = message
        self.port = port
        self.station = station
        self.command = command
        #: the station as the family writes it (decimal, hex...), for the message
        self.station_text = (
            station_text
            if station_text is not None
            else (None if station is None else str(station))
        )
        super().__init__(self._render())

    def _render(self) -> str:
        where = []
        if self.port is not None:
            where.append(f"port {self.port}")
        if self.station_text is not None:
            where.append(f"station {self.station_text}")
        if self.command is not None:
            where.append(f"command {self.command}")
        return f"{', '.join(where)}: {self.message}" if where else self.message


class LinkError(_Located):
    """The serial line failed."""


class PortError(LinkError):
    """The port cannot be opened, or it went away."""


class PortBusyError(LinkError):
    """Another harlsync process holds the port (or the robot's line)."""


class LinkTimeout(LinkError, TimeoutError):
    """No valid reply arrived in time, after every retry."""


class WriteUnconfirmed(LinkError):
    """No valid reply came to a write: the controller may or may not have applied it.

    The link never re-sends a write on its own; the controller layer reads the
    item back and decides on that evidence.
    """


class ControllerError(_Located):
    """The controller answered with its error reply where the operation cannot go on.

    ``status`` is the raw status or code, as the family's error reply carries it
    and its manual lists it; ``message`` words it for the family.
    """

    def __init__(
        self,
        status: str,
        *,
        port: str | None = None,
        station: int | None = None,
        command: str | None = None,
        message: str | None = None,
        station_text: str | None = None,
    ) -> None:
        self.status = status
        super().__init__(
            message or f"controller answered error status E{status}",
            port=port,
            station=station,
            command=command,
            station_text=station_text,
        )


class NotWritten(HarlsyncError):
    """Raised by a driver's write when nothing of that write was applied: the
    controller refused it, or the driver found before sending it that it must not
    go.  A push records such an item as not written, never as "may or may not"."""


class WriteRefused(ControllerError, NotWritten):
    """The controller answered a write with an error reply: it did not carry it out."""


class ProjectError(HarlsyncError):
    """The robot project on disk is unusable."""


class ProjectFormatError(ProjectError):
    """A project file cannot be read: YAML syntax, newer format version, missing file."""


class ProjectInvalid(ProjectError):
    """A project that breaks its schema or its own configuration.

    ``issues`` holds every problem found, each already formatted as
    ``file:line: field: what is wrong (allowed: ...)``.
    """

    def __init__(self, issues: list[str]) -> None:
        self.issues = list(issues)
        first = self.issues[0] if self.issues else "invalid project"
        more = f" (and {len(self.issues) - 1} more)" if len(self.issues) > 1 else ""
        super().__init__(first + more)


class SyncError(HarlsyncError):
    """Pull, diff, plan or push cannot go on."""


class InterlockError(SyncError):
    """The robot is not idle (its status forbids writes): nothing may be written to it."""


class PolicyError(SyncError):
    """A deployment policy refuses the push (dirty tree, window, reconfiguration)."""


class StalePlanError(SyncError):
    """The controller changed since the saved plan was computed."""


class VerifyError(SyncError):
    """A written item does not read back as written."""


class PartlyWritten(SyncError):
    """A write of one item that takes several commands stopped part way.

    ``sent`` names the parts of the item that went out and took, in the family's
    words (``["x", "y"]``); ``unknown`` the part that may or may not have (a lost
    reply), if any; ``left`` the parts not sent.  ``cause`` is what stopped it
    (an :class:`InterlockError`, a lost reply ...): a push is refused or fails as
    its cause says, and records the item as partly written.
    """

    def __init__(
        self,
        message: str,
        *,
        sent: list[str],
        left: list[str],
        unknown: str | None,
        cause: HarlsyncError,
    ) -> None:
        self.sent = list(sent)
        self.left = list(left)
        self.unknown = unknown
        self.cause = cause
        super().__init__(message)


def partly_words(sent: list[str], unknown: object, left: list[str]) -> str:
    """What went out of an item written part way, for a person: ``x, y went out;
    z may or may not have; u, hand not sent``."""
    parts = [f"{', '.join(sent) or 'nothing'} went out"]
    if unknown:
        parts.append(f"{unknown} may or may not have")
    if left:
        parts.append(f"{', '.join(left)} not sent")
    return "; ".join(parts)
