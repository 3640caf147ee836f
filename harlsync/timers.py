"""The kernel's timer slack, lowered for threads that keep deadlines.

Linux lets a sleeping thread wake up to 50 us late by default (its *timer slack*),
so that nearby wake-ups can be served together.  An emulated line that writes a
reply's last byte when it is due wants its deadline: 50 us is half of what an
exchange at 115200 baud may spend between a reply and the next request.
:func:`precise_timers` lowers the calling thread's slack to :data:`SLACK_NS`;
elsewhere than Linux it does nothing.  The simulators' reply threads call it (the
link itself waits for bytes, not for timers).  ``ctypes`` is imported on the first
call, not before.
"""

from __future__ import annotations

import logging
import sys
import threading

__all__ = ["SLACK_NS", "precise_timers"]

log = logging.getLogger(__name__)

#: The timer slack asked for, in nanoseconds.
SLACK_NS = 1000
_PR_SET_TIMERSLACK = 29
_done = threading.local()


def precise_timers() -> None:
    """Lower the calling thread's timer slack to :data:`SLACK_NS`, once a thread."""
    if getattr(_done, "slack", False):
        return
    _done.slack = True
    if sys.platform != "linux":
        return
    import ctypes

    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_TIMERSLACK, SLACK_NS, 0, 0, 0)
    except (OSError, AttributeError) as exc:
        log.debug("cannot lower the timer slack: %s", exc)
