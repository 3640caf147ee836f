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

from .schemafast import Check, compile_check
from .yamlio import KeyPath, Number, Parsed

if TYPE_CHECKING:
    from jsonschema import FormatChecker, ValidationError
    from jsonschema.protocols import Validator

__all__ = ["Issue", "SchemaSet", "show"]

#: The fast check, by the name tests/test_schema_fast.py imports.
_compile = compile_check


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


def _text_matches(pattern: re.Pattern[str]) -> Callable[[object], bool]:
    def check(instance: object) -> bool:
        if isinstance(instance, Number):
            return pattern.fullmatch(instance.text) is not None
        return True  # other types are the "type" keyword's business

    return check


@cache
def _jsonschema() -> Any:
    """jsonschema's validator class, as harlsync uses it; imported when first needed
    (a file the fast check cannot pass), not by every command that reads robot.yaml.

    A file may hold hundreds of sequence items, and jsonschema's keywords check each one
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

    A file is checked first by its schema compiled into plain checks
    (:func:`~harlsync.project.schemafast.compile_check`), which passes a valid
    file in a fraction of jsonschema's time; a file it does not pass (or a schema
    it cannot compile) goes to jsonschema, which finds and words the errors.
    """

    def __init__(
        self, package: str, kinds: Iterable[str], formats: Mapping[str, re.Pattern[str]]
    ) -> None:
        self.package = package
        self.kinds = tuple(kinds)
        self._patterns = dict(formats)
        self._formats: FormatChecker | None = None  # once needed
        self._schemas: dict[str, dict[str, Any]] = {}
        self._validators: dict[str, Validator] = {}
        self._fast: dict[str, Check | None] = {}

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

        return files(self.package).joinpath(name).read_text(encoding="utf-8")

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
            self._fast[kind] = compile_check(schema, schema, self._patterns)
        fast = self._fast[kind]
        if fast is not None and fast(doc.data):
            return []
        issues: dict[KeyPath, tuple[int, Issue]] = {}
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


def _dotted(path: Iterable[object]) -> str:
    return ".".join(str(p) for p in path) or "(top)"


def _issues(error: ValidationError, file: str, doc: Parsed) -> list[tuple[int, KeyPath, Issue]]:
    path = tuple(error.absolute_path)
    subschema: dict[str, Any] = error.schema if isinstance(error.schema, dict) else {}
    allowed: str | None = subschema.get("x-allowed")
    keyword = str(error.validator)
    value: Any = error.instance
    expected: Any = error.validator_value

    def issue(at: KeyPath, message: str, hint: str | None = allowed) -> Issue:
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
