"""Requests that identify the robot: its type and model name (§8.5)."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import NamedTuple

from .request import Request, _read, _Words

# --- the robot (§8.5) ---------------------------------------------------------------


#: Manipulator type codes of 2153.
ROBOT_TYPES: Mapping[int, str] = MappingProxyType(
    {1: "Joint", 2: "Cartesian", 3: "SCARA", 5: "6-AXIS", 6: "RS"}
)


#: Control device numbers of 2156 (§8.5); the Remote Control function works while
#: it is Remote I/O, the device the manual says 2156 answers "during normal state".
CONTROL_DEVICES: Mapping[int, str] = MappingProxyType(
    {20: "TP3", 21: "PC / TP4", 22: "Remote I/O", 26: "Remote Ethernet", 29: "Remote RS232C"}
)
REMOTE_IO = 22


def read_controller_error() -> Request[int]:
    """2155: the controller's error code, 0 in the normal state (the interlock's)."""
    return _read(2155, (), "controller error", 1, lambda words: words.word("error code"))


def read_control_device() -> Request[int]:
    """2156: the control device (:data:`CONTROL_DEVICES`; the interlock's)."""
    return _read(2156, (), "control device", 1, lambda words: words.word("control device"))


def read_robot_type() -> Request[int]:
    """2153: the manipulator type (:data:`ROBOT_TYPES`)."""

    def parse(words: _Words) -> int:
        code = words.word("manipulator type")
        if code not in ROBOT_TYPES:
            raise ValueError(f"manipulator type {code} is not one the manual lists")
        return code

    return _read(2153, (), "manipulator type", 1, parse)


class NameChar(NamedTuple):
    """One answer of 2154: ``status`` 0 = this is the last character, 1 = more
    follow, 2 = the name is complete (no character)."""

    status: int
    char: str


def read_model_name_char(start: bool) -> Request[NameChar]:
    """2154: the next character of the model name (``start``: from the first one)."""

    def parse(words: _Words) -> NameChar:
        status = words.word("acquisition status")
        if status & ~0x7 or status & 0x7 > 2:
            raise ValueError(f"acquisition status {status:04X}H is not 0, 1 or 2")
        code = words.word("character")
        if code & ~0xFF or (status != 2 and not 0x20 <= code <= 0x7E):
            raise ValueError(f"character {code:04X}H is not printable ASCII")
        return NameChar(status, "" if status == 2 else chr(code))

    return _read(2154, (int(start),), "model name", 2, parse)
