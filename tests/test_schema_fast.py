"""The fast schema check (project/schema.py, _compile) against jsonschema, the
reference: it never passes a document jsonschema finds an error in, and it passes the
valid documents harlsync writes, so that checking them needs no jsonschema at all
(jsonschema's import alone is about the whole start-up budget of a pull: issue 32
kept the compiled check for that, inside the one check, SchemaSet.check).

Documents: every file of generated HARL-U2 projects, of IAI and Epson projects,
and of the example; then the same with one part changed at random (a value of
another type or text, a key removed or added), which jsonschema mostly refuses.
"""

from __future__ import annotations

import copy
import subprocess
import sys
from decimal import Decimal
from pathlib import Path
from typing import Any

import pytest
from conftest import examples
from families.epson.sample import sample_data
from hypothesis import given, settings
from hypothesis import strategies as st
from test_project_roundtrip import TRICKY, projects
from test_yaml_writer import _iai_project, _rendered

from harlsync import families
from harlsync.project import Project, load_project, yamlio
from harlsync.project.schema import SchemaSet, _compile

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "projects" / "pick-and-place"


def _schemas(family: str) -> SchemaSet:
    module = __import__(f"{families.FAMILIES[family]}.layout", fromlist=["SCHEMAS"])
    schemas: SchemaSet = module.SCHEMAS
    return schemas


def _kind(family: str, name: str) -> str:
    """The schema kind of a file of ``family``'s projects."""
    if name.startswith("programs/"):
        return "program"
    return name.removesuffix(".yaml")


def _documents(project: Project) -> list[tuple[str, str, Any]]:
    """(family, kind, data) of every file of ``project``."""
    family = project.robot.family
    return [
        (family, _kind(family, name), yamlio.parse(text).data)
        for name, text in _rendered(project).items()
    ]


def _fast(family: str, kind: str) -> Any:
    schemas = _schemas(family)
    schema = schemas.schema(kind)
    check = _compile(schema, schema, schemas._patterns)
    assert check is not None, f"{family} {kind}: the fast check cannot compile its schema"
    return check


def _jsonschema_errors(family: str, kind: str, data: Any) -> list[str]:
    return [error.message for error in _schemas(family)._validator(kind).iter_errors(data)]


def _agree(family: str, kind: str, data: Any) -> None:
    if _fast(family, kind)(data):
        errors = _jsonschema_errors(family, kind, data)
        assert not errors, f"{family} {kind}: passed by the fast check, refused: {errors}"


OTHERS = [
    Project(
        Path("."),
        families.get("epson").new_robot("cell", "modbus://10.0.0.5", None),
        sample_data(axes),
    )
    for axes in (4, 6)
] + [_iai_project(a) for a in (3, 8)]


@settings(max_examples=examples(20))
@given(projects())
def test_every_valid_harl_u2_file_passes_the_fast_check(project: Project) -> None:
    for family, kind, data in _documents(project):
        errors = _jsonschema_errors(family, kind, data)
        if not errors:
            assert _fast(family, kind)(data), f"{kind}: valid, not passed"


@pytest.mark.parametrize(
    "project",
    [load_project(EXAMPLE), *OTHERS],
    ids=["example", "epson-4", "epson-6", "iai-3", "iai-8"],
)
def test_every_file_of_the_families_passes_the_fast_check(project: Project) -> None:
    for family, kind, data in _documents(project):
        assert not _jsonschema_errors(family, kind, data), (family, kind)
        assert _fast(family, kind)(data), (family, kind)


# --- changed documents ---------------------------------------------------------------

replacement = st.one_of(
    st.text(max_size=8),
    st.sampled_from(TRICKY),
    st.sampled_from(
        [
            "0",
            "12",
            "-3",
            "1.5",
            "0.00",
            "1000000000",
            "99999999999",
            "1e3",
            "-0.005",
            "1000",
            "0.001",
            "300",
            "256",
        ]
    ).map(yamlio.Number),
    st.booleans(),
    st.none(),
    st.just({}),
    st.just([]),
    st.just({"x": 1}),
    st.integers(-5, 300),
    st.floats(allow_nan=False, width=32),
    st.decimals(places=2).filter(lambda d: d.is_finite()).map(Decimal),
)


def _paths(data: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [path]
    if isinstance(data, dict):
        for key, value in data.items():
            out += _paths(value, (*path, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            out += _paths(value, (*path, i))
    return out


def _change(data: Any, path: tuple[Any, ...], how: str, value: Any) -> Any:
    changed = copy.deepcopy(data)
    if not path:
        return value if how == "replace" else changed
    parent = changed
    for part in path[:-1]:
        parent = parent[part]
    last = path[-1]
    if how == "replace":
        parent[last] = value
    elif how == "remove" and isinstance(parent, dict):
        del parent[last]
    elif how == "add" and isinstance(parent, dict):
        parent[str(value)[:12] if not isinstance(value, str) else value] = value
    elif how == "add" and isinstance(parent, list):
        parent.append(value)
    return changed


SOURCES = [doc for project in [load_project(EXAMPLE), *OTHERS] for doc in _documents(project)]


@settings(max_examples=examples(1000))
@given(
    st.sampled_from(SOURCES), st.data(), st.sampled_from(["replace", "remove", "add"]), replacement
)
def test_a_changed_document_is_never_passed_when_jsonschema_refuses_it(
    source: tuple[str, str, Any], data: st.DataObject, how: str, value: Any
) -> None:
    family, kind, document = source
    path = data.draw(st.sampled_from(_paths(document)))
    _agree(family, kind, _change(document, path, how, value))


def test_reading_a_valid_robot_yaml_needs_no_jsonschema() -> None:
    # Start-up: a pull reads robot.yaml before its first request; jsonschema (about
    # 0.05 s to import) is imported only for a file the fast check cannot pass.
    code = (
        "import sys; from harlsync.project import load_robot; "
        f"load_robot({str(EXAMPLE)!r}); print('jsonschema' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


@pytest.mark.parametrize("family", sorted(families.FAMILIES))
def test_issue_24_a_schema_is_read_as_the_resources_api_reads_it(family: str) -> None:
    from importlib.resources import files

    schemas = _schemas(family)
    for kind in schemas.kinds:
        name = f"{kind}.schema.json"
        assert schemas.text(kind) == files(schemas.package).joinpath(name).read_text("utf-8")
