"""The simulator's ``BUSY-after-writes`` schedule (issue 22 item 11): ``stop`` disarms
it, ``status`` shows it while it is armed, and it fires once, so a station stopped
after it fired stays idle through the writes that follow."""

from __future__ import annotations

from typing import Any

import pytest

from harlsync.families import names
from harlsync.sim import sim_family
from harlsync.sim.control import after_writes_verb, apply_command
from harlsync.sim.device import Device


@pytest.fixture(params=sorted(names()))
def sim(request: pytest.FixtureRequest) -> Device[Any]:
    family = sim_family(request.param)
    return family.generate(3, [family.default_station])


def write(sim: Device[Any], times: int = 1) -> None:
    """As the family does after each write it carries out."""
    for _ in range(times):
        sim.wrote(sim.stations[min(sim.stations)])


def busy(sim: Device[Any]) -> bool:
    return sim.busy(sim.stations[min(sim.stations)])


def test_stop_disarms_the_schedule_and_status_shows_it_while_armed(sim: Device[Any]) -> None:
    verb = sim.family.busy_verb
    schedule = after_writes_verb(verb)
    assert f"{verb} after" not in apply_command(sim, "status")
    apply_command(sim, f"{schedule} 2")
    assert apply_command(sim, "status").endswith(f"; {verb} after 2 more writes")
    write(sim)
    assert apply_command(sim, "status").endswith(f"; {verb} after 1 more writes")
    shown = apply_command(sim, "stop")
    assert f"{verb} after" not in shown and f"{verb} after" not in apply_command(sim, "status")
    write(sim, 3)
    assert not busy(sim)  # disarmed: the writes that would have fired it did not


def test_the_schedule_fires_once(sim: Device[Any]) -> None:
    verb = sim.family.busy_verb
    apply_command(sim, f"{after_writes_verb(verb)} 1")
    write(sim)
    assert busy(sim) and f"{verb} after" not in apply_command(sim, "status")
    apply_command(sim, "stop")
    write(sim, 2)
    assert not busy(sim)  # the operator stopped it: nothing switches it back on
