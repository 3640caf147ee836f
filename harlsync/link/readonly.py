"""A line that carries reads only: what ``harlsync probe`` talks through.

While :func:`reads_only` is in force, every transport refuses a write before its
bytes are made: the shared serial link (:meth:`Link.exchange
<harlsync.link.exchange.Link.exchange>`, for a request whose ``is_write`` is set) and
a family's own transport (which calls :func:`refuse_write`).  The probe is read-only
by construction, whatever a family's code asks for::

    with reads_only("harlsync probe"):
        family.survey(robot)      # a write anywhere below raises WriteForbidden

The flag is process-wide (a transport's thread sees it too), counted so that
nested uses nest.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from ..errors import InterlockError

__all__ = ["WriteForbidden", "active", "reads_only", "refuse_write"]

_lock = threading.Lock()
_why: list[str] = []


class WriteForbidden(InterlockError):
    """A write asked for on a line that carries reads only; nothing was sent."""


@contextmanager
def reads_only(why: str) -> Iterator[None]:
    """Refuse every write on every line until the block ends; ``why`` names what
    reads only (``harlsync probe``), for the refusal's message."""
    with _lock:
        _why.append(why)
    try:
        yield
    finally:
        with _lock:
            _why.remove(why)


def active() -> str | None:
    """What reads only now (:func:`reads_only`'s ``why``), or None."""
    with _lock:
        return _why[-1] if _why else None


def refuse_write(command: str, *, port: str | None = None, station: int | None = None) -> None:
    """Raise :class:`WriteForbidden` naming ``command`` when the line carries reads only."""
    why = active()
    if why is not None:
        where = ", ".join(
            part
            for part in (
                f"port {port}" if port else "",
                f"station {station}" if station is not None else "",
            )
            if part
        )
        raise WriteForbidden(
            f"{where + ': ' if where else ''}{command} is a write, and {why} sends reads "
            "only: nothing was sent"
        )
