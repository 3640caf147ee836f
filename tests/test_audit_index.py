"""Issue 24: the audit log's size costs nothing; its index answers what a pull, a push
and status ask, from what was appended since, exactly as the whole log would."""

from __future__ import annotations

import json
import os
import random
from pathlib import Path
from typing import Any

import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from harlsync.sync import audit, auditindex

PORTS = ["sim://a", "sim://b", "/dev/ttyS7", "loop://"]


def record(event: str, rid: str, n: int, port: str = "sim://a", **more: Any) -> dict[str, Any]:
    base: dict[str, Any] = {
        "event": event,
        "id": rid,
        "time": f"2026-11-{1 + n % 28:02d}T10:00:00+00:00",
    }
    if event != "write":
        base.update(
            action="push", user="alice", host="pc", robot={"name": "r", "port": port, "station": 1}
        )
    return base | more


def push(rid: str, n: int, port: str, result: str | None, writes: int = 2) -> list[dict[str, Any]]:
    """A push's records: its start, its writes, and its end (``result`` None: killed)."""
    records = [record("start", rid, n, port, plan=["a", "b"])]
    records += [record("write", rid, n, item=f"step {i}", command=f"SN{i}") for i in range(writes)]
    if result is not None:
        records.append(record("end", rid, n, port, result=result, written=[]))
    return records


def write_log(path: Path, records: list[Any], *, raw: bytes = b"") -> None:
    with open(path, "ab") as f:
        f.writelines((r if isinstance(r, str) else json.dumps(r)).encode() + b"\n" for r in records)
        f.write(raw)


def whole(path: Path, port: str, station: int = 1, project: Path | None = None) -> tuple[Any, Any]:
    """What the whole log says, read as ``harlsync log`` reads it."""
    mine = audit.of_robot(audit.results(path, []), port, station, project)
    return mine[-auditindex.RECENT :], audit.unsettled(mine)


def assert_as_whole(path: Path, project: Path | None = None) -> auditindex.AuditIndex:
    index = auditindex.load(path)
    for port in PORTS:
        found = index.robot(port, 1, project)
        recent, unsettled = whole(path, port, 1, project)
        assert found.recent == recent, port
        assert found.unsettled == unsettled, port
    return index


def random_records(rng: random.Random, count: int, project: str) -> list[Any]:
    out: list[Any] = []
    for n in range(count):
        rid = f"{rng.randrange(40):016x}"  # ids come back: a start over an open one
        port = rng.choice(PORTS)
        kind = rng.random()
        if kind < 0.5:
            out += push(
                rid, n, port, rng.choice(["ok", "failed", "refused", "nothing to write", None])
            )
        elif kind < 0.6:
            out.append(record("end", rid, n, port, result="ok"))  # an end without a start
        elif kind < 0.7:
            out.append(
                {
                    "action": "push",
                    "result": "ok",
                    "project": project,
                    "time": "2026-11-01T00:00:00+00:00",
                }
            )
        elif kind < 0.8:
            out.append(record("write", rid, n, item="late", command="SN9"))
        elif kind < 0.85:
            out.append(record("recover", rid, n, port, note="reset"))
        elif kind < 0.9:
            out.append("not json")
        else:
            out.append("[]")
    return out


@pytest.mark.parametrize("seed", range(6))
def test_the_index_answers_as_the_whole_log_does_built_at_once_or_as_the_log_grows(
    tmp_path: Path, seed: int
) -> None:
    rng = random.Random(seed)
    project = tmp_path / "cell"
    project.mkdir()
    grown, at_once = tmp_path / "grown.jsonl", tmp_path / "at-once.jsonl"
    batches = [random_records(rng, rng.randrange(1, 40), str(project.resolve())) for _ in range(8)]
    for batch in batches:
        write_log(grown, batch)
        assert_as_whole(grown, project)  # each read takes up the index the last one saved
        assert_as_whole(grown)
    write_log(at_once, [r for batch in batches for r in batch])
    assert_as_whole(at_once, project)


def big_log(path: Path, pushes: int) -> None:
    """``pushes`` finished pushes to other robots: 5 records each."""
    with open(path, "w") as f:
        for n in range(pushes):
            f.writelines(
                json.dumps(r) + "\n"
                for r in push(f"{n:016x}", n, f"/dev/ttyUSB{n % 128}", "ok", writes=3)
            )


def test_a_10000_record_log_is_read_at_its_tail_only(tmp_path: Path) -> None:
    log = tmp_path / "audit.jsonl"
    big_log(log, 2_000)
    write_log(log, push("f" * 16, 1, "sim://a", None))  # killed: unfinished
    size = log.stat().st_size
    first = auditindex.load(log)  # a log of the previous release: indexed once
    assert first.lines_parsed == 10_003
    assert auditindex.index_path(log).exists()

    write_log(log, [record("end", "e" * 16, 2, "sim://b", result="ok")])
    again = auditindex.load(log)
    unfinished = again.robot("sim://a", 1)
    assert again.lines_parsed == 1  # only what was appended
    assert again.bytes_read < size / 100
    assert [u.id for u in unfinished.unsettled] == ["f" * 16]
    assert unfinished.unsettled[0].failed_item == "step 1"
    assert unfinished.unsettled == whole(log, "sim://a")[1]


def test_a_pull_asks_the_index_not_the_whole_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "audit.jsonl"
    big_log(log, 2_000)
    auditindex.load(log)

    def whole_log(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the whole audit log was read")

    monkeypatch.setattr(audit, "read", whole_log)
    assert auditindex.unfinished("/dev/ttyUSB3", 1, log) == []
    pushes = auditindex.pushes_since("/dev/ttyUSB3", 1, tmp_path, "2026-11-20T00:00:00+00:00", log)
    assert pushes and all(p.startswith("push ok 2026-11-2") for p in pushes)


def test_more_pushes_since_the_last_backup_than_the_index_keeps_are_all_named(
    tmp_path: Path,
) -> None:
    log = tmp_path / "audit.jsonl"
    many = auditindex.RECENT + 5
    write_log(log, [r for n in range(many) for r in push(f"{n:016x}", 0, "sim://a", "ok")])
    assert len(auditindex.pushes_since("sim://a", 1, tmp_path, None, log)) == many
    assert (
        len(auditindex.pushes_since("sim://a", 1, tmp_path, "2026-11-01T00:00:00+00:00", log))
        == many
    )


def test_a_line_cut_short_by_a_crash_mid_append_is_named_once_the_next_append_ends_it(
    tmp_path: Path,
) -> None:
    log = tmp_path / "audit.jsonl"
    write_log(log, push("a" * 16, 1, "sim://a", "ok"), raw=b'{"event": "start", "id": "bbbb')
    problems: list[str] = []
    auditindex.index(log, problems)
    assert len(problems) == 1 and problems[0].startswith(f"{log}:5: not an audit record (not JSON")
    saved = json.loads(auditindex.index_path(log).read_text())
    assert saved["size"] == log.stat().st_size - len(b'{"event": "start", "id": "bbbb')

    start, _ = audit.AuditRecord.from_json(record("start", "c" * 16, 2, "sim://a"))
    audit.append(start, log)  # ends the cut line first
    problems = []
    index = auditindex.index(log, problems)
    assert len(problems) == 1 and problems[0].startswith(f"{log}:5: not an audit record")
    assert index.lines_parsed == 2
    assert [u.id for u in index.robot("sim://a", 1).unsettled] == ["c" * 16]
    assert_as_whole(log)
    # Said again from the saved index, as a read of the whole log says it every time.
    problems = []
    assert auditindex.index(log, problems).lines_parsed == 0
    assert len(problems) == 1 and problems[0].startswith(f"{log}:5: ")


def test_malformed_lines_are_named_by_file_and_line_five_at_most(tmp_path: Path) -> None:
    log = tmp_path / "audit.jsonl"
    write_log(log, ["[1]", *push("a" * 16, 1, "sim://a", "ok"), *["nope"] * 7])
    problems: list[str] = []
    auditindex.index(log, problems)
    expected: list[str] = []
    audit.results(log, expected)
    assert problems == expected
    assert problems[0].startswith(f"{log}:1: not an audit record (a list, not an object)")
    assert problems[-1] == f"and 4 more malformed lines in {log}"


@pytest.mark.parametrize(
    "change", ["truncated", "replaced", "rewritten", "index garbage", "index without its marks"]
)
def test_an_index_that_no_longer_matches_its_log_is_built_again(
    tmp_path: Path, change: str
) -> None:
    log = tmp_path / "audit.jsonl"
    write_log(log, push("a" * 16, 1, "sim://a", None) + push("b" * 16, 2, "sim://b", "ok"))
    auditindex.load(log)
    if change == "truncated":  # copytruncate, by hand
        log.write_text("")
        write_log(log, push("c" * 16, 3, "sim://a", None))
    elif change == "replaced":  # moved away, a new log begun
        log.rename(tmp_path / "audit-2026.jsonl")
        write_log(log, push("c" * 16, 3, "sim://a", None) * 3)
    elif change == "rewritten":  # same size, other content
        text = log.read_text()
        log.write_text(text.replace('"sim://a"', '"sim://c"'))
    elif change == "index without its marks":
        saved = json.loads(auditindex.index_path(log).read_text())
        del saved["ino"], saved["head"]
        auditindex.index_path(log).write_text(json.dumps(saved))
    else:
        auditindex.index_path(log).write_text('{"version": 1, "size": "x"}')
    index = assert_as_whole(log)
    assert index.lines_parsed == len(log.read_text().splitlines())


def test_a_log_in_a_directory_the_reader_may_not_write_is_still_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "audit.jsonl"
    write_log(log, push("a" * 16, 1, "sim://a", None))
    real = os.replace

    def refuse(src: Any, dst: Any) -> None:
        if str(dst).endswith(".index"):
            raise PermissionError(13, "Permission denied", str(dst))
        real(src, dst)

    monkeypatch.setattr(os, "replace", refuse)
    assert [u.id for u in auditindex.unfinished("sim://a", 1, log, [])] == ["a" * 16]
    assert not auditindex.index_path(log).exists()
    assert [p.name for p in tmp_path.iterdir()] == ["audit.jsonl"]  # no temporary left


def test_harlsync_log_still_reads_the_whole_history(tmp_path: Path) -> None:
    log = tmp_path / "audit.jsonl"
    many = auditindex.RECENT * 3
    write_log(log, [r for n in range(many) for r in push(f"{n:016x}", n, "sim://a", "ok")])
    auditindex.load(log)
    assert len(audit.results(log)) == many


def test_an_end_that_names_another_robot_than_its_start_counts_for_that_robot(
    tmp_path: Path,
) -> None:
    # harlsync writes one robot in both; the log is read as results() reads it anyway.
    log = tmp_path / "audit.jsonl"
    write_log(log, push("a" * 16, 1, "sim://a", None))
    auditindex.load(log)
    write_log(log, [record("end", "a" * 16, 2, "sim://b", result="failed")])
    index = assert_as_whole(log)
    assert index.robot("sim://a", 1).recent == []
    assert [r.result for r in index.robot("sim://b", 1).recent] == ["failed"]


# --- an index entry of the wrong shape (issue 34 item 9) -------------------------------

#: JSON values of every type.
JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 10**6) | st.floats(-1e3, 1e3) | st.text(max_size=3),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=2)
    ),
    max_leaves=4,
)


def json_type(value: Any) -> str:
    return "bool" if isinstance(value, bool) else type(value).__name__


def nodes(value: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """The path of every value in ``value``, itself first."""
    found = [path]
    if isinstance(value, dict):
        for key, inner in value.items():
            found += nodes(inner, (*path, key))
    elif isinstance(value, list):
        for n, inner in enumerate(value):
            found += nodes(inner, (*path, n))
    return found


def fixed_size(path: tuple[Any, ...]) -> bool:
    """Whether the index always writes the array at ``path`` with the same number of
    values: a key's entry, a ``[seq, offset]`` pair, a problem's ``[line, text]``."""
    return (
        (len(path) == 2 and path[0] == "keys")
        or (len(path) == 4 and path[0] == "keys" and path[2] in (0, 3))
        or (len(path) == 2 and path[0] == "problems")
    )


def replaced(state: Any, path: tuple[Any, ...], value: Any) -> Any:
    if not path:
        return value
    inner = state
    for part in path[:-1]:
        inner = inner[part]
    inner[path[-1]] = value
    return state


@settings(max_examples=examples(100))
@given(data=st.data())
def test_issue_34_an_index_entry_of_any_other_shape_is_built_again_from_the_log(
    tmp_path_factory: pytest.TempPathFactory, data: st.DataObject
) -> None:
    root = tmp_path_factory.mktemp("index")
    log, project = root / "audit.jsonl", root / "cell"
    project.mkdir()
    write_log(
        log,
        push("a" * 16, 1, "sim://a", None)
        + push("b" * 16, 2, "sim://b", "ok")
        + [record("end", "c" * 16, 3, "sim://a", result="refused", project=str(project.resolve()))]
        + ["not json"],
    )
    auditindex.load(log)
    saved = json.loads(auditindex.index_path(log).read_text())
    path = data.draw(st.sampled_from(nodes(saved)), label="path")
    old = eval_path(saved, path)
    if isinstance(old, list) and old and fixed_size(path) and data.draw(st.booleans(), "shorter"):
        new: Any = old[:-1]
    else:  # a value of another type: an offset as text, a pair as a bare number ...
        new = data.draw(JSON.filter(lambda v: json_type(v) != json_type(old)), label="value")
    auditindex.index_path(log).write_text(json.dumps(replaced(saved, path, new)))

    expected: list[str] = []
    audit.results(log, expected)
    problems: list[str] = []
    index = auditindex.index(log, problems)  # what a pull, diff and status ask
    assert problems == expected
    assert [u.id for u in auditindex.unfinished("sim://a", 1, log, [])] == ["a" * 16]
    assert_as_whole(log, project)
    assert_as_whole(log)
    assert len(auditindex.pushes_since("sim://a", 1, project, None, log)) == 2
    assert index.lines_parsed in (0, len(log.read_text().splitlines()))


def eval_path(state: Any, path: tuple[Any, ...]) -> Any:
    for part in path:
        state = state[part]
    return state


def _sync_imports(module: str) -> set[str]:
    """The modules of harlsync.sync that ``module`` imports, anywhere in it (in a
    function, or for type checking only, too)."""
    import ast

    source = Path(auditindex.__file__).with_name(f"{module}.py").read_text(encoding="utf-8")
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            found |= {node.module} if node.module else {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module == "harlsync.sync":
            found |= {a.name for a in node.names}
    return found


def test_issue_32_the_record_the_log_and_its_index_import_one_way_only() -> None:
    """auditrecord <- audit <- auditindex: the index owns its reading API, and the log
    asks nothing of it (they imported each other)."""
    assert "auditindex" not in _sync_imports("audit")
    assert {"audit"} <= _sync_imports("auditindex")
    assert _sync_imports("auditrecord") == set()
