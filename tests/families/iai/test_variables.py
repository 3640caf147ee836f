"""IAI global flags and integer and real variables, kept only when robot.yaml opts in:
variables.yaml round-trips byte for byte, reals keep their double exactly, a
positions-only project is what it was, every bad input is one line naming
file:line and the field, and a plan writes only what changed, in runs that fit."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from harlsync import families
from harlsync.errors import ProjectInvalid
from harlsync.families.iai.catalogue import CATALOGUE, PositionKey, Run, VariableKey, runs
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position, Version, canonical_integer, canonical_real
from harlsync.families.iai.protocol import max_variables_per_write
from harlsync.families.iai.sim import SIM_FAMILY
from harlsync.project import Project, Robot, load_project, save_project, validate_project
from harlsync.sync.items import diff

from .test_project import assert_issue_after_edit

VERSION = Version(0, 0, "12", "34", "0102", "2024-05-01 10:20:30")
TABLE = {1: Position(1, (1, 2, 3), "0.30", "0.30", 100, ("100.000", "-1.000", "0.000"))}
FLAGS = {n: n in (601, 604) for n in range(600, 608)}
INTEGERS = {200: 0, 201: -1000, 202: 2147483647, 203: -2147483648}
REALS = {300: "0.0", 301: "0.1", 302: "-2.5", 303: "1e+300", 304: "5e-324", 305: "-0.0"}


def robot(keep: bool = True) -> Robot:
    robot = families.get("iai").new_robot("cell-9", "sim://nowhere", None)
    robot.options["axes"] = (1, 2, 3)
    if keep:
        robot.keep_registers = True
        robot.options.update(flags=(600, 607), integers=(200, 203), reals=(300, 305))
    return robot


def data(**variables: object) -> IaiData:
    return IaiData(VERSION, dict(TABLE), **variables)  # type: ignore[arg-type]


KEPT = {"flags": FLAGS, "integers": INTEGERS, "reals": REALS}


@pytest.fixture
def project(tmp_path: Path) -> Path:
    path = tmp_path / "cell-9"
    save_project(path, Project(path, robot(), data(**KEPT)))
    return path


def files(path: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(path)): p.read_bytes()
        for p in path.rglob("*")
        if p.is_file() and ".harlsync" not in p.parts
    }


# --- the files ------------------------------------------------------------------------


def test_variables_load_as_saved_and_save_byte_for_byte(project: Path) -> None:
    before = files(project)
    loaded = load_project(project)
    assert loaded.robot.keep_registers
    assert (loaded.data.flags, loaded.data.integers, loaded.data.reals) == (FLAGS, INTEGERS, REALS)
    assert save_project(project, loaded) == []
    assert files(project) == before


def test_variables_are_one_per_line_keyed_by_number_in_exact_text(project: Path) -> None:
    lines = (project / "variables.yaml").read_text().splitlines()
    assert lines[:3] == [
        "# yaml-language-server: $schema=.schemas/variables.schema.json",
        "format: 1",
        "flags:",
    ]
    assert lines[3:] == [
        *(f"  {n}: {'true' if on else 'false'}" for n, on in FLAGS.items()),
        "integers:",
        "  200: 0",
        "  201: -1000",
        "  202: 2147483647",
        "  203: -2147483648",
        "reals:",
        "  300: 0.0",
        "  301: 0.1",
        "  302: -2.5",
        "  303: 1e+300",
        "  304: 5e-324",
        "  305: -0.0",
    ]


def test_robot_yaml_says_keep_registers_and_the_ranges(project: Path) -> None:
    text = (project / "robot.yaml").read_text()
    assert "  flags: {first: 600, last: 607}\n" in text
    assert "  integers: {first: 200, last: 203}\n" in text
    assert "  reals: {first: 300, last: 305}\n" in text
    assert text.endswith("maintenance_windows: []\nkeep_registers: true\n")


#: robot.yaml of a positions-only project, as harlsync wrote it before flags and
#: variables could be kept.
POSITIONS_ONLY_ROBOT = """\
# yaml-language-server: $schema=.schemas/robot.schema.json
format: 1
family: iai
name: cell-9
connection:
  port: sim://nowhere
  station: "99"
  baudrate: 9600
  bytesize: 8
  parity: N
  stopbits: 1
  rtscts: false
  timeout: 0.5
  retries: 3
controller:
  model: TTA
  axes: [1, 2, 3]
  first_position: 1
  last_position: 1000
maintenance_windows: []
"""


def test_a_positions_only_project_holds_the_same_files_as_before(tmp_path: Path) -> None:
    path = tmp_path / "cell-9"
    save_project(path, Project(path, robot(keep=False), data()))
    assert (path / "robot.yaml").read_text() == POSITIONS_ONLY_ROBOT
    assert sorted(p.name for p in path.iterdir() if p.is_file()) == [
        "controller.yaml",
        "positions.yaml",
        "robot.yaml",
    ]
    loaded = load_project(path)
    assert loaded.data == data() and loaded.data.variables() == {}
    assert save_project(path, loaded) == []


def test_a_project_that_does_not_keep_them_ignores_variables_yaml_and_the_next_save_removes_it(
    project: Path,
) -> None:
    path = project / "robot.yaml"
    path.write_text(path.read_text().replace("keep_registers: true", "keep_registers: false"))
    (project / "variables.yaml").write_text("not: [valid")
    loaded = load_project(project)
    assert loaded.data.variables() == {}
    assert save_project(project, loaded) == ["variables.yaml"]
    assert not (project / "variables.yaml").exists()


def test_a_project_that_keeps_them_but_has_no_file_yet_is_valid(project: Path) -> None:
    (project / "variables.yaml").unlink()
    assert validate_project(project) == []
    assert load_project(project).data.variables() == {}


NOT_FINITE = (
    "(allowed: a finite real in its shortest form (0.1, -2.5, 3.0, 1e+300); not .nan "
    "or .inf: a NaN never equals itself, so a diff of it never converges)"
)
BAD = [
    # variables.yaml
    (
        "  201: -1000",
        "  201: 2147483648",
        (
            "variables.yaml:14: integers.201: 2147483648 is out of range (allowed: a whole number, "
            "-2147483648 to 2147483647)"
        ),
    ),
    (
        "  201: -1000",
        "  201: -0001000",
        "variables.yaml:14: integers.201: -0001000 is not written in its one form (write -1000",
    ),
    ("  201: -1000", "  201: 1.5", "variables.yaml:14: integers.201: 1.5 is not an integer"),
    (
        "  301: 0.1",
        "  301: .nan",
        f"variables.yaml:19: reals.301: '.nan' is not a number {NOT_FINITE}",
    ),
    (
        "  301: 0.1",
        "  301: -.inf",
        f"variables.yaml:19: reals.301: '-.inf' is not a number {NOT_FINITE}",
    ),
    ("  301: 0.1", "  301: 1e400", "variables.yaml:19: reals.301: 1e400 is out of range"),
    (
        "  301: 0.1",
        "  301: 0.10",
        (
            "variables.yaml:19: reals.301: 0.10 is not written in its one form (write 0.1: the "
            "controller reads it back so, and a push would never converge)"
        ),
    ),
    (
        "  302: -2.5",
        "  302: 3",
        ("variables.yaml:20: reals.302: 3 is not written in its one form (write 3.0"),
    ),
    ("  300: 0.0", "  300: zero", "variables.yaml:18: reals.300: 'zero' is not a number"),
    (
        "  601: true",
        "  601: yes",
        "variables.yaml:5: flags.601: 'yes' is not true or false (allowed: true, false)",
    ),
    (
        "  607: false",
        "  607: false\n  608: true",
        (
            "variables.yaml:12: flags.608: flag 608 is outside the robot's range (allowed: 600-607, "
            "robot.yaml controller.flags)"
        ),
    ),
    (
        "  203: -2147483648",
        "  203: -2147483648\n  299: 1",
        (
            "variables.yaml:17: integers.299: integer variable 299 is outside the robot's range "
            "(allowed: 200-203, robot.yaml controller.integers)"
        ),
    ),
    (
        "  600: false",
        "  600: false\n  600: true",
        "variables.yaml:5: flags.600: written twice (lines 4 and 5)",
    ),
    (
        "reals:",
        "strings:\n  1: 65\nreals:",
        "variables.yaml:17: strings: unknown key (allowed: format, flags, integers, reals)",
    ),
    # robot.yaml
    (
        "flags: {first: 600, last: 607}",
        "flags: {first: 600, last: 500}",
        (
            "robot.yaml:20: controller.flags.last: 500 is before first 600 (allowed: a number at or "
            "after first)"
        ),
    ),
    (
        "integers: {first: 200, last: 203}",
        "integers: {first: 200, last: 5000}",
        (
            "robot.yaml:21: controller.integers.last: 5000 is out of range (allowed: a variable number, "
            "0-4095)"
        ),
    ),
    (
        "reals: {first: 300, last: 305}",
        "reals: {first: 300}",
        "robot.yaml:22: controller.reals.last: is missing",
    ),
    (
        "keep_registers: true",
        "keep_registers: yes",
        "robot.yaml:24: keep_registers: 'yes' is not true or false (allowed: true, false)",
    ),
]


@pytest.mark.parametrize(("old", "new", "expected"), BAD, ids=[b[2][:48] for b in BAD])
def test_a_bad_variables_file_or_range_names_file_line_field_and_what_is_allowed(
    project: Path, old: str, new: str, expected: str
) -> None:
    assert_issue_after_edit(project, old, new, expected, expected.split(":")[0])


def test_a_nan_read_from_the_controller_is_refused_naming_the_variable(tmp_path: Path) -> None:
    path = tmp_path / "cell-9"
    with pytest.raises(ProjectInvalid) as refused:
        save_project(path, Project(path, robot(), data(reals={300: "nan"}, flags={}, integers={})))
    assert "real variable 300: nan is not kept: a NaN never equals itself" in str(refused.value)
    assert not path.exists()


def test_the_simulator_serves_the_flags_and_variables_of_a_project(project: Path) -> None:
    state = SIM_FAMILY.from_project(project, None).stations[0x99]
    assert state.flags == {601, 604}
    assert state.integers == INTEGERS
    assert {n: repr(v) for n, v in state.reals.items()} == REALS


# --- exact numbers ----------------------------------------------------------------------


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_every_finite_double_has_one_text_that_reads_back_as_the_same_bits(value: float) -> None:
    text = canonical_real(repr(value))
    assert struct.pack(">d", float(text)) == struct.pack(">d", value)
    assert canonical_real(text) == text


@pytest.mark.parametrize(
    ("text", "one"),
    [
        ("0.10", "0.1"),
        ("3", "3.0"),
        ("1e16", "1e+16"),
        ("+.5", "0.5"),
        ("-0", "-0.0"),
        ("1e-400", "0.0"),
    ],
)
def test_a_real_has_one_form(text: str, one: str) -> None:
    assert canonical_real(text) == one


@pytest.mark.parametrize(
    "text", ["nan", ".NaN", "inf", "-.inf", "Infinity", "1e400", "0x10", "1_000", ""]
)
def test_nan_infinity_and_other_texts_are_no_real(text: str) -> None:
    with pytest.raises(ValueError):
        canonical_real(text)


def test_an_integer_has_one_form_within_32_bits() -> None:
    assert canonical_integer("+007") == "7"
    assert canonical_integer("-0") == "0"
    for text in ("2147483648", "-2147483649", "1.0", "0x10"):
        with pytest.raises(ValueError):
            canonical_integer(text)
    assert math.isfinite(float(canonical_real("1.7976931348623157e+308")))


# --- items and plans ----------------------------------------------------------------------


def test_flags_and_variables_are_items_only_when_asked() -> None:
    kept = data(**KEPT)
    assert set(CATALOGUE.items(kept, registers=False)) == {PositionKey("position", 1)}
    items = CATALOGUE.items(kept, registers=True)
    assert items[VariableKey("flag", 601)] is True
    assert items[VariableKey("integer", 201)] == -1000
    assert items[VariableKey("real", 303)] == "1e+300"
    assert len(items) == 1 + len(FLAGS) + len(INTEGERS) + len(REALS)


def test_runs_split_consecutive_numbers_at_the_limit() -> None:
    live = {n: 0 for n in range(10)}
    project = {n: n for n in range(10)}
    found = runs("integers", [7, 1, 2, 3, 5, 4, 9], 3, live, project)
    assert [r for r, _, _ in found] == [
        Run("integers", 1, 3),
        Run("integers", 4, 2),
        Run("integers", 7, 1),
        Run("integers", 9, 1),
    ]
    assert found[1][1:] == ((0, 0), (4, 5))


def test_a_plan_writes_runs_of_changed_variables_and_each_changed_flag_after_them() -> None:
    live = data(**KEPT)
    project = data(
        flags={**FLAGS, 600: True, 605: True},
        integers={**INTEGERS, 201: 5, 202: 6},
        reals={**REALS, 305: "0.0"},
    )
    changes = [(c.key, c.old, c.new) for c in diff(CATALOGUE, live, project, registers=True)]
    shape = CATALOGUE.plan(live, project, changes, registers=True)
    wanted = sorted(shape.wanted, key=lambda w: CATALOGUE.order(w[0]))
    assert [(CATALOGUE.describe(k), old, new) for k, old, new in wanted] == [
        ("integer variables 201-202", (-1000, 2147483647), (5, 6)),
        ("real variable 305", ("-0.0",), ("0.0",)),
        ("flag 600", False, True),
        ("flag 605", False, True),
    ]
    assert shape.unwritable == []
    assert CATALOGUE.summary(changes) == "2 integer variables, 1 real variable, 2 flags"


def test_a_run_of_variables_never_exceeds_the_receive_buffer() -> None:
    limit = max_variables_per_write("XSEL-J", "reals")
    assert 10 + 7 + 16 * limit <= 1023 < 10 + 7 + 16 * (limit + 1)
    reals = {n: "0.0" for n in range(300, 400)}
    live, project = data(reals=reals), data(reals={n: "1.5" for n in reals})
    live.model = project.model = "XSEL-J"
    changes = [(c.key, c.old, c.new) for c in diff(CATALOGUE, live, project, registers=True)]
    shape = CATALOGUE.plan(live, project, changes, registers=True)
    assert [k.size if isinstance(k, Run) else k for k, _, _ in shape.wanted] == [limit, 100 - limit]


def test_a_plan_with_variables_for_a_project_that_does_not_keep_them_is_refused() -> None:
    live = data(**KEPT)
    changes = [(c.key, c.old, c.new) for c in diff(CATALOGUE, live, data(), registers=True)]
    shape = CATALOGUE.plan(live, data(), changes, registers=True)
    assert shape.wanted == []
    assert shape.unwritable == [
        (
            "flags, integers, reals: the project does not keep them; set keep_registers: true in "
            "robot.yaml and pull, or push without --registers"
        )
    ]
