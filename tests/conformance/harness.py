"""What the conformance suite needs to know of each family, and no more: how a
pendant changes one of its simulated controllers, and what a blank one of the
same robot is.  Everything else the suite asks of the family itself (its
registry entry, catalogue, driver and simulator).

A family joins the suite with one entry in :data:`HARNESSES`; the toy family
(tests/toyfamily) is one, registered from outside harlsync.
"""

from __future__ import annotations

import dataclasses
import random
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest
import toyfamily

from harlsync import families
from harlsync.sim import ServedFamily, protocol_sim, sim_family, variants
from harlsync.sim.device import Device


@dataclass(frozen=True)
class Harness:
    #: change the station's state as a person at the controller would; says what
    edit: Callable[[Any, random.Random], str]
    #: a controller of the same robot with nothing taught or set yet
    blank: Callable[[Any], Any]
    #: what keeps a test of the family fast (a first pull that reads fewer points)
    quick: Callable[[pytest.MonkeyPatch], None] = lambda monkeypatch: None
    #: how many seeds of the property run (a family whose every read is slow runs fewer)
    property_seeds: int = 4
    #: make a served simulator answer at once (what its controller would take time for)
    prompt: Callable[[Any], None] = lambda device: None


def _toy_edit(state: Any, rng: random.Random) -> str:
    n = rng.randrange(16)
    state.slots[n] = (state.slots.get(n, 0) + 1 + rng.randrange(100)) % 10000
    return f"slot {n} = {state.slots[n]}"


def _toy_blank(state: Any) -> Any:
    from toyfamily.sim import SimState

    return SimState()


def _harl_u2_edit(state: Any, rng: random.Random) -> str:
    n = rng.choice(sorted(state.data.timers))
    old = state.data.timers[n]
    value = f"{(float(old) * 100 + 1 + rng.randrange(50)) % 1000 / 100:.2f}"
    state.data.timers[n] = value
    return f"timer {n} = {value}"


def _harl_u2_blank(state: Any) -> Any:
    from harlsync.families.harl_u2.sim import SimState

    return SimState.blank(state.data.config, state.data.version)


def _iai_edit(state: Any, rng: random.Random) -> str:
    n = rng.choice(sorted(state.positions))
    p = state.positions[n]
    state.positions[n] = dataclasses.replace(p, speed=1 + (p.speed + rng.randrange(1, 50)) % 100)
    return f"position {n} speed {state.positions[n].speed}"


def _iai_blank(state: Any) -> Any:
    from harlsync.families.iai.sim import SimState

    return SimState.from_positions(
        {},
        axes=state.axes,
        model=state.model,
        position_range=state.position_range,
        version=next(iter(state.versions.values())),
    )


def _epson_edit(state: Any, rng: random.Random) -> str:
    state.weight = (state.weight[0] + 100 * rng.randint(1, 5), state.weight[1])
    return f"Weight {state.weight[0]}"


def _epson_quick(monkeypatch: pytest.MonkeyPatch) -> None:
    """A robot of ten points, P0-P9, on a controller whose point table ends at P19
    (harlsync takes it so too), and a first pull of P0-P9; the pull still probes
    past them to the table's end, as every pull does, finds nothing there, and asks
    P20, past the table, twice (what it answers is a variant)."""
    from harlsync.families.epson import profile
    from harlsync.families.epson.sim import state
    from harlsync.families.epson.sim.state import SimState

    monkeypatch.setattr(profile, "DEFAULT_POINT_RANGE", (0, 9))
    monkeypatch.setattr(profile, "POINT_PROBE_END", 19)
    monkeypatch.setattr(state, "MAX_POINT", 19)
    generate = SimState.generate.__func__  # type: ignore[attr-defined]

    def ten_points(cls: type[SimState], /, seed: int, **options: Any) -> SimState:
        return generate(cls, seed, **{"point_range": (0, 9), **options})  # type: ignore[no-any-return]

    monkeypatch.setattr(SimState, "generate", classmethod(ten_points))


def _epson_prompt(device: Any) -> None:
    """Commands run in no time: the handshake's first poll finds each one done.  What
    a command's run time does to a push is the ``write_time`` variant's and the
    property run's (tests/families/epson/test_interlock_property.py) to show."""
    device.execution_time = 0.0


def _epson_blank(state: Any) -> Any:
    from harlsync.families.epson.sim.state import SimState

    return SimState(robot_type=state.robot_type, model=state.model)


HARNESSES: dict[str, Harness] = {
    "toy": Harness(_toy_edit, _toy_blank),
    "harl-u2": Harness(_harl_u2_edit, _harl_u2_blank),
    "iai": Harness(_iai_edit, _iai_blank),
    # A whole Epson read is some thousand Modbus exchanges: one property seed.
    "epson": Harness(
        _epson_edit, _epson_blank, _epson_quick, property_seeds=1, prompt=_epson_prompt
    ),
}


def variant_cases() -> list[Any]:
    """``(family, variant)`` for every registered family: the profile's guesses and
    each other value of each variant on its own in the default run, and every other
    combination marked ``slow`` (the full matrix)."""
    cases = []
    for name in names():
        declared = () if name == toyfamily.NAME else sim_family(name).variants
        profile = variants.defaults(declared)
        for full in variants.combinations(declared):
            case = {k: v for k, v in full.items() if v != profile[k]}
            label = ",".join(f"{k}={v}" for k, v in sorted(case.items())) or "profile"
            marks = [pytest.mark.slow] if len(case) > 1 else []
            cases.append(pytest.param(name, case, id=f"{name}-{label}", marks=marks))
    return cases


def names() -> list[str]:
    """Every registered family and the toy; one without a harness fails the suite."""
    return [*families.names(), toyfamily.NAME]


def join(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the registry hold ``name`` for one test: the toy registers itself in a
    copy of the registry that the test's end throws away."""
    monkeypatch.setattr(families, "FAMILIES", dict(families.FAMILIES))
    if name == toyfamily.NAME:
        toyfamily.register()


@contextmanager
def served(
    name: str, seed: int, variant: Mapping[str, str] | None = None
) -> Iterator[tuple[Device[Any], int, str]]:
    """A generated controller of family ``name``: the simulator, its station and
    the URL a port option gives for it; ``variant`` says how it fills its manual's
    silences where not as the profile guesses (:mod:`harlsync.sim.variants`)."""
    side = sim_family(name)
    device = side.generate(seed, [side.default_station])
    device.vary(variant or {})
    HARNESSES[name].prompt(device)
    station = side.default_station
    if isinstance(side, ServedFamily):
        server = side.serve(device, "127.0.0.1", 0)
        try:
            yield device, station, server.url
        finally:
            server.stop()
    else:
        url = protocol_sim.register(device)  # type: ignore[arg-type]  # a line family's Simulator
        try:
            yield device, station, url
        finally:
            protocol_sim.unregister(url)
