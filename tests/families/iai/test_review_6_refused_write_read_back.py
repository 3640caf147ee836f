"""Review finding 6: an ``&`` reply to a write is "not written" only when the
items read back exactly as they were before it; a controller that applied part
or all of what it refused leaves them "may or may not have been written"."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from harlsync.errors import ControllerError, NotWritten, WriteRefused
from harlsync.families.iai.controller import Controller
from harlsync.families.iai.model import Position
from harlsync.families.iai.protocol import Frame
from harlsync.families.iai.sim import SimState, Simulator, codes
from harlsync.settings import SerialSettings
from harlsync.sim import Refused
from harlsync.sim.protocol_sim import register, unregister

QUICK = SerialSettings(baudrate=115200, timeout=0.05, retries=2)
AXES = (1, 2)
TABLE = {n: Position(n, AXES, "0.30", "0.30", 100, ("1.000", "2.000")) for n in (1, 2, 3)}
NEW = [Position(n, AXES, "0.30", "0.30", 100, ("9.000", "2.000")) for n in (1, 2, 3)]


class Refuses(Simulator):
    """Answers ``&`` to every write; with ``applies``, only after carrying out its
    first item (a 291H's first position, a 24CH's first integer) or all of it."""

    def __init__(self, state: SimState, applies: str | None) -> None:
        super().__init__({0x99: state})
        self.state = state
        self.applies = applies

    def handle(self, state: SimState, frame: Frame) -> str:
        if frame.message_id in (0x291, 0x24C, 0x24D, 0x24B):
            if self.applies == "all":
                super().handle(state, frame)
            elif self.applies == "first" and frame.message_id == 0x291:
                state.positions[1] = NEW[0]
            elif self.applies == "first" and frame.message_id == 0x24C:
                state.integers[200] = 5
            raise Refused(codes.BAD_DATA)
        return super().handle(state, frame)


@pytest.fixture
def controller(
    request: pytest.FixtureRequest, lock_dir: object
) -> Iterator[tuple[Controller, Refuses]]:
    state = SimState.from_positions(TABLE, axes=AXES, position_range=(1, 20))
    state.integers = {200: 1, 201: 2}
    sim = Refuses(state, request.param)
    url = register(sim)
    c = Controller.from_url(url, 0x99, QUICK, axes=AXES, first=1, last=20)
    try:
        yield c, sim
    finally:
        c.close()
        unregister(url)


def after_write(sim: Refuses, write: str) -> list[str]:
    commands = [r.command for r in sim.received]
    return commands[commands.index(write) + 1 :]


@pytest.mark.parametrize("controller", [None], indirect=True)
def test_review_6_a_refused_write_that_reads_back_unchanged_is_not_written(
    controller: tuple[Controller, Refuses],
) -> None:
    c, sim = controller
    with pytest.raises(WriteRefused) as refused:
        c.write_integers(200, [5, 6], [1, 2])
    assert "not written" in str(refused.value)
    assert after_write(sim, "24C") == ["20E"]  # read back before saying so
    with pytest.raises(WriteRefused):
        c.write_run(1, NEW, [TABLE[n] for n in (1, 2, 3)])
    assert after_write(sim, "291") == ["22D"]


@pytest.mark.parametrize("controller", ["first", "all"], indirect=True)
def test_review_6_a_refused_write_that_reads_back_changed_may_have_been_written(
    controller: tuple[Controller, Refuses],
) -> None:
    c, sim = controller
    with pytest.raises(ControllerError) as integers:
        c.write_integers(200, [5, 6], [1, 2])
    with pytest.raises(ControllerError) as positions:
        c.write_run(1, NEW, [TABLE[n] for n in (1, 2, 3)])
    for exc in (integers.value, positions.value):
        assert not isinstance(exc, NotWritten), "reported not written, yet it reads back changed"
        assert "may or may not have been written" in str(exc)
        assert "error code 0A2H" in str(exc)
    assert sim.state.integers[200] == 5  # what the controller really did
