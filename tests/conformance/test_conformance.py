"""One suite every registered family passes, the toy family included: round
trip, drift, interlock refusal, bad input, restore to a blank controller, and a
small seeded property run of pushes against an operator.  What each test
asserts of the controller it takes from the simulator's own record of what it
received.  Run one family with ``-k <name>``.
"""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

import pytest

from harlsync import cli, families
from harlsync.errors import InterlockError
from harlsync.project import load_project, save_project
from harlsync.sim import sim_family
from harlsync.sync import comparison, deploy, pulling
from harlsync.sync.deploy import PushFailed, PushOptions

from .harness import HARNESSES, join, names, served, variant_cases

FAMILIES = names()
#: Seeds of the property run: a few, fixed, so the suite stays fast and repeatable
#: (each family runs the first ``Harness.property_seeds`` of them).
PROPERTY_SEEDS = range(4)


def pulled(tmp_path: Path, name: str, url: str, station: int) -> Path:
    family = families.get(name)
    project = tmp_path / f"{name}-cell"
    pulling.pull(project, port=url, station=station, family=family)
    return project


def busy(device: Any, station: int) -> None:
    device.control(sim_family(device.family.name).busy_verb, device.stations[station], ())


def writes_since(device: Any, first: int) -> list[Any]:
    return [r for r in device.received[first:] if r.is_write]


@pytest.fixture(params=FAMILIES)
def name(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    assert request.param in HARNESSES, (
        f"family {request.param} has no conformance harness: add it to tests/conformance/harness.py"
    )
    join(request.param, monkeypatch)
    HARNESSES[request.param].quick(monkeypatch)
    return str(request.param)


def test_a_pull_saves_what_the_controller_holds_and_reads_back_the_same(
    name: str, tmp_path: Path
) -> None:
    with served(name, 11) as (device, station, url):
        project = pulled(tmp_path, name, url, station)
        loaded = load_project(project)
        assert loaded.family.name == name
        assert save_project(project, loaded) == []  # the files are what a save writes
        found = comparison.compare(project)
        assert found.changes == []
        assert writes_since(device, 0) == []  # a pull and a diff never write


def test_a_change_at_the_controller_shows_as_drift_item_by_item(name: str, tmp_path: Path) -> None:
    with served(name, 12) as (device, station, url):
        project = pulled(tmp_path, name, url, station)
        said = HARNESSES[name].edit(device.stations[station], random.Random(1))
        found = comparison.compare(project)
        assert len(found.changes) >= 1, said
        for change in found.changes:
            assert change.old != change.new
            assert change.name  # in the family's words
        assert cli.main(["diff", str(project)]) == 1


def test_a_push_to_a_running_controller_is_refused_and_writes_nothing(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with served(name, 13) as (device, station, url):
        project = pulled(tmp_path, name, url, station)
        HARNESSES[name].edit(device.stations[station], random.Random(2))
        busy(device, station)
        first = len(device.received)
        capsys.readouterr()
        assert cli.main(["push", str(project), "--yes", "--allow-dirty"]) == 3
        err = capsys.readouterr().err
        assert "is not idle" in err and "Traceback" not in err
        assert writes_since(device, first) == []
        with pytest.raises(PushFailed) as failed:
            deploy.push(project, PushOptions(yes=True, allow_dirty=True))
        assert isinstance(failed.value.cause, InterlockError)
        assert writes_since(device, first) == []


def test_bad_input_is_one_line_and_reaches_no_controller(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with served(name, 14) as (device, station, url):
        project = pulled(tmp_path, name, url, station)
        first = len(device.received)
        (project / "robot.yaml").write_text("name: [unclosed\n")
        capsys.readouterr()
        assert cli.main(["push", str(project), "--yes", "--allow-dirty"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "robot.yaml" in err and "Traceback" not in err
        assert (
            cli.main(
                [
                    "pull",
                    str(tmp_path / "new"),
                    "--port",
                    url,
                    "--family",
                    name,
                    "--station",
                    "not-a-station",
                ]
            )
            == 2
        )
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "--station" in err
        assert device.received[first:] == []  # nothing was even asked


def test_a_backup_restores_a_blank_controller(name: str, tmp_path: Path) -> None:
    with served(name, 15) as (device, station, url):
        project = pulled(tmp_path, name, url, station)
        device.stations[station] = HARNESSES[name].blank(device.stations[station])
        assert comparison.compare(project).changes  # the blank differs
        result = deploy.push(
            project, PushOptions(yes=True, allow_dirty=True, allow_reconfigure=True)
        )
        assert result.ok and result.written
        assert comparison.compare(project).changes == []
        assert all(not r.busy for r in writes_since(device, 0))


@pytest.mark.parametrize("seed", PROPERTY_SEEDS)
def test_no_write_reaches_a_controller_started_mid_push_and_an_undisturbed_push_converges(
    name: str, seed: int, tmp_path: Path
) -> None:
    """An operator edits the controller, then starts it after a random number of
    requests of the push.  From the simulator's record: at most the one write
    already on its way when it started arrives while it runs (no client can
    prevent that race), and the push then fails or warns; a push nobody
    disturbed leaves the controller as the project says."""
    if seed >= HARNESSES[name].property_seeds:
        pytest.skip(f"the {name} family runs {HARNESSES[name].property_seeds} seed(s)")
    rng = random.Random(seed)
    with served(name, 100 + seed) as (device, station, url):
        project = pulled(tmp_path, name, url, station)
        story = [HARNESSES[name].edit(device.stations[station], rng) for _ in range(3)]
        first = len(device.received)
        start_after = rng.randrange(1, 40)
        switched: list[int] = []

        def operator(_: Any) -> None:
            if not switched and len(device.received) - first == start_after:
                switched.append(len(device.received))
                busy(device, station)

        device.listeners.append(operator)
        try:
            result = deploy.push(project, PushOptions(yes=True, allow_dirty=True))
            failed = None
        except PushFailed as exc:
            result, failed = exc.result, exc
        finally:
            device.listeners.remove(operator)
        why = f"seed {seed}: {story}, started after {start_after} requests: {switched}"
        received = device.received[first:]
        late = [i for i, r in enumerate(received, first) if r.is_write and r.busy]
        assert len(late) <= 1, why
        if late:
            assert late == switched, why  # the write right after the start, no other
            assert failed is not None or result.warnings, why
        if not switched:
            assert failed is None, f"{why}: {failed}"
            assert comparison.compare(project).changes == [], why


@pytest.mark.parametrize(("family", "variant"), variant_cases())
def test_every_variant_of_a_controller_is_pulled_diffed_pushed_and_restored_with_the_defaults(
    family: str, variant: dict[str, str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 29: a controller that fills its manual's silences otherwise than the
    profile guesses (each variant of its simulator) is backed up, compared, pushed to
    and restored with robot.yaml's defaults, as the profile's own is."""
    join(family, monkeypatch)
    HARNESSES[family].quick(monkeypatch)
    with served(family, 21, variant) as (device, station, url):
        project = pulled(tmp_path, family, url, station)
        assert comparison.compare(project).changes == []
        assert writes_since(device, 0) == []
        HARNESSES[family].edit(device.stations[station], random.Random(3))
        assert comparison.compare(project).changes
        result = deploy.push(project, PushOptions(yes=True, allow_dirty=True))
        assert result.ok and result.written
        assert comparison.compare(project).changes == []
        device.stations[station] = HARNESSES[family].blank(device.stations[station])
        result = deploy.push(
            project, PushOptions(yes=True, allow_dirty=True, allow_reconfigure=True)
        )
        assert result.ok and result.written
        assert comparison.compare(project).changes == []
        assert all(not r.busy for r in writes_since(device, 0))
