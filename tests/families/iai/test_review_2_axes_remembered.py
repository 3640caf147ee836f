"""Review finding 2: with no axes in robot.yaml, an axis a 212H once reported and
then left out of a later reply (while a task holds it) must refuse the write, in
the same push and in a later one (the pull keeps the axes in controller.yaml).
Every check of what reached the robot reads the simulator's own record."""

from __future__ import annotations

from pathlib import Path

import pytest

from harlsync import families
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position
from harlsync.families.iai.protocol import Frame
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import Project, load_project, save_project
from harlsync.settings import SerialSettings
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import PushFailed, PushOptions, engine

QUICK = SerialSettings(baudrate=115200, timeout=0.05, retries=2)
USED = (1, 2)  # the table's positions use axes 1-2; the robot has 3 axes
TABLE = {n: Position(n, USED, "0.30", "0.30", 100, ("1.000", "2.000")) for n in (1, 2, 3)}


class Axis3VanishesAfterTheRead(Simulator):
    """A task takes axis 3 once the table is read, and 212H stops listing it."""

    def handle(self, state: SimState, frame: Frame) -> str:
        reply = super().handle(state, frame)
        if frame.message_id == 0x22D:
            state.axes_in_use.add(3)
            state.unreported_axes.add(3)
        return reply


def project(path: Path, url: str, state: SimState, data: IaiData | None = None) -> Path:
    robot = families.get("iai").new_robot("cell", url, None)
    robot.serial = QUICK
    robot.options.update(first=1, last=20)  # no axes in robot.yaml
    target = dict(TABLE)
    target[2] = Position(2, USED, "0.30", "0.30", 100, ("9.000", "2.000"))
    base = data or IaiData(state.versions[(0, 0)])
    base.positions = target
    save_project(path, Project(path, robot, base))
    return path


def push(path: Path) -> PushFailed | None:
    try:
        engine.push(path, PushOptions(yes=True, allow_dirty=True))
    except PushFailed as exc:
        return exc
    return None


@pytest.mark.usefixtures("lock_dir")
def test_review_2_an_axis_212h_reported_then_leaves_out_while_in_use_refuses_the_write(
    tmp_path: Path,
) -> None:
    state = SimState.from_positions(TABLE, axes=(1, 2, 3), position_range=(1, 20))
    sim = Axis3VanishesAfterTheRead({0x99: state})
    url = register(sim)
    try:
        failed = push(project(tmp_path / "cell", url, state))
    finally:
        unregister(url)
    assert not [r for r in sim.received if r.command == "291"], "291H sent with axis 3 unseen"
    assert failed is not None and not failed.result.written
    assert "axis 3 not reported by 212H" in str(failed.cause)


@pytest.mark.usefixtures("lock_dir")
def test_review_2_a_pull_keeps_the_axes_212h_reported_and_a_later_push_wants_them(
    tmp_path: Path,
) -> None:
    state = SimState.from_positions(TABLE, axes=(1, 2, 3), position_range=(1, 20))
    sim = Simulator({0x99: state})
    url = register(sim)
    try:
        path = project(tmp_path / "cell", url, state)
        robot = load_project(path).robot
        live = families.get("iai").connect(robot, None, None, lock_timeout=5.0)
        try:
            pulled = live.read_all(registers=False, whole=True)
        finally:
            live.close()
        assert pulled.axes == (1, 2, 3)
        project(path, url, state, pulled)
        assert "axes: [1, 2, 3]" in (path / "controller.yaml").read_text()
        assert load_project(path).data.axes == (1, 2, 3)
        # Before the next push a task takes axis 3, and 212H leaves it out from the first reply.
        state.axes_in_use.add(3)
        state.unreported_axes.add(3)
        failed = push(path)
    finally:
        unregister(url)
    assert not [r for r in sim.received if r.command == "291"], "291H sent with axis 3 unseen"
    assert failed is not None and not failed.result.written
    assert "axis 3 not reported by 212H" in str(failed.cause)
