"""robot.yaml as its one reader, the project store, reads it before a pull's first
request: a robot.yaml harlsync writes reads back as the robot it wrote, and whatever a
hand edit does to one, the store reads a robot or refuses the file with a
ProjectError (one line), never another exception.

(Issue 32: these were the quick reader's tests, tests/test_robot_quick.py, which
checked it against the store; the quick reader is gone and what they said of the
store stays.)"""

from __future__ import annotations

from dataclasses import replace
from datetime import time
from pathlib import Path
from typing import Literal

import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from harlsync.errors import ProjectError
from harlsync.families.harl_u2.layout import render_robot
from harlsync.project import store
from harlsync.project.robot import DAYS, Robot, Window
from harlsync.settings import SerialSettings

ROOT = Path(__file__).parents[1]


def full(root: Path) -> tuple[str, Robot] | None:
    """The family and robot the store reads, or None when it refuses the file."""
    try:
        family = store.family_of(root)
        return family.name, store.load_robot(root, family)
    except ProjectError:
        return None


def written(tmp_path: Path, text: str) -> Path:
    root = tmp_path / "cell"
    root.mkdir(exist_ok=True)
    (root / "robot.yaml").write_text(text, encoding="utf-8")
    return root


def test_the_example_projects_robot_yaml_is_read_by_the_store() -> None:
    roots = [p.parent for p in sorted((ROOT / "projects").glob("*/robot.yaml"))]
    assert roots
    for root in roots:
        assert full(root) is not None, root


SURROGATES: tuple[Literal["Cs"]] = ("Cs",)
wild = st.text(st.characters(codec="utf-8", exclude_categories=SURROGATES), max_size=12)
#: What people write: letters of any script, digits, punctuation, spaces.
words = st.text(st.characters(codec="utf-8", categories=("L", "N", "P", "S", "Zs")), max_size=16)
plain = st.from_regex(r"[a-z][a-z0-9_./:-]{0,10}", fullmatch=True)
texts = st.one_of(plain, words, wild)
windows = st.builds(
    Window,
    st.lists(st.sampled_from(DAYS), min_size=1, max_size=3, unique=True).map(tuple),
    st.builds(time, st.integers(0, 23), st.integers(0, 59)),
    st.builds(time, st.integers(0, 23), st.integers(0, 59)),
)
serials = st.builds(
    SerialSettings,
    baudrate=st.sampled_from([1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 14400]),
    bytesize=st.sampled_from([7, 8]),
    parity=st.sampled_from("NEOX"),
    stopbits=st.sampled_from([1, 2]),
    rtscts=st.booleans(),
    timeout=st.sampled_from([0.1, 0.5, 1.0, 2.5, 60.0, 61.0, 0.1234567]),
    retries=st.integers(0, 11),
)


@st.composite
def robots(draw: st.DrawFn) -> Robot:
    robot = Robot(
        name=draw(texts),
        port=draw(st.sampled_from(["/dev/ttyUSB0", "COM3", "socket://h:4001"]) | texts),
        station=draw(st.integers(0, 100)),
        serial=draw(serials),
        windows=draw(st.lists(windows, max_size=2)),
        keep_registers=draw(st.booleans()),
        description=draw(st.none() | texts),
    )
    if draw(st.booleans()):
        robot.options["offset_tables"] = draw(st.integers(0, 10001))
    if draw(st.booleans()):  # issue 29: E and a status, or something else
        robot.options["no_such_table"] = draw(st.sampled_from(["E21", "E2", "E", "21"]) | texts)
    return robot


@settings(max_examples=examples(200))
@given(robot=robots())
def test_a_robot_yaml_harlsync_writes_is_read_back_as_that_robot_or_refused_in_words(
    tmp_path_factory: pytest.TempPathFactory, robot: Robot
) -> None:
    root = written(tmp_path_factory.mktemp("w"), render_robot(robot))
    found = full(root)
    assert found is None or found == ("harl-u2", replace(robot, family="harl-u2"))


def test_the_plain_robot_yaml_harlsync_writes_is_read_back_as_written(tmp_path: Path) -> None:
    robot = Robot(
        name="press-3",
        port="sim:///plant/press-3",
        station=7,
        windows=[Window(("mon", "fri"), time(22, 0), time(6, 30))],
        description="Press 3: the 'old' one",
        family="harl-u2",
        options={"offset_tables": 12, "no_such_table": "E2"},
    )
    root = written(tmp_path, render_robot(robot))
    assert full(root) == ("harl-u2", robot)
    for name, description in [("プレス3", "第2工場: 組立ライン"), ("Zelle #4", 'a "quoted" word')]:
        robot = Robot(name=name, port="/dev/ttyS0", description=description, family="harl-u2")
        root = written(tmp_path, render_robot(robot))
        assert full(root) == ("harl-u2", robot)


#: Values a hand edit may leave, some of them valid: each is put in place of one
#: value of a valid robot.yaml.
ODD = [
    "0012",
    "1e3",
    "0x10",
    "0o7",
    "+1",
    "-1",
    "1.",
    ".5",
    "0",
    "100",
    "99",
    "1.0",
    "~",
    "null",
    "Null",
    "true",
    "True",
    "TRUE",
    "yes",
    "no",
    "''",
    '""',
    "'a'",
    '"a b"',
    '"a\\nb"',
    "'it''s'",
    "'open",
    '"open',
    "[mon, mon]",
    "[mon]",
    "[]",
    "[Mon]",
    "[mon, ]",
    "{}",
    "{a: b}",
    "&a x",
    "*a",
    "!!str 3",
    "|",
    ">",
    "2:60",
    "25:00",
    "22:00",
    "'22:00'",
    "sim://x y",
    "a #b",
    "a#b",
    "a: b",
    "a:",
    "-",
    "- x",
    "60.0000000000000001",
    "60",
    "0.0",
    "115200",
    "14400",
    "E",
    "X",
    "\u3000",
    "caf\u00e9",
    "'caf\u00e9'",
    "x\u2028y",
]


@settings(max_examples=examples(400))
@given(
    at=st.integers(0, 60),
    how=st.sampled_from(["value", "duplicate", "indent", "drop", "unknown", "tab", "comment"]),
    odd=st.sampled_from(ODD),
)
def test_whatever_a_hand_edit_does_the_store_reads_a_robot_or_refuses_it_in_one_line(
    tmp_path_factory: pytest.TempPathFactory, at: int, how: str, odd: str
) -> None:
    robot = Robot(
        name="cell",
        port="/dev/ttyUSB0",
        windows=[Window(("sat", "sun"), time(22, 0), time(6, 0))],
        description="Cell",
        options={"offset_tables": 12},
    )
    lines = render_robot(robot).splitlines()
    n = at % len(lines)
    line = lines[n]
    key, colon, _ = line.partition(": ")
    if how == "value" and colon:
        lines[n] = f"{key}: {odd}"
    elif how == "duplicate":
        lines.insert(n, line)
    elif how == "indent":
        lines[n] = " " + line
    elif how == "drop":
        del lines[n]
    elif how == "unknown":
        lines.insert(n, f"{' ' * (len(line) - len(line.lstrip()))}extra: {odd}")
    elif how == "tab":
        lines[n] = line.replace(" ", "\t", 1)
    else:
        lines[n] = f"{line}  # {odd}"
    root = written(tmp_path_factory.mktemp("e"), "\n".join(lines) + "\n")
    try:
        store.load_robot(root, store.family_of(root))
    except ProjectError as exc:
        assert "\n" not in str(exc), str(exc)
