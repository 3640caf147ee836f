"""Battery-backed memory for ``harlsync sim --state DIR``: the robots survive a restart.

A real HNC keeps its programs, tables, timers and registers in battery-backed
memory, so a controller restarted in the middle of a push still holds what had
been written.  With a state directory the simulator does the same: station N is
the robot project ``DIR/station-N``, loaded when the simulator starts if it is
there, and saved (atomically, as a pull saves) after every write, before the
write is answered.  Tasks and I/O are not kept: a restarted controller comes up
with every task stopped.
"""

from __future__ import annotations

import logging
from pathlib import Path

from ..families.harl_u2.sim.device import Received, Simulator
from ..families.harl_u2.sim.state import SimState
from ..project import Project, load_project, new_robot, save_project

__all__ = ["keep_state"]

log = logging.getLogger(__name__)


def keep_state(sim: Simulator, directory: str | Path) -> None:
    """Load ``sim``'s stations from ``directory`` (those saved there) and save each
    after every write it receives.  Raises ProjectError for an unreadable state."""
    root = Path(directory)
    paths = {number: root / f"station-{number}" for number in sim.stations}
    for number, path in paths.items():
        if (path / "robot.yaml").exists():
            sim.stations[number] = SimState.from_robot_data(load_project(path).data)
        else:
            _save(sim, number, path)

    def save_after_write(request: Received) -> None:
        if request.is_write and request.station in paths:
            try:
                _save(sim, request.station, paths[request.station])
            except Exception as exc:  # noqa: BLE001  the simulator must go on answering
                log.error("sim: cannot save station %d to %s: %s",
                          request.station, paths[request.station], exc)

    sim.listeners.append(save_after_write)


def _save(sim: Simulator, number: int, path: Path) -> None:
    robot = new_robot(path.name, f"sim://{path.resolve()}", number, keep_registers=True)
    save_project(path, Project(path, robot, sim.stations[number].data))
