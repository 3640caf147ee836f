"""The one place an Epson controller's commands go through: the handshake, the
allow-list of what the map's words can carry, and an error response as a
:class:`~harlsync.errors.ControllerError` with its §7.1 meaning.

Each read asks for the most a command answers within the map's words: 59 (an
AccelS entry, 6 response words), or its two halves 60 and 61 when RC+ assigned
fewer (:meth:`CommandChannel.either`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from ...errors import ControllerError, ProjectError
from . import protocol as p
from .handshake import Handshake
from .protocol import ErrorReply, Request

__all__ = ["CommandChannel"]

T = TypeVar("T")
A = TypeVar("A")
B = TypeVar("B")


class CommandChannel:
    """Commands to one controller through ``handshake``, one at a time."""

    def __init__(self, handshake: Handshake) -> None:
        self.handshake = handshake
        self.map = handshake.map

    @property
    def label(self) -> str:
        return self.handshake.label

    def fits(self, request: Request[object]) -> bool:
        """Whether the map has the command and response words ``request`` needs."""
        return (
            request.command_words <= self.map.command_words
            and request.response_words <= self.map.response_words
        )

    def error(self, request: Request[object], reply: ErrorReply) -> ControllerError:
        """The error response ``reply`` to ``request``, as the error it raises."""
        return ControllerError(
            f"{reply.code:04X}",
            port=self.label,
            command=str(request),
            message=f"controller answered error {p.describe_code(reply.code, reply.detail)} "
            f"({reply.remedy})",
        )

    def execute(self, request: Request[T]) -> T | ErrorReply:
        """Send ``request``; its value or its error response.  Raises ProjectError for
        a request the register map has too few words for (nothing sent)."""
        try:
            return self.handshake.execute(request)
        except ValueError as exc:  # more words than RC+ assigned: nothing was sent
            raise ProjectError(
                f"{exc}: assign more words in RC+ and in robot.yaml connection.map"
            ) from exc

    def ask(self, request: Request[T]) -> T:
        """Send one read and return its value; an error response raises ControllerError.

        Raises ProjectError for a read the register map has too few words for.
        """
        reply = self.execute(request)
        if isinstance(reply, ErrorReply):
            raise self.error(request, reply)
        return reply

    def ask_if_there(self, request: Request[T], absent: frozenset[int]) -> T | None:
        """As :meth:`ask`, but None for an error response whose code is in ``absent``."""
        reply = self.execute(request)
        if isinstance(reply, ErrorReply):
            if reply.code in absent:
                return None
            raise self.error(request, reply)
        return reply

    def either(
        self,
        full: Request[T],
        first: Request[A],
        second: Request[B],
        join: Callable[[A, B], T],
        absent: frozenset[int] = frozenset(),
    ) -> T | None:
        """``full`` when the map has the words for it, else its two halves joined."""
        if self.fits(full):
            return self.ask_if_there(full, absent)
        a = self.ask_if_there(first, absent)
        return None if a is None else join(a, self.ask(second))
