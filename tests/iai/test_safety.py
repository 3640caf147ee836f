"""Regression tests for what the IAI interlock property test
(tests/iai/test_interlock_property.py) found, each asserted on the simulated
controller's own record."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from harlsync import families
from harlsync.errors import InterlockError
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position
from harlsync.families.iai.protocol import Frame
from harlsync.families.iai.sim import MANUAL, SimState, Simulator
from harlsync.project import Project, save_project
from harlsync.settings import SerialSettings
from harlsync.sim import Faults
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import PushFailed, PushOptions, engine

AXES = (1, 2, 3)
TABLE = {n: Position(n, AXES, "0.30", "0.30", 100, ("1.000", "2.000", "3.000")) for n in (1, 2, 3)}
#: Short deadlines: each lost reply here costs two of them.
QUICK = SerialSettings(baudrate=115200, timeout=0.05, retries=2)


class AxisRepliesLost(Simulator):
    """A controller whose replies to the 212H numbered in ``lost`` (1: the first) are
    lost on the line, and whose operator switches it to MANUAL right after answering
    212H number ``manual`` (0: never).

    MANUAL mode is in 215H's reply, not in 212H's: a 212H sent again finds every
    axis idle.
    """

    def __init__(self, state: SimState, lost: Callable[[int], bool], manual: int = 0) -> None:
        super().__init__(state)
        self.lost, self.manual = lost, manual
        self.axis_reads = 0

    def handle(self, state: SimState, frame: Frame) -> str:
        reply = super().handle(state, frame)
        self.faults = Faults()
        if frame.message_id == 0x212:
            self.axis_reads += 1
            if self.axis_reads == self.manual:
                state.mode = MANUAL
            if self.lost(self.axis_reads):
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


def test_issue_12_a_212h_sent_again_makes_the_interlock_read_215h_again_before_the_write(
    tmp_path: Path,
) -> None:
    # 212H number 2 is the interlock's before the first write (number 1 is before
    # the long read).  Its reply is lost and the controller goes MANUAL meanwhile:
    # the 215H before it is stale by a whole deadline.  A 291H must not follow the
    # 212H sent again without a 215H after it.
    sim = AxisRepliesLost(controller(), lambda n: n == 2, manual=2)
    target = dict(TABLE)
    target[2] = Position(2, AXES, "0.30", "0.30", 100, ("9.000", "2.000", "3.000"))

    failed = push(tmp_path, sim, target)

    assert not sim.writes_received(), [r.payload for r in sim.writes_received()]
    assert failed is not None and isinstance(failed.cause, InterlockError)
    assert "MANUAL mode (215H mode 2)" in str(failed.cause)
    commands = [r.command for r in sim.received]
    assert commands[-5:] == ["215", "212", "212", "215", "212"]  # 212H lost: both again
    assert sim.stations[0x99].positions == TABLE


def test_issue_12_a_line_that_never_answers_215h_and_212h_back_to_back_is_not_idle(
    tmp_path: Path,
) -> None:
    sim = AxisRepliesLost(controller(), lambda n: n % 2 == 1)  # the first of each pair
    target = dict(TABLE)
    target[3] = Position(3, AXES, "0.30", "0.30", 100, ("1.000", "9.000", "3.000"))

    failed = push(tmp_path, sim, target)

    assert failed is not None and isinstance(failed.cause, InterlockError)
    assert "215H and 212H could not be read back to back" in str(failed.cause)
    assert not sim.writes_received()
    rounds = 1 + QUICK.retries
    assert [r.command for r in sim.received] == ["215", "212", "212"] * rounds
