"""The fast check of a project file against its schema: the schema compiled once
into plain Python checks that say only whether a document is valid.

It passes a valid file in a fraction of jsonschema's time; a file it does not
pass, or a schema it cannot compile (:func:`compile_check` returns None), goes to
jsonschema, which finds and words the errors (:class:`~harlsync.project.schema.SchemaSet`).
A compiled check returns True only when jsonschema would find no error.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from decimal import Decimal

from .yamlio import Number

__all__ = ["Check", "compile_check"]


#: A compiled schema: True only when jsonschema would find no error in the instance.
Check = Callable[[object], bool]

#: Keywords that say nothing about validity.
_ANNOTATIONS = frozenset(
    {
        "$schema",
        "$defs",
        "$comment",
        "title",
        "description",
        "default",
        "examples",
        "x-allowed",
        "x-volatility",
    }
)
_TYPES: dict[str, Check] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
    # Numbers come from yamlio.parse as Number only: anything else is left to jsonschema.
    "number": lambda v: isinstance(v, Number),
    "integer": lambda v: isinstance(v, Number) and v.integral,
}


def _other_number(value: object) -> bool:
    """A number that is not a :class:`Number` (never from parse): left to jsonschema."""
    return isinstance(value, (int, float, Decimal)) and not isinstance(value, bool)


def compile_check(
    schema: object,
    root: Mapping[str, object],
    formats: Mapping[str, re.Pattern[str]],
    depth: int = 0,
) -> Check | None:
    """A check of ``schema`` (``root`` resolves ``$ref``) that passes an instance only
    when jsonschema, with harlsync's types and formats, would find no error in it: it
    may refuse a valid one (jsonschema then has the last word), never pass an invalid
    one.  None when the schema uses a keyword this does not know.

    The keywords are those of the project schemas, with jsonschema's meaning: a
    keyword about one type ignores instances of another; ``pattern`` searches,
    ``format`` is the family's exact text of a number; ``enum`` and ``const`` compare
    text with text and numbers with numbers (refusing anything else).
    """
    if schema is True:
        return lambda v: True
    if schema is False or not isinstance(schema, dict) or depth > 32:
        return None
    rules = {k: v for k, v in schema.items() if k not in _ANNOTATIONS}
    leaf = _text_leaf(rules) or _number_leaf(rules, formats)
    if leaf is not None:  # the commonest leaves, in one test each
        return leaf
    scope = _Scope(schema, root, formats, depth)
    if rules.get("type") in ("array", "object") and rules.keys() <= _COLLECTION:
        return _collection(rules, scope)
    if rules.keys() == {"pattern"}:  # a property name, always text
        name = re.compile(rules["pattern"])
        return lambda v: not isinstance(v, str) or name.search(v) is not None
    checks: list[Check] = []
    for keyword, value in schema.items():
        if keyword in _ANNOTATIONS:
            continue
        check = _keyword(keyword, value, scope)
        if check is None:
            return None
        checks.append(check)
    return _every(checks)


def _every(checks: list[Check]) -> Check:
    """A check that passes what every one of ``checks`` passes."""
    if not checks:
        return lambda v: True
    if len(checks) == 1:
        return checks[0]
    if len(checks) == 2:
        first, second = checks
        return lambda v: first(v) and second(v)
    chain = tuple(checks)

    def every(v: object) -> bool:
        for check in chain:  # a loop, not all() of a generator: checked per value
            if not check(v):
                return False
        return True

    return every


def _text_leaf(rules: Mapping[str, object]) -> Check | None:
    """``type`` (text, or text or other scalar types) with a ``pattern``, in one test:
    a step (text or null), a token (text or a number).  None for any other rules."""
    if rules.keys() != {"type", "pattern"} or not isinstance(rules["pattern"], str):
        return None
    kinds = [rules["type"]] if isinstance(rules["type"], str) else rules["type"]
    if not isinstance(kinds, list) or "string" not in kinds:
        return None
    if not all(kind in _TYPES for kind in kinds):
        return None
    text = re.compile(rules["pattern"])
    others = [_TYPES[kind] for kind in kinds if kind != "string"]
    if not others:
        return lambda v: isinstance(v, str) and text.search(v) is not None
    if others == [_TYPES["null"]]:
        return lambda v: v is None or (isinstance(v, str) and text.search(v) is not None)
    # pattern says nothing of a value that is not text: the other types pass as they are
    return lambda v: (
        text.search(v) is not None if isinstance(v, str) else any(test(v) for test in others)
    )


def _number_leaf(
    rules: Mapping[str, object], formats: Mapping[str, re.Pattern[str]]
) -> Check | None:
    """``type`` number or integer with any of ``format`` and the four limits, in one
    test (a coordinate, an offset, a timer: most values of a file): once the value is
    a :class:`Number`, each keyword's test of another type falls away.  None for any
    other rules."""
    kind = rules.get("type")
    if kind not in ("number", "integer") or not rules.keys() <= _NUMBER_LEAF:
        return None
    limits: dict[str, int | Decimal] = {
        k: v
        for k, v in rules.items()
        if k in _LIMITS and isinstance(v, (int, Decimal)) and not isinstance(v, bool)
    }
    if len(limits) != len(rules.keys() & _LIMITS):  # a limit that is no number
        return None
    integral = kind == "integer"
    given = rules.get("format")
    exact = formats.get(given) if isinstance(given, str) else None
    low, high = limits.get("minimum"), limits.get("maximum")
    above, below = limits.get("exclusiveMinimum"), limits.get("exclusiveMaximum")

    def number(v: object) -> bool:
        return (
            isinstance(v, Number)
            and (not integral or v.integral)
            and (exact is None or exact.fullmatch(v.text) is not None)
            and (low is None or v >= low)
            and (high is None or v <= high)
            and (above is None or v > above)
            and (below is None or v < below)
        )

    return number


#: What :func:`_collection` takes of a list's or a mapping's rules.
_COLLECTION = frozenset(
    {"type", "minItems", "maxItems", "uniqueItems", "items"}
    | {"required", "properties", "additionalProperties"}
)


def _collection(rules: Mapping[str, object], scope: _Scope) -> Check | None:
    """``type`` array or object with its own keywords, in one function: the type
    tested once, the sizes and the required names there, each other keyword's own
    check after (a position, its axes and coordinates: thousands in a file)."""
    kind = rules["type"]
    wanted = (
        ("minItems", "maxItems", "uniqueItems", "items")
        if kind == "array"
        else ("required", "properties", "additionalProperties")
    )
    if not rules.keys() - {"type"} <= set(wanted):
        return None
    given = [rules.get("minItems"), rules.get("maxItems")]
    sizes = [n if isinstance(n, int) and not isinstance(n, bool) else None for n in given]
    if sizes != given:  # a size that is no whole number
        return None
    fewest, most = sizes
    required = rules.get("required")
    if required is not None and not isinstance(required, list):
        return None
    names = frozenset(required) if required is not None else None
    checks = []
    for keyword in ("uniqueItems", "items", "properties", "additionalProperties"):
        if keyword in rules:
            check = _keyword(keyword, rules[keyword], scope)
            if check is None:
                return None
            checks.append(check)
    rest = tuple(checks)
    if kind == "array":

        def array(v: object) -> bool:
            if not isinstance(v, list):
                return False
            if (fewest is not None and len(v) < fewest) or (most is not None and len(v) > most):
                return False
            for check in rest:
                if not check(v):
                    return False
            return True

        return array

    def mapping(v: object) -> bool:
        if not isinstance(v, dict) or (names is not None and not v.keys() >= names):
            return False
        for check in rest:
            if not check(v):
                return False
        return True

    return mapping


_LIMITS = frozenset({"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"})
_NUMBER_LEAF = _LIMITS | {"type", "format"}


class _Scope:
    """Where a keyword is compiled: its schema, the root ``$ref`` resolves in, the
    family's formats and the depth of nesting."""

    __slots__ = ("depth", "formats", "root", "schema")

    def __init__(
        self,
        schema: Mapping[str, object],
        root: Mapping[str, object],
        formats: Mapping[str, re.Pattern[str]],
        depth: int,
    ) -> None:
        self.schema, self.root, self.formats, self.depth = schema, root, formats, depth

    def sub(self, subschema: object) -> Check | None:
        """The check of a schema inside this one."""
        return compile_check(subschema, self.root, self.formats, self.depth + 1)


def _keyword(keyword: str, value: object, scope: _Scope) -> Check | None:
    """The check of one keyword of ``scope``'s schema; None for a keyword (or a value
    of it) this does not know."""
    build = _KEYWORDS.get(keyword)
    return None if build is None else build(keyword, value, scope)


def _type(keyword: str, value: object, scope: _Scope) -> Check | None:
    kinds = [value] if isinstance(value, str) else value
    if not isinstance(kinds, list) or not all(kind in _TYPES for kind in kinds):
        return None
    tests = [_TYPES[kind] for kind in kinds]
    if len(tests) == 1:
        return tests[0]
    return lambda v: any(test(v) for test in tests)


def _members(keyword: str, value: object, scope: _Scope) -> Check | None:
    """``enum`` or ``const``: text compared with text, numbers with numbers."""
    members = value if keyword == "enum" else [value]
    if not isinstance(members, list):
        return None
    texts = {m for m in members if isinstance(m, str)}
    numbers = [m for m in members if isinstance(m, (int, Decimal)) and not isinstance(m, bool)]
    return lambda v: (
        v in texts if isinstance(v, str) else isinstance(v, Number) and any(v == n for n in numbers)
    )


def _pattern(keyword: str, value: object, scope: _Scope) -> Check | None:
    if not isinstance(value, str):
        return None
    pattern = re.compile(value)
    return lambda v: not isinstance(v, str) or pattern.search(v) is not None


def _format(keyword: str, value: object, scope: _Scope) -> Check | None:
    exact = scope.formats.get(value) if isinstance(value, str) else None
    if exact is None:
        return lambda v: True  # a format the checker does not know passes there too
    return lambda v: not isinstance(v, Number) or exact.fullmatch(v.text) is not None


def _limit(keyword: str, value: object, scope: _Scope) -> Check | None:
    """``minimum``, ``maximum`` and their exclusive kin."""
    if isinstance(value, bool) or not isinstance(value, (int, Decimal)):
        return None
    limit = value
    compare: Callable[[Number], bool] = {
        "minimum": lambda v: v >= limit,
        "maximum": lambda v: v <= limit,
        "exclusiveMinimum": lambda v: v > limit,
        "exclusiveMaximum": lambda v: v < limit,
    }[keyword]
    return lambda v: compare(v) if isinstance(v, Number) else not _other_number(v)


def _size(keyword: str, value: object, scope: _Scope) -> Check | None:
    """``minLength``, ``maxLength``, ``minItems`` and ``maxItems``."""
    if isinstance(value, bool) or not isinstance(value, int):
        return None
    size = value
    fits: Callable[[int], bool] = (
        (lambda n: n >= size) if keyword.startswith("min") else (lambda n: n <= size)
    )
    if keyword.endswith("Length"):
        return lambda v: not isinstance(v, str) or fits(len(v))
    return lambda v: not isinstance(v, list) or fits(len(v))


def _unique(keyword: str, value: object, scope: _Scope) -> Check | None:
    if value is not True:
        return (lambda v: True) if value is False else None
    # Items all text, or all numbers (compared by value, as jsonschema does: 1 and
    # 1.0 are the same item); anything else is left to jsonschema.
    return lambda v: (
        not isinstance(v, list)
        or (
            (
                all(isinstance(item, str) for item in v)
                or all(isinstance(item, Number) for item in v)
            )
            and len(set(v)) == len(v)
        )
    )


def _items(keyword: str, value: object, scope: _Scope) -> Check | None:
    item = scope.sub(value)
    if item is None:
        return None
    return lambda v: not isinstance(v, list) or all(map(item, v))


def _required(keyword: str, value: object, scope: _Scope) -> Check | None:
    if not isinstance(value, list):
        return None
    names = frozenset(value)
    return lambda v: not isinstance(v, dict) or v.keys() >= names


def _properties(keyword: str, value: object, scope: _Scope) -> Check | None:
    if not isinstance(value, dict):
        return None
    props = {name: scope.sub(subschema) for name, subschema in value.items()}
    if any(check is None for check in props.values()):
        return None
    pairs = tuple((name, check) for name, check in props.items() if check is not None)

    def properties(v: object) -> bool:
        if isinstance(v, dict):
            for name, check in pairs:
                if name in v and not check(v[name]):
                    return False
        return True

    return properties


def _additional(keyword: str, value: object, scope: _Scope) -> Check | None:
    if "patternProperties" in scope.schema:
        return None
    properties = scope.schema.get("properties", {})
    if not isinstance(properties, dict):
        return None
    known = frozenset(properties)
    if value is False:
        return lambda v: not isinstance(v, dict) or all(name in known for name in v)
    extra = scope.sub(value)
    if extra is None:
        return None
    if not known:  # every value is an additional one (a program's steps)
        return lambda v: not isinstance(v, dict) or all(map(extra, v.values()))

    def additional(v: object) -> bool:
        if isinstance(v, dict):
            for name, each in v.items():
                if name not in known and not extra(each):
                    return False
        return True

    return additional


def _property_names(keyword: str, value: object, scope: _Scope) -> Check | None:
    name_check = scope.sub(value)
    if name_check is None:
        return None
    return lambda v: not isinstance(v, dict) or all(map(name_check, v))


def _ref(keyword: str, value: object, scope: _Scope) -> Check | None:
    if not isinstance(value, str) or not value.startswith("#/$defs/"):
        return None
    defs = scope.root.get("$defs", {})
    target = defs.get(value[len("#/$defs/") :]) if isinstance(defs, dict) else None
    return None if target is None else scope.sub(target)


#: Each keyword the fast check knows, with the builder of its check.
_KEYWORDS: dict[str, Callable[[str, object, _Scope], Check | None]] = {
    "type": _type,
    "enum": _members,
    "const": _members,
    "pattern": _pattern,
    "format": _format,
    "minimum": _limit,
    "maximum": _limit,
    "exclusiveMinimum": _limit,
    "exclusiveMaximum": _limit,
    "minLength": _size,
    "maxLength": _size,
    "minItems": _size,
    "maxItems": _size,
    "uniqueItems": _unique,
    "items": _items,
    "required": _required,
    "properties": _properties,
    "additionalProperties": _additional,
    "propertyNames": _property_names,
    "$ref": _ref,
}
