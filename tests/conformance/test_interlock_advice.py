"""The interlock's advice fits its cause (issue 22 item 11): MANUAL mode, an emergency
stop, a flash write, an error and a paused task each get their own sentence, in the
family's words, in the push's refusal and in the plan's warning.  Each cause is set
on the simulated controller with its control verb, as ``harlsync sim`` takes it."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from plantsim import SMALL

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister


@dataclass
class Served:
    sim: Any
    url: str
    family: list[str]
    drift: Callable[[], None]  # the robot changes, so that a push has something to write


def harl_u2(stack: ExitStack) -> Served:
    from harlsync.families.harl_u2.sim import SimState, Simulator

    sim = Simulator({1: SimState.generate(7, SMALL)})
    url = register(sim)
    stack.callback(unregister, url)

    def drift() -> None:
        sim.stations[1].data.timers[1] = "6.66"

    return Served(sim, url, [], drift)


def iai(stack: ExitStack) -> Served:
    from harlsync.families.iai.sim import SimState, Simulator

    sim = Simulator({0x99: SimState.generate(5, position_range=(1, 20))})
    url = register(sim)
    stack.callback(unregister, url)

    def drift() -> None:
        positions = sim.stations[0x99].positions
        first = min(positions)
        positions[first] = dataclasses.replace(positions[first], speed=positions[first].speed + 1)

    return Served(sim, url, ["--family", "iai"], drift)


def epson(stack: ExitStack) -> Served:
    from families.epson.sample import sample_data

    from harlsync.families.epson.sim import SimState, Simulator

    sim = Simulator(SimState.from_data(sample_data()), execution_time=0.0)
    server = stack.enter_context(sim.serve())

    def drift() -> None:
        sim.stations[1].limz -= 1000

    return Served(sim, server.url, [], drift)


FAMILIES = {"harl-u2": harl_u2, "iai": iai, "epson": epson}

#: (family, the simulator's verb, what the advice must say)
CAUSES = [
    ("harl-u2", "auto", "Stop the robot (or wait for the cycle to end) and run again"),
    ("harl-u2", "suspend", "A suspended task goes on where it stopped: stop it on the controller"),
    ("iai", "run", "Stop the program (or wait for it to end)"),
    ("iai", "manual", "Set the controller's mode switch to AUTO"),
    ("iai", "estop", "Find why the emergency stop is on; when it is safe, release it and reset"),
    ("iai", "flash", "Wait for the flash ROM write to finish (do not switch the controller off"),
    ("iai", "error", "Look the code up in the controller's error list"),
    ("iai", "hold", "Wait for the axis to stop"),
    ("epson", "run", "Stop the task from RC+"),
    ("epson", "pause", "A paused task goes on where it stopped: stop it from RC+"),
    ("epson", "estop", "Find why the emergency stop is on; when it is safe, release it and reset"),
    ("epson", "error", "Read the error in RC+ (its number says what it is), remove its cause"),
]


@pytest.fixture(params=sorted(FAMILIES))
def served(request: pytest.FixtureRequest, repo: Path) -> Iterator[tuple[str, Served, Path]]:
    with ExitStack() as stack:
        robot = FAMILIES[request.param](stack)
        project = repo / "cell"
        if request.param == "epson":  # the sample as its backup, points 0-29: a quick read
            from families.epson.projects import saved

            saved(repo, robot.url, "cell")
        else:
            pull = ["pull", str(project), "--port", robot.url, "--commit", *robot.family]
            assert main(pull) == 0
        yield request.param, robot, project


def refusal_of(
    robot: Served, project: Path, verb: str, capsys: pytest.CaptureFixture[str]
) -> tuple[str, str]:
    """The plan's warning and the push's refusal with the simulator set by ``verb``."""
    robot.drift()
    station = robot.sim.stations[min(robot.sim.stations)]
    robot.sim.control(verb, station, ())
    capsys.readouterr()
    try:
        assert main(["plan", str(project)]) == 0
        warning = capsys.readouterr().err
        writes = len(robot.sim.writes_received())
        assert main(["push", str(project), "--yes"]) == 3
        refused = capsys.readouterr().err
        assert len(robot.sim.writes_received()) == writes  # nothing was written
    finally:
        robot.sim.control("stop", station, ())
    return warning, refused


def test_each_cause_gets_its_own_advice_in_the_push_and_the_plan(
    served: tuple[str, Served, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    family, robot, project = served
    seen: dict[str, str] = {}
    for verb, advice in [(verb, advice) for f, verb, advice in CAUSES if f == family]:
        warning, refused = refusal_of(robot, project, verb, capsys)
        assert refused.count("\n") == 1 and refused.startswith("harlsync: refused: "), refused
        assert f". {advice}" in refused, (verb, refused)
        assert warning.count("\n") == 1 and f". {advice}" in warning, (verb, warning)
        sentence = refused.split("; stopped before reading the robot. ", 1)[1]
        assert sentence not in seen.values(), (verb, seen)  # its own, not another cause's
        seen[verb] = sentence
    assert len(seen) >= 2


def test_the_advice_names_no_other_familys_tools(
    served: tuple[str, Served, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    family, robot, project = served
    verb = {"harl-u2": "auto", "iai": "estop", "epson": "estop"}[family]
    _, refused = refusal_of(robot, project, verb, capsys)
    others = {"harl-u2": ("RC+", "215H"), "iai": ("RC+", "LNR"), "epson": ("215H", "LNR")}
    assert not any(word in refused for word in others[family]), refused
