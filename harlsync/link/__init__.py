"""The shared serial link: one port, request/reply exchanges, the line lock.

::

    harlsync/link/exchange.py   Link: request/reply with deadlines, retries, late replies, stats
    harlsync/link/lock.py       the line lock: lock_key, lock_path, who holds it
    harlsync/link/port.py       opening a port by URL, and why it failed or went away

pyserial's exceptions never leave this package.
"""

from __future__ import annotations

import serial

from ..settings import SerialSettings
from .exchange import Link, LinkStats
from .lock import DEFAULT_LOCK_TIMEOUT, default_lock_dir, lock_key, lock_path
from .port import POLL_INTERVAL

__all__ = [
    "DEFAULT_LOCK_TIMEOUT",
    "POLL_INTERVAL",
    "Link",
    "LinkStats",
    "SerialSettings",
    "default_lock_dir",
    "lock_key",
    "lock_path",
]

# sim:// URLs are served by harlsync/sim/protocol_sim.py.  pyserial imports the
# handler by name when such a URL is opened: the link itself never imports sim.
if "harlsync.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("harlsync.sim")
