"""Issue 31: ``harlsync probe`` tells what answers on a port, with reads only.

What each test asserts of the controller it takes from the simulator's own record.
The conformance suite (tests/conformance/test_probe.py) runs the probe against every
family and every simulator variant; here: its words, its JSON, its capture, the
line it refuses to write, and the first pull that points to it.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from simline import SMALL, ScriptedSim

from harlsync.cli import main
from harlsync.families.harl_u2.controller import Controller
from harlsync.families.harl_u2.sim import SimState
from harlsync.link.lock import LineLock, lock_path
from harlsync.link.readonly import WriteForbidden, reads_only
from harlsync.sim.protocol_sim import register, unregister


@pytest.fixture
def served() -> Iterator[tuple[ScriptedSim, str]]:
    """A small generated HARL-U2 with the profile's answers, on a ``sim://`` URL."""
    sim = ScriptedSim(SimState.generate(5, SMALL))
    url = register(sim)
    yield sim, url
    unregister(url)


def probed_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, object]:
    capsys.readouterr()
    assert main(["probe", "--json", *argv]) == 0, capsys.readouterr().err
    found: dict[str, object] = json.loads(capsys.readouterr().out)
    return found


def test_issue_31_probe_reports_family_identity_extent_guesses_and_pull_time_in_words(
    served: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.vary({"missing_table": "E2", "offset_tables": "64"})
    assert main(["probe", "--port", url]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"Hirata HARL-U2 (harl-u2) at port {url} station 1\n")
    assert "serial settings: 9600 8N1" in out
    assert f"version: {sim.stations[1].data.version}" in out
    assert (
        "offset tables: 64 (tables, 0 to count - 1); past the end the controller answers E2" in out
    )
    assert (
        "guess contradicted: the reply to an offset table the controller does not have (profile: E21, this controller: E2; robot.yaml no_such_table)"
        in out
    )
    assert (
        "guess contradicted: how many offset tables the controller has (at most) (profile: 100, this controller: 64; robot.yaml offset_tables)"
        in out
    )
    assert "interlock now: idle" in out
    assert "reply turnaround measured: " in out
    assert "a full pull: " in out and " exchanges, about " in out
    assert "Traceback" not in out and "'" not in out  # words, no Python repr
    assert not sim.writes_received()


def test_issue_31_probe_finds_the_station_when_none_is_given_and_says_the_interlock(
    served: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.stations[2] = sim.stations.pop(1)
    sim.control("auto", sim.stations[2], ("0",))
    found = probed_json(capsys, "--port", url, "--stations", "1-2", "--family", "harl-u2")
    assert found["family"] == "harl-u2" and found["station"] == "2"
    assert found["tried"] == ["Hirata HARL-U2 station 1 at 9600 baud: no answer"]
    interlock = found["interlock"]
    assert isinstance(interlock, dict) and interlock["idle"] is False
    assert interlock["status"].startswith("task 0 in execution")
    assert found["robot_options"] == {"no_such_table": "E21"}
    assert not sim.writes_received()


def test_issue_31_probe_write_refuses_an_existing_project_before_opening_the_line(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    (tmp_path / "cell").mkdir()
    (tmp_path / "cell" / "robot.yaml").write_text("name: cell\n")
    assert main(["probe", "--port", url, "--write", str(tmp_path / "cell")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists and is not empty" in err[0]
    assert (tmp_path / "cell" / "robot.yaml").read_text() == "name: cell\n"
    assert not sim.received


def test_issue_31_a_probe_capture_replays_through_replay_urls(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.vary({"missing_table": "E99"})
    capture = tmp_path / "probe.txt"
    live = probed_json(
        capsys, "--port", url, "--family", "harl-u2", "--station", "1", "--capture", str(capture)
    )
    assert capture.read_text().startswith("# harlsync capture")
    sim.stations.clear()  # the replay alone answers now
    replayed = probed_json(
        capsys, "--port", f"replay://{capture}?timing=0", "--family", "harl-u2", "--station", "1"
    )
    timing = ("turnaround_seconds", "pull_seconds", "held_seconds", "port")
    assert {k: v for k, v in replayed.items() if k not in timing} == {
        k: v for k, v in live.items() if k not in timing
    }
    assert replayed["extents"] == [
        {
            "table": "offset tables",
            "count": 100,
            "counted": "tables, 0 to count - 1",
            "not_there": "E99",
            "settings": ["offset_tables", "no_such_table"],
        }
    ]


def test_issue_31_a_line_that_carries_reads_only_refuses_a_write_before_sending_it(
    served: tuple[ScriptedSim, str],
) -> None:
    sim, url = served
    controller = Controller.from_url(url, 1)
    try:
        with (
            reads_only("harlsync probe"),
            pytest.raises(WriteForbidden, match="SNT 0 .* is a write"),
        ):
            controller.write_timer(0, "1.00")
        assert controller.read_timer(0)  # reads go on
    finally:
        controller.close()
    assert not sim.writes_received()


def test_issue_31_a_first_pull_that_gets_no_answer_points_to_harlsync_probe(
    served: tuple[ScriptedSim, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    sim.stations[2] = sim.stations.pop(1)  # not where a first pull looks (station 1)
    assert main(["pull", str(tmp_path / "cell"), "--port", url]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert f"harlsync probe --port {url} tells which controller answers there" in err[0]
    assert not (tmp_path / "cell" / "robot.yaml").exists()


def test_issue_31_probe_waits_for_the_line_lock_and_says_who_holds_the_line(
    served: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    held = LineLock(url, lock_path(url))
    held.acquire(1.0)
    try:
        assert main(["probe", "--port", url, "--lock-timeout", "0.2"]) == 2
    finally:
        held.release()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert not sim.received  # nothing went on a line another harlsync holds


def test_issue_31_probe_without_family_finds_an_iai_controller(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The other families' identity reads get no answer (one try each, at the
    station given, read as each family writes it), then IAI's does."""
    from conformance.harness import join
    from conformance.harness import served as family_served

    join("iai", monkeypatch)
    with family_served("iai", 21) as (device, _station, url):
        found = probed_json(
            capsys, "--port", url, "--stations", "99", "--write", str(tmp_path / "c")
        )
        assert not device.writes_received()
    assert found["family"] == "iai" and found["station"] == "99"
    assert found["tried"] == ["Hirata HARL-U2 station 99 at 9600 baud: no answer"]
    assert "family: iai" in (tmp_path / "c" / "robot.yaml").read_text()


def test_issue_31_nothing_answering_is_one_line_naming_each_attempt(
    served: tuple[ScriptedSim, str], capsys: pytest.CaptureFixture[str]
) -> None:
    sim, url = served
    assert main(["probe", "--port", url, "--family", "harl-u2", "--stations", "5-6"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        (
            f"harlsync: error: port {url}: nothing answered a read of any family tried "
            "(Hirata HARL-U2 station 5 at 9600 baud: no answer; Hirata HARL-U2 station 6 at 9600 "
            "baud: no answer); check the cable and that the controller is on, give --family and "
            "--station if you know them, or --baud auto on a local serial port"
        )
    ]
    assert not sim.writes_received()
