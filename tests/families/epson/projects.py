"""Epson projects in a test's git repository: pulled from a simulator, then edited."""

from __future__ import annotations

from pathlib import Path

from conftest import git

from harlsync import cli


def pulled(repo: Path, url: str, name: str = "cell-3") -> Path:
    """``harlsync pull`` of the controller at ``url`` into ``repo/name``, its points
    kept to 0-29, committed."""
    project = repo / name
    assert cli.main(["pull", str(project), "--family", "epson", "--port", url]) == 0
    path = project / "robot.yaml"
    path.write_text(path.read_text().replace("last_point: 99", "last_point: 29"))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", "backup")
    return project


def saved(repo: Path, url: str, name: str = "cell-3", **options: object) -> Path:
    """The sample data saved as the backup of the controller at ``url`` into
    ``repo/name``, its points kept to 0-29 (``options``: robot.yaml's others),
    committed: a project with no pull's minutes of reading."""
    from harlsync import families
    from harlsync.project import Project, save_project

    from .sample import sample_data

    robot = families.get("epson").new_robot(name, url, 1)
    robot.options.update({"last": 29, **options})
    project = repo / name
    save_project(project, Project(project, robot, sample_data()))
    git(repo, "add", "-A")
    git(repo, "commit", "-qm", f"{name}: backup")
    return project


def edit(project: Path, repo: Path, file: str, old: str, new: str) -> None:
    """Replace ``old`` with ``new`` in the project's ``file``, and commit it."""
    path = project / file
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))
    git(repo, "commit", "-qam", f"edit {file}")
