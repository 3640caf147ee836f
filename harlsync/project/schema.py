"""The JSON Schemas of project files and the validator that applies them.

Each family ships its schemas in its own package
(``harlsync/families/<name>/schemas/<kind>.schema.json``) and reaches them
through a :class:`SchemaSet`.  The schemas serve two readers.  Editors use
``type``, ``minimum`` and ``maximum``.  harlsync also checks each number's
*text* through custom formats the family names (``harl-timer``: two decimals,
``iai-coord``: three, ...) that editors ignore, and lets ``integer`` accept a
:class:`~harlsync.project.yamlio.Number` written without a dot.  Each leaf
carries an ``x-allowed`` annotation quoted in error messages.
"""

from __future__ import annotations

import importlib
import json
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from decimal import Decimal
from functools import cache
from typing import TYPE_CHECKING, Any

from .yamlio import Number, Parsed

if TYPE_CHECKING:
    from jsonschema import ValidationError
    from jsonschema.protocols import Validator

__all__ = ["Issue", "SchemaSet", "show"]


@dataclass(frozen=True)
class Issue:
    """One problem in one file, rendered as ``file:line: field: message``.

    ``fatal`` marks issues that make a file unreadable (syntax, newer format,
    missing file): :func:`~harlsync.project.load_project` raises
    :class:`~harlsync.errors.ProjectFormatError` for those.
    """

    file: str
    line: int | None
    field: str | None
    message: str
    fatal: bool = False

    def __str__(self) -> str:
        """One line, whatever the file held: control characters in a key, a file
        name or a message are escaped, and a key of thousands of characters is cut."""
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        field = f"{_cut(self.field)}: " if self.field else ""
        return _one_line(f"{where}: {field}{self.message}")


#: Longest key or value quoted in a message, in characters.
MAX_SHOWN = 80

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def _one_line(text: str) -> str:
    return _CONTROL.sub(
        lambda m: (
            f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100 else f"\\u{ord(m.group()):04x}"
        ),
        text,
    )


def _cut(text: str) -> str:
    return text if len(text) <= MAX_SHOWN else text[: MAX_SHOWN - 3] + "..."


def _text_matches(pattern: re.Pattern[str]) -> Any:
    def check(instance: object) -> bool:
        if isinstance(instance, Number):
            return pattern.fullmatch(instance.text) is not None
        return True  # other types are the "type" keyword's business

    return check


@cache
def _jsonschema() -> Any:
    """jsonschema's validator class, as harlsync uses it; imported when first needed
    (a file the fast check cannot pass), not by every command that reads robot.yaml.

    A program file holds up to 256 steps, and jsonschema's keywords check each one
    through ``descend``, which builds a new validator per value: that, not the
    checks themselves, was most of a full-size project's load time.  The two
    keywords here first check every value (or key) with one validator, and only when
    one fails run jsonschema's own keyword, which then finds and words the errors
    exactly as before.  The short cut applies where ``descend`` adds nothing to
    ``evolve``: a subschema without ``$id`` (which would move the base URI), and,
    for additionalProperties, an object without properties or patternProperties
    (so every key is an "additional" one).
    """
    from jsonschema import Draft202012Validator
    from jsonschema.validators import extend

    base = Draft202012Validator.VALIDATORS

    def is_integer(checker: Any, instance: object) -> bool:
        if isinstance(instance, Number):
            return instance.integral
        return bool(Draft202012Validator.TYPE_CHECKER.is_type(instance, "integer"))

    def one_validator_passes(validator: Any, subschema: Any, instances: Iterable[Any]) -> bool:
        if not isinstance(subschema, dict) or "$id" in subschema:
            return False
        one = validator.evolve(schema=subschema)
        return all(one.is_valid(instance) for instance in instances)

    def additional_properties(validator: Any, aP: Any, instance: Any, schema: Any) -> Any:
        if (
            "properties" not in schema
            and "patternProperties" not in schema
            and validator.is_type(instance, "object")
            and one_validator_passes(validator, aP, instance.values())
        ):
            return
        yield from base["additionalProperties"](validator, aP, instance, schema)

    def property_names(validator: Any, names: Any, instance: Any, schema: Any) -> Any:
        if validator.is_type(instance, "object") and one_validator_passes(
            validator, names, instance
        ):
            return
        yield from base["propertyNames"](validator, names, instance, schema)

    return extend(  # type: ignore[no-untyped-call]
        Draft202012Validator,
        validators={
            "additionalProperties": additional_properties,
            "propertyNames": property_names,
        },
        type_checker=Draft202012Validator.TYPE_CHECKER.redefine("integer", is_integer),
    )


class SchemaSet:
    """One family's schemas: ``<kind>.schema.json`` files in the Python package
    ``package``, and the text formats (name -> exact pattern) they use.

    A file is checked first by :func:`_compile`'s check of its schema, which passes
    a valid file in a fraction of jsonschema's time; a file it does not pass (or a
    schema it cannot compile) goes to jsonschema, which finds and words the errors.
    """

    def __init__(
        self, package: str, kinds: Iterable[str], formats: Mapping[str, re.Pattern[str]]
    ) -> None:
        self.package = package
        self.kinds = tuple(kinds)
        self._patterns = dict(formats)
        self._formats: Any = None  # jsonschema's FormatChecker, once needed
        self._schemas: dict[str, dict[str, Any]] = {}
        self._validators: dict[str, Validator] = {}
        self._fast: dict[str, _Check | None] = {}

    def text(self, kind: str) -> str:
        """The schema file's exact text (copied into each project's ``.schemas/``).

        Read from the package's folder as a file, as ``importlib.resources`` reads
        it there; only a package that is no folder (a zip) goes through that API,
        whose first use imports its readers (about 1.5 ms, paid by every save)."""
        name = f"{kind}.schema.json"
        module = sys.modules.get(self.package) or importlib.import_module(self.package)
        origin = getattr(module, "__file__", None)
        if isinstance(origin, str) and os.path.basename(origin) == "__init__.py":
            try:
                with open(os.path.join(os.path.dirname(origin), name), encoding="utf-8") as f:
                    return f.read()
            except FileNotFoundError:
                pass  # not unpacked: the resources API finds it, or says so
        from importlib.resources import files  # its readers: only for a package in a zip

        folder: Any = files(self.package)
        text: str = folder.joinpath(name).read_text(encoding="utf-8")
        return text

    def schema(self, kind: str) -> dict[str, Any]:
        """The parsed schema, decimals as ``Decimal`` so limits compare exactly."""
        if kind not in self._schemas:
            self._schemas[kind] = json.loads(self.text(kind), parse_float=Decimal)
        return self._schemas[kind]

    def files(self) -> dict[str, str]:
        """File name -> text of every schema, for a project's ``.schemas/``."""
        return {f"{kind}.schema.json": self.text(kind) for kind in self.kinds}

    def check(self, kind: str, file: str, doc: Parsed) -> list[Issue]:
        """Every schema violation of one parsed file, one issue per field, by line."""
        if kind not in self._fast:
            schema = self.schema(kind)
            self._fast[kind] = _compile(schema, schema, self._patterns)
        fast = self._fast[kind]
        if fast is not None and fast(doc.data):
            return []
        issues: dict[tuple[Any, ...], tuple[int, Issue]] = {}
        for error in self._validator(kind).iter_errors(doc.data):
            for rank, path, issue in _issues(error, file, doc):
                old = issues.get(path)
                if old is None or rank < old[0]:
                    issues[path] = (rank, issue)
        return sorted((issue for _, issue in issues.values()), key=lambda i: i.line or 0)

    def _validator(self, kind: str) -> Validator:
        if self._formats is None:
            from jsonschema import FormatChecker

            self._formats = FormatChecker(formats=())
            for name, pattern in self._patterns.items():
                self._formats.checks(name)(_text_matches(pattern))
        if kind not in self._validators:
            self._validators[kind] = _jsonschema()(self.schema(kind), format_checker=self._formats)
        return self._validators[kind]


# -- the fast check ---------------------------------------------------------------------

#: A compiled schema: True only when jsonschema would find no error in the instance.
_Check = Callable[[Any], bool]

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
_TYPES: dict[str, Callable[[Any], bool]] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
    # Numbers come from yamlio.parse as Number only: anything else is left to jsonschema.
    "number": lambda v: isinstance(v, Number),
    "integer": lambda v: isinstance(v, Number) and v.integral,
}


def _other_number(value: Any) -> bool:
    """A number that is not a :class:`Number` (never from parse): left to jsonschema."""
    return isinstance(value, (int, float, Decimal)) and not isinstance(value, bool)


def _compile(
    schema: Any, root: dict[str, Any], formats: Mapping[str, re.Pattern[str]], depth: int = 0
) -> _Check | None:
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
    if rules.get("type") in ("array", "object") and rules.keys() <= _COLLECTION:
        return _collection(rules, schema, root, formats, depth)
    if rules.keys() == {"pattern"}:  # a property name, always text
        name = re.compile(rules["pattern"])
        return lambda v: not isinstance(v, str) or name.search(v) is not None
    checks: list[_Check] = []
    for keyword, value in schema.items():
        if keyword in _ANNOTATIONS:
            continue
        check = _keyword(keyword, value, schema, root, formats, depth)
        if check is None:
            return None
        checks.append(check)
    return _every(checks)


def _every(checks: list[_Check]) -> _Check:
    """A check that passes what every one of ``checks`` passes."""
    if not checks:
        return lambda v: True
    if len(checks) == 1:
        return checks[0]
    if len(checks) == 2:
        first, second = checks
        return lambda v: first(v) and second(v)
    chain = tuple(checks)

    def every(v: Any) -> bool:
        for check in chain:  # a loop, not all() of a generator: checked per value
            if not check(v):
                return False
        return True

    return every


def _text_leaf(rules: Mapping[str, Any]) -> _Check | None:
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


def _number_leaf(rules: Mapping[str, Any], formats: Mapping[str, re.Pattern[str]]) -> _Check | None:
    """``type`` number or integer with any of ``format`` and the four limits, in one
    test (a coordinate, an offset, a timer: most values of a file): once the value is
    a :class:`Number`, each keyword's test of another type falls away.  None for any
    other rules."""
    kind = rules.get("type")
    if kind not in ("number", "integer") or not rules.keys() <= _NUMBER_LEAF:
        return None
    limits = {k: v for k, v in rules.items() if k in _LIMITS}
    if any(isinstance(v, bool) or not isinstance(v, (int, Decimal)) for v in limits.values()):
        return None
    integral = kind == "integer"
    exact = formats.get(rules["format"]) if "format" in rules else None
    low, high = limits.get("minimum"), limits.get("maximum")
    above, below = limits.get("exclusiveMinimum"), limits.get("exclusiveMaximum")

    def number(v: Any) -> bool:
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


def _collection(
    rules: Mapping[str, Any],
    schema: dict[str, Any],
    root: dict[str, Any],
    formats: Mapping[str, re.Pattern[str]],
    depth: int,
) -> _Check | None:
    """``type`` array or object with its own keywords, in one function: the type
    tested once, the sizes and the required names there, each other keyword's own
    check after (a position, its axes and coordinates: thousands in a file)."""
    kind = rules["type"]
    wanted = {"array": ("minItems", "maxItems", "uniqueItems", "items")}.get(
        kind, ("required", "properties", "additionalProperties")
    )
    if not rules.keys() - {"type"} <= set(wanted):
        return None
    sizes = [rules.get("minItems"), rules.get("maxItems")]
    if any(n is not None and (isinstance(n, bool) or not isinstance(n, int)) for n in sizes):
        return None
    fewest, most = sizes
    required = rules.get("required")
    names = frozenset(required) if required is not None else None
    checks = []
    for keyword in ("uniqueItems", "items", "properties", "additionalProperties"):
        if keyword in rules:
            check = _keyword(keyword, rules[keyword], schema, root, formats, depth)
            if check is None:
                return None
            checks.append(check)
    rest = tuple(checks)
    if kind == "array":

        def array(v: Any) -> bool:
            if not isinstance(v, list):
                return False
            if (fewest is not None and len(v) < fewest) or (most is not None and len(v) > most):
                return False
            for check in rest:
                if not check(v):
                    return False
            return True

        return array

    def mapping(v: Any) -> bool:
        if not isinstance(v, dict) or (names is not None and not v.keys() >= names):
            return False
        for check in rest:
            if not check(v):
                return False
        return True

    return mapping


_LIMITS = frozenset({"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"})
_NUMBER_LEAF = _LIMITS | {"type", "format"}


def _keyword(
    keyword: str,
    value: Any,
    schema: dict[str, Any],
    root: dict[str, Any],
    formats: Mapping[str, re.Pattern[str]],
    depth: int,
) -> _Check | None:
    def sub(subschema: Any) -> _Check | None:
        return _compile(subschema, root, formats, depth + 1)

    if keyword == "type":
        kinds = [value] if isinstance(value, str) else value
        if not all(kind in _TYPES for kind in kinds):
            return None
        tests = [_TYPES[kind] for kind in kinds]
        if len(tests) == 1:
            return tests[0]
        return lambda v: any(test(v) for test in tests)
    if keyword in ("enum", "const"):
        members = value if keyword == "enum" else [value]
        texts = {m for m in members if isinstance(m, str)}
        numbers = [m for m in members if isinstance(m, (int, Decimal)) and not isinstance(m, bool)]
        return lambda v: (
            v in texts
            if isinstance(v, str)
            else isinstance(v, Number) and any(v == n for n in numbers)
        )
    if keyword == "pattern":
        pattern = re.compile(value)
        return lambda v: not isinstance(v, str) or pattern.search(v) is not None
    if keyword == "format":
        exact = formats.get(value)
        if exact is None:
            return lambda v: True  # a format the checker does not know passes there too
        return lambda v: not isinstance(v, Number) or exact.fullmatch(v.text) is not None
    if keyword in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        if isinstance(value, bool) or not isinstance(value, (int, Decimal)):
            return None
        limit = value
        compare: Callable[[Any], bool] = {
            "minimum": lambda v: v >= limit,
            "maximum": lambda v: v <= limit,
            "exclusiveMinimum": lambda v: v > limit,
            "exclusiveMaximum": lambda v: v < limit,
        }[keyword]
        return lambda v: compare(v) if isinstance(v, Number) else not _other_number(v)
    if keyword in ("minLength", "maxLength", "minItems", "maxItems"):
        if isinstance(value, bool) or not isinstance(value, int):
            return None
        size = value
        fits: Callable[[int], bool] = (
            (lambda n: n >= size) if keyword.startswith("min") else (lambda n: n <= size)
        )
        if keyword.endswith("Length"):
            return lambda v: not isinstance(v, str) or fits(len(v))
        return lambda v: not isinstance(v, list) or fits(len(v))
    if keyword == "uniqueItems":
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
    if keyword == "items":
        item = sub(value)
        if item is None:
            return None
        return lambda v: not isinstance(v, list) or all(map(item, v))
    if keyword == "required":
        names = frozenset(value)
        return lambda v: not isinstance(v, dict) or v.keys() >= names
    if keyword == "properties":
        props = {name: sub(subschema) for name, subschema in value.items()}
        if any(check is None for check in props.values()):
            return None
        pairs = tuple((name, check) for name, check in props.items() if check is not None)

        def properties(v: Any) -> bool:
            if isinstance(v, dict):
                for name, check in pairs:
                    if name in v and not check(v[name]):
                        return False
            return True

        return properties
    if keyword == "additionalProperties":
        if "patternProperties" in schema:
            return None
        known = frozenset(schema.get("properties", ()))
        if value is False:
            return lambda v: not isinstance(v, dict) or all(name in known for name in v)
        extra = sub(value)
        if extra is None:
            return None
        if not known:  # every value is an additional one (a program's steps)
            return lambda v: not isinstance(v, dict) or all(map(extra, v.values()))

        def additional(v: Any) -> bool:
            if isinstance(v, dict):
                for name, each in v.items():
                    if name not in known and not extra(each):
                        return False
            return True

        return additional
    if keyword == "propertyNames":
        name_check = sub(value)
        if name_check is None:
            return None
        return lambda v: not isinstance(v, dict) or all(map(name_check, v))
    if keyword == "$ref":
        if not isinstance(value, str) or not value.startswith("#/$defs/"):
            return None
        target = root.get("$defs", {}).get(value[len("#/$defs/") :])
        return None if target is None else sub(target)
    return None


# -- turning jsonschema errors into issues ------------------------------------------

_TYPE_WORDS = {
    "object": "a mapping",
    "array": "a list",
    "string": "text",
    "number": "a number",
    "integer": "an integer",
    "boolean": "true or false",
    "null": "nothing",
}
#: When one value breaks several keywords, report the first of these only.
_PRIORITY = (
    "type",
    "const",
    "enum",
    "minimum",
    "maximum",
    "exclusiveMinimum",
    "exclusiveMaximum",
    "format",
    "pattern",
)
_RANGE = {"minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"}


def show(value: object) -> str:
    """A value as the user wrote it, for messages."""
    if isinstance(value, Number):
        return _cut(value.text)
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "nothing"
    if isinstance(value, str):
        return repr(value) if len(value) <= MAX_SHOWN else repr(value[: MAX_SHOWN - 3]) + "..."
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return repr(value)


def _dotted(path: Any) -> str:
    return ".".join(str(p) for p in path) or "(top)"


def _issues(error: ValidationError, file: str, doc: Parsed) -> list[tuple[int, Any, Issue]]:
    path = tuple(error.absolute_path)
    subschema: dict[str, Any] = error.schema if isinstance(error.schema, dict) else {}
    allowed: str | None = subschema.get("x-allowed")
    keyword = str(error.validator)
    value: Any = error.instance
    expected: Any = error.validator_value

    def issue(at: tuple[Any, ...], message: str, hint: str | None = allowed) -> Issue:
        text = f"{message} (allowed: {hint})" if hint else message
        return Issue(file, doc.line(at), _dotted(at), text)

    rank = _PRIORITY.index(keyword) if keyword in _PRIORITY else len(_PRIORITY)
    if "propertyNames" in error.absolute_schema_path:
        at = (*path, value)
        return [(rank, at, issue(at, f"{show(value)} is not a valid key"))]
    if keyword == "additionalProperties":
        properties: dict[str, Any] = subschema.get("properties", {})
        known = ", ".join(properties)
        extra = [k for k in value if k not in properties]
        return [(rank, (*path, k), issue((*path, k), "unknown key", known)) for k in extra]
    if keyword == "required":
        missing = [k for k in expected if k not in value]
        return [(rank, (*path, k), issue((*path, k), "is missing", None)) for k in missing]
    if keyword == "type":
        types = expected if isinstance(expected, list) else [expected]
        words = " or ".join(_TYPE_WORDS.get(t, str(t)) for t in types)
        message = f"{show(value)} is not {words}"
    elif keyword in _RANGE:
        message = f"{show(value)} is out of range"
    elif keyword in ("format", "pattern", "enum", "const"):
        message = f"{show(value)} is not allowed"
    elif keyword == "minItems":
        message = "must not be empty"
    elif keyword == "uniqueItems":
        message = "has an item twice"
    else:
        message = error.message
    return [(rank, path, issue(path, message))]
