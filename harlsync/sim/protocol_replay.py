"""The ``replay://`` port: a recorded spy:// capture answering as the controller.

pyserial finds this module the way it finds ``sim://`` (see
:mod:`harlsync.sim.protocol_sim`).  URL forms::

    replay://tests/fixtures/traffic/cell-3.txt     a capture file, relative path
    replay:///abs/path/capture.txt?timing=0        absolute path, every reply at once
    replay://cell-7.txt?family=iai                 a capture of another family's line
    replay://@name                                 a Replay registered with register()

So a capture taken at a site replays through any command, e.g.
``harlsync pull /tmp/cell-3 --port replay://cell-3.txt`` for a capture of a pull.
A request that differs from the capture fails the write (the link reports a
:class:`~harlsync.errors.PortError` that says what was expected).
"""

from __future__ import annotations

import time
from urllib.parse import parse_qs

from serial.serialutil import SerialException

from ..errors import ProjectError
from . import protocol_sim
from .family import line_family
from .replay import Replay, ReplayMismatch, load_spy_log

__all__ = ["Serial", "register", "replay_from_url", "unregister"]

_replays: protocol_sim.Registry[Replay] = protocol_sim.Registry("replay")
register = _replays.register
unregister = _replays.unregister


def replay_from_url(url: str) -> Replay:
    """The replay a ``replay://`` URL names (a new one, unless ``@name``).

    Raises SerialException for a missing or unreadable capture or an unknown family.
    """
    rest = url.split("://", 1)[1]
    path, _, query = rest.partition("?")
    if path.startswith("@"):
        return _replays.get(path)
    opts = {k: v[-1] for k, v in parse_qs(query, keep_blank_values=True).items()}
    unknown = set(opts) - {"timing", "family"}
    if unknown or opts.get("timing", "1") not in ("0", "1"):
        raise SerialException(f"{url}: replay:// takes only timing=0 or timing=1, and family")
    if not path:
        raise SerialException(f"{url}: no capture file")
    try:
        chunks = load_spy_log(path)
    except (OSError, ValueError) as exc:
        raise SerialException(f"cannot replay {path}: {exc}") from exc
    try:
        decoder = line_family(opts.get("family")).decoder
    except ProjectError as exc:
        raise SerialException(f"{url}: {exc}") from exc
    return Replay(chunks, timing=opts.get("timing", "1") == "1", decoder=decoder)


class Serial(protocol_sim.Serial):
    """pyserial port class for ``replay://`` URLs.

    The reading side is ``sim://``'s: replies fall due after their delay.  Only
    the peer differs, a :class:`Replay` where ``sim://`` has a Simulator (both
    answer ``receive(bytes)`` with ``(delay, bytes)`` chunks).
    """

    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self.port is None:
            raise SerialException("Port must be configured before it can be used.")
        replay = replay_from_url(self.port)
        self.sim = replay
        self._decoder = None
        now = time.monotonic()
        self._pending = [(now + delay, data) for delay, data in replay.start()]
        self.is_open = True

    def write(self, data: bytes) -> int:  # type: ignore[override]  # as sim://'s
        try:
            return super().write(data)
        except ReplayMismatch as exc:
            raise SerialException(str(exc)) from exc

    def reset_input_buffer(self) -> None:
        """Keep every recorded byte: the recorded client read each one, none was discarded."""
