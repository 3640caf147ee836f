"""The record in each family's own words (issue 22 items 1 and 2): the audit log,
``log``, ``status`` and the report page show what a push changed field by field, as
``diff`` shows it (``position 3: speed 0 → 150``), never a Python repr and never a
wire frame; the push prompt and ``plan`` show the same readable diff, the wire
commands only with -v, and the count of items matches the diff."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import pytest
from conftest import git
from plantsim import SMALL

from harlsync import cli
from harlsync.cli import robot as cli_robot
from harlsync.families.epson.sim import SimState as EpsonState
from harlsync.families.epson.sim import Simulator as EpsonSimulator
from harlsync.families.harl_u2.sim import SimState as HarlState
from harlsync.families.harl_u2.sim import Simulator as HarlSimulator
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.families.iai.sim import Simulator as IaiSimulator
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import audit

#: What must never reach a line a person reads: a Python repr, or hex words.
REPR = re.compile(r"\b[A-Z]\w*\(\w+=|None -> None|None → None")
HEX = re.compile(r"\b(?:[0-9A-F]{4} ){3,}")


@dataclass
class Pushed:
    family: str
    project: Path
    #: the lines log must show for the push, as diff's fields
    expected: list[str]
    #: what plan and the prompt show without -v
    plan_lines: list[str]


def _edit(project: Path, repo: Path, file: str, pattern: str, new: str) -> None:
    path = project / file
    text, n = re.subn(pattern, new, path.read_text(), count=1, flags=re.MULTILINE)
    assert n == 1, pattern
    path.write_text(text)
    git(repo, "commit", "-qam", f"edit {file}")


def _pull(repo: Path, name: str, *args: str) -> Path:
    project = repo / name
    assert cli.main(["pull", str(project), *args]) == 0
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    return project


@pytest.fixture(params=["harl-u2", "iai", "epson"])
def edited(request: pytest.FixtureRequest, repo: Path) -> Iterator[Pushed]:
    """A robot of each family pulled, and a committed edit of its project to push."""
    family = request.param
    if family == "harl-u2":
        url = register(HarlSimulator({1: HarlState.generate(7, SMALL)}))
        project = _pull(repo, "press", "--port", url)
        old = re.search(r"(?m)^  1: (.*)$", (project / "timers.yaml").read_text())
        assert old is not None
        _edit(project, repo, "timers.yaml", r"^  1: .*$", "  1: 0.80")
        yield Pushed(family, project, [f"timer 1: {old.group(1)} → 0.80"], [])
        unregister(url)
    elif family == "iai":
        url = register(IaiSimulator({0x99: IaiState.generate(5, position_range=(1, 20))}))
        project = _pull(repo, "cell-9", "--family", "iai", "--port", url, "--station", "99")
        robot = project / "robot.yaml"
        robot.write_text(robot.read_text().replace("last_position: 1000", "last_position: 20"))
        git(repo, "commit", "-qam", "20 positions")
        text = (project / "positions.yaml").read_text()
        first, second = re.findall(r"(?m)^  (\d+): .*speed: (\d+)", text)[:2]
        _edit(project, repo, "positions.yaml", rf"^(  {first[0]}: .*speed: )\d+", r"\g<1>150")
        _edit(project, repo, "positions.yaml", rf"^(  {second[0]}: .*speed: )\d+", r"\g<1>151")
        yield Pushed(
            family,
            project,
            [
                f"position {first[0]}: speed {first[1]} → 150",
                f"position {second[0]}: speed {second[1]} → 151",
            ],
            [],
        )
        unregister(url)
    else:
        from families.epson.sample import sample_data

        sim = EpsonSimulator(EpsonState.from_data(sample_data()), execution_time=0.0)
        with sim.serve() as server:
            project = _pull(repo, "cell-3", "--family", "epson", "--port", server.url)
            _edit(
                project,
                repo,
                "settings.yaml",
                r"3: \{accel: 100\.123, decel: 200\.000\}",
                "3: {accel: 100.123, decel: 250.000}",
            )
            yield Pushed(family, project, ["AccelS 3: decel 200.000 → 250.000"], [])


def readable(text: str) -> None:
    assert not REPR.search(text), text
    assert not HEX.search(text), text


def test_log_status_and_the_report_page_show_each_field_old_to_new_in_the_family_words(
    edited: Pushed, repo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    project = edited.project
    assert cli.main(["push", str(project), "--yes", "--reason", "tuning"]) == 0
    capsys.readouterr()
    record = audit.read()[-1]
    for entry in record.done:
        assert entry.changes, entry
    assert [audit.change_line(c) for w in record.done for c in w.changes or ()] == (edited.expected)
    readable(
        json.dumps([w.to_json() for w in record.done], ensure_ascii=False).replace(
            str(record.done[0].command), ""
        )
    )

    assert cli.main(["log", str(project)]) == 0
    out = capsys.readouterr().out
    readable(out)
    assert [line.strip() for line in out.splitlines() if "wrote" in line] == [
        f"wrote {line}" for line in edited.expected
    ]

    assert cli.main(["status", str(repo), "--html", str(tmp_path / "page.html")]) in (0, 1)
    out = capsys.readouterr().out
    readable(out)
    for line in edited.expected:
        assert f"    {line}\n" in out
    page = (tmp_path / "page.html").read_text()
    readable(page)
    for line in edited.expected:
        assert f'<span class="d-change">{line}</span>' in page


def test_log_folds_long_lists_hides_frames_and_old_reprs_unless_asked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    frame = " ".join(f"{n:02X}" for n in range(40))
    record = audit.base_record("push")
    record.robot = audit.RecordedRobot("cell-9", "sim://x", 1)
    record.result = "failed"
    record.error = f"the controller refused 291H: reply {frame}"
    record.written = [
        audit.Written(f"position {n}", f"291H {frame}", changes=(
            audit.Change(f"position {n}", "speed", "0", str(n)),
        ))
        for n in range(50)
    ] + [audit.Written("position 99", "291H", "Position(axes=(1,), speed=0)",
                       "Position(axes=(1,), speed=5)")]  # fmt: skip
    audit.append(record)
    assert cli.main(["log"]) == 0
    out = capsys.readouterr().out
    readable(out)
    assert "    wrote position 0: speed 0 → 0\n" in out
    assert "    and 42 more (-v shows them)\n" in out  # 51 entries: 9 shown, then the count
    assert "[a 40-byte frame: -vv shows it]" in out
    assert cli.main(["log", "-v"]) == 0
    out = capsys.readouterr().out
    assert "    wrote position 49: speed 0 → 49\n" in out and "position 99: changed" in out
    assert "Position(" not in out
    assert f"command position 0: 291H {frame}" in out  # the wire with -v
    assert cli.main(["log", "-vv"]) == 0
    assert frame in capsys.readouterr().out


def test_plan_and_the_push_prompt_show_the_diff_of_what_is_written_and_the_wire_only_with_v(
    edited: Pushed, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    project = str(edited.project)
    assert cli.main(["diff", project]) == 1
    shown = capsys.readouterr().out.splitlines()[2:]  # after --- robot, +++ project
    assert cli.main(["diff", project, "--format", "json"]) == 1
    items = len(json.loads(capsys.readouterr().out)["changes"])
    assert cli.main(["plan", project]) == 0
    out = capsys.readouterr().out
    readable(out)
    lines = out.splitlines()
    assert lines[:-1] == shown  # the same lines as diff: every difference is written
    assert re.fullmatch(rf"# {items} item\(s\)( in \d+ write\(s\))? to \S+ \(.*\)", lines[-1])

    assert cli.main(["plan", project, "-v"]) == 0
    verbose = capsys.readouterr().out.splitlines()
    commands = [line for line in verbose if line.startswith("# ") and ": " in line]
    assert commands and verbose[: len(shown)] == shown

    from harlsync.sync import engine

    asked: list[str] = []

    def answer(prompt: str) -> str:
        asked.append(prompt)
        return "n"

    monkeypatch.setattr("builtins.input", answer)
    the_plan = engine.compare(project, lock_timeout=5).plan()
    assert cli_robot._confirm(the_plan) is False
    out = capsys.readouterr().out
    readable(out)
    assert out.splitlines()[:-1] == shown
    assert asked == [f"Write these {lines[-1][2:].split(' to ')[0]} to {the_plan.robot}? [y/N] "]


def test_an_error_line_names_a_frame_by_its_size_and_shows_it_with_vv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from harlsync.errors import ReplyError
    from harlsync.sync import comparison

    frame = " ".join(f"{n:02X}" for n in range(60))

    def refused(*args: object, **kwargs: object) -> NoReturn:
        raise ReplyError(f"port sim://x station 99: the controller answered & to 291H: {frame}")

    monkeypatch.setattr(comparison, "compare", refused)
    assert cli.main(["diff", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and frame not in err
    assert "answered & to 291H: [a 60-byte frame: -vv shows it]" in err
    assert cli.main(["-vv", "diff", str(tmp_path)]) == 2
    assert frame in capsys.readouterr().err


def test_issue_32_a_drift_error_names_the_fields_of_a_value_of_several_numbers() -> None:
    """``audit.difference`` asks the family's fields of the value as it is: a setting
    of four joints is one value (it said "its value differs", having compared its
    numbers one by one as if they were a run, and swallowed the TypeError); a run of
    IAI positions is compared position by position by the IAI catalogue."""
    from harlsync import families
    from harlsync.families.epson.model import SettingKey
    from harlsync.families.iai.catalogue import PositionKey, Run
    from harlsync.families.iai.model import Position

    epson = families.get("epson").catalogue
    fine = SettingKey("fine")
    assert audit.difference(epson, fine, (10, 10, 10, 10), (10, 9, 10, 10)) == "joint 2 10 → 9"
    iai = families.get("iai").catalogue
    at = Position(3, (1, 2), "0.30", "0.30", 100, ("1.000", "2.000"))
    faster = Position(4, (1, 2), "0.30", "0.30", 150, ("1.000", "2.000"))
    assert audit.difference(iai, Run("positions", 3, 2), (at, at), (at, faster)) == (
        "speed 100 → 150"
    )
    assert audit.difference(iai, PositionKey("position", 3), at, None) == (
        "axes [1, 2] coords [1.000, 2.000] acc 0.30 dec 0.30 speed 100 → (empty)"
    )
