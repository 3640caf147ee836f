"""Review finding 3: the probe past the kept flags and variables looked at one
query's window and took any ``&`` for "the table ends here", yet recorded the
section as checked.  It now reads up to the last number the message can name,
or to where the controller's table ends (issue 29: the number past it refused
twice, not walked past one by one), narrows a refused query to find that end,
and records ``checked_to`` as the last number it actually read."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from harlsync.families.iai import profile
from harlsync.families.iai.controller import Controller
from harlsync.families.iai.layout import Coverage
from harlsync.families.iai.protocol import Frame
from harlsync.families.iai.sim import SimState, Simulator, codes
from harlsync.project import load_project
from harlsync.settings import SerialSettings
from harlsync.sim import Refused
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sim.serve import TcpServer

from .test_coverage import STATION, controller, pull, pull_after_edit

QUICK = SerialSettings(baudrate=115200, timeout=0.05, retries=2)
KEEP = ("maintenance_windows", "keep_registers: true\n$&")
INTEGERS = profile.VARIABLE_NUMBER_END["integers"]


class Numbered(Simulator):
    """A controller that has only the integer variables in ``has`` and answers ``&``
    to a 20EH naming any other number (X-SEL style ranges with gaps)."""

    def __init__(self, state: SimState, has: list[range]) -> None:
        super().__init__({STATION: state})
        self.has = has

    def handle(self, state: SimState, frame: Frame) -> str:
        if frame.message_id == 0x20E:
            start, count = int(frame.data[2:5], 16), int(frame.data[5:7], 16)
            if not all(any(n in r for r in self.has) for n in range(start, start + count)):
                raise Refused(codes.OUT_OF_RANGE)
        return super().handle(state, frame)


@pytest.fixture
def numbered(
    request: pytest.FixtureRequest, lock_dir: object
) -> Iterator[tuple[Controller, Numbered]]:
    has, integers = request.param
    state = controller([1, 2])
    state.integers = integers
    sim = Numbered(state, has)
    url = register(sim)
    c = Controller.from_url(url, STATION, QUICK, first=1, last=1000)
    try:
        yield c, sim
    finally:
        c.close()
        unregister(url)


def test_review_3_an_integer_far_past_the_first_query_fails_the_pull(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = controller([1, 2])
    state.integers = {250: 5, 1250: 7}  # kept: 200-299; 1250 a global integer on an X-SEL
    err = pull_after_edit(repo, state, capsys, *KEEP)
    assert "integer variable 1250 is set past the range this backup keeps (200-299)" in err


def test_review_3_a_flag_near_the_last_number_20dh_names_fails_the_pull(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = controller([1, 2])
    state.flags = {600, 65000}  # kept: 600-899
    err = pull_after_edit(repo, state, capsys, *KEEP)
    assert "flag 65000 is set past the range this backup keeps (600-899)" in err


def test_review_3_nothing_set_past_the_ranges_records_each_checked_to_the_wire_end(
    repo: Path,
) -> None:
    state = controller([1, 2])
    state.integers = {250: 5}
    server = TcpServer(Simulator({STATION: state}))
    try:
        assert pull(repo, server.start()) == 0
        robot = repo / "cell" / "robot.yaml"
        robot.write_text(robot.read_text().replace(KEEP[0], KEEP[1].replace("$&", KEEP[0])))
        assert pull(repo, server.start(), "--allow-dirty") == 0
    finally:
        server.stop()
    covered = load_project(repo / "cell").data.covered
    # issue 29: below the range too, down to the lowest number (integers and reals from
    # 1, flags from 0: profile.NUMBER_FIRST)
    assert covered["integers"] == Coverage(200, 299, INTEGERS, checked_from=1)
    assert covered["reals"] == Coverage(
        300, 399, profile.VARIABLE_NUMBER_END["reals"], checked_from=1
    )
    assert covered["flags"] == Coverage(
        600, 899, profile.VARIABLE_NUMBER_END["flags"], checked_from=0
    )


class EndsAt310(Simulator):
    """Answers ``&`` to a 20EH that reaches past integer 310."""

    def handle(self, state: SimState, frame: Frame) -> str:
        if frame.message_id == 0x20E:
            start, count = int(frame.data[2:5], 16), int(frame.data[5:7], 16)
            if start + count - 1 > 310:
                raise Refused(codes.TOO_LONG)
        return super().handle(state, frame)


def test_review_3_a_refused_probe_is_narrowed_and_finds_what_it_straddled(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = controller([1, 2])
    state.integers = {250: 5, 305: 9}
    server = TcpServer(EndsAt310({STATION: state}))
    try:
        assert pull(repo, server.start()) == 0
        robot = repo / "cell" / "robot.yaml"
        robot.write_text(robot.read_text().replace(KEEP[0], KEEP[1].replace("$&", KEEP[0])))
        capsys.readouterr()
        assert pull(repo, server.start(), "--allow-dirty") == 2
    finally:
        server.stop()
    assert "integer variable 305 is set past the range this backup keeps" in capsys.readouterr().err


@pytest.mark.parametrize("numbered", [([range(311)], {250: 5})], indirect=True)
def test_review_3_a_controller_that_has_no_numbers_past_one_records_the_last_read(
    numbered: tuple[Controller, Numbered],
) -> None:
    _, covered = numbered[0].read_section("integers")
    assert covered == Coverage(200, 299, 310, checked_from=1, end=310, past="error 0B4H")


@pytest.mark.parametrize(
    "numbered",
    [([range(400), range(1000, 1400)], {250: 5, 1250: 7})],
    ids=["x-sel gaps"],
    indirect=True,
)
def test_issue_29_a_gap_of_refused_numbers_ends_the_table_in_a_few_queries(
    numbered: tuple[Controller, Numbered],
) -> None:
    """Changed on purpose (issue 29): a gap the controller refuses twice is the
    table's end, recorded with its reply; the probe no longer walks through it one
    number at a time (15,642 queries to 65535), so what lies past a gap is not
    looked for.  The review's walk past the gap found 1250 here."""
    c, sim = numbered
    before = len(sim.received)
    values, covered = c.read_section("integers")
    assert covered == Coverage(200, 299, 399, checked_from=1, end=399, past="error 0B4H")
    assert values[250] == 5
    asked = len(sim.received) - before
    # the range (one query), 300-552 refused, then 552 alone and about log2(253) halvings
    # to 399, 300-399 read, 400 asked again; below it 1-199 (one query)
    assert asked <= 16, asked
