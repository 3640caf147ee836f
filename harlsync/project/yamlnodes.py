"""The nodes project files are written from: :func:`num`, :func:`text`,
:func:`mapping`, :func:`row` ... (see :mod:`harlsync.project.yamlio`, which
re-exports them; :func:`~harlsync.project.yamlio.dump` writes them).
"""

from __future__ import annotations

from collections.abc import Iterable

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from .yamlread import (
    _DECIMAL_FLOAT,
    _DECIMAL_INT,
    BOOL,
    FLOAT,
    INT,
    MAP,
    NULL,
    SEQ,
    STR,
    is_number_text,
)


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
    """A flow mapping of numbers, a table's row on one line (a position, say), as
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
