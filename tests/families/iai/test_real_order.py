"""Issue 20 item 3: the word order of IAI real variables (20FH, p.24) is a profile
choice in robot.yaml, ``controller.real_word_order``: ``upper-first`` (big endian,
the default, as before) or ``lower-first`` (the lower 4 bytes first: X-SEL-J/K
V0.41 or earlier, or Other parameter No. 46 bits 0-3 at 0).  Decoding and
encoding are right both ways, and the simulator serves either order."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import git

from harlsync import cli
from harlsync.families.iai.protocol import (
    Frame,
    read_reals,
    real_from_wire,
    real_to_wire,
    write_reals,
)
from harlsync.families.iai.sim import SimState, Simulator
from harlsync.project import load_project
from harlsync.sim.serve import TcpServer

from .backups import first_backup

STATION = 0x99


def test_the_digests_example_reads_the_same_double_both_ways() -> None:
    # p.24: 0x0123456789ABCDEF is sent '89ABCDEF01234567' in the lower-first format.
    assert real_from_wire("89ABCDEF01234567", "lower-first") == real_from_wire(
        "0123456789ABCDEF", "upper-first"
    )
    # 0.1 is 3FB999999999999A (IEEE 754, written by hand)
    assert real_from_wire("3FB999999999999A") == 0.1
    assert real_from_wire("9999999A3FB99999", "lower-first") == 0.1
    assert real_to_wire(0.1, "lower-first") == "9999999A3FB99999"
    assert real_to_wire(-2.5, "upper-first") == "C004000000000000"
    assert real_to_wire(-2.5, "lower-first") == "00000000C0040000"


def test_the_requests_carry_the_robots_order_and_refuse_an_unknown_one() -> None:
    assert write_reals(300, [0.1], order="lower-first").data == "0012C019999999A3FB99999"
    reply = read_reals(300, 1, order="lower-first")
    assert reply.decode(Frame("#", STATION, 0x20F, "0012C019999999A3FB99999")) == (0.1,)
    with pytest.raises(ValueError, match="real word order 'middle'"):
        read_reals(300, 1, order="middle")


@pytest.mark.parametrize("order", ["upper-first", "lower-first"])
def test_a_controller_of_either_order_is_backed_up_and_pushed_exactly(
    repo: Path, order: str
) -> None:
    state = SimState.generate(4, position_range=(1, 30))
    state.reals = {300: 0.1, 301: -2.5, 302: 1e300}
    state.real_word_order = order
    sim = Simulator({STATION: state})
    server = TcpServer(sim)
    project = repo / "cell"
    try:
        url = server.start()
        first_backup(
            project,
            url,
            last=30,
            controller="  reals: {first: 300, last: 303}\n"
            + (f"  real_word_order: {order}\n" if order == "lower-first" else ""),
            keep_registers=True,
        )
        data = load_project(project).data
        assert data.reals == {300: "0.1", 301: "-2.5", 302: "1e+300", 303: "0.0"}
        text = (project / "robot.yaml").read_text()
        assert ("real_word_order: lower-first" in text) == (order == "lower-first")
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "backup")
        path = project / "variables.yaml"
        path.write_text(path.read_text().replace("303: 0.0", "303: 0.3"))
        git(repo, "commit", "-qam", "a real changed")
        assert cli.main(["push", str(project), "--yes", "--registers"]) == 0
        assert cli.main(["diff", str(project), "--registers"]) == 0
    finally:
        server.stop()
    assert state.reals[303] == 0.3  # the simulator's own value, decoded its own way
    assert not sim.off_list()


def test_the_wrong_order_reads_other_numbers(repo: Path) -> None:
    # Why the setting matters: a lower-first controller read as upper-first.
    state = SimState.generate(4, position_range=(1, 30))
    state.reals = {300: 0.1}
    state.real_word_order = "lower-first"
    sim = Simulator({STATION: state})
    server = TcpServer(sim)
    try:
        url = server.start()
        from harlsync.families.iai.controller import Controller

        c = Controller.from_url(url, STATION, variables={"reals": (300, 300)})
        try:
            assert c.read_reals(300, 300) != {300: "0.1"}
        finally:
            c.close()
    finally:
        server.stop()


def test_an_unknown_word_order_is_one_line_naming_the_field_and_what_is_allowed(
    repo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    server = TcpServer(Simulator({STATION: SimState.generate(4, position_range=(1, 30))}))
    project = repo / "cell"
    try:
        first_backup(project, server.start(), last=30)
    finally:
        server.stop()
    robot = project / "robot.yaml"
    robot.write_text(
        robot.read_text().replace("controller:\n", "controller:\n  real_word_order: middle\n")
    )
    capsys.readouterr()
    assert cli.main(["validate", str(project)]) == 1  # validate: 1 = the project is invalid
    captured = capsys.readouterr()
    err = captured.out + captured.err
    assert "robot.yaml:" in err and "controller.real_word_order" in err
    assert "upper-first, lower-first" in err
