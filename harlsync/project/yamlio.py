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

Three modules do the work, this one is the way in: :mod:`.yamlread` (the resolver,
:class:`Number`, nodes into data), :mod:`.yamlnodes` (the node builders) and
:mod:`.yamlwrite` (:func:`dump` and its writer).
"""

from __future__ import annotations

import yaml
from yaml.reader import ReaderError

from .yamlnodes import (
    RowValue,
    boolean,
    mapping,
    null,
    num,
    quoted,
    row,
    scalar_for,
    sequence,
    text,
    texts,
)
from .yamlread import (
    ALIAS_BUDGET,
    MAX_DEPTH,
    SEQ,
    CoreResolver,
    KeyPath,
    Number,
    Parsed,
    YamlSyntaxError,
    _Budget,
    _build,
    _compose,
    _FastLoader,
    _Loader,
    is_number_text,
)

# The writer's memo and its two writers, as tests/test_yaml_writer.py reaches them here.
from .yamlwrite import _WRITTEN, _emit, _recall, _Writer, dump  # noqa: F401

__all__ = [
    "MAX_DEPTH",
    "SEQ",
    "CoreResolver",
    "KeyPath",
    "Number",
    "Parsed",
    "RowValue",
    "YamlSyntaxError",
    "boolean",
    "dump",
    "is_number_text",
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
