"""The shared serial link, speaking HARL-U2 frames.

``Link(url, station, settings)`` is :class:`harlsync.link.Link` with the HARL-U2
codec: ``link.exchange(commands.read_step(...))`` returns a ``Step`` (or an
``ErrorReply``), typed.
"""

from __future__ import annotations

import os

from ...link import DEFAULT_LOCK_TIMEOUT
from ...link import Link as SharedLink
from ...settings import SerialSettings
from .protocol import Frame
from .protocol.codec import CODEC

__all__ = ["Link"]


class Link(SharedLink[Frame]):
    """One port to HARL-U2 controllers (stations 1-4 may share it).

    ``settings`` default to the profile's; the rest is as :class:`harlsync.link.Link`.
    """

    def __init__(
        self,
        url: str,
        station: int = 1,
        settings: SerialSettings | None = None,
        *,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT,
        lock_dir: str | os.PathLike[str] | None = None,
        late_window: float | None = None,
    ) -> None:
        super().__init__(
            url,
            station,
            settings,
            codec=CODEC,
            lock_timeout=lock_timeout,
            lock_dir=lock_dir,
            late_window=late_window,
        )
