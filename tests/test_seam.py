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

import harlsync

ROOT = Path(harlsync.__file__).parent
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
