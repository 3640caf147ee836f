"""Issue 21: the engine names no family.

Outside ``harlsync/families/`` no module imports a family package, and no code
(a name, an attribute or a string that is not a docstring) names a family: what
only a family knows it declares (``Family.options``, ``schemes``, ``words``,
``help``), and the command line, the line lock and the engine read it from there.
Docstrings may give a family as an example.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import harlsync

ROOT = Path(harlsync.__file__).parent
TESTS = Path(__file__).parent
FAMILY_WORDS = re.compile(r"harl.?u2|\biai\b|epson|modbus", re.IGNORECASE)


def _engine_modules() -> list[Path]:
    return [p for p in sorted(ROOT.rglob("*.py")) if "families" not in p.relative_to(ROOT).parts]


def _docstrings(tree: ast.AST) -> set[int]:
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            first = node.body[0] if node.body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def _family_words_in_code(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = _docstrings(tree)
    found = []
    for node in ast.walk(tree):
        text = None
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            text = node.value
        elif isinstance(node, ast.Name):
            text = node.id
        elif isinstance(node, ast.Attribute):
            text = node.attr
        elif isinstance(node, ast.alias):
            text = node.name
        elif isinstance(node, ast.ImportFrom):
            text = node.module or ""
        if text is not None and FAMILY_WORDS.search(text):
            found.append(
                f"{path.relative_to(ROOT.parent)}:{getattr(node, 'lineno', '?')}: {text!r}"
            )
    return found


def test_issue_21_no_module_outside_the_families_names_a_family_in_code() -> None:
    found = [line for path in _engine_modules() for line in _family_words_in_code(path)]
    assert found == []


def test_issue_32_an_installed_distribution_adds_a_family_through_its_entry_point(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A site adds a family without editing the registry: its distribution declares
    the package in the ``harlsync.families`` entry-point group, and ``--family``,
    the registry and a robot.yaml then know it."""
    import importlib.metadata

    from harlsync import cli, families

    point = importlib.metadata.EntryPoint("toy", "toyfamily", families.ENTRY_POINTS)
    asked: list[str] = []

    def entry_points(*, group: str) -> list[importlib.metadata.EntryPoint]:
        asked.append(group)
        return [point] if group == families.ENTRY_POINTS else []

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    monkeypatch.setattr(families, "FAMILIES", dict(families.FAMILIES))
    monkeypatch.setattr(families, "_discovered", False)
    assert families.get("harl-u2").name == "harl-u2"
    assert asked == []  # a registered name needs no look at the installed distributions
    assert families.get("toy").name == "toy"
    assert asked == [families.ENTRY_POINTS]
    assert "toy" in families.names() and "toy" in families.KNOWN
    with pytest.raises(SystemExit):
        cli.main(["pull", "--help"])
    assert "toy" in capsys.readouterr().out


def test_issue_32_a_family_asked_for_while_another_thread_discovers_them_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A backup's lines are read in threads: one thread's lookup of an installed
    family, made while another thread is still reading the installed entry points,
    finds it (it was "unknown controller family" while the first thread had marked
    the discovery done before it was)."""
    import importlib.metadata
    import threading

    from harlsync import families

    point = importlib.metadata.EntryPoint("toy", "toyfamily", families.ENTRY_POINTS)
    found: list[str] = []
    asked: list[str] = []

    def other_line() -> None:
        found.append(families.get("toy").name)

    def entry_points(*, group: str) -> list[importlib.metadata.EntryPoint]:
        asked.append(group)
        if len(asked) == 1:  # the first discovery: another line asks before it is over
            thread = threading.Thread(target=other_line)
            thread.start()
            thread.join()
        return [point] if group == families.ENTRY_POINTS else []

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    monkeypatch.setattr(families, "FAMILIES", dict(families.FAMILIES))
    monkeypatch.setattr(families, "_discovered", False)
    assert families.get("toy").name == "toy"
    assert found == ["toy"]


def _imports_of(path: Path, module: str, modules: set[str]) -> set[str]:
    """The harlsync modules ``module`` (at ``path``) imports, anywhere in it: at the
    top, under TYPE_CHECKING, or inside a function (``from . import x`` imports the
    module ``x``, not its package's ``__init__``)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
            target = ".".join([*base, node.module] if node.module else base)
            if not node.level:
                target = node.module or ""
            for alias in node.names:
                named = f"{target}.{alias.name}"
                found.add(named if named in modules else target)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return found


def test_issue_32_no_module_of_harlsync_imports_one_that_imports_it_back() -> None:
    """Issue 32 item 4: no import cycle, not even a type-only or a lazy one (audit and
    auditindex, backup and fleet, deploy and writes, sim/device and sim/family were)."""
    modules = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        modules[name] = path
    graph = {
        name: {m for m in _imports_of(path, name, set(modules)) if m in modules and m != name}
        for name, path in modules.items()
    }
    cycles = []
    for start, imported in graph.items():  # a path from its imports back to start
        seen, todo = set(), list(imported)
        while todo:
            here = todo.pop()
            if here == start:
                cycles.append(start)
                break
            if here not in seen:
                seen.add(here)
                todo.extend(graph[here])
    assert cycles == []


def test_issue_32_the_registry_looks_up_what_the_command_line_says_of_every_family(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 32 item 2: each family's ``--help`` phrases, its connection options and
    its URL schemes are looked up in the registry, in its order (an option two
    families offer, once); the command line only adds them to its parsers.  Item 5:
    what a family calls its reconfiguration is its own phrase, not the CLI's."""
    import sys
    from types import ModuleType

    from toyfamily.family import ToyFamily

    from harlsync import cli, families
    from harlsync.families.base import Help, Option, Scheme

    class Other(ToyFamily):
        name = "other"
        options = (Option("reset", "reset it (other)"), Option("slow", "go slow (other)"))
        schemes = (Scheme("other", 7, "an Other controller: other://HOST[:PORT]"),)
        help = Help(stations="A-F", runtime="counters", reconfigure="RCF")

    class Third(ToyFamily):
        name = "third"
        options = (Option("reset", "reset it (third)"),)
        help = Help()

    for package, family in (("otherfamily", Other()), ("thirdfamily", Third())):
        module = ModuleType(f"{package}.family")
        module.FAMILY = family  # type: ignore[attr-defined]
        monkeypatch.setitem(sys.modules, package, ModuleType(package))
        monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setattr(
        families, "FAMILIES", {"toy": "toyfamily", "other": "otherfamily", "third": "thirdfamily"}
    )
    monkeypatch.setattr(families, "_discovered", True)

    assert families.help_phrases("stations") == "toy: 0-99; other: A-F"
    assert families.help_phrases("runtime") == "other: counters"
    assert families.help_phrases("busy") == ""
    assert [(o.name, o.help) for o in families.options()] == [
        ("reset", "reset it (other)"),
        ("slow", "go slow (other)"),
    ]
    assert families.port_kinds() == (
        "/dev/ttyUSB0, COM3, socket://HOST:PORT, rfc2217://HOST:PORT, sim://PROJECT_DIR; "
        "an Other controller: other://HOST[:PORT]"
    )
    monkeypatch.setenv("COLUMNS", "1000")
    with pytest.raises(SystemExit):
        cli.main(["pull", "--help"])
    shown = capsys.readouterr().out
    assert "(toy: 0-99; other: A-F)" in shown
    assert "sim://PROJECT_DIR; an Other controller: other://HOST[:PORT]" in shown
    assert "--reset" in shown and "go slow (other)" in shown
    with pytest.raises(SystemExit):
        cli.main(["push", "--help"])
    assert "reconfigures the controller and clears what it holds (other: RCF);" in (
        capsys.readouterr().out.replace("\n", " ")
    )


#: The engine's tests (and helpers) that still import a family: each drives a HARL-U2
#: (or an IAI or Epson) simulator, or reads or writes one family's files, as the robot
#: of an engine test. They are the ones where the toy family (tests/toyfamily/; conftest's
#: ``toy``, and ``toy_installed`` for a harlsync process) does not yet serve: a family's
#: own files edited on disk, its line timing or frames, its words asserted. A test
#: converted to the toy leaves this list;
#: a family's own tests live in tests/families/<family>/, and what every family does in
#: tests/conformance/.
FAMILY_USERS = {
    "plantsim.py",
    "simline.py",
    "test_bad_input.py",
    "test_feedback.py",
    "test_fleet.py",
    "test_link.py",
    "test_link_pacing.py",
    "test_probe.py",
    "test_process_faults.py",
    "test_project_roundtrip.py",
    "test_project_save.py",
    "test_robot_yaml.py",
    "test_rough_edges.py",
    "test_schema_fast.py",
    "test_startup.py",
    "test_sync.py",
    "test_yaml_writer.py",
}


def _is_family(module: str) -> bool:
    """``module`` is (in) a family package: harlsync's own (harlsync.families.<name>),
    or one family's test package (tests/families/<name>/, imported as families.<name>)."""
    parts = module.split(".")
    if parts[:2] == ["harlsync", "families"] and len(parts) > 2:
        return (ROOT / "families" / parts[2] / "__init__.py").is_file()
    return parts[0] == "families" and len(parts) > 1


def _family_imports(path: Path) -> list[str]:
    """The family packages ``path`` imports, anywhere in it, as ``line: module``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            named = [node.module, *(f"{node.module}.{alias.name}" for alias in node.names)]
            if any(_is_family(module) for module in named):
                found.append(f"{node.lineno}: {node.module}")
        elif isinstance(node, ast.Import):
            found += [f"{node.lineno}: {a.name}" for a in node.names if _is_family(a.name)]
    return found


def test_issue_32_no_engine_test_imports_a_family_but_the_listed_ones() -> None:
    """Issue 32 item 6: tests are laid out as the code is. Outside tests/families/ and
    tests/conformance/ a test imports no family package, unless FAMILY_USERS lists it
    (and a listed one that no longer does leaves the list)."""
    users = {}
    for path in sorted(TESTS.rglob("*.py")):
        relative = path.relative_to(TESTS)
        if relative.parts[0] not in ("families", "conformance", "toyfamily"):
            imports = _family_imports(path)
            if imports:
                users[relative.as_posix()] = imports
    assert {name: found for name, found in users.items() if name not in FAMILY_USERS} == {}
    assert sorted(FAMILY_USERS - set(users)) == []
