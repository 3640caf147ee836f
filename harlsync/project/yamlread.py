"""Reading project YAML: the core-schema resolver, exact-text numbers, and the
node tree built into plain data with the line of every path (see
:mod:`harlsync.project.yamlio`, which says how, and re-exports these names).

The ``yaml*`` modules are one unit split by job (read, nodes, write); the names
with a leading underscore that they share stay out of :mod:`yamlio`'s surface.
"""

from __future__ import annotations

import decimal
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol

from yaml.composer import Composer, ComposerError
from yaml.nodes import Node, ScalarNode, SequenceNode
from yaml.parser import Parser
from yaml.reader import Reader
from yaml.resolver import BaseResolver
from yaml.scanner import Scanner

STR = "tag:yaml.org,2002:str"
INT = "tag:yaml.org,2002:int"
FLOAT = "tag:yaml.org,2002:float"
BOOL = "tag:yaml.org,2002:bool"
NULL = "tag:yaml.org,2002:null"
MAP = "tag:yaml.org,2002:map"
SEQ = "tag:yaml.org,2002:seq"

#: A location in the data: mapping keys (text) and sequence indexes.
KeyPath = tuple[str | int, ...]

#: Deepest nesting of lists and mappings a project file may have (they need 4).
MAX_DEPTH = 64
#: Values an alias may add beyond one per character of the text (a document
#: without aliases never has more values than characters).
ALIAS_BUDGET = 10_000

_DECIMAL_INT = re.compile(r"[-+]?[0-9]+")
_DECIMAL_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")


class Number(decimal.Decimal):
    """A number read from YAML that remembers how it was written.

    ``Number("1.50") == Decimal("1.5")`` and compares exactly with the schema's
    limits, while ``.text`` is ``"1.50"``: the wire text to write back.
    """

    __slots__ = ("text",)
    text: str

    def __new__(cls, text: str) -> Number:
        obj = super().__new__(cls, text)
        obj.text = text
        return obj

    @property
    def integral(self) -> bool:
        """Written as an integer: digits only, no dot or exponent."""
        return _DECIMAL_INT.fullmatch(self.text) is not None

    def __repr__(self) -> str:
        return f"Number({self.text!r})"

    def __str__(self) -> str:
        return self.text


def is_number_text(value: str) -> bool:
    """Whether ``value`` is a plain decimal number that :class:`Number` can keep."""
    return bool(_DECIMAL_INT.fullmatch(value) or _DECIMAL_FLOAT.fullmatch(value))


class CoreResolver(BaseResolver):
    """YAML 1.2 core schema: null, bool, int, float; everything else is a string."""


CoreResolver.add_implicit_resolver(
    NULL, re.compile(r"^(?:~|null|Null|NULL|)$"), ["~", "n", "N", ""]
)
CoreResolver.add_implicit_resolver(
    BOOL, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF")
)
CoreResolver.add_implicit_resolver(
    INT, re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789")
)
CoreResolver.add_implicit_resolver(
    FLOAT,
    re.compile(
        r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
    ),
    list("-+.0123456789"),
)


class _Loader(Reader, Scanner, Parser, Composer, CoreResolver):
    """Reads a node tree; constructs nothing.  Refuses nesting deeper than MAX_DEPTH
    (PyYAML's composer recurses: deeper input would raise RecursionError)."""

    def __init__(self, stream: str) -> None:
        Reader.__init__(self, stream)
        Scanner.__init__(self)
        Parser.__init__(self)
        Composer.__init__(self)
        CoreResolver.__init__(self)
        self._depth = 0

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH + 1:
                raise ComposerError(
                    None,
                    None,
                    f"nested more than {MAX_DEPTH} levels deep",
                    self.peek_event().start_mark,  # type: ignore[no-untyped-call]
                )
            node: Node | None = super().compose_node(parent, index)
            return node
        finally:
            self._depth -= 1


try:
    from yaml.cyaml import CParser  # type: ignore[attr-defined]
except ImportError:  # PyYAML built without libyaml
    _FastLoader: type | None = None
else:

    class _CLoader(CParser, CoreResolver):
        """libyaml's parser with our resolver: same nodes, several times faster."""

        def __init__(self, stream: str) -> None:
            CParser.__init__(self, stream)
            CoreResolver.__init__(self)

    _FastLoader = _CLoader


class YamlSyntaxError(Exception):
    """Text that is not YAML (or not data we accept), at a 1-based line."""

    def __init__(self, line: int, message: str) -> None:
        self.line = line
        self.message = message
        super().__init__(f"line {line}: {message}")


@dataclass
class Parsed:
    """A parsed document: plain data, the line of each path, and duplicate keys."""

    data: Any
    lines: dict[KeyPath, int] = field(default_factory=dict)
    #: (path, first line, second line) for every key written more than once.
    duplicates: list[tuple[KeyPath, int, int]] = field(default_factory=list)

    def line(self, path: Iterable[str | int]) -> int:
        """The line of ``path``, or of its nearest ancestor that has one."""
        path = tuple(path)
        while path and path not in self.lines:
            path = path[:-1]
        return self.lines.get(path, 1)


class _Budget:
    """How many more values :func:`_build` may make (aliases can multiply them)."""

    def __init__(self, values: int) -> None:
        self.left = values

    def spend(self, node: Node) -> None:
        self.left -= 1
        if self.left < 0:
            raise YamlSyntaxError(
                _line(node),
                "aliases expand to far more values than the file holds (a 'billion laughs'); "
                "write the values out instead of repeating aliases",
            )


class _Composing(Protocol):
    """What :func:`_compose` asks of a loader (ours, or libyaml's)."""

    def get_single_node(self) -> Node | None: ...

    def dispose(self) -> None: ...


def _compose(loader: _Composing) -> Node | None:
    try:
        node: Node | None = loader.get_single_node()
    finally:
        loader.dispose()
    return node


def _line(node: Node) -> int:
    return node.start_mark.line + 1


def _build(node: Node, path: KeyPath, out: Parsed, active: set[int], budget: _Budget) -> object:
    budget.spend(node)
    out.lines.setdefault(path, _line(node))
    if isinstance(node, ScalarNode):
        return _scalar(node)
    if id(node) in active:
        raise YamlSyntaxError(_line(node), "recursive alias")
    if len(active) >= MAX_DEPTH:  # libyaml composes deeper than the pure-Python loader
        raise YamlSyntaxError(_line(node), f"nested more than {MAX_DEPTH} levels deep")
    active.add(id(node))
    try:
        if isinstance(node, SequenceNode):
            if node.tag != SEQ:
                raise YamlSyntaxError(_line(node), f"unsupported tag {node.tag}")
            return [
                _build(item, (*path, i), out, active, budget) for i, item in enumerate(node.value)
            ]
        if node.tag != MAP:
            raise YamlSyntaxError(_line(node), f"unsupported tag {node.tag}")
        result: dict[str, object] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, ScalarNode):
                raise YamlSyntaxError(_line(key_node), "a mapping key must be a plain value")
            key = _key(key_node)
            key_path = (*path, key)
            if key in result:
                out.duplicates.append((key_path, out.lines[key_path], _line(key_node)))
                continue
            out.lines[key_path] = _line(key_node)
            result[key] = _build(value_node, key_path, out, active, budget)
        return result
    finally:
        active.discard(id(node))


def _scalar(node: ScalarNode) -> Number | str | bool | None:
    value: str = node.value
    if node.tag in (INT, FLOAT):
        # 0x1F, .inf and friends are core-schema numbers Number cannot keep: text.
        return Number(value) if is_number_text(value) else value
    if node.tag == BOOL:
        if value.lower() not in ("true", "false"):
            raise YamlSyntaxError(_line(node), f"{value!r} is not true or false")
        return value.lower() == "true"
    if node.tag == NULL:
        return None
    if node.tag == STR:
        return value
    raise YamlSyntaxError(_line(node), f"unsupported tag {node.tag}")


def _key(node: ScalarNode) -> str:
    """A key's text; integer keys are normalised (``07`` and ``7`` are the same key)."""
    value = str(node.value)
    if node.tag == INT and _DECIMAL_INT.fullmatch(value):
        # As str(int(value)), without int(): a key of 5000 digits is still a key.
        digits = value.lstrip("+-").lstrip("0") or "0"
        return "-" + digits if value.startswith("-") and digits != "0" else digits
    return value
