"""Regression tests for what the IAI interlock property test
(tests/families/iai/test_interlock_property.py) found, each asserted on the simulated
controller's own record."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from harlsync import families
from harlsync.errors import InterlockError
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position
from harlsync.families.iai.protocol import Frame
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import Project, save_project
from harlsync.settings import SerialSettings
from harlsync.sim import Faults
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import PushFailed, PushOptions, engine

AXES = (1, 2, 3)
TABLE = {n: Position(n, AXES, "0.30", "0.30", 100, ("1.000", "2.000", "3.000")) for n in (1, 2, 3)}
#: Short deadlines: each lost reply here costs two of them.
QUICK = SerialSettings(baudrate=115200, timeout=0.05, retries=2)


class StatusRepliesLost(Simulator):
    """A controller whose replies to the 215H numbered in ``lost`` (1: the first) are
    lost on the line, and whose operator takes axis 2 right after answering 215H
    number ``hold`` (0: never).

    An axis in use is in 212H's reply, not in 215H's: a 215H sent again finds the
    system idle.
    """

    def __init__(self, state: SimState, lost: Callable[[int], bool], hold: int = 0) -> None:
        super().__init__(state)
        self.lost, self.hold = lost, hold
        self.status_reads = 0

    def handle(self, state: SimState, frame: Frame) -> str:
        reply = super().handle(state, frame)
        self.faults = Faults()
        if frame.message_id == 0x215:
            self.status_reads += 1
            if self.status_reads == self.hold:
                state.axes_in_use.add(2)
            if self.lost(self.status_reads):
                self.faults = Faults(drop=1.0)
        return reply


def controller() -> SimState:
    return SimState.from_positions(TABLE, axes=AXES, position_range=(1, 20))


def push(tmp_path: Path, sim: Simulator, target: dict[int, Position]) -> PushFailed | None:
    url = register(sim)
    try:
        robot = families.get("iai").new_robot("cell", url, None)
        robot.serial = QUICK
        robot.options.update(axes=AXES, first=1, last=20)
        path = tmp_path / "cell"
        data = IaiData(sim.stations[0x99].versions[(0, 0)], target)
        save_project(path, Project(path, robot, data))
        try:
            engine.push(path, PushOptions(yes=True, allow_dirty=True))
        except PushFailed as failed:
            return failed
        return None
    finally:
        unregister(url)


def test_issue_19_a_215h_sent_again_makes_the_interlock_read_212h_again_before_the_write(
    tmp_path: Path,
) -> None:
    # 215H number 2 is the interlock's before the first write (number 1 is before
    # the long read).  Its reply is lost and axis 2 is taken meanwhile: the 212H
    # before it is stale by a whole deadline.  A 291H must not follow the 215H sent
    # again without a 212H before it.
    sim = StatusRepliesLost(controller(), lambda n: n == 2, hold=2)
    target = dict(TABLE)
    target[2] = Position(2, AXES, "0.30", "0.30", 100, ("9.000", "2.000", "3.000"))

    failed = push(tmp_path, sim, target)

    assert not sim.writes_received(), [r.payload for r in sim.writes_received()]
    assert failed is not None and isinstance(failed.cause, InterlockError)
    assert "axis 2 servo axis in use (212H axis status bit 0)" in str(failed.cause)
    commands = [r.command for r in sim.received]
    assert commands[-5:] == ["212", "215", "215", "212", "215"]  # 215H lost: both again
    assert sim.stations[0x99].positions == TABLE


def test_issue_12_a_line_that_never_answers_212h_and_215h_back_to_back_is_not_idle(
    tmp_path: Path,
) -> None:
    sim = StatusRepliesLost(controller(), lambda n: n % 2 == 1)  # the first of each pair
    target = dict(TABLE)
    target[3] = Position(3, AXES, "0.30", "0.30", 100, ("1.000", "9.000", "3.000"))

    failed = push(tmp_path, sim, target)

    assert failed is not None and isinstance(failed.cause, InterlockError)
    assert "212H and 215H could not be read back to back" in str(failed.cause)
    assert not sim.writes_received()
    rounds = 1 + QUICK.retries
    assert [r.command for r in sim.received] == ["212", "215", "215"] * rounds


class AxesVanishAfterTheRead(Simulator):
    """Once the table is read, axis 1 is taken and 212H's replies list no axis."""

    def handle(self, state: SimState, frame: Frame) -> str:
        reply = super().handle(state, frame)
        if frame.message_id == 0x22D:
            state.axes_in_use.add(1)
            state.unreported_axes.update(state.axes)
        return reply


def test_issue_19_a_212h_reply_listing_no_axis_stops_a_write_to_a_robot_whose_axes_robot_yaml_omits(
    tmp_path: Path,
) -> None:
    # Axis 1 in use, and a checksum-valid 212H reply that lists no axis at all: it
    # once read as "no axis in use".  robot.yaml names no axes; the table does.
    state = controller()
    sim = AxesVanishAfterTheRead(state)
    target = dict(TABLE)
    target[2] = Position(2, AXES, "0.30", "0.30", 100, ("9.000", "2.000", "3.000"))
    url = register(sim)
    try:
        robot = families.get("iai").new_robot("cell", url, None)
        robot.serial = QUICK
        robot.options.update(first=1, last=20)  # no axes
        path = tmp_path / "cell"
        save_project(path, Project(path, robot, IaiData(state.versions[(0, 0)], target)))
        try:
            engine.push(path, PushOptions(yes=True, allow_dirty=True))
            failed = None
        except PushFailed as exc:
            failed = exc
    finally:
        unregister(url)

    assert failed is not None and isinstance(failed.cause, InterlockError)
    assert "axis 1 not reported by 212H (its reply lists no axis)" in str(failed.cause)
    assert "\n" not in str(failed.cause)
    assert not sim.writes_received()
    assert state.positions == TABLE
