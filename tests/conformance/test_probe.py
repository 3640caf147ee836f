"""Issue 31: ``harlsync probe`` against every family's simulator and every variant.

From the simulator's own record: the probe sends no write, whichever way the
controller fills its manual's silences; and ``probe --write DIR`` followed by
``pull DIR`` backs the robot up with no setting typed by hand.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from harlsync import cli, families
from harlsync.project import load_project

from .harness import HARNESSES, join, served, variant_cases
from .test_conformance import writes_since


def _probe(family: str, url: str, station: int, *extra: str) -> int:
    fam = families.get(family)
    return cli.main(
        [
            "probe",
            "--port",
            url,
            "--family",
            family,
            "--station",
            fam.format_station(station),
            *extra,
        ]
    )


@pytest.mark.parametrize(("family", "variant"), variant_cases())
def test_issue_31_the_probe_sends_only_reads_to_every_variant_of_every_family(
    family: str, variant: dict[str, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    join(family, monkeypatch)
    HARNESSES[family].quick(monkeypatch)
    with served(family, 21, variant) as (device, station, url):
        assert _probe(family, url, station) == 0
        assert writes_since(device, 0) == []
        # a simulator that counts its register accesses too (a Modbus slave's
        # handshake signals are written without a command): none was a write
        accesses = getattr(device, "accesses", None)
        if accesses is not None:
            assert accesses()["write"] == 0


@pytest.mark.parametrize(
    ("family", "variant"),
    [case for case in variant_cases() if case.values[0] in families.names()],
)
def test_issue_31_probe_write_then_pull_backs_up_every_variant_with_no_setting_typed(
    family: str,
    variant: dict[str, str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    join(family, monkeypatch)
    HARNESSES[family].quick(monkeypatch)
    project = tmp_path / "cell"
    with served(family, 21, variant) as (device, station, url):
        assert _probe(family, url, station, "--write", str(project)) == 0
        assert (project / "robot.yaml").read_text().startswith("# Written by harlsync probe")
        assert cli.main(["pull", str(project)]) == 0, capsys.readouterr().err
        assert writes_since(device, 0) == []
    loaded = load_project(project)
    assert loaded.robot.family in (family, "")


@pytest.mark.parametrize("family", [n for n in families.names() if not families.get(n).schemes])
def test_issue_31_a_probe_capture_of_every_serial_family_replays(
    family: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    join(family, monkeypatch)
    capture = tmp_path / "probe.txt"
    with served(family, 21) as (_device, station, url):
        assert _probe(family, url, station, "--json", "--capture", str(capture)) == 0
        live = json.loads(capsys.readouterr().out)
    replay = f"replay://{capture}?timing=0&family={family}"
    assert _probe(family, replay, station, "--json") == 0, capsys.readouterr().err
    replayed = json.loads(capsys.readouterr().out)
    timing = ("turnaround_seconds", "pull_seconds", "held_seconds", "port")
    assert {k: v for k, v in replayed.items() if k not in timing} == {
        k: v for k, v in live.items() if k not in timing
    }
