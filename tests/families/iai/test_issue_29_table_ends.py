"""Issue 29 for IAI: where each table ends is the controller's own answer, checked
twice, recorded, and compared at the next pull; no probe costs more than a few
queries beyond the table's own reads; the probes cope with ``&`` on every path,
above and below the range (and issue 34 items 1 and 6).

Each controller here is the project's simulator answering as one of its variants
(harlsync/families/iai/sim/device.py ``VARIANTS``) where the manual is silent;
every count of queries is the simulator's own record of what it received."""

from __future__ import annotations

import random
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from harlsync import cli
from harlsync.errors import LinkTimeout
from harlsync.families.iai.controller import Controller
from harlsync.families.iai.model import Position
from harlsync.families.iai.sim import MANUAL, SimState, Simulator
from harlsync.families.iai.tables import Coverage
from harlsync.project import load_project
from harlsync.settings import SerialSettings
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine

STATION = 0x99
AXES = (1, 2)
QUICK = SerialSettings(baudrate=115200, timeout=0.05, retries=1)


def position(n: int) -> Position:
    rng = random.Random(n)
    return Position(n, AXES, "0.30", "0.30", 100, (f"{rng.randint(0, 999)}.000", "1.500"))


def controller(numbers: list[int] | range, table: tuple[int, int] = (1, 1000)) -> SimState:
    """A controller whose position table holds ``table`` (numbers), with ``numbers``
    defined."""
    return SimState.from_positions([position(n) for n in numbers], axes=AXES, position_range=table)


@contextmanager
def served(state: SimState, **variant: str) -> Iterator[tuple[Simulator, str]]:
    sim = Simulator({STATION: state})
    sim.vary(variant)
    url = register(sim)
    try:
        yield sim, url
    finally:
        unregister(url)


def pull(project: Path, url: str | None = None, *extra: str) -> int:
    port = ["--family", "iai", "--port", url, "--station", "99"] if url else ["--allow-dirty"]
    return cli.main(["pull", str(project), *port, *extra])


def set_robot(project: Path, old: str, new: str) -> None:
    robot = project / "robot.yaml"
    text = robot.read_text()
    assert old in text
    robot.write_text(text.replace(old, new))


def asked(sim: Simulator, command: str, since: int = 0) -> list[str]:
    return [r.payload for r in sim.received[since:] if r.command == command]


KEEP = ("maintenance_windows", "keep_registers: true\nmaintenance_windows")


# --- positions ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("past_table", "probes", "covered"),
    [
        (
            "refused-0A3",
            ["22D0003E90001", "22D0003E90001"],  # 1001 alone, refused twice
            Coverage(1, 1000, 1000, 1, None, 1000, None, "error 0A3H"),
        ),
        (
            "empty",
            ["22D0003E90001", "22D000003FFFD"],  # 1001 alone, then every number from 3
            Coverage(1, 1000, 0xFFFF, 1, None, None, None, "empty"),
        ),
    ],
)
def test_issue_29_positions_past_a_1000_table_cost_two_queries_whatever_it_answers(
    repo: Path,
    capsys: pytest.CaptureFixture[str],
    past_table: str,
    probes: list[str],
    covered: Coverage,
) -> None:
    """The controller of the issue: its 1000-position table answers & 0A3 to a 22DH
    whose head lies past it.  Every pull failed on the wire's words.  One that
    answers it empty is probed as cheaply."""
    with served(controller([1, 2, 999, 1000]), past_table=past_table) as (sim, url):
        assert pull(repo / "cell", url) == 0, capsys.readouterr().err
    reads = -(-1000 // 24)
    assert asked(sim, "22D")[reads:] == probes  # the table's reads, then two queries
    assert load_project(repo / "cell").data.covered["positions"] == covered
    if past_table == "refused-0A3":
        text = (repo / "cell" / "controller.yaml").read_text()
        assert (
            "positions: {first: 1, last: 1000, checked_from: 1, checked_to: 1000, end: 1000, "
            'past: "error 0A3H"}'
        ) in text


@pytest.mark.parametrize("past_table", ["refused-0A3", "empty"])
def test_issue_29_the_probe_below_first_position_copes_with_a_refusal(
    repo: Path, capsys: pytest.CaptureFixture[str], past_table: str
) -> None:
    """A table that starts at 10: read from there with robot.yaml's default
    first_position 1, and probed below first_position 10: the number before it
    refused (or empty), twice.  The one 22DH below the range had no fallback: &
    failed the pull."""
    state = controller([10, 11, 500], table=(10, 1000))
    with served(state, past_table=past_table) as (sim, url):
        project = repo / "cell"
        assert pull(project, url) == 0, capsys.readouterr().err
        covered = load_project(project).data.covered["positions"]
        if past_table != "empty":
            assert (covered.start, covered.before) == (10, "error 0A3H")
        set_robot(project, "first_position: 1\n", "first_position: 10\n")
        capsys.readouterr()
        before = len(sim.received)
        assert pull(project) == 0, capsys.readouterr().err
        probes = asked(sim, "22D", before)[-4:]
    covered = load_project(project).data.covered["positions"]
    if past_table == "empty":
        # an empty reply before the table: the numbers 1-9 read, in one query
        assert probes[-2:] == ["22D0000090001", "22D0000010008"]
        assert (covered.checked_from, covered.start, covered.before) == (1, None, "empty")
    else:
        assert probes[-2:] == ["22D0000090001", "22D0000090001"]
        assert covered.start == 10 and covered.before == "error 0A3H"
        assert covered.checked_from == 10


def test_issue_29_a_position_before_the_range_is_found_when_wide_queries_are_refused(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = controller([50, 120, 121])
    with served(state, wide_query="refused") as (_, url):
        project = repo / "cell"
        pull(project, url)
        set_robot(project, "first_position: 1\n", "first_position: 100\n")
        capsys.readouterr()
        assert pull(project) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "position 50 is defined before the range this backup reads (100-1000)" in err[0]
    assert "set controller.first_position: 50 (or lower) in robot.yaml" in err[0]


def test_issue_29_a_controller_that_scans_fewer_numbers_than_asked_is_not_trusted(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It answers a 22DH for every number past the range with zero records (it scans
    only as many as a read carries): the pull recorded the range as covered to
    65535 and missed position 1500.  The reply to a wide query from inside the range
    leaves out positions the read found, so the probe reads on in read-sized queries
    to the table's end."""
    numbers = [*range(1, 1001, 7), 1500]
    with served(controller(numbers, table=(1, 2000)), wide_query="scans-less") as (_, url):
        assert pull(repo / "cell", url) == 2
    err = capsys.readouterr().err
    assert "position 1500 is defined past the range this backup reads (1-1000)" in err
    assert "set controller.last_position: 1500 (or higher)" in err


def test_issue_29_nothing_past_a_range_that_scans_fewer_numbers_reads_to_the_tables_end(
    repo: Path,
) -> None:
    numbers = list(range(1, 1001, 7))
    with served(controller(numbers, table=(1, 1500)), wide_query="scans-less") as (sim, url):
        assert pull(repo / "cell", url) == 0
    covered = load_project(repo / "cell").data.covered["positions"]
    assert (covered.checked_to, covered.end, covered.past) == (1500, 1500, "error 0A3H")
    # the table's reads, 1001 alone, the wide query, 1002-1500 in reads of 24, and
    # the edge: a handful of queries beyond reading the table itself
    table_reads = -(-1000 // 24) + -(-(1500 - 1001) // 24)
    assert len(asked(sim, "22D")) <= table_reads + 12


@pytest.mark.parametrize("past_table", ["refused-0A3", "empty"])
def test_issue_29_a_position_table_smaller_than_the_range_is_read_to_its_end_and_said(
    repo: Path, capsys: pytest.CaptureFixture[str], past_table: str
) -> None:
    state = controller([1, 2, 590, 601], table=(1, 610))
    with served(state, past_table=past_table) as (sim, url):
        said = engine.pull(repo / "cell", port=url, station=STATION, family="iai").contents
    data = load_project(repo / "cell").data
    assert sorted(data.positions) == [1, 2, 590, 601]
    covered = data.covered["positions"]
    if past_table == "refused-0A3":
        assert (covered.end, covered.past, covered.checked_to) == (610, "error 0A3H", 610)
        assert said == (
            "4 positions in 1-610 (the controller's table ends at 610, inside robot.yaml's "
            "1-1000; none defined outside it)"
        )
        # its reads to 624 (26), 625 refused, then halving between 601 and 625 to 610
        assert len(asked(sim, "22D")) <= 26 + 1 + 7
    else:  # an empty reply past it cannot be told from undefined positions: all read
        assert covered.end is None and covered.past == "empty"


def test_issue_29_a_controller_counting_records_not_numbers_is_read_and_probed(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """22DH's count may be the records returned, not the numbers scanned: a read of
    24 numbers then carries positions past them, and past the range."""
    with served(controller([1, 30, 1500], table=(1, 2000)), count_means="records") as (_, url):
        assert pull(repo / "cell", url) == 2
    assert "position 1500 is defined past the range" in capsys.readouterr().err
    with served(controller([1, 30, 999], table=(1, 2000)), count_means="records") as (_, url):
        assert pull(repo / "cell2", url) == 0
    assert sorted(load_project(repo / "cell2").data.positions) == [1, 30, 999]


# --- the "not there" reply, recorded and compared -------------------------------------


@pytest.mark.parametrize(
    ("was", "now", "said"),
    [
        ("refused-0A3", "refused-0B4", ("error code 0B4H", "error code 0A3H")),
        ("refused-0A3", "empty", ("an empty reply", "error code 0A3H")),
        ("empty", "refused-0A3", ("error code 0A3H", "an empty reply")),
    ],
)
def test_issue_29_a_not_there_reply_that_changes_between_pulls_fails_naming_both(
    repo: Path, capsys: pytest.CaptureFixture[str], was: str, now: str, said: tuple[str, str]
) -> None:
    project = repo / "cell"
    with served(controller([1, 2, 3]), past_table=was) as (sim, url):
        assert pull(project, url) == 0
        kept = (project / "controller.yaml").read_text()
        sim.vary({"past_table": now})
        capsys.readouterr()
        assert pull(project) == 3
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        assert f"the controller now answers {said[0]}, where the last pull got {said[1]}" in err[0]
        assert "controller.yaml covered.positions.past" in err[0]
        assert "--new-robot" in err[0]
        assert (project / "controller.yaml").read_text() == kept  # the backup left as it was
        assert cli.main(["diff", str(project)]) == 2  # not compared either
        assert pull(project, None, "--new-robot") == 0  # taken as it answers now
        assert pull(project) == 0


def test_issue_29_a_changed_range_is_not_taken_for_a_changed_reply(repo: Path) -> None:
    project = repo / "cell"
    with served(controller([1, 2, 3], table=(1, 1000))) as (_, url):
        assert pull(project, url) == 0  # past 1000: error 0A3H
        set_robot(project, "last_position: 1000", "last_position: 800")
        assert pull(project) == 0  # past 800: an empty reply (800 is inside its table)
    assert load_project(project).data.covered["positions"].past == "empty"


# --- flags and variables ----------------------------------------------------------------


def test_issue_29_keep_registers_on_tables_refused_past_their_ends_costs_a_few_queries(
    repo: Path,
) -> None:
    """The flags and variables end where the profile's ranges do, and the controller
    refuses every number outside (before and past).  The probe walked one query per
    number to 65535 or 4095: 15,642 queries."""
    project = repo / "cell"
    with served(controller([1, 2]), tables="exact") as (sim, url):
        assert pull(project, url) == 0
        set_robot(project, *KEEP)
        before = len(sim.received)
        assert pull(project) == 0
        counts = {c: len(asked(sim, c, before)) for c in ("20D", "20E", "20F")}
    covered = load_project(project).data.covered
    for section, (first, last) in {
        "flags": (600, 899),
        "integers": (200, 299),
        "reals": (300, 399),
    }.items():
        assert covered[section] == Coverage(
            first, last, last, first, first, last, "error 0A3H", "error 0A3H"
        ), section
    # each: its read; past it the query refused and the number alone refused (flags:
    # once more, their query began at 896); before it the query refused and the
    # number alone refused twice
    assert counts == {"20D": 7, "20E": 6, "20F": 6}, counts


def test_issue_34_item_6_a_flag_range_past_the_table_is_read_to_its_end_and_said(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """flags: {first: 600, last: 999} where the controller's flags end at 899 failed
    with the wire's words, "command 20DH: ... error code 0A3H"."""
    project = repo / "cell"
    state = controller([1, 2])
    with served(state, tables="exact") as (sim, url):
        sim.stations[STATION].flags = {600, 899}
        assert pull(project, url) == 0
        set_robot(project, *KEEP)
        set_robot(project, "controller:\n", "controller:\n  flags: {first: 600, last: 999}\n")
        said = engine.pull(project, allow_dirty=True).contents
    assert "300 flags in 600-899 (the controller's table ends at 899, inside robot.yaml's " in said
    data = load_project(project).data
    assert data.flags is not None and sorted(n for n, on in data.flags.items() if on) == [600, 899]
    assert data.covered["flags"].end == 899


def test_issue_34_item_1_integers_set_below_the_kept_range_fail_the_pull_naming_them(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    project = repo / "cell"
    state = controller([1, 2])
    state.integers = {206: 1, 213: -7, 218: 40, 260: 5}
    with served(state) as (_, url):
        assert pull(project, url) == 0
        set_robot(project, *KEEP)
        set_robot(project, "controller:\n", "controller:\n  integers: {first: 250, last: 299}\n")
        capsys.readouterr()
        assert pull(project) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert (
        "integer variables 206, 213 and 218 are set before the range this backup keeps "
        "(250-299), and not backed up; set controller.integers: {first: 206, last: 299} "
        "(or lower) in robot.yaml"
    ) in err[0]
    assert not (project / "variables.yaml").exists()


# --- the real variables' word order --------------------------------------------------------


def test_issue_29_a_lower_first_controller_is_pulled_and_pushed_exactly_with_the_defaults(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """robot.yaml says nothing of the word order: the values tell it, the pull
    records it, and a push to a blank controller (every real 0) writes in it."""
    project = repo / "cell"
    state = controller([1, 2])
    state.reals = {300: 0.1, 301: -2.5, 305: 1250.75, 306: 3.0}
    with served(state, real_word_order="lower-first") as (sim, url):
        assert pull(project, url) == 0
        set_robot(project, *KEEP)
        assert pull(project) == 0
        data = load_project(project).data
        assert data.reals is not None
        assert {n: v for n, v in data.reals.items() if v != "0.0"} == {
            300: "0.1",
            301: "-2.5",
            305: "1250.75",
            306: "3.0",
        }
        assert "real_word_order: lower-first" in (project / "controller.yaml").read_text()
        assert "real_word_order" not in (project / "robot.yaml").read_text()
        blank = sim.stations[STATION]
        blank.reals = {}
        capsys.readouterr()
        assert cli.main(["push", str(project), "--yes", "--registers", "--allow-dirty"]) == 0, (
            capsys.readouterr().err
        )
        assert blank.reals == {300: 0.1, 301: -2.5, 305: 1250.75, 306: 3.0}


def test_issue_29_robot_yamls_word_order_contradicted_by_the_values_fails_naming_it(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    project = repo / "cell"
    state = controller([1, 2])
    state.reals = {300: 0.1, 301: -2.5, 302: 7.25}
    with served(state, real_word_order="lower-first") as (_, url):
        assert pull(project, url) == 0
        set_robot(project, *KEEP)
        set_robot(project, "controller:\n", "controller:\n  real_word_order: upper-first\n")
        capsys.readouterr()
        assert pull(project) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "the controller keeps them lower-first" in err[0]
    assert "set controller.real_word_order: lower-first in robot.yaml" in err[0]


def test_issue_29_a_real_written_where_no_value_tells_the_order_is_refused_naming_the_setting(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    project = repo / "cell"
    with served(controller([1, 2])) as (sim, url):  # every real 0: no order to be seen
        assert pull(project, url) == 0
        set_robot(project, *KEEP)
        assert pull(project) == 0
        assert "real_word_order" not in (project / "controller.yaml").read_text()
        variables = project / "variables.yaml"
        variables.write_text(variables.read_text().replace("  300: 0.0\n", "  300: 2.5\n"))
        capsys.readouterr()
        code = cli.main(["push", str(project), "--yes", "--registers", "--allow-dirty"])
        err = capsys.readouterr().err
        assert code != 0
        assert "real variable 300 is not written" in err
        assert "set controller.real_word_order in robot.yaml" in err
        assert not sim.writes_received()


# --- the rest of the simulator's variants ------------------------------------------------


def test_issue_29_a_controller_answering_in_lower_case_hex_is_pulled(repo: Path) -> None:
    with served(controller([1, 2, 3]), reply_case="lower") as (_, url):
        assert pull(repo / "cell", url) == 0
    assert sorted(load_project(repo / "cell").data.positions) == [1, 2, 3]


def test_issue_29_a_controller_silent_in_manual_mode_is_never_taken_for_idle(
    lock_dir: Path,
) -> None:
    """p.7: the protocol runs in AUTO mode; what a controller in MANUAL answers is
    not said.  One that answers nothing is no idle robot: its status cannot be read."""
    state = controller([1, 2])
    state.mode = MANUAL
    with served(state, manual_mode="silent") as (sim, url):
        c = Controller.from_url(url, STATION, QUICK)
        try:
            with pytest.raises(LinkTimeout):
                c.status()
        finally:
            c.close()
        assert not sim.writes_received()
