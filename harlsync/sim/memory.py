"""Battery-backed memory for ``harlsync sim --state DIR``: the robots survive a restart.

A real controller keeps its programs, tables and positions in battery-backed
memory, so a controller restarted in the middle of a push still holds what had
been written.  With a state directory the simulator does the same: station N is
kept in ``DIR/station-N`` (N as the family writes stations), loaded when the
simulator starts if it is there, and saved after every write, before the write
is answered.  How a station is kept is the family's (a robot project, say);
modes and running programs are not kept: a restarted controller comes up idle.
"""

from __future__ import annotations

import logging
from pathlib import Path

from .device import Device, Received, S

__all__ = ["keep_state"]

log = logging.getLogger(__name__)


def keep_state(sim: Device[S], directory: str | Path) -> None:
    """Load ``sim``'s stations from ``directory`` (those saved there) and save each
    after every write it receives.  Raises ProjectError for an unreadable state."""
    root = Path(directory)
    paths = {number: root / f"station-{sim.show_station(number)}" for number in sim.stations}
    for number, path in paths.items():
        if not sim.load_station(number, path):
            sim.save_station(number, path)

    def save_after_write(request: Received) -> None:
        if request.is_write and request.station in paths:
            try:
                sim.save_station(request.station, paths[request.station])
            except Exception as exc:  # noqa: BLE001  the simulator must go on answering
                log.error(
                    "sim: cannot save station %s to %s: %s",
                    sim.show_station(request.station),
                    paths[request.station],
                    exc,
                )

    sim.listeners.append(save_after_write)
