"""Property: any robot data saves, loads back equal, and saves again byte for byte."""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
from datetime import time
from pathlib import Path

import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from harlsync.families.harl_u2.layout import render_program
from harlsync.families.harl_u2.model import (
    MAX_STEP_DATA,
    OFFSET_TABLE_COUNT,
    PARAMETER_NAMES,
    Config,
    OffsetTable,
    Parameters,
    ProgramArea,
    ProgramType,
    RobotData,
    Step,
)
from harlsync.link import SerialSettings
from harlsync.project import (
    DAYS,
    Project,
    Robot,
    Window,
    load_project,
    migrate_project,
    save_project,
    validate_project,
)

EXAMPLE = Path(__file__).resolve().parent.parent / "projects" / "pick-and-place"
#: The example project as format 1 wrote it (steps keyed by number), kept as it was.
FORMAT_1 = Path(__file__).resolve().parent / "fixtures" / "format-1" / "pick-and-place"

# Tokens YAML would misread if they were not quoted, or that look like numbers.
TRICKY = [
    "0012",
    "1.50",
    "-0",
    "+7",
    "1e5",
    ".5",
    "1.",
    "0x1F",
    "0o17",
    ".inf",
    ".NaN",
    "true",
    "FALSE",
    "null",
    "~",
    "-",
    "--",
    "---",
    "...",
    "#",
    "a#b",
    "'",
    '"',
    ":",
    "a:",
    "?",
    "*x",
    "&y",
    "!t",
    "!!str",
    "%",
    "@",
    "`",
    "[",
    "]",
    "{",
    "}",
    ",",
    "|",
    ">",
    "=",
    "<<",
    "\\",
]
token = st.one_of(
    st.text(st.characters(min_codepoint=0x21, max_codepoint=0x7E), min_size=1, max_size=6),
    st.sampled_from(TRICKY),
)
step = st.builds(
    lambda command, data: Step(command, tuple(data)),
    token,
    st.lists(token, max_size=MAX_STEP_DATA),
)
two_decimals = st.integers(-999_999, 999_999).map(
    lambda n: f"{'-' if n < 0 else ''}{abs(n) // 100}.{abs(n) % 100:02d}"
)
# M and F as a controller gives them back, unpadded: the one form validate accepts.
code = st.integers(0, 99).map(str)
table = st.builds(OffsetTable, *[two_decimals] * 6, code, code)
timer = st.integers(0, 999).map(lambda n: f"{n // 100}.{n % 100:02d}")
register = st.integers(0, 9999).map(lambda n: f"{n:04d}")
area = st.builds(ProgramArea, st.integers(0, 3), st.integers(0, 8))
config = st.builds(
    Config,
    start=st.builds(ProgramArea, st.integers(0, 1), st.integers(0, 8)),
    main=area,
    sub=area,
    hand=area,
    timers=st.integers(0, 5),
    memory_bits=st.integers(0, 256),
    registers=st.integers(0, 5),
)
text = st.text(
    st.characters(blacklist_categories=("Cs", "Cc", "Co", "Cn", "Zl", "Zp")),
    min_size=1,
    max_size=20,
)


@st.composite
def robot_data(draw: st.DrawFn) -> RobotData:
    cfg = draw(config)
    programs = {}
    for key in cfg.programs():
        steps = cfg.area(key[0]).steps
        numbers = draw(st.sets(st.integers(0, steps - 1))) if steps else set()
        programs[key] = {n: draw(step) for n in sorted(numbers)}
    tables = draw(st.dictionaries(st.integers(0, OFFSET_TABLE_COUNT - 1), table, max_size=5))
    keep = draw(st.booleans())
    return RobotData(
        version=draw(token),
        config=cfg,
        # The first parameter leads the LNE reply: validate refuses one beginning with a
        # letter (E reads as an error status, any other as a command never sent).
        parameters=Parameters(
            draw(token.filter(lambda t: not t[:1].isalpha())),
            *draw(st.lists(token, min_size=12, max_size=12)),
        ),
        programs=programs,
        offsets={n: tables.get(n, OffsetTable()) for n in range(OFFSET_TABLE_COUNT)},
        timers={n: draw(timer) for n in range(cfg.timers)},
        registers={n: draw(register) for n in range(cfg.registers)} if keep else None,
    )


window = st.builds(
    Window,
    st.lists(st.sampled_from(DAYS), min_size=1, unique=True).map(tuple),
    st.builds(time, st.integers(0, 23), st.integers(0, 59)),
    st.builds(time, st.integers(0, 23), st.integers(0, 59)),
)
serial = st.builds(
    SerialSettings,
    baudrate=st.sampled_from([1200, 9600, 19200, 115200]),
    bytesize=st.sampled_from([7, 8]),
    parity=st.sampled_from(["N", "E", "O"]),
    stopbits=st.sampled_from([1, 2]),
    rtscts=st.booleans(),
    timeout=st.floats(0.001, 60),
    retries=st.integers(0, 10),
)


@st.composite
def projects(draw: st.DrawFn) -> Project:
    data = draw(robot_data())
    robot = Robot(
        name=draw(text),
        port=draw(st.text(st.characters(min_codepoint=0x21, max_codepoint=0x7E), min_size=1)),
        station=draw(st.integers(1, 99)),
        serial=draw(serial),
        windows=draw(st.lists(window, max_size=2)),
        keep_registers=data.registers is not None,
        description=draw(st.none() | text),
    )
    return Project(Path("."), robot, data)


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@settings(max_examples=examples(30))
@given(projects())
def test_any_project_saves_loads_equal_and_saves_byte_identical(project: Project) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        first, second = Path(tmp, "first"), Path(tmp, "second")
        save_project(first, project)
        loaded = load_project(first)
        assert loaded.data == project.data
        assert loaded.robot == project.robot
        save_project(second, loaded)
        assert _files(second) == _files(first)
        assert save_project(first, loaded) == []


def test_steps_are_a_list_in_step_order_an_empty_one_null_trailing_ones_left_out() -> None:
    # Format 2 (issue 23): a step inserted or deleted renumbers nothing in the file.
    steps = {0: Step.parse("MOVE P010 S50"), 1: Step(), 3: Step.parse("END"), 7: Step()}
    text = render_program((ProgramType.MAIN, 2), steps)
    assert text.splitlines()[1:] == [
        "format: 2",
        "type: MAIN",
        "number: 2",
        "steps:",
        "  - MOVE P010 S50",
        "  - null",
        "  - null",
        "  - END",
    ]
    assert render_program((ProgramType.START, 0), {}).endswith(
        "type: START\nnumber: 0\nsteps: []\n"
    )


@pytest.mark.parametrize("empty", ["null", "~", "", "NULL"])
def test_an_empty_step_may_be_written_as_any_yaml_null(empty: str, tmp_path: Path) -> None:
    root = tmp_path / "cell"
    shutil.copytree(EXAMPLE, root)
    path = root / "programs" / "main-00.yaml"
    text = path.read_text(encoding="utf-8")
    path.write_text(text.replace("  - WAIT DI02 ON\n", f"  -{' ' * bool(empty)}{empty}\n"))
    steps = load_project(root).data.programs[(ProgramType.MAIN, 0)]
    assert 2 not in steps
    assert steps[3] == Step.parse("MOVE P002 S30")


def test_a_format_1_project_loads_to_the_same_data_and_saves_as_format_2_byte_exactly(
    tmp_path: Path,
) -> None:
    # The example project as harlsync wrote it in format 1, before issue 23.
    root = tmp_path / "old"
    shutil.copytree(FORMAT_1, root)
    old = load_project(root)
    # Format 1 has no record of where the offset tables end (issue 29): a pull adds it.
    assert old.data == dataclasses.replace(load_project(EXAMPLE).data, offset_end=None)
    written = save_project(root, old)
    assert "programs/main-00.yaml" in written and "robot.yaml" not in written
    # Every file it rewrote is the one a pull of the same robot writes today, byte
    # for byte, but for that record; robot.yaml is a person's and is never rewritten
    # (format 1 still loads).
    for name in written:
        today = (EXAMPLE / name).read_bytes()
        if name == "controller.yaml":
            today = b"".join(
                line for line in today.splitlines(True) if not line.startswith(b"offset_tables:")
            )
        assert (root / name).read_bytes() == today, name
    assert (root / "robot.yaml").read_bytes() == (FORMAT_1 / "robot.yaml").read_bytes()
    # ... and from then on the round trip is unchanged: the same data, no rewrite.
    again = load_project(root)
    assert again.data == old.data
    assert save_project(root, again) == []


def test_migrate_project_rewrites_a_format_1_project_without_a_robot(tmp_path: Path) -> None:
    root = tmp_path / "old"
    shutil.copytree(FORMAT_1, root)
    written = migrate_project(root)
    assert "programs/start.yaml" in written
    assert (root / "programs/start.yaml").read_bytes() == (
        EXAMPLE / "programs/start.yaml"
    ).read_bytes()
    assert migrate_project(root) == []  # a format-2 project: nothing to do


def test_a_format_1_files_issues_name_the_line_the_step_is_written_on(tmp_path: Path) -> None:
    root = tmp_path / "old"
    shutil.copytree(FORMAT_1, root)
    path = root / "programs" / "sub-00.yaml"
    path.write_text(path.read_text(encoding="utf-8").replace("  5: END", "  5: 17"))
    assert validate_project(root) == [
        (
            "programs/sub-00.yaml:11: steps.5: 17 is not text or nothing (allowed: a command and "
            "at most 4 data items, printable ASCII tokens separated by single spaces, or null "
            "for an empty step)"
        )
    ]


def test_parameter_names_are_the_yaml_keys() -> None:
    project = Project(
        Path("."),
        Robot("r", "COM3"),
        RobotData(
            version="5.00",
            config=Config(
                ProgramArea(0, 0), ProgramArea(0, 0), ProgramArea(0, 0), ProgramArea(0, 0), 0, 0, 0
            ),
            parameters=Parameters(*[str(n) for n in range(13)]),
            offsets={n: OffsetTable() for n in range(OFFSET_TABLE_COUNT)},
        ),
    )
    with tempfile.TemporaryDirectory() as tmp:
        save_project(tmp, project)
        lines = Path(tmp, "parameters.yaml").read_text().splitlines()
    assert lines[2:] == [f"{name}: {n}" for n, (name, _) in enumerate(PARAMETER_NAMES)]


def test_libyaml_and_pure_python_parsing_agree_on_data_lines_and_duplicates(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from harlsync.project import yamlio

    example = Path(__file__).resolve().parent.parent / "projects" / "pick-and-place"
    sources = [p.read_text(encoding="utf-8") for p in sorted(example.rglob("*.yaml"))]
    sources += [
        "a: 0012\nb: 1.50\nc: '0012'\nd: 22:00\ne: [1, x, true, null, ~, .inf, 0x1F]\n",
        "steps:\n  3: A\n  03: B\n  4: 'a #b'\n  5:\n    - x\n    - {y: 1}\n",
        "# only a comment\n",
        "",
    ]
    fast = [yamlio.parse(s) for s in sources]
    monkeypatch.setattr(yamlio, "_FastLoader", None)
    pure = [yamlio.parse(s) for s in sources]
    for a, b in zip(fast, pure):
        assert (a.data, a.lines, a.duplicates) == (b.data, b.lines, b.duplicates)
        assert repr(a.data) == repr(b.data)  # same Number texts
