"""Timeouts are printed as configured (issue 22 item 11): robot.yaml's ``timeout: 0.5``
is "0.5 s" in every message, never rounded to other digits (``0.123457``) nor the
deadline a codec stretched for a long reply (``0.5123``)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from conftest import git
from plantsim import SMALL

from harlsync.cli import main
from harlsync.settings import SerialSettings, seconds
from harlsync.sim import Faults
from harlsync.sim.device import Simulator
from harlsync.sim.protocol_sim import register, unregister


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (0.5, "0.5"),
        (1.0, "1.0"),
        (0.1234567, "0.1234567"),
        (0.1 + 0.2, "0.30000000000000004"),  # not what anyone configured: not rounded either
        (1e-05, "0.00001"),
        (2500000.0, "2500000.0"),
    ],
)
def test_a_duration_reads_as_the_number_it_is(value: float, text: str) -> None:
    assert seconds(value) == text
    assert float(seconds(value)) == value


def test_the_serial_settings_say_their_timeout_as_robot_yaml_writes_it() -> None:
    assert "reply timeout 0.1234567 s" in str(SerialSettings(timeout=0.1234567))
    assert "reply timeout 1.0 s" in str(SerialSettings())


def configure(project: Path, repo: Path, timeout: str) -> None:
    robot_yaml = project / "robot.yaml"
    text = re.sub(r"(?m)^  timeout: .*$", f"  timeout: {timeout}", robot_yaml.read_text())
    robot_yaml.write_text(text)
    git(repo, "commit", "-qam", f"timeout {timeout}")


@pytest.mark.parametrize("family", ["harl-u2", "iai"])
def test_a_reply_that_never_comes_names_the_configured_timeout(
    family: str, repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim: Simulator[Any, Any]
    if family == "iai":
        from harlsync.families.iai.sim import SimState as IaiState
        from harlsync.families.iai.sim import Simulator as IaiSimulator

        sim = IaiSimulator({0x99: IaiState.generate(5, position_range=(1, 20))})
        options = ["--family", "iai"]
    else:
        from harlsync.families.harl_u2.sim import SimState as HarlState
        from harlsync.families.harl_u2.sim import Simulator as HarlSimulator

        sim = HarlSimulator({1: HarlState.generate(7, SMALL)})
        options = []
    url = register(sim)
    try:
        project = repo / "cell"
        assert main(["pull", str(project), "--port", url, "--commit", *options]) == 0
        configure(project, repo, "0.01234567")  # more digits than :g keeps
        sim.faults = Faults(drop=1.0)
        capsys.readouterr()
        assert main(["diff", str(project)]) == 2
        err = capsys.readouterr().err
    finally:
        unregister(url)
    assert err.count("\n") == 1, err
    assert "no reply within 0.01234567 s" in err, err
    if family == "iai":  # its codec gives a long reply its time on the wire, said apart
        assert re.search(r"no reply within 0\.01234567 s \(\+\d\.\d{3} s for its time", err), err


def test_an_epson_transaction_that_never_answers_names_the_configured_timeout(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from families.epson.projects import saved
    from families.epson.sample import sample_data

    from harlsync.families.epson.sim import SimState, Simulator

    sim = Simulator(SimState.from_data(sample_data()), execution_time=0.0)
    with sim.serve() as server:
        project = saved(repo, server.url, "scara", timeout=0.05432198, retries=1)
        assert "timeout: 0.05432198" in (project / "robot.yaml").read_text()
        sim.faults = Faults(drop=1.0)
        capsys.readouterr()
        assert main(["diff", str(project)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no answer within 0.05432198 s" in err, err
