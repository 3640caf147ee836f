"""The register map's robot.yaml form (``connection.map``): a plain dict to a
:class:`~.profile.RegisterMap`, checked, and back.

Every key is optional; a signal is a bit of its base register, a
``{register, bit}`` pair anywhere, or ``null`` for a status signal the site did
not map::

    in_base: 0
    out_base: 0
    command_base: 1          # default in_base + 1
    command_words: 8         # 3 to 8, as assigned in RC+
    response_base: 1         # default out_base + 1
    response_words: 8        # 3 to 8
    signals:
      ExtCmdSet: 0
      Running: {register: 20, bit: 3}
      SafeguardOn: null
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeGuard

from .profile import (
    COMMAND_WORDS,
    DEFAULT_BITS,
    HANDSHAKE_INPUTS,
    IN_BASE,
    OUT_BASE,
    RESPONSE_WORDS,
    SIGNAL_FIELDS,
    SIGNAL_NAMES,
    Bit,
    RegisterMap,
    RegisterMapInvalid,
)

__all__ = ["MAP_KEYS", "map_from_dict", "map_to_dict"]

MAP_KEYS = (
    "in_base",
    "out_base",
    "command_base",
    "command_words",
    "response_base",
    "response_words",
    "signals",
)


def map_from_dict(data: Mapping[str, object] | None) -> RegisterMap:
    """The map a robot file's dict describes (``None`` or ``{}``: the default).

    Raises :class:`RegisterMapInvalid` naming every problem: an unknown key
    or signal, a value of the wrong type or out of range, a handshake signal
    left unmapped, two signals on one bit, command words over the input
    signals, a map the handshake cannot read in one request.
    """
    data = data or {}
    issues: list[str] = []
    for key in data:
        if key not in MAP_KEYS:
            issues.append(f"unknown key {key!r} (known: {', '.join(MAP_KEYS)})")

    def number(key: str, default: int) -> int:
        value = data.get(key, default)
        if not _whole(value):
            issues.append(f"{key}: {value!r} is not a whole number")
            return default
        return value

    in_base = number("in_base", IN_BASE)
    out_base = number("out_base", OUT_BASE)
    values: dict[str, Any] = {
        "command_base": number("command_base", in_base + 1),
        "command_words": number("command_words", COMMAND_WORDS),
        "response_base": number("response_base", out_base + 1),
        "response_words": number("response_words", RESPONSE_WORDS),
    }
    given = data.get("signals", {})
    if not isinstance(given, Mapping):
        issues.append(f"signals: {given!r} is not a mapping of signal names")
        given = {}
    for name in given:
        if name not in SIGNAL_FIELDS:
            issues.append(f"signals: unknown signal {name!r} (known: {', '.join(SIGNAL_NAMES)})")
    for signal, field_name in SIGNAL_FIELDS.items():
        is_input = signal in HANDSHAKE_INPUTS
        base = in_base if is_input else out_base
        if signal not in given:
            values[field_name] = Bit(base, DEFAULT_BITS[signal])
            continue
        values[field_name] = _signal(
            signal, given[signal], base, issues, Bit(base, DEFAULT_BITS[signal])
        )
    try:
        built = RegisterMap(**values)
    except RegisterMapInvalid as exc:
        raise RegisterMapInvalid(issues + exc.issues) from None
    if issues:
        raise RegisterMapInvalid(issues)
    return built


def map_to_dict(register_map: RegisterMap) -> dict[str, object]:
    """The map in its robot-file form, every register and bit spelt out
    (``map_from_dict(map_to_dict(m)) == m``)."""
    signals: dict[str, object] = {}
    for signal, bit in register_map.signals():
        signals[signal] = None if bit is None else {"register": bit.register, "bit": bit.bit}
    return {
        "command_base": register_map.command_base,
        "command_words": register_map.command_words,
        "response_base": register_map.response_base,
        "response_words": register_map.response_words,
        "signals": signals,
    }


def _whole(value: object) -> TypeGuard[int]:
    return isinstance(value, int) and not isinstance(value, bool)


def _signal(name: str, value: object, base: int, issues: list[str], default: Bit) -> Bit | None:
    """One signal of the dict form: a bit of ``base``, ``{register, bit}`` or None
    (``default`` after an issue, so that the map's own checks can still run)."""
    if value is None:
        return None  # a handshake signal left out is reported by the map's own check
    if _whole(value):
        return Bit(base, value)
    if isinstance(value, Mapping) and set(value) <= {"register", "bit"}:
        register, bit = value.get("register", base), value.get("bit")
        if _whole(register) and _whole(bit):
            return Bit(register, bit)
    issues.append(
        f"signals: {name}: {value!r} is not a bit number, {{register: N, bit: B}} or null"
    )
    return default
