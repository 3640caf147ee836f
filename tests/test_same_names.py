"""Two robots with one name (lineA/cell, lineB/cell) stay apart in the metrics file, the
backup report, ``status`` and the report page (issue 22 item 5).  The metrics file is
read with prometheus_client's text-format parser, and checked as node_exporter's
textfile collector does: every series once, each metric's samples in one group."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
import toyfamily
from conftest import git
from prometheus_client.parser import text_string_to_metric_families
from toyfamily.sim import SimState, Simulator

from harlsync.cli import main
from harlsync.sim.protocol_sim import register, unregister
from harlsync.sync import engine

#: The robots are the toy family's (conftest's ``toy``): what is said of names is the
#: engine's, whatever the family.
pytestmark = pytest.mark.usefixtures("toy")


@pytest.fixture
def twins(repo: Path) -> Iterator[list[Path]]:
    urls = [register(Simulator({1: SimState.generate(seed)})) for seed in (1, 2)]
    projects = [repo / "lineA" / "cell", repo / "lineB" / "cell"]
    for project, url in zip(projects, urls):
        engine.pull(project, port=url, commit=True, family=toyfamily.NAME)
    yield projects
    for url in urls:
        unregister(url)


def check_metrics(text: str) -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
    """Every sample by (name, labels); fails on a duplicate series or a metric whose
    samples are not in one group, as node_exporter would."""
    seen: dict[tuple[str, tuple[tuple[str, str], ...]], float] = {}
    names = []
    for family in text_string_to_metric_families(text):
        names.append(family.name)
        for sample in family.samples:
            key = (sample.name, tuple(sorted(sample.labels.items())))
            assert key not in seen, f"duplicate series {key}"
            seen[key] = sample.value
    assert len(names) == len(set(names)), f"a metric in more than one group: {names}"
    order = [
        line.split("{")[0].split(" ")[0] for line in text.splitlines() if not line.startswith("#")
    ]
    groups = [name for n, name in enumerate(order) if n == 0 or order[n - 1] != name]
    assert len(groups) == len(set(groups)), f"samples of a metric not grouped: {groups}"
    return seen


def test_two_robots_named_alike_stay_apart_in_metrics_report_and_status(
    twins: list[Path], repo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    metrics, page = tmp_path / "backup.prom", tmp_path / "page.html"
    assert main(["backup", str(repo), "--metrics", str(metrics), "--html", str(page)]) == 0
    report = capsys.readouterr().out
    samples = check_metrics(metrics.read_text())
    projects = {dict(labels).get("project") for (name, labels) in samples if labels}
    assert projects == {"lineA/cell", "lineB/cell"}
    assert samples[("harlsync_backup_success", (("project", "lineA/cell"), ("robot", "cell")))] == 1
    assert "cell (lineA/cell)" in report and "cell (lineB/cell)" in report

    assert main(["status", str(repo)]) == 0
    out = capsys.readouterr().out
    rows = [line.split("  ")[0] for line in out.splitlines()[1:3]]
    assert rows == ["cell (lineA/cell)", "cell (lineB/cell)"]
    assert main(["status", str(repo), "--format", "json"]) == 0
    robots = json.loads(capsys.readouterr().out)["robots"]
    assert [r["label"] for r in robots] == ["cell (lineA/cell)", "cell (lineB/cell)"]
    html = page.read_text()
    assert "cell (lineA/cell)" in html and "cell (lineB/cell)" in html


def test_a_robot_name_with_quotes_and_newlines_is_escaped_in_the_metrics(
    repo: Path, tmp_path: Path
) -> None:
    url = register(Simulator({1: SimState.generate(3)}))
    try:
        project = repo / "odd"
        engine.pull(project, port=url, commit=True, family=toyfamily.NAME)
        robot = project / "robot.yaml"
        named = 'name: "a \\"b\\" \\\\ c"'  # YAML for: a "b" \ c
        robot.write_text(re.sub(r"(?m)^name: .*$", lambda _: named, robot.read_text()))
        git(repo, "commit", "-qam", "odd name")
        metrics = tmp_path / "m.prom"
        assert main(["backup", str(repo), "--metrics", str(metrics)]) == 0
        samples = check_metrics(metrics.read_text())
        assert ("harlsync_backup_success", (("project", "odd"), ("robot", 'a "b" \\ c'))) in samples
    finally:
        unregister(url)
