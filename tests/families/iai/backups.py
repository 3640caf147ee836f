"""A first backup of an IAI robot, as a site makes one: ``harlsync pull`` with
--family, --port and --station, then robot.yaml edited to the robot's range and
what it keeps, and pulled again."""

from __future__ import annotations

from pathlib import Path

from harlsync import cli


def first_backup(
    project: Path, url: str, *, last: int, controller: str = "", keep_registers: bool = False
) -> None:
    """Pull ``project`` from ``url``; set ``last_position`` to ``last``, add the
    ``controller`` lines (each indented two spaces, ending in a newline) and
    ``keep_registers``, and pull again."""
    pull = ["pull", str(project), "--family", "iai", "--port", url, "--station", "99"]
    assert cli.main(pull) == 0
    robot = project / "robot.yaml"
    text = robot.read_text().replace("last_position: 1000", f"last_position: {last}")
    text = text.replace("controller:\n", "controller:\n" + controller)
    robot.write_text(text + ("keep_registers: true\n" if keep_registers else ""))
    assert cli.main(["pull", str(project), "--allow-dirty"]) == 0
