"""The controller's tables as :mod:`~harlsync.families.iai.tables` reads them (a
:class:`~harlsync.families.iai.tables.Table` each): what one query of the
position table (22DH), the flags and variables (20DH-20FH) or the read-only
records (2A0H, 210H) answers, and how the controller says a number is not there.
"""

from __future__ import annotations

from collections.abc import Callable

from ...errors import ControllerError
from . import profile
from .model import VARIABLE_SECTIONS, Position
from .protocol import (
    Request,
    max_coordinate_systems_per_read,
    max_flags_per_read,
    max_positions_per_read,
    max_string_columns_per_read,
    max_variables_per_read,
    read_coordinate_systems,
    read_flags,
    read_integers,
    read_positions,
    read_real_words,
    read_strings,
)
from .station import Station
from .tables import EMPTY, NotThere, Values, error_reply

__all__ = ["PositionTable", "RecordTable", "VariableTable"]


class PositionTable:
    """The position table as 22DH reads it (a :class:`~.tables.Table`): a number
    the controller lacks answers ``&``, or (to a 22DH that asks for it and defined
    ones) nothing, as an undefined position does."""

    section = "positions"
    called = "position"
    message = "22DH"
    align = 1
    exact = False
    lowest = profile.NUMBER_FIRST["positions"]
    setting = "controller.first_position/last_position"

    def __init__(self, controller: Station) -> None:
        self._controller = controller
        self.step = max_positions_per_read(controller.model)
        #: where a walk past the range stops (tables.py)
        self.highest = max(profile.POSITION_PROBE_FALLBACK_END, controller.last + 1)

    def ask(self, head: int, count: int) -> Values[Position] | NotThere:
        c = self._controller
        send = profile.BUFFERS[c.model].send
        try:
            records = c.request(read_positions(head, count, send))
        except ControllerError as refused:
            return NotThere(error_reply(refused.status))
        end = head + count - 1
        return Values({p.number: p for p in records if p.number <= end}, end)

    def is_set(self, value: Position) -> bool:
        return True  # a record in a 22DH reply is a defined position


class VariableTable:
    """Global flags (20DH), integer (20EH) or real variables (20FH, as their 16 hex
    digits) as a :class:`~.tables.Table`: a number the controller lacks answers
    ``&``, or a reply that stops before it."""

    def __init__(self, controller: Station, section: str) -> None:
        self._controller = controller
        self.section = section
        self.called = VARIABLE_SECTIONS[section]
        self.message = {"flags": "20DH", "integers": "20EH", "reals": "20FH"}[section]
        self.setting = f"controller.{section}"
        self.lowest = profile.NUMBER_FIRST[section]
        self.highest = profile.VARIABLE_NUMBER_END[section]
        model = controller.model
        self.step = (
            max_flags_per_read(model)
            if section == "flags"
            else max_variables_per_read(model, section)
        )
        self.align = profile.FLAG_QUERY_ALIGNMENT if section == "flags" else 1
        self.exact = True

    def ask(self, head: int, count: int) -> Values[object] | NotThere:
        query: Callable[[int, int], Request[tuple[object, ...]]] = {
            "flags": read_flags,
            "integers": read_integers,
            "reals": read_real_words,
        }[self.section]
        try:
            values = self._controller.request(query(head, count))
        except ControllerError as refused:
            return NotThere(error_reply(refused.status))
        if not values:
            return NotThere(EMPTY)
        return Values({head + i: v for i, v in enumerate(values)}, head + len(values) - 1)

    def is_set(self, value: object) -> bool:
        if isinstance(value, str):  # a real's digits: +0 and -0 as they read
            return int(value, 16) != 0
        return bool(value)


class RecordTable:
    """The read-only records (2A0H coordinate systems, 210H string variable
    columns) as a :class:`~.tables.Table`, for reading their range to the end of
    the controller's table (no probe outside it)."""

    def __init__(self, controller: Station, section: str) -> None:
        self._controller = controller
        self.section = section
        self.setting = f"controller.{section}"
        self.lowest = profile.NUMBER_FIRST[section]
        self.highest = profile.RECORD_NUMBER_END[section]
        self.align = 1
        self.exact = True
        if section == "strings":
            self.called, self.message = "string variable column", "210H"
            self.step = max_string_columns_per_read(controller.model)
        else:
            self.called = f"{section.split('_')[0]} coordinate system"
            self.message = "2A0H"
            self.step = max_coordinate_systems_per_read(controller.model)

    def ask(self, head: int, count: int) -> Values[object] | NotThere:
        if self.section == "strings":
            request: Request[tuple[object, ...]] = read_strings(head, count)
        else:
            kind = profile.COORDINATE_SYSTEM_TYPES[self.section]
            request = read_coordinate_systems(kind, head, min(count, 0xFF - head + 1))
        try:
            values = self._controller.request(request)
        except ControllerError as refused:
            return NotThere(error_reply(refused.status))
        if not values:
            return NotThere(EMPTY)
        return Values({head + i: v for i, v in enumerate(values)}, head + len(values) - 1)

    def is_set(self, value: object) -> bool:
        return False  # never probed outside their range
