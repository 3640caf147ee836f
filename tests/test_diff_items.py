"""items.diff_items (issue 24: a pull again works its changes out once, and sorts
only the items that differ) against the rule it keeps: every key of either side
whose values differ, ``None`` standing for a key one side does not have, in the
catalogue's push order."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st
from toyfamily.family import CATALOGUE, SlotKey

from harlsync.sync.items import diff_items

# The toy family's catalogue: the rule is the engine's, whatever family's keys it sorts.
keys = st.builds(SlotKey, st.just("slot"), st.integers(0, 60))
values = st.one_of(st.none(), st.sampled_from([0, 30, 50, 100]))
side = st.dictionaries(keys, values, max_size=15)


def _by_the_rule(a: dict[Any, Any], b: dict[Any, Any]) -> list[tuple[Any, Any, Any]]:
    every = sorted(a.keys() | b.keys(), key=CATALOGUE.order)
    return [(k, a.get(k), b.get(k)) for k in every if a.get(k) != b.get(k)]


@settings(max_examples=examples(300))
@given(side, side)
def test_diff_items_is_the_rule_item_by_item(a: dict[Any, Any], b: dict[Any, Any]) -> None:
    got = [(c.key, c.old, c.new) for c in diff_items(CATALOGUE, a, b)]
    assert got == _by_the_rule(a, b)


def test_issue_24_git_log_in_one_process_gives_the_commits_under_a_path(
    repo: Path, tmp_path: Path
) -> None:
    from conftest import git as run_git

    from harlsync.sync import git

    (repo / "a").mkdir()
    (repo / "b").mkdir()
    assert git.log(repo / "a") == []  # before the first commit
    for name in ("a", "b", "a"):
        (repo / name / "f").write_text(str(len(run_git(repo, "log", "--oneline", "--all"))))
        run_git(repo, "add", "-A")
        run_git(repo, "commit", "-qm", f"change {name}")
    assert [c.subject for c in git.log(repo / "a")] == ["change a", "change a"]
    assert [c.subject for c in git.log(repo / "b" / "f", 1)] == ["change b"]
    assert git.log(repo / "a" / "not yet" / "x", 1) == []  # no file there ever changed
    outside = tmp_path / "outside"
    outside.mkdir()
    assert git.log(outside) == []
