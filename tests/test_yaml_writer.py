"""The project files' own writer (yamlwrite._Writer) against PyYAML's emitter: the same
bytes for every document it writes, and the same data, lines and duplicates as
parsing them back.  Whatever the writer leaves to the emitter is written by the
emitter, so a save is byte-identical to what the emitter alone wrote.

Issue 15: saving a full-size project took 0.4 s in the emitter.  The writer has no
dependency of its own (no libyaml), so the bytes cannot change with a PyYAML built
against another libyaml; these tests run in CI against the installed PyYAML.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st
from test_project_roundtrip import TRICKY, projects
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from harlsync import families
from harlsync.families.iai.layout import IaiData
from harlsync.families.iai.model import Position
from harlsync.families.iai.sim import SimState as IaiState
from harlsync.project import Project, load_project, save_project, yamlio, yamlwrite

EXAMPLES = Path(__file__).resolve().parent.parent / "projects"


def _parsed(text: str) -> yamlio.Parsed:
    """``text`` parsed for real (never the writer's own account of it)."""
    yamlwrite._recall(text)
    return yamlio.parse(text)


def _same_as_emitter(node: Node, header: str = "") -> bool:
    """The writer writes ``node`` as the emitter does, and knows what parse reads back.
    Returns whether the writer wrote it (False: it left it to the emitter)."""
    written = yamlwrite._Writer(header).document(node)
    emitted = yamlwrite._emit(node, header)
    if written is None:
        return False
    text, parsed = written
    assert text == emitted
    again = _parsed(text)
    assert (parsed.data, parsed.lines, parsed.duplicates) == (
        again.data,
        again.lines,
        again.duplicates,
    )
    assert repr(parsed.data) == repr(again.data)  # the same Number texts
    return True


@contextmanager
def _emitter_only() -> Iterator[None]:
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(yamlwrite._Writer, "document", lambda self, node: None)
        yield


# --- any node of the shapes the layouts build -------------------------------------------

word = st.one_of(
    st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=12),
    st.text(max_size=6),  # any character: quotes, escapes, line breaks, unicode
    st.sampled_from(
        [
            *TRICKY,
            "",
            " ",
            "a ",
            " a",
            "- a",
            "-",
            "a: b",
            "a #b",
            "'a'",
            "5.00",
            "22:00",
            "MOVE P001 S100",
            "--- x",
            "... x",
            "x" * 130,
        ]
    ),
)
number = st.one_of(
    st.integers(-(10**6), 10**6).map(str),
    st.decimals(allow_nan=False, allow_infinity=False, places=3).map(str),
    st.sampled_from(["0012", "1.50", "-0", "+7", "1e5", ".5", "1.", "-.5", "5E-3"]),
)
scalar = st.one_of(
    word.map(yamlio.text),
    word.map(yamlio.quoted),
    word.map(yamlio.scalar_for),
    number.filter(yamlio.is_number_text).map(yamlio.num),
    st.booleans().map(yamlio.boolean),
    st.just(yamlio.null()),
)
key = st.one_of(
    word.filter(bool).map(yamlio.text),
    st.integers(0, 300).map(lambda n: yamlio.num(str(n))),
)


def _mapping(pairs: list[tuple[ScalarNode, Node]], flow: bool) -> MappingNode:
    return yamlio.mapping(pairs, flow=flow)


flow_sequence = st.builds(
    lambda items: yamlio.sequence(items, flow=True), st.lists(scalar, max_size=5)
)
number_text = number.filter(yamlio.is_number_text)
# A row of numbers (an IAI position's line): number texts, lists of them, or nodes.
row = st.builds(
    yamlio.row,
    st.lists(
        st.tuples(
            word,
            st.one_of(number_text, st.lists(number_text, max_size=4), scalar, flow_sequence),
        ),
        max_size=6,
    ),
)
# Flow mappings of scalars, flow sequences and flow mappings (an IAI position's axes
# and coords are sequences in a flow mapping).
flow_collection = st.one_of(
    flow_sequence,
    row,
    st.recursive(
        st.builds(_mapping, st.lists(st.tuples(key, scalar), max_size=5), st.just(True)),
        lambda inner: st.builds(
            _mapping,
            st.lists(st.tuples(key, st.one_of(scalar, flow_sequence, row, inner)), max_size=5),
            st.just(True),
        ),
        max_leaves=12,
    ),
)
value = st.recursive(
    st.one_of(
        scalar,
        flow_collection,
        st.builds(lambda items: yamlio.sequence(items), st.lists(scalar, max_size=3)),
        # a program's steps (issue 24): texts and nulls, without a node each
        st.builds(yamlio.texts, st.lists(st.one_of(st.none(), word), max_size=4)),
    ),
    lambda inner: st.builds(_mapping, st.lists(st.tuples(key, inner), max_size=5), st.just(False)),
    max_leaves=20,
)
document = st.builds(
    _mapping, st.lists(st.tuples(key, value), min_size=1, max_size=8), st.just(False)
)


@settings(max_examples=examples(100))
@given(document, st.sampled_from(["", "# a comment\n", "# one\n# two\n"]))
def test_any_document_is_written_as_the_emitter_writes_it(node: MappingNode, header: str) -> None:
    _same_as_emitter(node, header)


# Scalars near the edge of what the writer writes: the characters it writes plain and
# those that make the emitter quote, or that it leaves to the emitter, in few places.
edgy = st.text(
    st.sampled_from("aaZZ00995  ..__//++--==$^;~()<eE>:#,'\"!&*%@?[]{}|`\\"), min_size=1, max_size=4
)
edgy_scalar = st.one_of(edgy.map(yamlio.text), edgy.map(yamlio.quoted), edgy.map(yamlio.scalar_for))
small_document = st.one_of(
    edgy_scalar.map(lambda v: yamlio.mapping([("k", v)])),
    edgy_scalar.map(lambda v: yamlio.mapping([("k", yamlio.mapping([("a", v)], flow=True))])),
    edgy_scalar.map(lambda v: yamlio.mapping([("k", yamlio.sequence([v], flow=True))])),
    edgy.map(lambda k: yamlio.mapping([(k, yamlio.text("v"))])),
)


@settings(max_examples=examples(1000))
@given(small_document)
def test_a_scalar_is_written_plain_or_quoted_as_the_emitter_writes_it(node: MappingNode) -> None:
    _same_as_emitter(node)


def test_the_writer_writes_the_layouts_it_is_for() -> None:
    steps = yamlio.mapping(
        [(yamlio.num(str(n)), yamlio.text(f"MOVE P{n:03d} S100")) for n in range(256)]
    )
    table = yamlio.mapping([(name, yamlio.num("-12.50")) for name in "xyzwrc"], flow=True)
    node = yamlio.mapping(
        [
            ("format", yamlio.num("1")),
            ("type", yamlio.text("MAIN")),
            ("steps", steps),
            ("version", yamlio.text("5.00")),
            ("tables", yamlio.mapping([(yamlio.num("0"), table)])),
            ("days", yamlio.sequence([yamlio.text("mon")], flow=True)),
            ("empty", yamlio.mapping([])),
            ("start", yamlio.quoted("22:00")),
            ("on", yamlio.boolean(True)),
            ("off", yamlio.null()),
            # a format-2 program's steps: a block sequence, an empty step null
            ("listed", yamlio.sequence([yamlio.text("END"), yamlio.null(), yamlio.text("-1")])),
        ]
    )
    assert _same_as_emitter(node, "# yaml-language-server: $schema=x\n")
    assert yamlwrite._Writer("").document(node) is not None


# --- every file of any project, and the example ------------------------------------------


def _rendered(project: Project) -> dict[str, str]:
    return families.get(project.robot.family).render_files(project.robot, project.data)


@settings(max_examples=examples(30))
@given(projects())
def test_every_file_of_any_project_is_byte_identical_to_the_emitters(project: Project) -> None:
    written = _rendered(project)
    with _emitter_only():
        emitted = _rendered(project)
    assert written == emitted


@pytest.mark.parametrize("example", sorted(p.name for p in EXAMPLES.iterdir() if p.is_dir()))
def test_the_example_projects_save_byte_identical(example: str) -> None:
    source = EXAMPLES / example
    project = load_project(source)
    with tempfile.TemporaryDirectory() as tmp:
        save_project(tmp, project, rewrite_robot=True)
        for path in source.rglob("*.yaml"):
            name = path.relative_to(source).as_posix()
            assert (Path(tmp) / name).read_bytes() == path.read_bytes(), name


def _iai_project(axes: int) -> Project:
    positions = [
        Position(
            n,
            tuple(range(1, axes + 1)),
            "0.30",
            "0.30",
            100,
            tuple(f"{n * a}.{a:03d}" for a in range(1, axes + 1)),
        )
        for n in range(1, 40)
    ]
    state = IaiState.from_positions(positions, axes=tuple(range(1, axes + 1)))
    family = families.get("iai")
    robot = family.new_robot("iai", "/dev/ttyUSB0", 0x99)
    return Project(Path("."), robot, IaiData(state.versions[(0, 0)], dict(state.positions)))


@pytest.mark.parametrize("axes", [3, 4, 8])
def test_iai_files_are_byte_identical_to_the_emitters(axes: int) -> None:
    project = _iai_project(axes)
    yamlwrite._WRITTEN.clear()
    written = _rendered(project)
    assert written["positions.yaml"] in yamlwrite._WRITTEN  # by the writer, not the emitter
    yamlwrite._WRITTEN.clear()
    with _emitter_only():
        emitted = _rendered(project)
    assert written == emitted


def test_a_save_checks_what_it_wrote_without_parsing_it_again(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    project = load_project(EXAMPLES / "pick-and-place")
    yamlwrite._WRITTEN.clear()  # renderings of earlier tests that nothing parsed
    parsed: list[str] = []
    real = yamlwrite._recall

    def recall(text: str) -> yamlio.Parsed | None:
        known = real(text)
        if known is None:
            parsed.append(text.splitlines()[0])
        return known

    monkeypatch.setattr(yamlio, "_recall", recall)
    with tempfile.TemporaryDirectory() as tmp:
        save_project(tmp, project)
    # Only robot.yaml is parsed: its maintenance windows are a block sequence, which
    # the writer leaves to the emitter.
    assert parsed == ["# yaml-language-server: $schema=.schemas/robot.schema.json"]
    assert not yamlwrite._WRITTEN  # every rendering was taken once


def test_a_document_the_writer_leaves_to_the_emitter_is_parsed_back_for_real() -> None:
    windows = yamlio.sequence([yamlio.mapping([("start", yamlio.quoted("22:00"))])])
    node = yamlio.mapping([("maintenance_windows", windows)])
    assert yamlwrite._Writer("").document(node) is None
    text = yamlio.dump(node)
    assert text == 'maintenance_windows:\n  - start: "22:00"\n'
    assert yamlio.parse(text).data == {"maintenance_windows": [{"start": "22:00"}]}


def test_a_mapping_node_of_sequences_nested_is_left_to_the_emitter() -> None:
    inner = SequenceNode(yamlio.SEQ, [yamlio.text("a")], flow_style=True)
    node = yamlio.mapping([("x", yamlio.sequence([inner], flow=True))])
    assert yamlwrite._Writer("").document(node) is None


# --- a row of numbers (issue 24: an IAI position's line without a node per number) ------


def test_issue_24_a_row_is_written_as_the_mapping_it_stands_for() -> None:
    items: list[tuple[str, yamlio.RowValue]] = [
        ("axes", ["1", "2", "4"]),
        ("coords", ["-0.500", "12.000", "1e5"]),
        ("acc", "0.30"),
        ("none", []),
        ("arm1", yamlio.text("left")),
        ("inner", yamlio.row([("x", "1")])),
    ]
    as_nodes = yamlio.mapping(
        [
            ("axes", yamlio.sequence([yamlio.num(n) for n in ("1", "2", "4")], flow=True)),
            (
                "coords",
                yamlio.sequence([yamlio.num(n) for n in ("-0.500", "12.000", "1e5")], flow=True),
            ),
            ("acc", yamlio.num("0.30")),
            ("none", yamlio.sequence([], flow=True)),
            ("arm1", yamlio.text("left")),
            ("inner", yamlio.mapping([("x", yamlio.num("1"))], flow=True)),
        ],
        flow=True,
    )
    row = yamlio.mapping([(yamlio.num("7"), yamlio.row(items))])
    assert _same_as_emitter(row)
    written = yamlwrite._Writer("").document(row)
    assert written is not None
    assert written[0] == yamlwrite._emit(yamlio.mapping([(yamlio.num("7"), as_nodes)]), "")


@pytest.mark.parametrize("key", ["a: b", "5", "true", "", "x" * 130, "- a"])
def test_issue_24_a_row_with_a_key_to_quote_is_still_written_as_the_emitter_writes_it(
    key: str,
) -> None:
    _same_as_emitter(yamlio.mapping([("k", yamlio.row([(key, "1"), ("b", ["2"])]))]))


def test_issue_24_a_row_shared_or_changed_is_written_as_its_nodes() -> None:
    shared = yamlio.row([("a", "1")])
    assert not _same_as_emitter(yamlio.mapping([("x", shared), ("y", shared)]))  # an alias
    changed = yamlio.row([("a", "1")])
    changed.value = [(yamlio.text("b"), yamlio.num("2"))]
    assert _same_as_emitter(yamlio.mapping([("x", changed)]))
    assert yamlio.dump(yamlio.mapping([("x", changed)])) == "x: {b: 2}\n"


@pytest.mark.parametrize("bad", ["abc", "1.2.3", "", "0x1F", ".inf"])
def test_issue_24_a_row_refuses_what_num_refuses(bad: str) -> None:
    with pytest.raises(ValueError):
        yamlio.num(bad)
    with pytest.raises(ValueError):
        yamlio.row([("a", bad)])
    with pytest.raises(ValueError):
        yamlio.row([("a", ["1", bad])])


def test_issue_24_texts_are_written_as_the_sequence_they_stand_for() -> None:
    steps = ["MOVE P001 S100", None, "END", "5.00", "- a", "true"]
    as_nodes = yamlio.sequence([yamlio.null() if t is None else yamlio.text(t) for t in steps])
    node = yamlio.mapping([("steps", yamlio.texts(steps)), ("none", yamlio.texts([]))])
    assert not _same_as_emitter(node)  # "- a" is left to the emitter: so is all of it
    ok = [t for t in steps if t != "- a"]
    node = yamlio.mapping([("steps", yamlio.texts(ok)), ("none", yamlio.texts([]))])
    assert _same_as_emitter(node)
    expected = yamlio.mapping(
        [
            (
                "steps",
                yamlio.sequence([yamlio.null() if t is None else yamlio.text(t) for t in ok]),
            ),
            ("none", yamlio.sequence([], flow=True)),
        ]
    )
    assert yamlio.dump(node) == yamlwrite._emit(expected, "")
    assert yamlwrite._emit(yamlio.mapping([("s", yamlio.texts(steps))]), "") == yamlwrite._emit(
        yamlio.mapping([("s", as_nodes)]), ""
    )
