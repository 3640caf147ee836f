"""A small simulated plant of HARL-U2 and IAI robots, one in each state ``harlsync status``
knows, made the way a plant gets there: first pulls, a push, nightly backups, a line
that goes silent, a push killed part way.

Every robot is a simulator served in this process as ``sim://@name``
(:func:`harlsync.sim.protocol_sim.register`); :meth:`SimPlant.close` unregisters them
all, after which any command that opened a robot's port would fail.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import pytest
from conftest import git

from harlsync.families.harl_u2.model import Config, ProgramArea, ProgramType, Step
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.sim import Faults
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import audit, engine
from harlsync.sync.backup import backup
from harlsync.sync.engine import PushOptions

SMALL = Config(ProgramArea(1, 6), ProgramArea(2, 8), ProgramArea(1, 6), ProgramArea(1, 4), 4, 16, 4)
#: The IAI robots, and their station: 1A hex, which is 26, so a decimal slip shows.
IAI_ROBOTS = ("cell-9", "gripper")
IAI_STATION = 0x1A
#: What a step and a reason carry to prove the page never takes them as markup.
MARKUP = "<script>alert(1)</script>"

#: robot -> the state it ends in.
STATES = {
    "loader": "ok",  # backed up, then pushed (a reason with markup in it)
    "press": "changed",  # a step changed on the pendant, found by the last backup
    "cell-9": "changed",  # IAI: a position changed on the controller
    "welder": "failed",  # its line went silent
    "old-press": "stale",  # its last good backup is three days old
    "spare": "never backed up",  # a robot.yaml, but no good backup recorded
    "gripper": "unfinished push",  # IAI: a push killed after its first write
}


@dataclass
class SimPlant:
    root: Path
    sims: dict[str, Any]
    urls: dict[str, str] = field(default_factory=dict)

    def close(self) -> None:
        """Take every robot off the line: opening any of their ports now fails."""
        for url in self.urls.values():
            unregister(url)


def _fast(project: Path) -> None:
    """A short reply timeout, so a silent line fails the robot at once."""
    robot = project / "robot.yaml"
    text = re.sub(r"timeout: [0-9.]+", "timeout: 0.05", robot.read_text())
    robot.write_text(re.sub(r"retries: [0-9]+", "retries: 0", text))


def _first_pull(plant: SimPlant, name: str, station: int, family: str | None = None) -> Path:
    project = plant.root / name
    engine.pull(project, port=plant.urls[name], station=station, family=family, commit=True)
    if family == "iai":
        robot = project / "robot.yaml"
        robot.write_text(robot.read_text().replace("last_position: 1000", "last_position: 40"))
    _fast(project)
    git(plant.root, "add", "-A")
    git(plant.root, "commit", "-qm", f"{name}: robot.yaml as the plant runs it")
    return project


@contextmanager
def _killed_before_its_end_record() -> Iterator[None]:
    """A push whose process dies after its writes: the audit log keeps its start and
    write records and never gets the end record (as after SIGKILL or a power loss)."""
    real = audit.append

    def append(record: audit.AuditRecord, path: Path | None = None) -> Path:
        if record.event == "end":
            raise OSError("killed")
        return real(record, path)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(audit, "append", append)
        yield


def build(root: Path) -> SimPlant:
    """The plant of :data:`STATES` under ``root`` (a new git repository)."""
    root.mkdir(parents=True, exist_ok=True)
    git(root, "init", "-q")
    harl = {
        n: HarlState.generate(seed, SMALL)
        for seed, n in enumerate(("loader", "press", "welder", "old-press", "spare"), 30)
    }
    sims: dict[str, Any] = {n: HarlSimulator({1: s}) for n, s in harl.items()}
    for seed, name in enumerate(IAI_ROBOTS, 40):
        state = IaiState.generate(seed, position_range=(1, 40))
        sims[name] = IaiSimulator({IAI_STATION: state})
    plant = SimPlant(root, sims)
    plant.urls = {name: register(sim, f"{root.name}-{name}") for name, sim in sims.items()}
    projects = {
        name: _first_pull(plant, name, *((IAI_STATION, "iai") if name in IAI_ROBOTS else (1, None)))
        for name in sims
    }

    # old-press: backed up three days ago, not since.
    backup([projects["old-press"]], now=datetime.now(timezone.utc) - timedelta(days=3))

    # spare: its project came from elsewhere: no backup recorded on this machine.
    (projects["spare"] / ".harlsync" / "backup.json").unlink()

    # loader: an engineer's edit, pushed with a reason.
    timers = projects["loader"] / "timers.yaml"
    timers.write_text(re.sub(r"(?m)^  1: .*$", "  1: 0.80", timers.read_text()))
    git(root, "commit", "-qam", "loader: faster pick")
    engine.push(projects["loader"], PushOptions(yes=True, reason=f"faster pick {MARKUP}"))
    # The night after: its backup finds what the push wrote (issue 30: the backup
    # branch keeps the robot's state, which the push changed).
    backup([projects["loader"]], commit=True)

    # gripper: a push killed after its write, before its end record.
    positions = projects["gripper"] / "positions.yaml"
    positions.write_text(
        re.sub(r"coords: \[[^,\]]+", "coords: [7.000", positions.read_text(), count=1)
    )
    git(root, "commit", "-qam", "gripper: move position")
    with _killed_before_its_end_record():
        engine.push(projects["gripper"], PushOptions(yes=True, reason="new tool"))

    # Changed on the robots since their first backup.
    program = sims["press"].stations[1].data.programs[(ProgramType.MAIN, 0)]
    program[2] = Step.parse(f"MOVE {MARKUP}")
    iai = sims["cell-9"].stations[IAI_STATION]
    first = min(iai.positions)
    iai.positions.pop(first)

    # welder: its line goes silent before tonight's backup.
    sims["welder"].faults = Faults(drop=1.0)
    tonight = [projects[n] for n in ("loader", "press", "cell-9", "welder", "gripper")]
    report = backup(tonight, commit=True, attempts=1)
    assert {r.name for r in report.robots if not r.ok} == {"welder"}, report.render()
    return plant
