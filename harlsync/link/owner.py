"""What every family's controller shares about its link: the port it names, and
closing the link only when it opened it (``from_url``), also as a ``with`` block."""

from __future__ import annotations

from types import TracebackType
from typing import TYPE_CHECKING, Generic, TypeVar

from .codec import Frame
from .exchange import Link

if TYPE_CHECKING:  # for the checker only: not imported before a first request
    from typing_extensions import Self

__all__ = ["OnLink"]

F = TypeVar("F", bound=Frame)


class OnLink(Generic[F]):
    """A controller that talks through :attr:`link` (of the family's frames ``F``);
    :attr:`_owns_link` when it opened it."""

    link: Link[F]
    _owns_link: bool = False

    @property
    def port(self) -> str:
        return self.link.url

    def close(self) -> None:
        """Close the link if this controller opened it (``from_url``)."""
        if self._owns_link:
            self.link.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
