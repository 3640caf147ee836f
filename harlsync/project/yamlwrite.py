"""Writing project YAML: :func:`dump`, with a writer of the project files' own
layouts that matches PyYAML's emitter byte for byte and keeps what :func:`parse`
would read back (see :mod:`harlsync.project.yamlio`, which re-exports it).
"""

from __future__ import annotations

import io
import re
import threading
from typing import TypeVar

from yaml.emitter import Emitter
from yaml.nodes import CollectionNode, MappingNode, Node, ScalarNode, SequenceNode
from yaml.serializer import Serializer

from .yamlnodes import _Row, _Texts
from .yamlread import (
    _DECIMAL_INT,
    BOOL,
    FLOAT,
    INT,
    MAP,
    NULL,
    SEQ,
    STR,
    CoreResolver,
    KeyPath,
    Number,
    Parsed,
    _key,
    is_number_text,
)

KT = TypeVar("KT")
VT = TypeVar("VT")


class _IndentingEmitter(Emitter):
    """Indents block sequences under their key (PyYAML's default does not)."""

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        super().increase_indent(flow, False)


class _Dumper(_IndentingEmitter, Serializer, CoreResolver):
    def __init__(self, stream: io.StringIO) -> None:
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

    def _block(self, node: MappingNode, indent: str, path: KeyPath) -> dict[str, object]:
        self.nodes.append(id(node))
        lines = self.parsed.lines
        lines.setdefault(path, self.line)
        result: dict[str, object] = {}
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

    def _block_sequence(self, node: SequenceNode, indent: str, path: KeyPath) -> list[object]:
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

    def _flow_mapping(self, node: MappingNode, path: KeyPath) -> tuple[str, dict[str, object]]:
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

    def _flow_value(self, value: Node, at: KeyPath, result: dict[str, object], key: str) -> str:
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

    def _texts(self, node: _Texts, indent: str, path: KeyPath) -> list[object]:
        """A :func:`texts` as :meth:`_block_sequence` writes the sequence it stands for."""
        self.nodes.append(id(node))
        lines, line, out = self.parsed.lines, self.line, self.out
        lines.setdefault(path, line)
        result: list[object] = []
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

    def _row(self, node: _Row, path: KeyPath) -> tuple[str, dict[str, object]]:
        """A :func:`row` as :meth:`_flow_mapping` writes the mapping it stands for: a
        number is plain (what num() takes is), a key plain when it is plain text."""
        if node._nodes is not None:
            return self._flow_mapping(node, path)  # changed since: its nodes
        lines, line = self.parsed.lines, self.line
        lines.setdefault(path, line)
        parts: list[str] = []
        result: dict[str, object] = {}
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

    def _flow_sequence(self, node: SequenceNode, path: KeyPath) -> tuple[str, list[object]]:
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

    def _scalar(self, node: ScalarNode) -> tuple[str, object]:
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
_SCALARS: dict[tuple[str, str | None, str], tuple[str, object]] = {}
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


def _remembered(memo: dict[KT, VT], key: KT, value: VT) -> VT:
    if len(memo) >= _REMEMBERED_MAX:
        memo.clear()
    memo[key] = value
    return value


def _write_scalar(node: ScalarNode) -> tuple[str, object]:
    """How :class:`_Writer` writes a scalar, and its value as parse gives it; raises
    :class:`_Bail` for one it leaves to the emitter."""
    return _scalar_text(node.tag, node.style, node.value)


def _scalar_text(tag: str, style: str | None, value: str) -> tuple[str, object]:
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
