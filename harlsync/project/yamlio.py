"""YAML in and out for project files, keeping every number's exact text.

How this works
--------------
PyYAML resolves plain scalars by YAML 1.1 rules, which turn a register ``0012``
into octal 10 and a time ``22:00`` into 1320.  Project files use the YAML 1.2
*core* schema instead (:class:`CoreResolver`), and never let PyYAML construct
Python objects: :func:`parse` composes the node tree and builds the data itself.

- an int or float scalar becomes a :class:`Number`, a ``Decimal`` that keeps its
  source text (``1.50`` stays ``"1.50"``, ``0012`` stays ``"0012"``);
- every mapping key becomes its text (``7`` -> ``"7"``), so the data looks like
  JSON to the schema validator, and a key written twice is reported with both lines;
- the line of every path is recorded for error messages;
- hostile input is refused as a syntax error, never a crash or a hang: nesting
  deeper than :data:`MAX_DEPTH`, and aliases that expand to more values than the
  text could hold (a "billion laughs"), see :data:`ALIAS_BUDGET`.

Writing goes the other way: callers build nodes with :func:`num`, :func:`text`,
:func:`mapping` ... and :func:`dump` serializes them with the same resolver, so a
number is written plain with its exact text and a string is quoted only when it
would otherwise read back as something else.  The output is deterministic, which
makes load -> save byte-identical.
"""

from __future__ import annotations

import decimal
import io
import re
import threading
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import yaml
from yaml.composer import Composer, ComposerError
from yaml.emitter import Emitter
from yaml.nodes import CollectionNode, MappingNode, Node, ScalarNode, SequenceNode
from yaml.parser import Parser
from yaml.reader import Reader, ReaderError
from yaml.resolver import BaseResolver
from yaml.scanner import Scanner
from yaml.serializer import Serializer

__all__ = [
    "CoreResolver",
    "KeyPath",
    "Number",
    "Parsed",
    "YamlSyntaxError",
    "boolean",
    "dump",
    "mapping",
    "null",
    "num",
    "parse",
    "quoted",
    "row",
    "scalar_for",
    "sequence",
    "text",
    "texts",
]

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


def parse(source: str) -> Parsed:
    """Parse one YAML document.

    Raises :class:`YamlSyntaxError` for a syntax error, several documents, an
    unknown tag, a non-scalar mapping key or a recursive alias.
    """
    written = _recall(source)
    if written is not None:
        return written
    node = None
    if _FastLoader is not None:
        try:
            node = _compose(_FastLoader(source))
        except (yaml.YAMLError, RecursionError):
            pass  # report it as the pure-Python parser words it, on every install
    if node is None:
        try:
            node = _compose(_Loader(source))
        except ReaderError as exc:
            # Its str() is two lines and names a character position: say the line.
            line = source.count("\n", 0, exc.position) + 1
            raise YamlSyntaxError(
                line,
                f"unacceptable character #x{exc.character:04x}: control characters are not allowed",
            ) from None
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            line = mark.line + 1 if mark is not None else 1
            problem = exc.problem or exc.context or "invalid YAML"
            if exc.context and exc.problem and exc.context_mark is not None:
                problem = f"{problem} ({exc.context} at line {exc.context_mark.line + 1})"
            raise YamlSyntaxError(line, problem) from None
        except yaml.YAMLError as exc:
            raise YamlSyntaxError(1, str(exc)) from None
    parsed = Parsed(None)
    if node is not None:
        budget = _Budget(len(source) + ALIAS_BUDGET)
        parsed.data = _build(node, (), parsed, set(), budget)
    return parsed


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


def _compose(loader: Any) -> Node | None:
    try:
        node: Node | None = loader.get_single_node()
    finally:
        loader.dispose()
    return node


def _line(node: Node) -> int:
    return node.start_mark.line + 1


def _build(node: Node, path: KeyPath, out: Parsed, active: set[int], budget: _Budget) -> Any:
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
        result: dict[str, Any] = {}
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


def _scalar(node: ScalarNode) -> Any:
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


# -- writing ---------------------------------------------------------------------


def num(value: str) -> ScalarNode:
    """A number written exactly as ``value`` (which must be a decimal number)."""
    if _DECIMAL_INT.fullmatch(value):
        return ScalarNode(INT, value)
    if not _DECIMAL_FLOAT.fullmatch(value):
        raise ValueError(f"not a decimal number: {value!r}")
    return ScalarNode(FLOAT, value)


def text(value: str) -> ScalarNode:
    """A string; the emitter quotes it only when it would read back as another type."""
    return ScalarNode(STR, value)


def quoted(value: str) -> ScalarNode:
    """A string always written in double quotes (times like ``"22:00"``, which
    YAML 1.1 tools would read as a number of minutes)."""
    return ScalarNode(STR, value, style='"')


def boolean(value: bool) -> ScalarNode:
    return ScalarNode(BOOL, "true" if value else "false")


def null() -> ScalarNode:
    """Nothing: ``null`` (a setting deliberately left out, such as an unmapped signal)."""
    return ScalarNode(NULL, "null")


def scalar_for(value: str) -> ScalarNode:
    """Wire text of unknown kind: a plain number when it is one, else a string."""
    return num(value) if is_number_text(value) else text(value)


def mapping(items: Iterable[tuple[str | Node, Node]], *, flow: bool = False) -> MappingNode:
    """A mapping in the given key order; string keys become plain/quoted strings."""
    pairs = [(text(k) if isinstance(k, str) else k, v) for k, v in items]
    return MappingNode(MAP, pairs, flow_style=flow)


def sequence(items: Iterable[Node], *, flow: bool = False) -> SequenceNode:
    return SequenceNode(SEQ, list(items), flow_style=flow)


#: What a :func:`row` holds under a key: a number's text, a list of them, or a node.
RowValue = str | list[str] | Node


def row(items: Iterable[tuple[str, RowValue]]) -> MappingNode:
    """A flow mapping of numbers, a table's row on one line (an IAI position), as
    ``mapping(..., flow=True)`` with each number text given as :func:`num` and each
    list of them as ``sequence([num(...), ...], flow=True)``, or a node given as it
    is: the same document and the same data read back, without a node per number
    (a full-size table has ten thousand of them).  Raises ValueError as :func:`num`
    does, for a text that is not a decimal number."""
    return _Row(list(items))


class _Row(MappingNode):
    """:func:`row`'s node: :class:`_Writer` writes its items directly; anything else
    (PyYAML's emitter) finds the nodes ``mapping`` would have held, made when first
    asked for."""

    def __init__(self, items: list[tuple[str, RowValue]]) -> None:
        for key, value in items:
            if not isinstance(key, str):
                raise TypeError(f"a row's key is text, not {key!r}")
            if isinstance(value, str):
                _number_text(value)
            elif isinstance(value, list):
                for each in value:
                    _number_text(each)
            elif not isinstance(value, Node):
                raise TypeError(f"a row holds number texts, lists of them or nodes, not {value!r}")
        self.items = items
        self._nodes: list[tuple[Node, Node]] | None = None
        super().__init__(MAP, None, flow_style=True)

    @property
    def value(self) -> list[tuple[Node, Node]]:
        if self._nodes is None:
            self._nodes = [(text(key), _row_node(value)) for key, value in self.items]
        return self._nodes

    @value.setter
    def value(self, nodes: list[tuple[Node, Node]] | None) -> None:
        self._nodes = nodes


def texts(values: Iterable[str | None]) -> SequenceNode:
    """A block sequence of texts, an item a line, ``None`` written ``null`` (a
    program's steps), as ``sequence([text(v) if v is not None else null() ...])``
    would be, without a node per item (a full-size robot has 12,544 steps)."""
    return _Texts(list(values))


class _Texts(SequenceNode):
    """:func:`texts`'s node: :class:`_Writer` writes its items directly; PyYAML's
    emitter finds the nodes ``sequence`` would have held, made when first asked for."""

    def __init__(self, items: list[str | None]) -> None:
        for item in items:
            if item is not None and not isinstance(item, str):
                raise TypeError(f"texts holds text or None, not {item!r}")
        self.items = items
        self._nodes: list[Node] | None = None
        super().__init__(SEQ, None, flow_style=False)

    @property
    def value(self) -> list[Node]:
        if self._nodes is None:
            self._nodes = [null() if item is None else text(item) for item in self.items]
        return self._nodes

    @value.setter
    def value(self, nodes: list[Node] | None) -> None:
        self._nodes = nodes


def _number_text(value: str) -> None:
    if not _DECIMAL_FLOAT.fullmatch(value):  # every decimal integer matches it too
        raise ValueError(f"not a decimal number: {value!r}")


def _row_node(value: RowValue) -> Node:
    if isinstance(value, str):
        return num(value)
    if isinstance(value, list):
        return sequence([num(each) for each in value], flow=True)
    return value


class _IndentingEmitter(Emitter):
    """Indents block sequences under their key (PyYAML's default does not)."""

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        super().increase_indent(flow, False)


class _Dumper(_IndentingEmitter, Serializer, CoreResolver):
    def __init__(self, stream: Any) -> None:
        _IndentingEmitter.__init__(
            self, stream, indent=2, width=1 << 30, allow_unicode=True, line_break="\n"
        )
        Serializer.__init__(self)
        CoreResolver.__init__(self)


def dump(node: Node, *, header: str = "") -> str:
    """Serialize ``node`` as one YAML document, after the ``header`` comment lines.

    The project files' own layouts (block mappings of plain scalars, flow mappings
    and sequences of them: a step a line, a table a line) are written by
    :class:`_Writer`, which also keeps what :func:`parse` would read back from the
    text, so that a save checks its files without parsing them again.  Anything
    else goes through PyYAML's emitter, which the writer matches byte for byte
    (tests/test_yaml_writer.py proves it against the emitter).
    """
    fast = _Writer(header).document(node)
    if fast is not None:
        text, parsed = fast
        _remember(text, parsed)
        return text
    return _emit(node, header)


def _emit(node: Node, header: str) -> str:
    """``node`` as PyYAML's emitter writes it, after ``header``."""
    stream = io.StringIO()
    dumper = _Dumper(stream)
    try:
        dumper.open()
        dumper.serialize(node)
        dumper.close()
    finally:
        dumper.dispose()
    return header + stream.getvalue()


# -- the writer of our own layouts ---------------------------------------------------


class _Bail(Exception):
    """The node holds something :class:`_Writer` leaves to PyYAML's emitter."""


#: A scalar the emitter writes as it is (plain), in a block or a flow: letters,
#: digits, punctuation that means nothing to YAML anywhere in a scalar, inner spaces;
#: not ``-`` alone or before a space (a list item), nor ``---`` or ``...`` first.
_PLAIN = re.compile(
    r"(?!-(?: |$)|---|\.\.\.)[A-Za-z0-9_./+=$^;~(-][A-Za-z0-9 _./+=$^;~()<-]*(?<! )"
)
#: What a ``'...'`` scalar holds as it is, but for its quotes, written twice.
_SINGLE_QUOTABLE = re.compile(r"[\x20-\x7e]+")
#: What a ``"..."`` scalar holds as it is (no quote, no backslash: nothing to escape).
_DOUBLE_QUOTABLE = re.compile(r"[\x20-\x21\x23-\x5b\x5d-\x7e]*")
_RESOLVERS: dict[str, list[tuple[str, re.Pattern[str]]]] = CoreResolver.yaml_implicit_resolvers


def _implicit(value: str) -> str:
    """The tag a plain ``value`` reads back as (CoreResolver.resolve, for plain text)."""
    for tag, regexp in _RESOLVERS.get(value[:1], ()):
        if regexp.match(value):
            return tag
    return STR


class _Writer:
    """Writes a document of the project files' layouts exactly as PyYAML's emitter
    (``_Dumper``: indent 2, no line width) does, and builds what :func:`parse` makes
    of the result: the data and the line of every path.

    Handled: a block mapping at the top; in block mappings, scalars, non-empty block
    mappings, block sequences of scalars, and flow mappings and sequences of scalars
    (empty ones as ``{}`` and ``[]``), flow mappings also of flow mappings and
    sequences; scalars that the emitter writes plain or quoted without escapes or line
    breaks.  Anything else (other block sequences, keys to quote, duplicate keys, non-ASCII
    text, tags to write) raises :class:`_Bail` inside and gives ``None``: the caller
    uses the emitter.
    """

    def __init__(self, header: str) -> None:
        self.header = header
        self.out: list[str] = []
        self.line = header.count("\n") + 1  # the line the next output line is on
        self.parsed = Parsed(None)
        # Every node written (ids): one met twice would be written as an anchor and an
        # alias.  Checked once at the end.
        self.nodes: list[int] = []

    def document(self, node: Node) -> tuple[str, Parsed] | None:
        if not (
            isinstance(node, MappingNode) and node.tag == MAP and node.value and not node.flow_style
        ):
            return None
        try:
            self.parsed.data = self._block(node, "", ())
        except _Bail:
            return None
        if len(set(self.nodes)) != len(self.nodes):
            return None
        self.out.append("")
        return self.header + "\n".join(self.out), self.parsed

    def _block(self, node: MappingNode, indent: str, path: KeyPath) -> dict[str, Any]:
        self.nodes.append(id(node))
        lines = self.parsed.lines
        lines.setdefault(path, self.line)
        result: dict[str, Any] = {}
        for key_node, value in node.value:
            shown, key = self._key(key_node)
            if key in result:
                raise _Bail  # parse reports it: leave the lines to parse
            at = (*path, key)
            lines[at] = self.line
            if isinstance(value, ScalarNode):
                text, result[key] = self._scalar(value)
                self._emit(f"{indent}{shown}: {text}")
            elif type(value) is _Row:
                text, result[key] = self._row(value, at)
                self._emit(f"{indent}{shown}: {text}")
            elif isinstance(value, MappingNode) and value.tag == MAP:
                if value.value and not value.flow_style:
                    self._emit(f"{indent}{shown}:")
                    result[key] = self._block(value, indent + "  ", at)
                else:
                    text, result[key] = self._flow_mapping(value, at)
                    self._emit(f"{indent}{shown}: {text}")
            elif type(value) is _Texts and value._nodes is None:
                if value.items:
                    self._emit(f"{indent}{shown}:")
                    result[key] = self._texts(value, indent + "  ", at)
                else:  # as an empty sequence is written: []
                    text, result[key] = self._flow_sequence(value, at)
                    self._emit(f"{indent}{shown}: {text}")
            elif (
                isinstance(value, SequenceNode)
                and value.tag == SEQ
                and (value.flow_style or not value.value)
            ):
                text, result[key] = self._flow_sequence(value, at)
                self._emit(f"{indent}{shown}: {text}")
            elif isinstance(value, SequenceNode) and value.tag == SEQ:
                self._emit(f"{indent}{shown}:")
                result[key] = self._block_sequence(value, indent + "  ", at)
            else:
                raise _Bail
        return result

    def _block_sequence(self, node: SequenceNode, indent: str, path: KeyPath) -> list[Any]:
        """A block sequence of scalars, an item a line (a program's steps)."""
        self.nodes.append(id(node))
        lines, line, out, scalar = self.parsed.lines, self.line, self.out, self._scalar
        lines.setdefault(path, line)
        result = []
        dash = f"{indent}- "
        for i, value in enumerate(node.value):
            if not isinstance(value, ScalarNode):
                raise _Bail
            lines.setdefault((*path, i), line)
            text, data = scalar(value)
            out.append(dash + text)
            result.append(data)
            line += 1
        self.line = line
        return result

    def _flow_mapping(self, node: MappingNode, path: KeyPath) -> tuple[str, dict[str, Any]]:
        self.nodes.append(id(node))
        lines, line, scalar, key_of = self.parsed.lines, self.line, self._scalar, self._key
        lines.setdefault(path, line)
        parts, result = [], {}
        for key_node, value in node.value:
            shown, key = key_of(key_node)
            if key in result:
                raise _Bail
            at = (*path, key)
            lines[at] = line
            if isinstance(value, ScalarNode):
                text, result[key] = scalar(value)
            else:
                text = self._flow_value(value, at, result, key)
            parts.append(f"{shown}: {text}")
        return "{" + ", ".join(parts) + "}", result

    def _flow_value(self, value: Node, at: KeyPath, result: dict[str, Any], key: str) -> str:
        """A value in a flow mapping, written; what it reads back as put in ``result``."""
        if isinstance(value, ScalarNode):
            text, result[key] = self._scalar(value)
        elif isinstance(value, SequenceNode) and _flow(value, SequenceNode, SEQ):
            text, result[key] = self._flow_sequence(value, at)  # a position's axes, say
        elif type(value) is _Row:
            text, result[key] = self._row(value, at)
        elif isinstance(value, MappingNode) and _flow(value, MappingNode, MAP):
            text, result[key] = self._flow_mapping(value, at)
        else:
            raise _Bail
        return text

    def _texts(self, node: _Texts, indent: str, path: KeyPath) -> list[Any]:
        """A :func:`texts` as :meth:`_block_sequence` writes the sequence it stands for."""
        self.nodes.append(id(node))
        lines, line, out = self.parsed.lines, self.line, self.out
        lines.setdefault(path, line)
        result: list[Any] = []
        dash, null_line = f"{indent}- ", f"{indent}- null"
        known = _SCALARS.get
        for i, item in enumerate(node.items):
            lines.setdefault((*path, i), line)
            if item is None:
                out.append(null_line)
                result.append(None)
            else:
                seen = (STR, None, item)
                written = known(seen)
                if written is None:
                    written = _remembered(_SCALARS, seen, _scalar_text(STR, None, item))
                out.append(dash + written[0])
                result.append(written[1])
            line += 1
        self.line = line
        return result

    def _row(self, node: _Row, path: KeyPath) -> tuple[str, dict[str, Any]]:
        """A :func:`row` as :meth:`_flow_mapping` writes the mapping it stands for: a
        number is plain (what num() takes is), a key plain when it is plain text."""
        if node._nodes is not None:
            return self._flow_mapping(node, path)  # changed since: its nodes
        lines, line = self.parsed.lines, self.line
        lines.setdefault(path, line)
        parts: list[str] = []
        result: dict[str, Any] = {}
        for key, value in node.items:
            if key not in _KEYS_PLAIN and not _plain_key(key):
                # a key to look at: as the mapping's nodes are written (the lines set
                # so far are the ones that sets too)
                return self._flow_mapping(node, path)
            if key in result:
                raise _Bail
            at = (*path, key)
            lines[at] = line
            if isinstance(value, str):
                parts.append(f"{key}: {value}")
                result[key] = Number(value)
            elif isinstance(value, list):
                for i in range(len(value)):
                    lines.setdefault((*at, i), line)
                parts.append(f"{key}: [{', '.join(value)}]")
                result[key] = [Number(each) for each in value]
            else:  # a node: as _flow_mapping writes one
                parts.append(f"{key}: {self._flow_value(value, at, result, key)}")
        self.nodes.append(id(node))
        return "{" + ", ".join(parts) + "}", result

    def _flow_sequence(self, node: SequenceNode, path: KeyPath) -> tuple[str, list[Any]]:
        self.nodes.append(id(node))
        lines, line = self.parsed.lines, self.line
        lines.setdefault(path, line)
        parts, result, scalar = [], [], self._scalar
        for i, value in enumerate(node.value):
            if not isinstance(value, ScalarNode):
                raise _Bail
            lines.setdefault((*path, i), line)
            text, data = scalar(value)
            parts.append(text)
            result.append(data)
        return "[" + ", ".join(parts) + "]", result

    def _emit(self, text: str) -> None:
        self.out.append(text)
        self.line += 1

    def _key(self, node: Node) -> tuple[str, str]:
        """How a key is written, and its text as parse gives it."""
        if not isinstance(node, ScalarNode) or node.style or len(node.value) >= 128:
            raise _Bail
        self.nodes.append(id(node))
        value = node.value
        if (
            node.tag == INT
            and value.isascii()
            and value.isdigit()
            and (value[0] != "0" or value == "0")
        ):
            return value, value  # a step or table number: plain, and parse keeps it so
        known = _KEYS.get((node.tag, value))
        if known is None:
            if not _PLAIN.fullmatch(value) or _implicit(value) != node.tag:
                raise _Bail
            known = _remembered(_KEYS, (node.tag, value), (value, _key(node)))
        return known

    def _scalar(self, node: ScalarNode) -> tuple[str, Any]:
        """How a scalar is written, and its value as parse gives it (the same in a
        block and in a flow: the plain scalars written hold no flow indicator)."""
        self.nodes.append(id(node))
        seen = (node.tag, node.style, node.value)
        known = _SCALARS.get(seen)
        if known is None:
            known = _remembered(_SCALARS, seen, _write_scalar(node))
        return known


#: How each scalar (tag, style, text) and each key (tag, text) is written and what it
#: reads back as, as :class:`_Writer` worked it out: a project repeats most of them (a
#: table's keys, axes and speeds, a program's commands), and a value read back (text,
#: a Number, true, null) is never changed.  Bounded: emptied when full.
_SCALARS: dict[tuple[str, Any, str], tuple[str, Any]] = {}
_KEYS: dict[tuple[str, str], tuple[str, str]] = {}
_REMEMBERED_MAX = 8192


def _plain_key(key: str) -> bool:
    """Whether text ``key`` is written as it is and parse keeps it so."""
    if len(key) >= 128 or not _PLAIN.fullmatch(key) or _implicit(key) != STR:
        return False
    if len(_KEYS_PLAIN) >= _REMEMBERED_MAX:
        _KEYS_PLAIN.clear()
    _KEYS_PLAIN.add(key)
    return True


#: The texts :func:`_plain_key` found plain (a row's keys: a few, a thousand times).
_KEYS_PLAIN: set[str] = set()


def _remembered(memo: dict[Any, Any], key: Any, value: Any) -> Any:
    if len(memo) >= _REMEMBERED_MAX:
        memo.clear()
    memo[key] = value
    return value


def _write_scalar(node: ScalarNode) -> tuple[str, Any]:
    """How :class:`_Writer` writes a scalar, and its value as parse gives it; raises
    :class:`_Bail` for one it leaves to the emitter."""
    return _scalar_text(node.tag, node.style, node.value)


def _scalar_text(tag: str, style: str | None, value: str) -> tuple[str, Any]:
    """:func:`_write_scalar` of a scalar node of ``tag``, ``style`` and ``value``."""
    if style == '"':
        if tag != STR or not _DOUBLE_QUOTABLE.fullmatch(value):
            raise _Bail
        return f'"{value}"', value
    if style:
        raise _Bail
    if tag == INT and _DECIMAL_INT.fullmatch(value):  # what num() makes: plain, an int
        return value, Number(value)
    if tag == FLOAT and _FRACTION.fullmatch(value):  # ... and plain, a float
        return value, Number(value)
    implicit = _implicit(value)
    if implicit == tag and _PLAIN.fullmatch(value):
        if tag == STR:
            return value, value
        if tag in (INT, FLOAT) and is_number_text(value):
            return value, Number(value)
        if tag == BOOL and value in ("true", "false"):
            return value, value == "true"
        if tag == NULL and value == "null":
            return value, None
        raise _Bail
    # Text that would read back as another type ('5.00', 'true'): the emitter quotes
    # it, in single quotes when nothing in it needs escaping.
    if tag == STR and implicit != STR and _SINGLE_QUOTABLE.fullmatch(value):
        return "'" + value.replace("'", "''") + "'", value
    raise _Bail


#: A decimal number that is not an integer (``1.50``, ``.5``, ``1.``, ``5E-3``): the
#: core schema's float, and written plain (``_PLAIN`` takes every character of it).
_FRACTION = re.compile(r"[-+]?(\.[0-9]+|[0-9]+\.[0-9]*|[0-9]+(\.[0-9]*)?[eE][-+]?[0-9]+)")


def _flow(node: Node, kind: type[CollectionNode], tag: str) -> bool:
    """``node`` is a ``kind`` of ``tag`` that the emitter writes in flow style in a
    block (a flow collection, or an empty one): the same as it writes it in a flow."""
    return isinstance(node, kind) and node.tag == tag and bool(node.flow_style or not node.value)


#: What :func:`dump` wrote and :func:`parse` will be asked to read back, with what
#: it holds: save renders every file and checks it before writing it.  Bounded:
#: a rendering nobody checks is forgotten soon.
_WRITTEN: dict[str, Parsed] = {}
_WRITTEN_MAX = 256
_WRITTEN_LOCK = threading.Lock()


def _remember(text: str, parsed: Parsed) -> None:
    with _WRITTEN_LOCK:
        _WRITTEN[text] = parsed
        while len(_WRITTEN) > _WRITTEN_MAX:
            del _WRITTEN[next(iter(_WRITTEN))]


def _recall(text: str) -> Parsed | None:
    """What :func:`dump` knew ``text`` holds, once (the next parse of it parses)."""
    with _WRITTEN_LOCK:
        return _WRITTEN.pop(text, None)
