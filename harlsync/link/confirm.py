"""A write whose reply may be lost, confirmed by reading the item back, never
blindly repeated (every family's controller uses it)::

    send  --reply-->                                  done
      |  no reply (WriteUnconfirmed)
      v
    read back:  what was written   -> the write took: done
                what was there     -> it did not take: check (the interlock), send once more
                anything else      -> WriteUnconfirmed (someone else changed it, or worse)

``before_resend`` runs before the second send: a family checks there that the
robot is still idle (raising InterlockError stops the re-send).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

from ..errors import HarlsyncError, InterlockError, WriteUnconfirmed

if TYPE_CHECKING:
    from ..families.base import Status

__all__ = ["confirmed_write", "refuse_unless_idle"]

log = logging.getLogger(__name__)

T = TypeVar("T")


def confirmed_write(
    send: Callable[[], object],
    readback: Callable[[], T],
    wanted: T,
    old: T,
    *,
    before_resend: Callable[[WriteUnconfirmed], None],
    same: Callable[[T, T], bool] = lambda a, b: a == b,
    show: Callable[[T], str] = repr,
    what: str = "the item",
) -> None:
    """Send a write; when its reply is lost, decide on what ``readback`` returns.

    Raises WriteUnconfirmed when neither the new nor the old value reads back,
    or when a second send still did not take.
    """
    for attempt in (1, 2):
        try:
            send()
            return
        except WriteUnconfirmed as exc:
            now = readback()
            if same(now, wanted):
                log.info("%s: reply lost but the write took (read back)", exc)
                return
            if attempt == 1 and same(now, old):
                before_resend(exc)
                log.warning("%s: the write did not take (read back): sending it once more", exc)
                continue
            if attempt == 1:
                why = (
                    f"{what} reads back {show(now)}: neither what was written "
                    f"({show(wanted)}) nor what was there before ({show(old)})"
                )
            else:
                why = f"sent twice, and {what} still reads back {show(now)}"
            raise WriteUnconfirmed(
                f"write not confirmed: {why}",
                port=exc.port,
                station=exc.station,
                command=exc.command,
                station_text=exc.station_text,
            ) from exc


def refuse_unless_idle(
    status: Callable[[], Status], lost: WriteUnconfirmed, *, where: str, reading: str
) -> None:
    """Read the status now (``before_resend`` of a write that needs an idle robot):
    return when it is idle, else raise InterlockError, so the write is not sent again.

    ``where`` names the write for the message (port, station, command); ``reading``
    what the status is (``"the task states"``).
    """
    try:
        now = status()
    except HarlsyncError as exc:
        why = f"cannot read {reading} ({exc})"
    else:
        if now.idle:
            return
        why = f"the robot is not idle: {now.describe()}"
    raise InterlockError(
        f"{where}: the write did not take and {why}; not sending it again (it needs an idle robot)"
    ) from lost
