"""Validation of project files: every kind of bad input names its file, line and field.

Each test edits a copy of projects/pick-and-place.  Line numbers there: timers.yaml
and offsets.yaml hold timer/table n on line 4 + n, program files step n on line
6 + n (when steps are numbered from 0 without gaps).
"""

from __future__ import annotations

import re
import shutil
from datetime import datetime, time
from pathlib import Path

import pytest

from harlsync.cli import main
from harlsync.errors import FrameError, ProjectFormatError, ProjectInvalid
from harlsync.families.harl_u2.protocol import FrameDecoder, encode_frame
from harlsync.link import SerialSettings
from harlsync.project import (
    Window,
    load_project,
    load_robot,
    save_project,
    validate_project,
)

EXAMPLE = Path(__file__).resolve().parents[3] / "projects" / "pick-and-place"


@pytest.fixture
def root(tmp_path: Path) -> Path:
    target = tmp_path / "pick-and-place"
    shutil.copytree(EXAMPLE, target)
    return target


#: The example project as format 1 wrote it (steps keyed by number).
FORMAT_1 = Path(__file__).resolve().parents[2] / "fixtures" / "format-1" / "pick-and-place"


@pytest.fixture
def root1(tmp_path: Path) -> Path:
    target = tmp_path / "format-1"
    shutil.copytree(FORMAT_1, target)
    return target


def edit(root: Path, name: str, old: str, new: str) -> None:
    path = root / name
    text = path.read_text(encoding="utf-8")
    assert old in text, f"{old!r} not in {name}"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")


def only_issue(root: Path) -> str:
    issues = validate_project(root)
    assert len(issues) == 1, issues
    return issues[0]


def test_a_yaml_syntax_error_names_file_and_line_and_other_files_are_still_checked(
    root: Path,
) -> None:
    edit(root, "timers.yaml", "  3: 1.50", "  3: [1.50")
    edit(root, "programs/main-00.yaml", "type: MAIN", "type: MAIN\ntype: SUB")
    issues = validate_project(root)
    assert issues[0].startswith("timers.yaml:8: YAML syntax error: ")
    assert issues[1] == "programs/main-00.yaml:4: type: written twice (lines 3 and 4)"
    assert len(issues) == 2
    with pytest.raises(ProjectFormatError, match=r"^timers\.yaml:8: YAML syntax error"):
        load_project(root)


def test_a_value_of_the_wrong_type_is_reported(root: Path) -> None:
    edit(root, "timers.yaml", "  4: 0.05", "  4: abc")
    edit(root, "robot.yaml", "  station: 1", "  station: one")
    edit(root, "programs/sub-00.yaml", "  - END", "  - 17")
    assert validate_project(root) == [
        "robot.yaml:7: connection.station: 'one' is not an integer (allowed: 1-99)",
        "timers.yaml:8: timers.4: 'abc' is not a number (allowed: 0.00-9.99, two decimals)",
        (
            "programs/sub-00.yaml:11: steps.5: 17 is not text or nothing (allowed: a command and at most 4 "
            "data items, printable ASCII tokens separated by single spaces, or null for an "
            "empty step)"
        ),
    ]
    with pytest.raises(ProjectInvalid) as caught:
        load_project(root)
    assert len(caught.value.issues) == 3


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        ("  3: 1.50", "  3: 12.5", "timers.yaml:7: timers.3: 12.5 is out of range"),
        ("  3: 1.50", "  3: -0.01", "timers.yaml:7: timers.3: -0.01 is out of range"),
        ("  3: 1.50", "  3: 1.5", "timers.yaml:7: timers.3: 1.5 is not allowed"),
        ("  3: 1.50", "  3: 1.500", "timers.yaml:7: timers.3: 1.500 is not allowed"),
    ],
)
def test_a_timer_out_of_range_or_without_two_decimals_is_reported(
    root: Path, old: str, new: str, expected: str
) -> None:
    edit(root, "timers.yaml", old, new)
    assert only_issue(root) == expected + " (allowed: 0.00-9.99, two decimals)"


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (
            "x: 120.50",
            "x: 10000.00",
            (
                "offsets.yaml:11: tables.7.x: 10000.00 is out of range "
                "(allowed: -9999.99..9999.99, two decimals)"
            ),
        ),
        (
            "x: 120.50",
            "x: 120.5",
            (
                "offsets.yaml:11: tables.7.x: 120.5 is not allowed "
                "(allowed: -9999.99..9999.99, two decimals)"
            ),
        ),
        (
            "y: -35.00",
            "y: -10000.00",
            (
                "offsets.yaml:11: tables.7.y: -10000.00 is out of range "
                "(allowed: -9999.99..9999.99, two decimals)"
            ),
        ),
        (
            "m: 0, f: 3}",
            "m: 100, f: 3}",
            "offsets.yaml:11: tables.7.m: 100 is out of range (allowed: 0-99)",
        ),
        (
            "m: 0, f: 3}",
            "m: 0, f: -1}",
            "offsets.yaml:11: tables.7.f: -1 is out of range (allowed: 0-99)",
        ),
        (
            "m: 0, f: 3}",
            "m: 0, f: 3.0}",
            "offsets.yaml:11: tables.7.f: 3.0 is not an integer (allowed: 0-99)",
        ),
    ],
)
def test_an_offset_out_of_range_is_reported(root: Path, old: str, new: str, expected: str) -> None:
    edit(root, "offsets.yaml", old, new)
    assert only_issue(root) == expected


def longest_payload(station: int) -> int:
    """The longest payload the link's frame decoder takes from ``station``, found by
    feeding it frames one character longer each time (not from the profile's arithmetic)."""
    length = 0
    while True:
        decoder = FrameDecoder()
        decoder.feed(encode_frame(station, "1" * (length + 1)))
        try:
            if decoder.next_frame() is None:
                return length
        except FrameError:
            return length
        length += 1


#: The longest step text MAIN program 0 step 1 can hold: its SNM request (longer
#: than the LNM reply) must fit a frame to the widest station number, 99.
LONGEST_STEP = longest_payload(99) - len("SNM 0 1 ")


@pytest.mark.parametrize("extra", [0, 1, 400])
def test_issue_11_a_step_longer_than_a_frame_carries_is_refused_saying_how_long_it_may_be(
    root: Path, extra: int
) -> None:
    # Issue 11: such a step passed validate; once written it could never be read back.
    text = "MOVE P" + "1" * (LONGEST_STEP + extra - len("MOVE P"))
    edit(root, "programs/main-00.yaml", "  - MOVE P001 S80", f"  - {text}")
    if extra == 0:
        assert validate_project(root) == []
        return
    assert only_issue(root) == (
        f"programs/main-00.yaml:7: steps.1: {len(text)} characters are more than a frame "
        f"carries (allowed: at most {LONGEST_STEP} in this step, so that its SNM request "
        "and the LNM reply fit the frame limit of 512 bytes)"
    )


def test_issue_11_parameters_longer_together_than_a_frame_carries_are_refused_at_the_longest(
    root: Path,
) -> None:
    room = longest_payload(99) - len("SNE ")
    others = len("80 1 0 10.00 10.00 20.00 20.00 30.00 30.00 50 0 0.00 0") - len("0.00")
    edit(root, "parameters.yaml", "z_stop_pos: 0.00", "z_stop_pos: " + "9" * (room - others))
    assert validate_project(root) == []
    edit(root, "parameters.yaml", "z_stop_pos: 9", "z_stop_pos: 99")
    assert only_issue(root) == (
        f"parameters.yaml:14: z_stop_pos: the 13 parameters are {room + 1} characters with "
        f"their spaces, more than a frame carries (allowed: at most {room} together, so "
        "that the SNE request and the LNE reply fit the frame limit of 512 bytes)"
    )


@pytest.mark.parametrize("value", ["E12", "E", "Ex"])
def test_issue_11_a_parameter_the_controller_would_echo_as_an_error_status_is_refused(
    root: Path, value: str
) -> None:
    # Issue 11: the LNE reply begins with PULL LIMIT; one beginning with E is read as
    # "E" + status, so once pushed the robot could never be pulled again.
    edit(root, "parameters.yaml", "pull_limit: 80", f"pull_limit: {value}")
    assert only_issue(root) == (
        f"parameters.yaml:3: pull_limit: {value!r} would begin the LNE reply with 'E', "
        "which reads as an error status: the robot could not be read again (allowed: one "
        "token not beginning with 'E')"
    )


@pytest.mark.parametrize("value", ["e12", "1E", "x", "-5", "E12"])
def test_issue_11_only_the_first_parameter_leads_the_reply_so_only_it_may_not_begin_with_e(
    root: Path, value: str
) -> None:
    edit(root, "parameters.yaml", "arch_motion: 1", f"arch_motion: {value}")
    assert validate_project(root) == []


@pytest.mark.parametrize(
    ("field", "old", "new", "one"),
    [
        ("x", "x: 120.50", "x: 0120.50", "120.50"),
        ("x", "x: 120.50", "x: 00.50", "0.50"),
        ("y", "y: -35.00", "y: -0035.00", "-35.00"),
        ("y", "y: -35.00", "y: -0000.00", "0.00"),
        ("y", "y: -35.00", "y: -0.00", "0.00"),
        ("m", "m: 0, f: 3}", "m: 00, f: 3}", "0"),
        ("f", "m: 0, f: 3}", "m: 0, f: 03}", "3"),
    ],
)
def test_issue_11_an_offset_not_written_as_the_controller_returns_it_is_refused_with_its_one_form(
    root: Path, field: str, old: str, new: str, one: str
) -> None:
    # Issue 11: 0012.50 passed validate; the controller returned 12.50, so every push
    # wrote it again and failed its verification.
    edit(root, "offsets.yaml", old, new)
    written = new.split(f"{field}: ")[1].split(",")[0].rstrip("}")
    assert only_issue(root) == (
        f"offsets.yaml:11: tables.7.{field}: {written} is not written in its one form "
        f"(write {one}: the controller reads it back so, and a push would never converge)"
    )


def with_registers(root: Path) -> None:
    project = load_project(root)
    project.robot.keep_registers = True
    project.data.registers = {n: f"{n * 3:04d}" for n in range(project.data.config.registers)}
    save_project(root, project, rewrite_robot=True)
    assert (root / "registers.yaml").read_text().splitlines()[4] == "  1: 0003"


@pytest.mark.parametrize(
    ("new", "expected"),
    [
        ("  2: 10000", "registers.yaml:6: registers.2: 10000 is out of range"),
        ("  2: -1", "registers.yaml:6: registers.2: -1 is out of range"),
        ("  2: 12", "registers.yaml:6: registers.2: 12 is not allowed"),
        ("  2: 12.00", "registers.yaml:6: registers.2: 12.00 is not an integer"),
    ],
)
def test_a_register_out_of_range_or_not_four_digits_is_reported(
    root: Path, new: str, expected: str
) -> None:
    with_registers(root)
    edit(root, "registers.yaml", "  2: 0006", new)
    assert only_issue(root) == expected + " (allowed: 0000-9999, four digits)"


def test_registers_keep_their_leading_zeros(root: Path) -> None:
    with_registers(root)
    assert load_project(root).data.registers == {n: f"{n * 3:04d}" for n in range(16)}


def test_registers_yaml_is_ignored_and_removed_when_registers_are_not_kept(root: Path) -> None:
    with_registers(root)
    edit(root, "robot.yaml", "keep_registers: true", "keep_registers: false")
    edit(root, "registers.yaml", "  2: 0006", "  2: nonsense")
    assert validate_project(root) == []
    project = load_project(root)
    assert project.data.registers is None
    assert save_project(root, project) == ["registers.yaml"]
    assert not (root / "registers.yaml").exists()


def test_unknown_keys_are_reported_with_the_allowed_ones(root: Path) -> None:
    edit(root, "robot.yaml", "  baudrate: 9600", "  baud: 9600")
    edit(root, "robot.yaml", "keep_registers: false", "keep_registers: false\ncolour: red")
    edit(root, "programs/hand-01.yaml", "type: HAND", "type: HAND\ncomment: open")
    assert validate_project(root) == [
        (
            "robot.yaml:8: connection.baud: unknown key (allowed: port, station, baudrate, "
            "bytesize, parity, stopbits, rtscts, timeout, retries)"
        ),
        (
            "robot.yaml:20: colour: unknown key (allowed: format, family, name, description, connection, "
            "maintenance_windows, keep_registers, offset_tables, no_such_table)"
        ),
        "programs/hand-01.yaml:4: comment: unknown key (allowed: format, type, number, steps)",
    ]


def test_a_missing_required_key_is_reported(root: Path) -> None:
    edit(root, "robot.yaml", "  port: sim://projects/pick-and-place\n", "")
    assert only_issue(root) == "robot.yaml:5: connection.port: is missing"


def test_a_step_outside_the_configured_steps_is_reported(root: Path) -> None:
    edit(root, "programs/hand-02.yaml", "  - END", "  - END" + "\n  - null" * 13 + "\n  - END")
    assert only_issue(root) == (
        "programs/hand-02.yaml:22: steps.16: step 16 is outside the configuration "
        "(allowed: 0-15, controller.yaml programs.hand.steps)"
    )


def test_a_program_number_outside_the_configuration_is_reported(root: Path) -> None:
    (root / "programs" / "main-04.yaml").write_text(
        "format: 1\ntype: MAIN\nnumber: 4\nsteps:\n  0: END\n", encoding="utf-8"
    )
    assert only_issue(root) == (
        "programs/main-04.yaml:3: number: MAIN program 4 is outside the configuration "
        "(allowed: 0-3, controller.yaml programs.main.count)"
    )


def test_program_files_for_a_type_the_configuration_does_not_have_are_reported(root: Path) -> None:
    edit(root, "controller.yaml", "hand: {count: 4, steps: 16}", "hand: {count: 0, steps: 0}")
    assert validate_project(root) == [
        f"programs/hand-0{n}.yaml:4: number: HAND program {n} is outside the configuration "
        "(allowed: none, controller.yaml programs.hand.count)"
        for n in range(4)
    ]


def test_a_program_file_whose_content_does_not_match_its_name_is_reported(root: Path) -> None:
    edit(root, "programs/sub-02.yaml", "type: SUB\nnumber: 2", "type: MAIN\nnumber: 1")
    assert validate_project(root) == [
        "programs/sub-02.yaml:3: type: 'MAIN' does not match the file name (allowed: SUB)",
        "programs/sub-02.yaml:4: number: 1 does not match the file name (allowed: 2)",
    ]


def test_a_yaml_file_in_programs_with_another_name_is_reported(root: Path) -> None:
    (root / "programs" / "main-4.yaml").write_text("format: 1\n", encoding="utf-8")
    assert only_issue(root).startswith("programs/main-4.yaml:1: not a program file name")


def test_a_step_written_twice_in_format_1_is_reported_with_both_lines(root1: Path) -> None:
    root = root1
    edit(root, "programs/main-01.yaml", "  5: MOVE P010 S50", "  5: MOVE P010 S50\n  3: HAND H02")
    assert only_issue(root) == "programs/main-01.yaml:12: steps.3: written twice (lines 9 and 12)"
    with pytest.raises(ProjectInvalid):
        load_project(root)


@pytest.mark.parametrize(
    ("key", "shown"), [("-1", "'-1'"), ("'07'", "'07'"), ("1.5", "'1.5'"), ("10000", "'10000'")]
)
def test_issue_34_item_7_a_bad_step_key_in_format_1_is_named_with_its_line(
    root1: Path, key: str, shown: str
) -> None:
    edit(root1, "programs/main-00.yaml", "  2: WAIT DI02 ON", f"  {key}: WAIT DI02 ON")
    edit(root1, "programs/main-00.yaml", "  5: TIMER T00", "  5x: TIMER T00")
    plain = key.strip("'")
    assert validate_project(root1) == [
        (
            f"programs/main-00.yaml:8: steps.{plain}: {shown} is not a step number "
            "(allowed: 0-9999, written without sign, point or leading zero)"
        ),
        (
            "programs/main-00.yaml:11: steps.5x: '5x' is not a step number "
            "(allowed: 0-9999, written without sign, point or leading zero)"
        ),
    ]
    with pytest.raises(ProjectInvalid) as caught:
        load_project(root1)
    assert "programs/main-00.yaml:8: steps." in str(caught.value)


def test_a_file_in_a_newer_format_is_refused_and_never_rewritten(root: Path) -> None:
    edit(root, "programs/main-00.yaml", "format: 2", "format: 3")
    edit(root, "programs/main-00.yaml", "type: MAIN", "type: MAIN\nfuture: feature")
    message = (
        "programs/main-00.yaml:2: format 3 is newer than this harlsync understands (2): "
        "upgrade harlsync"
    )
    assert validate_project(root) == [message]
    with pytest.raises(ProjectFormatError) as caught:
        load_project(root)
    assert str(caught.value) == message
    before = (root / "programs" / "main-00.yaml").read_bytes()
    pulled = load_project(EXAMPLE)  # e.g. a pull that read the robot
    with pytest.raises(ProjectFormatError, match="not overwritten"):
        save_project(root, pulled)
    assert (root / "programs" / "main-00.yaml").read_bytes() == before


def test_an_unknown_older_format_is_reported(root: Path) -> None:
    edit(root, "parameters.yaml", "format: 2", "format: 0")
    assert only_issue(root) == "parameters.yaml:2: format: 0 is not a known format (allowed: 1-2)"


def test_a_missing_program_file_is_a_validation_error(root: Path) -> None:
    (root / "programs" / "sub-02.yaml").unlink()
    message = (
        "controller.yaml:7: programs.sub.count: 4 SUB programs configured, but "
        "programs/sub-02.yaml is missing (an empty program is written `steps: []`)"
    )
    assert validate_project(root) == [message]
    with pytest.raises(ProjectInvalid) as caught:
        load_project(root)
    assert caught.value.issues == [message]


def test_a_missing_project_file_makes_the_project_unreadable(root: Path) -> None:
    (root / "timers.yaml").unlink()
    assert validate_project(root) == ["timers.yaml: missing"]
    with pytest.raises(ProjectFormatError, match="timers.yaml: missing"):
        load_project(root)


def test_timers_must_match_the_configured_count(root: Path) -> None:
    edit(root, "timers.yaml", "  15: 0.00\n", "  16: 0.00\n")
    assert validate_project(root) == [
        "timers.yaml:3: timers: timer 15 missing (allowed: every timer 0-15)",
        "timers.yaml:19: timers.16: timer 16 is outside the configuration (allowed: 0-15)",
    ]


def test_every_offset_table_must_be_present_and_numbered_0_to_99(root: Path) -> None:
    edit(root, "offsets.yaml", "  9: {", "  100: {")
    assert validate_project(root) == [
        (
            "offsets.yaml:3: tables: table 9 missing "
            "(allowed: every table 0-99, robot.yaml offset_tables)"
        ),
        (
            "offsets.yaml:13: tables.100: table 100 is outside the configuration "
            "(allowed: 0-99, robot.yaml offset_tables)"
        ),
    ]


def test_a_step_with_five_data_items_or_a_double_space_is_reported(root: Path) -> None:
    edit(root, "programs/start.yaml", "  - CALL M00", "  - CALL M00 A B C D")
    edit(root, "programs/start.yaml", "  - CALL M01", "  - CALL  M01")
    allowed = (
        "(allowed: a command and at most 4 data items, printable ASCII tokens separated by "
        "single spaces, or null for an empty step)"
    )
    assert validate_project(root) == [
        f"programs/start.yaml:8: steps.2: 'CALL M00 A B C D' is not allowed {allowed}",
        f"programs/start.yaml:10: steps.4: 'CALL  M01' is not allowed {allowed}",
    ]


def test_a_bad_step_number_and_a_bad_step_among_valid_ones_are_each_reported_issue_7(
    root: Path,
) -> None:
    # The schema check passes a whole mapping at once while every key and value
    # is valid (issue 7); one bad one must still be found and worded as before.
    edit(root, "programs/start.yaml", "  - JUMP 7", "  - {JUMP: 7}")
    edit(root, "programs/start.yaml", "  - CALLS S02", "  - CALLS\tS02")
    allowed = (
        "(allowed: a command and at most 4 data items, printable ASCII tokens separated by "
        "single spaces, or null for an empty step)"
    )
    assert validate_project(root) == [
        f"programs/start.yaml:11: steps.5: a mapping is not text or nothing {allowed}",
        f"programs/start.yaml:15: steps.9: 'CALLS\\tS02' is not allowed {allowed}",
    ]


def test_every_issue_of_every_file_is_reported_in_one_run(root: Path) -> None:
    edit(root, "robot.yaml", "  parity: N", "  parity: X")
    edit(root, "robot.yaml", 'start: "22:00"', "start: 25:00")
    edit(root, "controller.yaml", "memory_bits: 128", "memory_bits: many")
    edit(root, "parameters.yaml", "pull_rate: 50", "pull_rate: 'a b'")
    edit(root, "programs/main-02.yaml", "steps:", "steps: [")
    (root / "programs" / "hand-03.yaml").unlink()
    issues = validate_project(root)
    assert issues == [
        "robot.yaml:10: connection.parity: 'X' is not allowed (allowed: N, E, O)",
        (
            "robot.yaml:17: maintenance_windows.0.start: '25:00' is not allowed "
            "(allowed: HH:MM, 00:00-23:59)"
        ),
        # memory_bits' schema error does not hide the cross-file check of the HAND
        # programs (issue 22 item 3): only controller.yaml's memory_bits is unsound
        (
            "controller.yaml:8: programs.hand.count: 4 HAND programs configured, but "
            "programs/hand-03.yaml is missing (an empty program is written `steps: []`)"
        ),
        "controller.yaml:10: memory_bits: 'many' is not an integer (allowed: 0-9999)",
        (
            "parameters.yaml:12: pull_rate: 'a b' is not allowed "
            "(allowed: one token: printable ASCII without spaces)"
        ),
        issues[5],
    ]
    assert issues[5].startswith("programs/main-02.yaml:6: YAML syntax error")


def test_a_path_that_is_not_a_directory_cannot_be_validated(tmp_path: Path) -> None:
    with pytest.raises(ProjectFormatError, match="not a project directory"):
        validate_project(tmp_path / "nowhere")


def test_issue_14_a_directory_without_robot_yaml_is_named_as_not_a_project(tmp_path: Path) -> None:
    with pytest.raises(
        ProjectFormatError,
        match=(
            rf"^{re.escape(str(tmp_path))}: not a robot project \(no robot.yaml\); a first "
            r"'harlsync pull DIR --port URL' makes one$"
        ),
    ):
        validate_project(tmp_path)


def test_a_project_missing_its_other_files_is_reported_file_by_file(tmp_path: Path) -> None:
    shutil.copy(EXAMPLE / "robot.yaml", tmp_path / "robot.yaml")
    assert validate_project(tmp_path) == [
        "controller.yaml: missing",
        "parameters.yaml: missing",
        "offsets.yaml: missing",
        "timers.yaml: missing",
    ]


def test_load_robot_needs_only_robot_yaml(tmp_path: Path) -> None:
    shutil.copy(EXAMPLE / "robot.yaml", tmp_path / "robot.yaml")
    robot = load_robot(tmp_path)
    assert (robot.name, robot.port, robot.station) == (
        "pick-and-place",
        "sim://projects/pick-and-place",
        1,
    )
    assert robot.serial.baudrate == 9600 and robot.serial.timeout == 1.0


def test_connection_settings_left_out_take_the_profile_defaults(tmp_path: Path) -> None:
    (tmp_path / "robot.yaml").write_text(
        "format: 1\nname: r\nconnection:\n  port: COM3\n", encoding="utf-8"
    )
    robot = load_robot(tmp_path)
    assert robot.station == 1 and robot.windows == [] and not robot.keep_registers
    assert robot.serial == SerialSettings()  # the profile's defaults
    assert robot.in_window(datetime(2026, 1, 1, 12, 0))


def test_save_refuses_invalid_data_before_writing_anything(root: Path) -> None:
    project = load_project(root)
    project.data.timers[3] = "12.5"
    before = {p: p.read_bytes() for p in root.rglob("*") if p.is_file()}
    with pytest.raises(ProjectInvalid) as caught:
        save_project(root, project)
    assert caught.value.issues == [
        "timers.yaml:7: timers.3: 12.5 is out of range (allowed: 0.00-9.99, two decimals)"
    ]
    assert {p: p.read_bytes() for p in root.rglob("*") if p.is_file()} == before


def test_windows_that_cross_midnight_belong_to_the_day_they_open() -> None:
    night = Window(("fri",), time(22, 0), time(6, 0))
    assert night.contains(datetime(2026, 3, 6, 22, 0))  # Friday 22:00
    assert night.contains(datetime(2026, 3, 7, 5, 59))  # Saturday 05:59
    assert not night.contains(datetime(2026, 3, 7, 22, 0))  # Saturday 22:00
    assert not night.contains(datetime(2026, 3, 6, 5, 0))  # Friday 05:00: Thursday's night
    lunch = Window(("mon", "tue"), time(12, 0), time(12, 30))
    assert lunch.contains(datetime(2026, 3, 3, 12, 29))
    assert not lunch.contains(datetime(2026, 3, 3, 12, 30))
    all_day = Window(("sun",), time(8, 0), time(8, 0))
    assert all_day.contains(datetime(2026, 3, 8, 8, 0)) and all_day.contains(
        datetime(2026, 3, 9, 7, 59)
    )
    assert not all_day.contains(datetime(2026, 3, 9, 8, 0))


def test_an_older_format_is_migrated_on_load_and_written_as_current_on_save(
    root: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from harlsync.families.harl_u2 import layout

    def tables_were_called_offsets(kind: str, data: dict[str, object]) -> dict[str, object]:
        if kind == "offsets":
            data["tables"] = data.pop("offsets")
        return data

    monkeypatch.setitem(layout.MIGRATIONS, 0, tables_were_called_offsets)
    edit(root, "offsets.yaml", "format: 2\ntables:", "format: 0\noffsets:")
    assert validate_project(root) == []
    project = load_project(root)
    assert project.data == load_project(EXAMPLE).data
    assert save_project(root, project) == ["offsets.yaml"]
    assert (root / "offsets.yaml").read_bytes() == (EXAMPLE / "offsets.yaml").read_bytes()


def test_issue_34_item_15_validate_says_in_one_line_what_it_checked_when_the_project_is_valid(
    root: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", str(root)]) == 0
    out, err = capsys.readouterr()
    checked = [p for p in root.rglob("*.yaml") if ".schemas" not in p.relative_to(root).parts]
    assert len(checked) == 18  # robot.yaml, four settings files, thirteen programs
    assert out == (
        f"{root}: valid harl-u2 project: 18 files checked against their schemas and "
        "its own configuration\n"
    )
    assert err == ""
