"""``validate`` reports every problem in one run, and refuses what the controller would
refuse (issue 22 item 3): a schema error does not hide the range and cross-file checks
of other items; Epson AccelS/AccelR/SpeedS/SpeedR of 0 or less and a negative weight are
refused by the schema, as the manual's controller refuses them; and a push of a project
that does not validate writes nothing."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import git
from families.epson.sample import sample_data

from harlsync import cli, families
from harlsync.project import Project, save_project, validate_project


@pytest.fixture
def epson(repo: Path) -> Path:
    robot = families.get("epson").new_robot("cell-3", "modbus://127.0.0.1:1", None)
    path = repo / "cell-3"
    save_project(path, Project(path, robot, sample_data()))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "cell-3")
    return path


def replace(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        (
            "3: {accel: 100.123, decel: 200.000}",
            "3: {accel: 0.000, decel: 200.000}",
            "accel_s.3.accel",
        ),
        (
            "3: {accel: 100.123, decel: 200.000}",
            "3: {accel: 1.000, decel: -2.000}",
            "accel_s.3.decel",
        ),
        ("2: {speed: 2000.000,", "2: {speed: 0.000,", "speed_s.2.speed"),
        ("  0: 720.000", "  0: -1.000", "speed_r.0"),
        ("weight: {weight: 2.000,", "weight: {weight: -0.001,", "weight.weight"),
    ],
)
def test_epson_values_the_controller_refuses_are_refused_by_validate(
    epson: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, said: str
) -> None:
    replace(epson / "settings.yaml", old, new)
    assert cli.main(["validate", str(epson)]) == 1
    out = capsys.readouterr().out
    assert f": {said}: " in out and "(allowed: " in out and ("above 0" in out or "0 or more" in out)


def test_a_schema_error_does_not_hide_the_checks_of_the_other_items(epson: Path) -> None:
    settings = epson / "settings.yaml"
    replace(settings, "3: {accel: 100.123, decel: 200.000}", "3: {accel: fast, decel: 200.000}")
    replace(
        settings, "  4: {lower: -100000, upper: 100000}", "  5: {lower: -100000, upper: 100000}"
    )
    said = [str(issue) for issue in validate_project(epson)]
    assert any(": accel_s.3.accel: " in line for line in said), said
    assert any("jrange.5: joint 5 of a 4-axis robot (allowed: 1-4)" in line for line in said), said


def test_a_push_of_a_project_that_does_not_validate_writes_nothing(
    epson: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    replace(epson / "settings.yaml", "  0: 720.000", "  0: 0.000")
    git(epson.parent, "commit", "-qam", "speed_r 0")
    # No controller is listening: a push that tried to connect would say so instead.
    assert cli.main(["push", str(epson), "--yes"]) == 2
    err = capsys.readouterr().err
    assert "speed_r.0" in err and "connect" not in err.lower()


def test_an_iai_schema_error_does_not_hide_the_range_checks_of_the_other_positions(
    repo: Path,
) -> None:
    import re

    from harlsync.families.iai.sim import SimState, Simulator
    from harlsync.sim.protocol_sim import register, unregister
    from harlsync.sync import engine

    url = register(Simulator({0x99: SimState.generate(5, position_range=(1, 20))}))
    try:
        project = repo / "cell-9"
        engine.pull(project, port=url, station=0x99, family="iai")
    finally:
        unregister(url)
    robot = project / "robot.yaml"
    robot.write_text(re.sub(r"last_position: \d+", "last_position: 10", robot.read_text()))
    positions = project / "positions.yaml"
    numbers = [int(n) for n in re.findall(r"(?m)^  (\d+): ", positions.read_text())]
    first = numbers[0]
    positions.write_text(
        re.sub(rf"(?m)^(  {first}: .*acc: )[0-9.]+", r"\g<1>fast", positions.read_text())
    )
    said = [str(issue) for issue in validate_project(project)]
    assert any(f": positions.{first}.acc: 'fast' is not a number" in line for line in said)
    beyond = [n for n in numbers if n > 10]
    assert beyond and all(
        any(f"position {n} is outside the robot's table (allowed: 1-10" in line for line in said)
        for n in beyond
    ), said


# -- HARL-U2: a schema error skips its own item's deeper checks, and nothing else --------

EXAMPLE = Path(__file__).resolve().parents[2] / "projects" / "pick-and-place"
#: A step as long as no frame carries (tests/families/harl_u2/test_project_validation.py words the limit).
TOO_LONG = "MOVE P" + "1" * 600


@pytest.fixture
def harl(tmp_path: Path) -> Path:
    import shutil

    target = tmp_path / "pick-and-place"
    shutil.copytree(EXAMPLE, target)
    return target


def said(root: Path) -> list[str]:
    return [str(issue) for issue in validate_project(root)]


def test_harl_a_bad_step_hides_neither_the_other_steps_nor_the_other_programs(harl: Path) -> None:
    main = harl / "programs" / "main-00.yaml"
    replace(main, "  - OFFSET L00", "  - OFFSET  L00")  # a double space: the schema's
    replace(main, "  - MOVE P001 S80", f"  - {TOO_LONG}")  # same file, the frame's
    replace(harl / "programs" / "main-01.yaml", "steps:\n", f"steps:\n  - {TOO_LONG}\n")
    sub = harl / "programs" / "sub-00.yaml"
    sub.write_text(sub.read_text().rstrip("\n") + "\n" + "  - null\n" * 40 + "  - END\n")
    lines = said(harl)
    assert lines[0].startswith("programs/main-00.yaml:6: steps.0: 'OFFSET  L00' is not allowed")
    assert lines[1].startswith("programs/main-00.yaml:7: steps.1: 606 characters are more than")
    assert lines[2].startswith("programs/main-01.yaml:6: steps.0: 606 characters are more than")
    assert lines[3].startswith("programs/sub-00.yaml:")
    assert (
        "is outside the configuration (allowed: 0-31, controller.yaml programs.sub.steps)"
        in (lines[3])
    )
    assert len(lines) == 4, lines


def test_harl_a_schema_error_in_controller_yaml_keeps_the_checks_its_sound_parts_make(
    harl: Path,
) -> None:
    replace(harl / "controller.yaml", "version: '5.00'", "version: '5 00'")
    replace(
        harl / "controller.yaml", "  sub: {count: 4, steps: 32}", "  sub: {count: four, steps: 32}"
    )
    replace(harl / "timers.yaml", "  3: 1.50", "  3: 1.50\n  99: 1.00")
    (harl / "programs" / "hand-03.yaml").unlink()
    (harl / "programs" / "main-04.yaml").write_text(
        (harl / "programs" / "main-03.yaml").read_text().replace("number: 3", "number: 4")
    )
    assert said(harl) == [
        (
            "controller.yaml:3: version: '5 00' is not allowed (allowed: text without spaces, "
            "e.g. '5.00')"
        ),
        "controller.yaml:7: programs.sub.count: 'four' is not an integer (allowed: 0-100)",
        (
            "controller.yaml:8: programs.hand.count: 4 HAND programs configured, but "
            "programs/hand-03.yaml is missing (an empty program is written `steps: []`)"
        ),
        "timers.yaml:8: timers.99: timer 99 is outside the configuration (allowed: 0-15)",
        (
            "programs/main-04.yaml:4: number: MAIN program 4 is outside the configuration "
            "(allowed: 0-3, controller.yaml programs.main.count)"
        ),
    ]


def test_harl_a_schema_error_in_robot_yaml_keeps_its_offset_tables(harl: Path) -> None:
    robot = harl / "robot.yaml"
    replace(robot, "keep_registers: false", "keep_registers: false\noffset_tables: 101\nbogus: 1")
    table = "{x: 0.00, y: 0.00, z: 0.00, w: 0.00, r: 0.00, c: 0.00, m: 0, f: 0}"
    replace(harl / "offsets.yaml", "  7: ", f"  100: {table}\n  7: ")
    # a project pulled before issue 29 recorded where the tables end: no record here
    replace(harl / "controller.yaml", "offset_tables: {count: 100, no_such_table: E21}\n", "")
    # robot.yaml's count is sound: table 100 is the robot's, not a problem
    assert said(harl) == [
        (
            "robot.yaml:21: bogus: unknown key (allowed: format, family, name, description, "
            "connection, maintenance_windows, keep_registers, offset_tables, no_such_table)"
        )
    ]
    replace(robot, "offset_tables: 101", "offset_tables: many")
    # ... and when the count is what is wrong, the tables are not checked against a guess
    assert [line.split(": ")[1] for line in said(harl)] == ["offset_tables", "bogus"]


def test_harl_a_bad_offset_table_hides_not_the_form_check_of_another(harl: Path) -> None:
    replace(harl / "offsets.yaml", "x: 120.50", "x: fast")  # table 7
    replace(harl / "offsets.yaml", "  0: {x: 0.00,", "  0: {x: 00.00,")
    lines = said(harl)
    assert lines[0].startswith("offsets.yaml:4: tables.0.x: 00.00 is not written in its one form")
    assert lines[1].startswith("offsets.yaml:11: tables.7.x: 'fast' is not a number")
    assert len(lines) == 2, lines


def test_harl_the_parameters_are_checked_when_each_of_them_passes_the_schema(harl: Path) -> None:
    params = harl / "parameters.yaml"
    replace(params, "pull_limit: 80", "pull_limit: E12")
    replace(params, "prg_count: 0", "prg_count: 0\nextra: 1")  # not a parameter
    lines = said(harl)
    assert [line.split(": ")[1] for line in lines] == ["pull_limit", "extra"], lines
    assert "would begin the LNE reply with 'E'" in lines[0]
    # a parameter the schema refuses makes the one SNE write unsound: it alone is said
    replace(params, "pull_rate: 50", "pull_rate: 'a b'")
    assert [line.split(": ")[1] for line in said(harl)] == ["pull_rate", "extra"]


def test_an_epson_point_the_schema_refuses_hides_not_the_checks_of_the_others(epson: Path) -> None:
    points = epson / "points.yaml"
    replace(
        points,
        "u: 0.000, hand: Righty, elbow: Above, wrist: NoFlip",
        "u: 0.000, hand: Sideways, elbow: Above, wrist: NoFlip",
    )  # P0
    replace(points, "  12: {x: 1.000,", "  12: {x: 01.000,")
    replace(points, "  13: {", "  150: {")
    assert said(epson) == [
        "points.yaml:4: points.0.hand: 'Sideways' is not allowed (allowed: Lefty, Righty)",
        (
            "points.yaml:5: points.12.x: 01.000 is not written in its one form (write 1.000: the "
            "controller reads it back so, and a push would never converge)"
        ),
        (
            "points.yaml:6: points.150: P150 is outside the robot's range (allowed: 0-99, robot.yaml "
            "controller.first_point/last_point)"
        ),
    ]


def test_an_iai_variable_the_schema_refuses_hides_not_the_checks_of_the_others(
    tmp_path: Path,
) -> None:
    from families.iai.test_variables import KEPT, data, robot

    path = tmp_path / "cell-9"
    save_project(path, Project(path, robot(), data(**KEPT)))
    variables = path / "variables.yaml"
    replace(variables, "  601: true", "  601: maybe")
    replace(variables, "  201: -1000", "  201: -01000")
    replace(variables, "  300: 0.0", "  399: 0.0")
    lines = said(path)
    assert [line.split(": ")[1] for line in lines] == ["flags.601", "integers.201", "reals.399"]
    assert "is outside the robot's range (allowed: 300-305" in lines[2], lines


@pytest.mark.parametrize(("words", "refused"), [(3, True), (5, True), (6, False), (8, False)])
def test_epson_response_words_fewer_than_the_reads_need_are_refused_by_validate(
    epson: Path, capsys: pytest.CaptureFixture[str], words: int, refused: bool
) -> None:
    replace(epson / "robot.yaml", "response_words: 8", f"response_words: {words}")
    assert cli.main(["validate", str(epson)]) == int(refused)
    out = capsys.readouterr().out.strip().splitlines()
    if refused:
        assert out == [
            (
                f"robot.yaml:17: connection.map.response_words: {words} words are fewer than "
                "harlsync's reads need: 210 (SpeedS speed and depart table 0) answers in 6 "
                "(allowed: 6-8, as many assigned in RC+)"
            )
        ]


# -- a push of a project that does not validate writes nothing, for every family ---------

#: Each family's simulated robot, its project, and two edits (file, pattern, new text):
#: a change a push would write, then a value the controller refuses.
PUSHES: dict[str, tuple[Callable[[], Any], str, list[tuple[str, str, str]]]] = {}


def _harl_sim() -> Any:
    from harlsync.families.harl_u2.model import Config, ProgramArea
    from harlsync.families.harl_u2.sim import SimState, Simulator

    small = Config(
        ProgramArea(1, 8), ProgramArea(2, 12), ProgramArea(2, 8), ProgramArea(1, 6), 4, 16, 4
    )
    return Simulator(SimState.generate(11, small))


def _iai_sim() -> Any:
    from harlsync.families.iai.sim import SimState, Simulator

    return Simulator({0x99: SimState.generate(5, position_range=(1, 20))})


def _epson_sim() -> Any:
    from harlsync.families.epson.sim import SimState, Simulator

    return Simulator(SimState.from_data(sample_data()), execution_time=0.0)


PUSHES["harl-u2"] = (
    _harl_sim,
    "1",
    [
        ("timers.yaml", r"(?m)^  0: \d\.\d\d$", "  0: 1.23"),
        ("timers.yaml", r"(?m)^  1: \d\.\d\d$", "  1: 12.00"),  # 0.00-9.99
    ],
)
PUSHES["iai"] = (
    _iai_sim,
    "99",
    [
        ("positions.yaml", r"(?m)^(  \d+: .*speed: )\d+", r"\g<1>77"),
        ("positions.yaml", r"(?m)^(  \d+: .*acc: )[0-9.]+", r"\g<1>700.00"),  # 0-655.35
    ],
)
PUSHES["epson"] = (
    _epson_sim,
    "1",
    [
        # Weight: the write the issue saw reach the memory card before the refusal
        ("settings.yaml", r"weight: \{weight: 2\.000,", "weight: {weight: 3.000,"),
        ("settings.yaml", r"(?m)^  0: 720\.000$", "  0: 0.000"),  # SpeedR above 0
    ],
)


def _edit(path: Path, pattern: str, new: str) -> None:
    import re

    text, count = re.subn(pattern, new, path.read_text(), count=1)
    assert count == 1, pattern
    path.write_text(text)


@pytest.mark.parametrize("name", list(PUSHES))
def test_a_push_of_a_project_that_does_not_validate_writes_nothing_to_the_robot(
    repo: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    from harlsync.sim.serve import TcpServer

    make, station, (change, refused) = PUSHES[name][0], PUSHES[name][1], PUSHES[name][2]
    sim = make()
    if name == "epson":  # Modbus TCP, its own server
        server: Any = sim.serve()
        url = server.url
    else:
        server = TcpServer(sim)
        url = server.start()
    project = repo / "cell"
    try:
        pull = ["pull", str(project), "--family", name, "--port", url, "--station", station]
        assert cli.main(pull) == 0
        _edit(project / change[0], change[1], change[2])
        fixed = (project / refused[0]).read_text()
        _edit(project / refused[0], refused[1], refused[2])
        git(repo, "add", "-A")
        git(repo, "commit", "-qm", "a change, and a value the controller refuses")
        capsys.readouterr()
        assert cli.main(["push", str(project), "--port", url, "--yes"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err and all("Traceback" not in line for line in err), err
        # the simulator's own record: no write received, none carried out
        assert (sim.writes_received(), sim.writes) == ([], 0)
        # the change alone is written: what the refusal held back was a real write
        (project / refused[0]).write_text(fixed)
        git(repo, "commit", "-qam", "the refused value put back")
        assert cli.main(["push", str(project), "--port", url, "--yes"]) == 0
        assert sim.writes_received() and sim.writes > 0
    finally:
        server.stop()
